"""The lab studies: study=lab (the MM400 at every lab.frequencies_hz x lab.ball_diameters_m ->
lab_summary.csv) and study=yield_calibration (the lab DEM of the kinetics experiments behind
the energy rules, lab_dose.py)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from .. import yield_rules
from ..config import MM400_GEOMETRY, ConfigError
from ..dem import SimulationError
from ..dose import dose_rates, with_basis
from ..lab import conditions, jar_ball_mass_kg, mm400_spec, simulate_mm400, summarise, wall_interaction
from ..lab_dose import calibration_conditions, calibration_folder, calibration_key, check_conditions, lab_rates
from ..scaleup import design_mill
from ..scenario import Scenario
from ..yields import fit_dose_line
from .mechanics import check_machine, check_numerics
from .plan import Plan


def plan_lab(s: Scenario) -> Plan:
    """The MM400 at the configured ball-wall pair: one summary row per frequency x ball size."""
    lab = s.lab
    if lab.settle_s >= lab.duration_s:
        raise ConfigError(f"lab.settle_s={lab.settle_s} leaves nothing of lab.duration_s={lab.duration_s} to measure: "
                          "make it shorter than the duration")
    pair = wall_interaction(s.interactions, lab)
    conds = conditions(lab, [pair.restitution], [pair.static_friction])
    check_numerics(mm400_spec(lab, conds, s.materials, s.interactions, s.sim), s.sim, "lab")

    def execute(out_dir: Path) -> dict:
        check_machine(s.sim)
        traj, collisions = simulate_mm400(lab, conds, s.materials, s.interactions, s.sim)
        model = s.yield_model
        doses = pd.DataFrame([
            with_basis(dose_rates(collisions[collisions.replica == k], lab.settle_s, lab.duration_s,
                                  jar_ball_mass_kg(lab, c.ball_diameter_m, s.materials), model.impact_threshold_j,
                                  model.dose_batches), "balls")
            for k, c in enumerate(conds)])
        summary = summarise(traj, collisions, lab, conds).join(doses).assign(
            balls=lab.balls_per_jar, **{k: getattr(lab, k) for k in MM400_GEOMETRY})
        if summary.mean_speed_m_per_s.isna().any():
            raise SimulationError(f"lab: no ball speed after lab.settle_s={lab.settle_s} s of "
                                  f"lab.duration_s={lab.duration_s} s: lengthen the run")
        summary.to_csv(out_dir / "lab_summary.csv", index=False)
        return {}

    return Plan({"balls": lab.balls_per_jar, "wall_restitution": pair.restitution,
                 "wall_friction": pair.static_friction, "conditions": len(conds),
                 "observations": s.study.observations}, execute)


def plan_yield_calibration(s: Scenario) -> Plan:
    """The lab DEM of the kinetics experiments (lab_dose.py): dose rates per condition, the dose
    lines at the nominal one (the lab's powder at the scale-up's NaOH:PET ratio), and how far
    each alternative (frequency, ball size and count, jar bore and length) moves the lab dose
    rate (an energy rule's residence time scales with it)."""
    model = s.yield_model
    check_conditions(calibration_conditions(s), s)
    design = design_mill(s.scaleup)
    ratio = design.naoh_feed_kg_per_h / design.pet_feed_kg_per_h

    def execute(out_dir: Path) -> dict:
        check_machine(s.sim)
        rates = lab_rates(s, model.impact_threshold_j)  # simulated first when missing
        nominal = rates.query("nominal").iloc[0]
        out = {"calibration_dir": str(calibration_folder(s)), "impact_threshold_j": model.impact_threshold_j}
        for rule in yield_rules.dose_lines():
            measure = rule.measure
            rates[f"{measure}_relative"] = rates[measure] / nominal[measure]
            line = fit_dose_line(measure, float(nominal[measure]), float(nominal[f"{measure}_se"]), model, ratio)
            out |= {f"{rule.name}_{k}": v for k, v in line.as_record().items()}
        rates.to_csv(out_dir / "lab_dose.csv", index=False)
        return out

    return Plan({"lab_frequency_hz": model.lab.frequency_hz, "lab_balls": model.lab.balls_per_jar,
                 "lab_ball_diameter_m": model.lab.ball_diameter_m, "lab_jar_material": model.lab.jar_material,
                 "bpr_basis": model.lab.bpr_basis, "calibration_key": calibration_key(s)}, execute)
