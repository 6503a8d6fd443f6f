"""What a run does, by `study.kind`: each study plans (checks the scenario and builds what the
run needs, in well under a second, simulating nothing) and then executes into the run's folder.

design: feed -> scale-up -> DEM of the rotating mill -> power -> economics.
drum:   the mill group's drum as configured -> torque and power over time.
lab:    the MM400 at every lab.frequencies_hz x lab.ball_diameters_m -> lab_summary.csv.

A new pipeline is one plan function here, its entry in STUDIES and its name in the choices of
config.StudyConfig.kind.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .config import MM400_GEOMETRY, ConfigError, DrumConfig, SimConfig
from .dem import SimulationError, SystemSpec
from .dose import dose_j_per_kg, dose_rates, with_basis
from .drum import DrumRun, ball_count, dem_key, drum_spec, simulate_drum
from .economics import bond_rowland_power_w, evaluate, margin_usd_per_t_tpa, purchase_cost_usd
from .lab import conditions, jar_ball_mass_kg, mm400_spec, simulate_mm400, summarise, wall_interaction
from .lab_dose import (
    calibrated,
    calibration_folder,
    calibration_key,
    kinetics_mills,
    lab_dose_line,
    lab_rates,
    lab_sim,
    simulate_kinetics_lab,
)
from .plant.flowsheet import flowsheet, mill_throughput_kg_per_h
from .plant.model import Mill
from .plant.model import evaluate as evaluate_plant
from .plant.uncertainty import monte_carlo, tornado
from .plots import plot_bed, plot_drum_loads, save_figure
from .scaleup import design_mill
from .scenario import Scenario, time_step_s
from .yields import MEASURE, bpr_line_yield, fit_dose_line, line_yield, solve_residence_time

log = logging.getLogger(__name__)
DT_WARN_FRACTION = 0.4  # LIGGGHTS and EDEM advise 20-40 % of the Rayleigh step; warn above
DENSE_BED_CONTACTS = 12  # a ball in a dense bed touches up to 12 others (plus walls)
MIN_SAMPLES = 2  # a mean power needs samples; its standard error needs many (10 batches)


@dataclass
class Plan:
    """A checked run: the record's inputs known before simulating, and how to produce the rest."""

    record: dict
    execute: Callable[[Path], dict]


def check_machine(sim: SimConfig) -> None:
    """Refuse settings this machine cannot honour (checked where the job runs, and up front when
    the jobs run here)."""
    cores = os.cpu_count() or 1
    if sim.threads > cores:
        raise ConfigError(f"sim.threads={sim.threads} is more than this machine's {cores} cores: use 0 (all) to {cores}")
    if sim.arch == "cuda" and not cuda_available():
        raise ConfigError("sim.arch=cuda: no CUDA device or driver on this machine; use sim.arch=cpu")


def check_numerics(spec: SystemSpec, sim: SimConfig, name: str) -> None:
    """Refuse settings that cannot give a meaningful run; warn on a time step near stability's edge."""
    ratio = time_step_s(spec, sim) / spec.rayleigh_timestep_s()
    if ratio >= 1.0 and not sim.allow_unstable_time_step:
        raise ConfigError(f"sim: the time step is {ratio:.2f} x the Rayleigh step of {spec.rayleigh_timestep_s():.3g} s "
                          "(unstable); lower sim.dt_fraction / sim.dt_s below 0.4 of it, or set "
                          "sim.allow_unstable_time_step=true")
    if ratio > DT_WARN_FRACTION:
        log.warning("%s: the time step is %.0f %% of the Rayleigh step (above %.0f %%): contacts may be poorly "
                    "resolved", name, 100 * ratio, 100 * DT_WARN_FRACTION)
    per_replica = spec.n_particles / spec.n_replicas
    if per_replica > DENSE_BED_CONTACTS and sim.max_contacts_per_particle < DENSE_BED_CONTACTS:
        raise ConfigError(f"sim.max_contacts_per_particle={sim.max_contacts_per_particle} is too few for a bed of "
                          f"{per_replica:.0f} balls (a ball touches up to {DENSE_BED_CONTACTS}): use at least "
                          f"{DENSE_BED_CONTACTS}")


def cuda_available() -> bool:
    """Whether Taichi finds a CUDA device (imports Taichi; launches nothing)."""
    import taichi as ti
    from taichi.lang.misc import is_arch_supported

    return bool(is_arch_supported(ti.cuda))


def check_window(sim: SimConfig) -> None:
    """An averaging window with samples in it."""
    if sim.steady_after_s >= sim.duration_s:
        raise ConfigError(f"sim.steady_after_s={sim.steady_after_s} leaves no samples to average in "
                          f"sim.duration_s={sim.duration_s}: make it shorter than the duration")
    if sim.sample_every_s > (sim.duration_s - sim.steady_after_s) / MIN_SAMPLES:
        raise ConfigError(f"sim.sample_every_s={sim.sample_every_s} gives fewer than {MIN_SAMPLES} samples in the "
                          f"averaging window of {sim.duration_s - sim.steady_after_s:g} s: sample more often")


def run_drum(s: Scenario, drum: DrumConfig, out_dir: Path | None = None) -> tuple[DrumRun, Path]:
    """The drum's DEM (cached by dem_key under cache_dir); its tables and figures into out_dir."""
    check_numerics(drum_spec(drum, s.materials, s.interactions, s.sim), s.sim, "mill")
    dem_dir = s.cache_dir / "dem" / dem_key(drum, s.materials, s.interactions, s.sim)
    check_machine(s.sim)
    run = simulate_drum(drum, s.materials, s.interactions, s.sim, dem_dir)
    if out_dir is not None:
        run.results.loads.to_csv(out_dir / "loads.csv", index=False)
        save_figure(plot_drum_loads(run.results.loads, steady_after_s=run.summary["averaging_from_s"]),
                    out_dir / "drum_loads")
        if len(run.results.trajectories):
            save_figure(plot_bed(run.results.trajectories, drum.ball_radius_m, drum.inner_diameter_m / 2),
                        out_dir / "bed")
    return run, dem_dir


def drum_record(run: DrumRun, dem_dir: Path) -> dict:
    return {f"dem_{k}": v for k, v in run.summary.items()} | {"dem_dir": str(dem_dir)}


def run_dose(run: DrumRun, mass_kg: float, s: Scenario) -> dict:
    """Dose rates of a drum run per kg of `mass_kg`, over its averaging window."""
    return dose_rates(run.results.collisions, run.summary["averaging_from_s"], run.summary["simulated_s"], mass_kg,
                      s.yield_model.impact_threshold_j, s.yield_model.dose_batches)


def plan_drum(s: Scenario) -> Plan:
    """The mill group's drum as configured: torque, power, and dose rates per kg of balls."""
    check_window(s.sim)
    check_numerics(drum_spec(s.mill, s.materials, s.interactions, s.sim), s.sim, "mill")

    def execute(out_dir: Path) -> dict:
        run, dem_dir = run_drum(s, s.mill, out_dir)
        one_ball = s.materials[s.mill.ball_material].density_kg_per_m3 * 4 / 3 * math.pi * s.mill.ball_radius_m**3
        return drum_record(run, dem_dir) | with_basis(run_dose(run, ball_count(s.mill) * one_ball, s), "balls")

    return Plan({}, execute)


def mill_drum(s: Scenario, design) -> DrumConfig:
    return replace(s.mill, inner_diameter_m=design.diameter_m, inner_length_m=design.length_m,
                   ball_radius_m=design.ball_radius_m, ball_count=design.ball_count, speed_rpm=design.speed_rpm)


def plan_design(s: Scenario) -> Plan:
    """Scale-up of the feed to a mill, whose DEM gives the power and the collision dose; the
    yield model's yield (under an energy rule with a target, the residence time that reaches
    it); costs and margin."""
    scale, econ, model = s.scaleup, s.economics, s.yield_model
    check_window(s.sim)
    line_y, extrapolated = bpr_line_yield(scale.bpr, model)  # an out-of-range BPR is refused here
    design = design_mill(scale)
    purchase_cost_usd(design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, econ)  # the data tables exist
    margin_usd_per_t_tpa(econ)
    check_numerics(drum_spec(mill_drum(s, design), s.materials, s.interactions, s.sim), s.sim, "mill")
    record = {"bpr": scale.bpr, "region": scale.region, "shape_rule": scale.shape_rule, "yield_rule": model.rule,
              "impact_threshold_j": model.impact_threshold_j, "bpr_line_yield_percent": line_y,
              "yield_extrapolated": extrapolated}
    energy = model.rule != "bpr_line"
    deferred = energy and model.run_lab_calibration and not calibrated(s)  # the lab DEM runs in execute
    line = lab_dose_line(s) if energy and not deferred else None  # refused until the lab is calibrated
    target = model.target_yield_percent or line_y if energy and model.mode == "target_yield" else None

    def line_record() -> dict:
        out = line.as_record() | {"yield_mode": model.mode, "calibration_dir": str(calibration_folder(s))}
        return out | ({"target_yield_percent": target, "target_dose_kj_per_kg_pet": line.dose_for(target) / 1e3}
                      if target is not None else {})

    if line is not None:
        record |= line_record()

    def pet_holdup_kg(design) -> float:
        return design.pet_feed_kg_per_h * design.residence_time_min / 60

    def evaluate_mill(design, run: DrumRun) -> dict:
        rates = run_dose(run, pet_holdup_kg(design), s)
        minutes = design.residence_time_min
        doses = {f"{m.removesuffix('_power_w_per_kg')}_dose_kj_per_kg_pet": dose_j_per_kg(rates[m], minutes) / 1e3
                 for m in ("collision_power_w_per_kg", "impact_power_w_per_kg")}
        y = line_y if line is None else line.yield_percent(dose_j_per_kg(rates[line.measure], minutes))
        return {**design.as_record(), **with_basis(rates, "pet"), **doses,
                **evaluate(run.summary["power_w"], y, design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, minutes, econ),
                "yield_capped": line is None and line_yield(scale.bpr, model) > 100.0,
                "bond_rowland_power_w": bond_rowland_power_w(design.diameter_m, design.ball_mass_kg,
                                                             scale.fill_fraction, design.fraction_of_critical,
                                                             2 * design.ball_radius_m)}

    def execute(out_dir: Path) -> dict:
        nonlocal line
        first = {}
        if deferred:
            simulate_kinetics_lab(s)
            line = lab_dose_line(s)
            first = line_record()
        if target is None:
            run, dem_dir = run_drum(s, mill_drum(s, design), out_dir)
            return first | drum_record(run, dem_dir) | evaluate_mill(design, run)
        mills = {}

        def rate_at(tau_min: float) -> tuple[float, float]:
            d = design_mill(replace(scale, residence_time_min=tau_min))
            run, dem_dir = run_drum(s, mill_drum(s, d))
            mills[tau_min] = d, dem_dir
            rates = run_dose(run, pet_holdup_kg(d), s)
            return rates[line.measure], rates[f"{line.measure}_se"]

        fp = solve_residence_time(scale.residence_time_min, line.dose_for(target), rate_at, model.tolerance,
                                  model.max_iterations)
        final, _ = mills[fp.residence_time_min]
        run, dem_dir = run_drum(s, mill_drum(s, final), out_dir)  # cached: the figures of the final mill
        log.info("residence time %.4g min after %d DEM runs: %s", fp.residence_time_min, fp.iterations,
                 ", ".join(f"{t:.4g}" for t in fp.history_min))
        return first | drum_record(run, dem_dir) | evaluate_mill(final, run) | {
            "residence_time_se_min": fp.se_min, "fixed_point_iterations": fp.iterations,
            "fixed_point_dose_miss": fp.miss,
            "fixed_point_history_min": " ".join(f"{t:.6g}" for t in fp.history_min)}

    return Plan(record, execute)


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
    lines at the nominal one, and how far each alternative moves the lab dose rate (an energy
    rule's residence time scales with it)."""
    model = s.yield_model
    for cfg, conds in kinetics_mills(s):
        check_numerics(mm400_spec(cfg, conds, s.materials, s.interactions, lab_sim(s)), lab_sim(s), "lab")

    def execute(out_dir: Path) -> dict:
        check_machine(s.sim)
        simulate_kinetics_lab(s)
        rates = lab_rates(s, model.impact_threshold_j)
        nominal = rates.query("nominal").iloc[0]
        out = {"calibration_dir": str(calibration_folder(s)), "impact_threshold_j": model.impact_threshold_j}
        for rule, measure in MEASURE.items():
            rates[f"{measure}_relative"] = rates[measure] / nominal[measure]
            line = fit_dose_line(measure, float(nominal[measure]), float(nominal[f"{measure}_se"]), model)
            out |= {f"{rule}_{k}": v for k, v in line.as_record().items()}
        rates.to_csv(out_dir / "lab_dose.csv", index=False)
        return out

    return Plan({"lab_frequency_hz": model.lab.frequency_hz, "lab_balls": model.lab.balls_per_jar,
                 "lab_ball_diameter_m": model.lab.ball_diameter_m, "lab_jar_material": model.lab.jar_material,
                 "bpr_basis": model.lab.bpr_basis, "calibration_key": calibration_key(s)}, execute)


def plan_plant(s: Scenario) -> Plan:
    """The whole plant for a fresh PET feed: the mill that converts it with the recycle closed
    (its throughput from the conversion per pass and the purge), designed and simulated as in
    `design`; then the flowsheet, costs, MSP, its Monte Carlo band and the tornado."""
    model, scale = s.yield_model, s.scaleup
    if model.rule != "bpr_line" and model.mode == "fixed_time":
        raise ConfigError("study=plant: yield_model.mode=fixed_time leaves the conversion, hence the mill's "
                          "throughput, unknown until the DEM; use yield_model.mode=target_yield")
    fresh = design_mill(scale).pet_feed_kg_per_h
    line_y, _ = bpr_line_yield(scale.bpr, model)
    conversion = (model.target_yield_percent or line_y if model.rule != "bpr_line" else line_y) / 100.0
    if scale.naoh_feed_kg_per_h is not None:
        raise ConfigError("study=plant: give the NaOH as scaleup.naoh_to_stoichiometric (the mill's NaOH follows its "
                          f"throughput), not scaleup.naoh_feed_kg_per_h={scale.naoh_feed_kg_per_h}")
    flowsheet(fresh, conversion, scale.naoh_to_stoichiometric, s.plant)  # refuses no conversion, too little NaOH
    mill_pet = mill_throughput_kg_per_h(fresh, conversion, s.plant.recycle_purge_fraction)
    mill_plan = plan_design(replace(s, scaleup=replace(scale, pet_feed_kg_per_h=mill_pet, region=None)))

    def execute(out_dir: Path) -> dict:
        rec = mill_plan.execute(out_dir)
        mill = Mill(mill_pet, rec["yield_percent"] / 100.0, scale.naoh_to_stoichiometric, rec["dem_power_w"],
                    rec["purchase_cost_usd"])
        plant = evaluate_plant(mill, s.plant, s.economics)
        plant.stream_table().to_csv(out_dir / "streams.csv")
        plant.equipment.to_csv(out_dir / "equipment.csv", index=False)
        spread = monte_carlo(mill, rec["dem_power_se_w"], s.plant, s.economics)
        tornado(mill, rec["dem_power_se_w"], s.plant, s.economics).to_csv(out_dir / "tornado.csv", index=False)
        band = np.percentile(spread, [5, 50, 95]) if len(spread) else [np.nan] * 3
        return rec | plant.record() | {"region": scale.region, "msp_p5_usd_per_kg": band[0],
                                       "msp_p50_usd_per_kg": band[1], "msp_p95_usd_per_kg": band[2]}

    return Plan(mill_plan.record | {"region": scale.region, "plant_fresh_pet_kg_per_h": fresh,
                                    "plant_mill_pet_kg_per_h": mill_pet,
                                    "recycle_purge_fraction": s.plant.recycle_purge_fraction}, execute)


STUDIES: dict[str, Callable[[Scenario], Plan]] = {"design": plan_design, "drum": plan_drum, "lab": plan_lab,
                                                   "yield_calibration": plan_yield_calibration, "plant": plan_plant}


def plan(s: Scenario) -> Plan:
    """The study's plan, with the study's name and kind at the head of its record."""
    p = STUDIES[s.study.kind](s)
    return Plan({"study": s.study.name, "kind": s.study.kind, **p.record}, p.execute)
