"""study=cheapest_mill: the cheapest mill for the feed and target yield by the surrogate
(surrogate/optimise.py), what each knob is worth, both mills confirmed by the DEM."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from .. import yield_rules
from ..config import ConfigError
from ..scaleup import design_mill
from ..scenario import Scenario
from ..surrogate.optimise import KNOBS, annualised_cost_usd_per_yr, design_knobs, knob_ranges, knob_scaleup, minimise
from ..surrogate.training import revolution_sim
from ..yields import NotConverged
from .design import check_design, evaluate_design, mill_record, yield_plan
from .mechanics import check_dem_mode, check_window, mechanics, mill_drum
from .plan import Plan, prefixed

INFEASIBLE_USD = 1e12  # an optimiser trial's cost when its mill cannot be built (the trial is marked infeasible)


def plan_cheapest_mill(s: Scenario) -> Plan:
    """The cheapest mill for the feed and target yield (surrogate/optimise.py): the paper's mill
    (the scale-up as configured) and the optimum over speed, fill, ball size and L/D, both by the
    surrogate; what each knob is worth (the optimum with that knob back at the paper's value);
    then both mills confirmed by the DEM at the surrogate's residence time (optimiser.confirm),
    with the surrogate's error on each."""
    model = s.yield_model
    if yield_rules.rule_of(model.rule).dose and model.mode == "fixed_time":
        raise ConfigError("study=cheapest_mill: yield_model.mode=fixed_time gives no target to reach; "
                          "use yield_model.mode=target_yield")
    fast = replace(s, dem=replace(s.dem, mode="surrogate"))
    check_dem_mode(fast)
    paper = design_mill(s.scaleup)
    y = yield_plan(s, paper)
    ranges = knob_ranges(s.optimiser)
    check_window(s.sim, mill_drum(s.mill, paper))
    check_design(s, paper)
    record = {"bpr": s.scaleup.bpr, "region": s.scaleup.region, "yield_rule": model.rule,
              "bpr_line_yield_percent": y.line_yield_percent, "optimiser_trials": s.optimiser.trials,
              "optimiser_seed": s.optimiser.seed} | y.record(s)

    def at(scale, extrapolate: bool = False):
        fit = replace(fast, scaleup=scale, dem=replace(fast.dem, allow_extrapolation=extrapolate))
        rec, design = evaluate_design(fit, y)
        return rec | {"fill_fraction": scale.fill_fraction,
                      "annualised_cost_usd_per_yr": annualised_cost_usd_per_yr(rec, s.plant)}, design

    def objective(knobs: dict[str, float]) -> tuple[float, float]:
        try:
            rec, _ = at(knob_scaleup(s.scaleup, knobs), extrapolate=True)
        except (ConfigError, NotConverged):  # a mill that cannot be built or reach the target
            return INFEASIBLE_USD, 1.0
        return rec["annualised_cost_usd_per_yr"], 0.0 if rec["dem_inside_hull"] else 1.0

    def confirm(design, label: str, out_dir: Path) -> dict:
        """The DEM of a mill the surrogate chose, at the run's preset (its speed's revolutions; the
        cheapest-mill sweeps run sim=surrogate, the surrogate's own protocol)."""
        full = replace(s, dem=replace(s.dem, mode="full"), sim=revolution_sim(s.sim, design.speed_rpm))
        folder = out_dir / label
        folder.mkdir(exist_ok=True)
        dem, rates = mechanics(full, design, y.threshold_j(s), folder)
        rec = dem | mill_record(full, design, dem, rates, y)
        return rec | {"annualised_cost_usd_per_yr": annualised_cost_usd_per_yr(rec, s.plant),
                      "sim_duration_s": full.sim.duration_s}

    def execute(out_dir: Path) -> dict:
        out = y.ready(s)
        base, base_design = at(s.scaleup, extrapolate=True)  # marked: paper_dem_inside_hull
        best_knobs, _, trials = minimise(objective, ranges, s.optimiser.trials, s.optimiser.seed)
        trials.to_csv(out_dir / "trials.csv", index=False)
        best, best_design = at(knob_scaleup(s.scaleup, best_knobs), extrapolate=True)  # inside: the constraint
        out |= prefixed(base, "paper") | prefixed(best, "optimum") | {
            "surrogate_design_s": trials.seconds.median(), "cost_saved_fraction":
                1 - best["annualised_cost_usd_per_yr"] / base["annualised_cost_usd_per_yr"]}
        paper_knobs = design_knobs(s.scaleup, base_design)
        for knob in KNOBS:  # the optimum with one knob back at the paper's value
            try:
                cost = at(knob_scaleup(s.scaleup, best_knobs | {knob: paper_knobs[knob]}), True)[0][
                    "annualised_cost_usd_per_yr"]
            except (ConfigError, NotConverged):
                cost = float("nan")
            out[f"knob_{knob}_cost_increase_fraction"] = cost / best["annualised_cost_usd_per_yr"] - 1
        if s.optimiser.confirm:
            for label, design, surrogate in (("paper", base_design, base), ("optimum", best_design, best)):
                started = time.perf_counter()
                dem = confirm(design, label, out_dir)
                out |= prefixed(dem, f"{label}_dem") | {
                    f"{label}_dem_design_s": time.perf_counter() - started,
                    f"{label}_surrogate_power_error": surrogate["dem_power_w"] / dem["dem_power_w"] - 1,
                    f"{label}_surrogate_cost_error": (surrogate["annualised_cost_usd_per_yr"]
                                                      / dem["annualised_cost_usd_per_yr"] - 1)}
            out["cost_saved_fraction_dem"] = (1 - out["optimum_dem_annualised_cost_usd_per_yr"]
                                              / out["paper_dem_annualised_cost_usd_per_yr"])
        return out

    return Plan(record, execute)
