"""study=design: feed -> scale-up -> the mill's mechanics -> power, dose, yield -> costs; under a
dose rule with a target yield, the residence time's fixed point."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .. import yield_rules
from ..config import ConfigError
from ..dose import above_threshold, dose_j_per_kg, with_basis
from ..drum import drum_spec
from ..economics import bond_rowland_power_w, evaluate, margin_usd_per_t_tpa, purchase_cost_usd
from ..kinetics import YieldCurve, curve_dose_for, curve_mean_yield
from ..plots import plot_yield_time, save_figure
from ..scaleup import design_mill
from ..scenario import Scenario
from ..yields import bpr_line_yield, line_yield, solve_residence_time
from .mechanics import check_dem_mode, check_numerics, check_window, mechanics, mill_drum
from .plan import Plan
from .yield_fit import TIME_SPAN

log = logging.getLogger(__name__)


@dataclass
class YieldPlan:
    """The yield model's part of a plan: the BPR line's yield and, under a dose rule, its yield
    curve (the calibration's dose line or the fit's chosen model; None until `ready` when the lab
    DEM or the fit runs first, `source` making it) and the target yield."""

    line_yield_percent: float
    extrapolated: bool
    curve: YieldCurve | None
    target: float | None
    source: Callable[[], YieldCurve] | None = None
    folder: dict | None = None  # where the curve comes from: {"calibration_dir": ...} (a fit says it itself)
    target_dose_j_per_kg: float | None = None  # the mean dose whose yield, averaged over the RTD, is the target

    @property
    def deferred(self) -> bool:
        return self.curve is None and self.source is not None

    def mill_scenario(self, s: Scenario) -> Scenario:
        """The scenario the mill's DEM runs under: an impact measure's at physical stiffness, so
        that lab and mill spectra are compared at one stiffness (yield_model.mill_stiffness)."""
        impacts = self.curve is not None and above_threshold(self.curve.rate)
        if not impacts or s.yield_model.mill_stiffness == "sim":
            return s
        return replace(s, sim=replace(s.sim, shear_modulus_scale=1.0))

    def threshold_j(self, s: Scenario) -> float:
        """E* of the mill's impact measures: the curve's where it has one, else yield_model's."""
        e = getattr(self.curve, "threshold_j", None)
        return s.yield_model.impact_threshold_j if e is None else e

    def record(self, s: Scenario) -> dict:
        if self.curve is None:
            return {}
        rtd = s.yield_model.rtd
        out = self.curve.as_record() | (self.folder or {}) | {"yield_mode": s.yield_model.mode, "rtd_kind": rtd.kind}
        out |= {"rtd_tanks": rtd.tanks} if rtd.kind == "tanks_in_series" else {}
        out |= {"rtd_peclet": rtd.peclet} if rtd.kind == "axial_dispersion" else {}
        if self.target is None:
            return out
        dose = self.target_dose_j_per_kg
        return out | {"target_yield_percent": self.target, "target_dose_kj_per_kg_pet": dose / 1e3,
                      "rtd_dose_factor": dose / self.curve.dose_for(self.target)}

    def ready(self, s: Scenario) -> dict:
        """Run the deferred lab calibration or fit, and solve the target's mean dose; the curve's
        record it gives (else nothing new)."""
        if not self.deferred:
            return {}
        self.curve = self.source()
        if s.dem.mode == "surrogate" and above_threshold(self.curve.rate):
            raise ConfigError(f"dem=surrogate: the yield's dose measure is impacts of at least {self.threshold_j(s)} J, "
                              "whose spectrum the surrogate does not predict; use dem=full")
        if self.curve.time_free:
            self.target = None
        if self.target is not None:
            self.target_dose_j_per_kg = curve_dose_for(self.curve, self.target, s.yield_model.rtd)
        return self.record(s)


def yield_plan(s: Scenario, design) -> YieldPlan:
    """Refuses a BPR outside the line's range; under a dose rule whose lab calibration or fit is
    missing, it runs first when the plan executes (planning simulates nothing).  The lab's
    powder is counted at the mill's NaOH:PET ratio."""
    model = s.yield_model
    line_y, extrapolated = bpr_line_yield(s.scaleup.bpr, model)
    target = model.target_yield_percent or line_y if model.mode == "target_yield" else None
    rule = yield_rules.rule_of(model.rule)
    if rule.dose and target == 100.0 and model.rtd.kind != "plug":
        raise ConfigError(f"yield_model.target_yield_percent=100 (the target at scaleup.bpr={s.scaleup.bpr}) cannot be "
                          f"reached under yield_model.rtd.kind={model.rtd.kind}: a share of the powder leaves early; "
                          "give a target below 100")
    if not rule.dose:
        return YieldPlan(line_y, extrapolated, None, None)
    curve = rule.plan(s, design)
    y = YieldPlan(line_y, extrapolated, None, target, curve.source, curve.folder)
    if curve.ready:
        y.ready(s)
    return y


def check_design(s: Scenario, design) -> None:
    """The costs' data tables exist; the mill's numerics are sound."""
    purchase_cost_usd(design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, s.economics)
    margin_usd_per_t_tpa(s.economics)
    check_numerics(drum_spec(mill_drum(s.mill, design), s.materials, s.interactions, s.sim), s.sim, "mill")


def plan_design(s: Scenario) -> Plan:
    """Scale-up of the feed to a mill, whose DEM (or its surrogate) gives the power and the
    collision dose; the yield model's yield (under a dose rule with a target, the residence
    time that reaches it, the yield averaged over the mill's RTD); costs and margin."""
    scale, model = s.scaleup, s.yield_model
    design = design_mill(scale)
    check_window(s.sim, mill_drum(s.mill, design))
    check_dem_mode(s, design)
    y = yield_plan(s, design)
    check_design(s, design)
    record = {"bpr": scale.bpr, "region": scale.region, "shape_rule": scale.shape_rule, "yield_rule": model.rule,
              "impact_threshold_j": model.impact_threshold_j, "bpr_line_yield_percent": y.line_yield_percent,
              "yield_extrapolated": y.extrapolated} | y.record(s)

    def execute(out_dir: Path) -> dict:
        first = y.ready(s)
        rec = evaluate_design(s, y, out_dir)[0]
        if y.curve is not None and not y.curve.time_free:
            save_figure(plot_yield_time(*time_curves(s, y, rec)), out_dir / "yield_time")
        return first | rec

    return Plan(record, execute)


def evaluate_design(s: Scenario, y: YieldPlan, out_dir: Path | None = None):
    """The scale-up's mill (under a target, at the residence time that reaches it) by `mechanics`:
    its record and its design."""
    design, threshold, s = design_mill(s.scaleup), y.threshold_j(s), y.mill_scenario(s)
    if y.target is None:
        dem, rates = mechanics(s, design, threshold, out_dir)
        return dem | mill_record(s, design, dem, rates, y), design
    # the surrogate may pass outside its hull on the way; the final mill is checked (mechanics)
    trial = replace(s, dem=replace(s.dem, allow_extrapolation=True)) if s.dem.mode == "surrogate" else s
    fp = solve_design(trial, design, y)
    final = design_mill(replace(s.scaleup, residence_time_min=fp.residence_time_min))
    dem, rates = mechanics(s, final, threshold, out_dir)  # the root's mill (cached when simulated on the way)
    miss = dose_j_per_kg(rates[y.curve.rate], final.residence_time_min) / y.target_dose_j_per_kg - 1
    return dem | mill_record(s, final, dem, rates, y) | fp.as_record() | {"fixed_point_dose_miss": miss}, final


def mill_record(s: Scenario, design, dem: dict, rates: dict, y: YieldPlan) -> dict:
    """A mill's design, dose rates and doses per kg of PET, yield (the BPR line's, or the yield
    curve's at its dose averaged over the RTD), costs and the Bond/Rowland power beside the DEM's."""
    minutes, scale, curve = design.residence_time_min, s.scaleup, y.curve
    doses = {f"{m.removesuffix('_power_w_per_kg')}_dose_kj_per_kg_pet": dose_j_per_kg(rates[m], minutes) / 1e3
             for m in ("collision_power_w_per_kg", "impact_power_w_per_kg")}
    if curve is None:
        yield_percent = bpr_line_yield(scale.bpr, s.yield_model)[0]
    elif curve.time_free:
        yield_percent = curve.yield_at_bpr(scale.bpr)
    else:
        yield_percent = curve_mean_yield(curve, dose_j_per_kg(rates[curve.rate], minutes), s.yield_model.rtd)
    return {**design.as_record(), **with_basis(rates, "pet"), **doses,
            **evaluate(dem["dem_power_w"], yield_percent, design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h,
                       minutes, s.economics),
            "yield_capped": curve is None and line_yield(scale.bpr, s.yield_model) > 100.0,
            "bond_rowland_power_w": bond_rowland_power_w(design.diameter_m, design.ball_mass_kg, scale.fill_fraction,
                                                         design.fraction_of_critical, 2 * design.ball_radius_m)}


def solve_design(s: Scenario, design, y: YieldPlan):
    """The residence time whose mean dose reaches the target's (a fixed point over the mills the
    scale-up makes at each residence time, each given to `mechanics`)."""
    threshold, rate = y.threshold_j(s), y.curve.rate

    def rate_at(tau_min: float) -> tuple[float, float]:
        _, rates = mechanics(s, design_mill(replace(s.scaleup, residence_time_min=tau_min)), threshold)
        return rates[rate], rates[f"{rate}_se"]

    fp = solve_residence_time(design.residence_time_min, y.target_dose_j_per_kg, rate_at, s.yield_model.tolerance,
                              s.yield_model.max_iterations, y.curve.dose_rel_se(y.target),
                              s.yield_model.sensitivity_step)
    log.info("residence time %.4g min (%s) after %d mill evaluations (%s): %s", fp.residence_time_min, fp.root,
             fp.iterations, s.dem.mode, ", ".join(f"{t:.4g}" for t in fp.history_min))
    return fp


def time_curves(s: Scenario, y: YieldPlan, rec: dict) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    """Yield against time in the lab (the fit's conditions, or the calibration's nominal one at
    this BPR) and in the designed mill at its dose rate (plug flow, and averaged over its RTD
    against the mean residence time); the experiments as points."""
    curve, rtd, rule = y.curve, s.yield_model.rtd, yield_rules.rule_of(s.yield_model.rule)
    rate = rec[f"{curve.rate.replace('_per_kg', '_per_kg_pet')}"]
    until = TIME_SPAN * max(rec["residence_time_min"], rule.longest_lab_time_min(s, curve))  # past the last experiment
    lab, points = rule.lab_time_curves(s, curve, rec, until)
    t = np.linspace(0.0, until, 200)
    mill = [pd.DataFrame({"series": "mill, plug flow", "time_min": t,
                          "yield_percent": curve.yield_percent(rate * t * 60)})]
    if rtd.kind != "plug":
        mill.append(pd.DataFrame({"series": f"mill, {rtd.kind} (mean residence time)", "time_min": t,
                                  "yield_percent": [curve_mean_yield(curve, rate * m * 60, rtd) for m in t]}))
    return pd.concat([lab, *mill], ignore_index=True), points
