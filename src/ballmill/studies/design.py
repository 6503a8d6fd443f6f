"""study=design: feed -> scale-up -> the mill's mechanics -> power, dose, yield -> costs; under an
energy rule with a target yield, the residence time's fixed point."""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from pathlib import Path

from ..dose import dose_j_per_kg, with_basis
from ..drum import drum_spec
from ..economics import bond_rowland_power_w, evaluate, margin_usd_per_t_tpa, purchase_cost_usd
from ..lab_dose import calibrated, calibration_folder, lab_dose_line
from ..scaleup import design_mill
from ..scenario import Scenario
from ..yields import DoseLine, bpr_line_yield, line_yield, solve_residence_time
from .mechanics import check_dem_mode, check_numerics, check_window, mechanics, mill_drum
from .plan import Plan

log = logging.getLogger(__name__)


@dataclass
class YieldPlan:
    """The yield model's part of a plan: the BPR line's yield and, under an energy rule, the dose
    line (None until `ready` when the lab calibration runs first) and the target yield."""

    line_yield_percent: float
    extrapolated: bool
    line: DoseLine | None
    target: float | None
    deferred: bool

    def record(self, s: Scenario) -> dict:
        if self.line is None:
            return {}
        out = self.line.as_record() | {"yield_mode": s.yield_model.mode,
                                       "calibration_dir": str(calibration_folder(s))}
        return out | ({"target_yield_percent": self.target,
                       "target_dose_kj_per_kg_pet": self.line.dose_for(self.target) / 1e3}
                      if self.target is not None else {})

    def ready(self, s: Scenario) -> dict:
        """Run the deferred lab calibration; the dose line's record it gives (else nothing new)."""
        if not self.deferred:
            return {}
        self.line, self.deferred = lab_dose_line(s), False  # simulates the lab first
        return self.record(s)


def yield_plan(s: Scenario) -> YieldPlan:
    """Refuses a BPR outside the line's range; under an energy rule whose lab calibration is
    missing, the calibration runs first when the plan executes (planning simulates nothing)."""
    model = s.yield_model
    line_y, extrapolated = bpr_line_yield(s.scaleup.bpr, model)
    energy = model.rule != "bpr_line"
    deferred = energy and not calibrated(s)  # the lab DEM runs in execute
    line = lab_dose_line(s) if energy and not deferred else None
    target = model.target_yield_percent or line_y if energy and model.mode == "target_yield" else None
    return YieldPlan(line_y, extrapolated, line, target, deferred)


def check_design(s: Scenario, design) -> None:
    """The costs' data tables exist; the mill's numerics are sound."""
    purchase_cost_usd(design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, s.economics)
    margin_usd_per_t_tpa(s.economics)
    check_numerics(drum_spec(mill_drum(s.mill, design), s.materials, s.interactions, s.sim), s.sim, "mill")


def plan_design(s: Scenario) -> Plan:
    """Scale-up of the feed to a mill, whose DEM (or its surrogate) gives the power and the
    collision dose; the yield model's yield (under an energy rule with a target, the residence
    time that reaches it); costs and margin."""
    scale, model = s.scaleup, s.yield_model
    design = design_mill(scale)
    check_window(s.sim, mill_drum(s.mill, design))
    check_dem_mode(s, design)
    y = yield_plan(s)
    check_design(s, design)
    record = {"bpr": scale.bpr, "region": scale.region, "shape_rule": scale.shape_rule, "yield_rule": model.rule,
              "impact_threshold_j": model.impact_threshold_j, "bpr_line_yield_percent": y.line_yield_percent,
              "yield_extrapolated": y.extrapolated} | y.record(s)

    def execute(out_dir: Path) -> dict:
        first = y.ready(s)
        return first | evaluate_design(s, y.line, y.target, out_dir)[0]

    return Plan(record, execute)


def evaluate_design(s: Scenario, line, target: float | None, out_dir: Path | None = None):
    """The scale-up's mill (under a target, at the residence time that reaches it) by `mechanics`:
    its record and its design."""
    design = design_mill(s.scaleup)
    if target is None:
        dem, rates = mechanics(s, design, out_dir)
        return dem | mill_record(s, design, dem, rates, line), design
    # the surrogate may pass outside its hull on the way; the final mill is checked (mechanics)
    trial = replace(s, dem=replace(s.dem, allow_extrapolation=True)) if s.dem.mode == "surrogate" else s
    fp, final = solve_design(trial, design, line, target)
    dem, rates = mechanics(s, final, out_dir)  # cached: the figures of the final mill
    return dem | mill_record(s, final, dem, rates, line) | fp.as_record(), final


def mill_record(s: Scenario, design, dem: dict, rates: dict, line) -> dict:
    """A mill's design, dose rates and doses per kg of PET, yield (the BPR line's, or the dose
    line's at its dose), costs and the Bond/Rowland power beside the DEM's."""
    minutes, scale = design.residence_time_min, s.scaleup
    doses = {f"{m.removesuffix('_power_w_per_kg')}_dose_kj_per_kg_pet": dose_j_per_kg(rates[m], minutes) / 1e3
             for m in ("collision_power_w_per_kg", "impact_power_w_per_kg")}
    y = (bpr_line_yield(scale.bpr, s.yield_model)[0] if line is None
         else line.yield_percent(dose_j_per_kg(rates[line.measure], minutes)))
    return {**design.as_record(), **with_basis(rates, "pet"), **doses,
            **evaluate(dem["dem_power_w"], y, design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, minutes,
                       s.economics),
            "yield_capped": line is None and line_yield(scale.bpr, s.yield_model) > 100.0,
            "bond_rowland_power_w": bond_rowland_power_w(design.diameter_m, design.ball_mass_kg, scale.fill_fraction,
                                                         design.fraction_of_critical, 2 * design.ball_radius_m)}


def solve_design(s: Scenario, design, line, target: float):
    """The residence time whose dose reaches the target yield's (a fixed point over the mills
    the scale-up makes at each residence time, each given to `mechanics`); the final mill."""
    mills = {}

    def rate_at(tau_min: float) -> tuple[float, float]:
        d = design_mill(replace(s.scaleup, residence_time_min=tau_min))
        _, rates = mechanics(s, d)
        mills[tau_min] = d
        return rates[line.measure], rates[f"{line.measure}_se"]

    fp = solve_residence_time(design.residence_time_min, line.dose_for(target), rate_at, s.yield_model.tolerance,
                              s.yield_model.max_iterations)
    log.info("residence time %.4g min after %d mill evaluations (%s): %s", fp.residence_time_min, fp.iterations,
             s.dem.mode, ", ".join(f"{t:.4g}" for t in fp.history_min))
    return fp, mills[fp.residence_time_min]
