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
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import pandas as pd

from .config import MM400_GEOMETRY, BallSizeConfig, ConfigError, DrumConfig, SimConfig
from .data import lookup, table
from .dem import SimulationError, SystemSpec
from .dose import MEASURES, dose_j_per_kg, dose_rates, with_basis
from .drum import (
    DrumRun,
    ball_radii_as_run,
    charge_fill,
    charge_mass_kg,
    dem_key,
    drum_spec,
    drum_speed_rpm,
    mean_ball_diameter_m,
    sim_in_seconds,
    simulate_drum,
)
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
)
from .liner import liner_profile
from .plots import plot_bed, plot_drum_loads, save_figure
from .scaleup import design_mill
from .scenario import Scenario, time_step_s
from .surrogate.model import load as load_surrogate
from .surrogate.model import predict_drum
from .surrogate.optimise import KNOBS, annualised_cost_usd_per_yr, design_knobs, knob_ranges, knob_scaleup, minimise
from .surrogate.training import revolution_sim
from .yields import MEASURE, DoseLine, NotConverged, bpr_line_yield, fit_dose_line, line_yield, solve_residence_time

log = logging.getLogger(__name__)
DT_WARN_FRACTION = 0.4  # LIGGGHTS and EDEM advise 20-40 % of the Rayleigh step; warn above
DENSE_BED_CONTACTS = 12  # a ball in a dense bed touches up to 12 others (plus walls)
MIN_SAMPLES = 2  # a mean power needs samples; its standard error needs many (10 batches)
INFEASIBLE_USD = 1e12  # an optimiser trial's cost when its mill cannot be built (the trial is marked infeasible)


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


def check_window(sim: SimConfig, drum: DrumConfig) -> None:
    """An averaging window with samples in it, for the drum's speed."""
    sim = sim_in_seconds(sim, drum_speed_rpm(drum))
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
    run = simulate_drum(drum, s.materials, s.interactions, s.sim, dem_dir, s.cache_dir / "beds")
    if out_dir is not None:
        run.results.loads.to_csv(out_dir / "loads.csv", index=False)
        save_figure(plot_drum_loads(run.results.loads, steady_after_s=run.summary["averaging_from_s"]),
                    out_dir / "drum_loads")
        if len(run.results.trajectories):
            save_figure(plot_bed(run.results.trajectories, ball_radii_as_run(drum, s.sim.seed), liner_profile(drum),
                                 drum_speed_rpm(drum) * math.pi / 30, s.sim.settle_s, run.summary), out_dir / "bed")
    return run, dem_dir


def drum_record(run: DrumRun, dem_dir: Path) -> dict:
    return prefixed(run.summary, "dem") | {"dem_dir": str(dem_dir)}


def run_dose(run: DrumRun, mass_kg: float, s: Scenario) -> dict:
    """Dose rates of a drum run per kg of `mass_kg`, over its averaging window."""
    return dose_rates(run.results.collisions, run.summary["averaging_from_s"], run.summary["simulated_s"], mass_kg,
                      s.yield_model.impact_threshold_j, s.yield_model.dose_batches)


def plan_drum(s: Scenario) -> Plan:
    """The mill group's drum as configured: torque, power, and dose rates per kg of balls."""
    if s.dem.mode != "full":
        raise ConfigError("dem=surrogate: study=drum is the DEM of the mill group's drum; the surrogate serves "
                          "study=design, plant and cheapest_mill")
    check_window(s.sim, s.mill)
    check_numerics(drum_spec(s.mill, s.materials, s.interactions, s.sim), s.sim, "mill")

    def execute(out_dir: Path) -> dict:
        run, dem_dir = run_drum(s, s.mill, out_dir)
        balls = charge_mass_kg(s.mill, s.materials[s.mill.ball_material].density_kg_per_m3)
        wall = wall_interaction(s.interactions, s.mill)
        return (drum_record(run, dem_dir) | with_basis(run_dose(run, balls, s), "balls")
                | {"experiment": s.study.experiment, "ball_mass_kg": balls, "wall_restitution": wall.restitution,
                   "wall_friction": wall.static_friction, "liner": s.mill.liner.kind,
                   "bond_rowland_power_w": bond_rowland_power_w(
                       s.mill.inner_diameter_m, balls, charge_fill(s.mill), run.summary["speed_rpm"]
                       / run.summary["critical_speed_rpm"], mean_ball_diameter_m(s.mill))})

    return Plan({}, execute)


def mill_drum(mill: DrumConfig, design) -> DrumConfig:
    """The designed mill as a drum: its size, speed and charge (graded when the scale-up's is), the
    mill group's liner (lifters sized by height_to_diameter grow with it)."""
    charge = [BallSizeConfig(d, n) for d, n in zip(design.charge_diameters_m, design.charge_counts)]
    return replace(mill, inner_diameter_m=design.diameter_m, inner_length_m=design.length_m,
                   ball_radius_m=design.ball_radius_m, ball_count=design.ball_count, speed_rpm=design.speed_rpm,
                   charge=charge)


def pet_holdup_kg(design) -> float:
    return design.pet_feed_kg_per_h * design.residence_time_min / 60


def check_dem_mode(s: Scenario, design=None) -> None:
    """The surrogate knows shaft and collision power, not the impact spectrum; its table exists
    and (unless extrapolation is allowed) the design's mill lies inside its training runs."""
    if s.dem.mode != "surrogate":
        return
    if s.yield_model.rule == "impact_threshold":
        raise ConfigError("dem=surrogate: yield_model.rule=impact_threshold needs the impact spectrum, which the "
                          "surrogate does not predict; use dem=full, or yield_model=specific_energy")
    model = load_surrogate(s.dem.table)
    if design is not None:
        predict_drum(model, mill_drum(s.mill, design), s.materials, s.interactions, s.dem.allow_extrapolation)


def mechanics(s: Scenario, design, out_dir: Path | None = None) -> tuple[dict, dict]:
    """The design's mill: its record (dem_*: power, its standard error, ...) and its dose rates
    per kg of PET held up, from the DEM (dem=full) or the surrogate (dem=surrogate, marked)."""
    drum, pet_kg = mill_drum(s.mill, design), pet_holdup_kg(design)
    if s.dem.mode == "full":
        run, dem_dir = run_drum(s, drum, out_dir)
        return drum_record(run, dem_dir) | {"dem_source": "full"}, run_dose(run, pet_kg, s)
    p = predict_drum(load_surrogate(s.dem.table), drum, s.materials, s.interactions, s.dem.allow_extrapolation)
    record = prefixed(p, "dem") | {"dem_source": "surrogate", "dem_table": s.dem.table}
    unknown = {k: float("nan") for m in MEASURES for k in (m, f"{m}_se")}  # the surrogate predicts collision power
    return record, unknown | {"impact_threshold_j": s.yield_model.impact_threshold_j,
                              "collision_power_w_per_kg": p["collision_power_w"] / pet_kg,
                              "collision_power_w_per_kg_se": p["collision_power_se_w"] / pet_kg}


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
        rates = lab_rates(s, model.impact_threshold_j)  # simulated first when missing
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


def mill_throughput_kg_per_h(fresh_pet_kg_per_h: float, conversion: float, purge: float) -> float:
    """PET through the mill for a fresh feed, a conversion per pass and a purge of the unreacted PET."""
    return fresh_pet_kg_per_h / (1.0 - (1.0 - purge) * (1.0 - conversion))


PLANT_PRICES = {"pet_bale", "naoh", "h2so4", "tpa", "eg", "low_pressure_steam", "medium_pressure_steam",
                "high_pressure_steam", "cooling_tower_chemicals", "process_water", "cod_removal", "disposal",
                "na2so4_sale"}


def check_plant_tables(plant, prices_file: str) -> None:
    """The plant's data tables hold the columns and rows its config names (before BioSTEAM is
    imported)."""
    keys = set(table("cost_correlations.csv").key)
    for name in ("granulator_cost", "pulveriser_cost", "evaporator_cost", "crystallizer_cost"):
        if getattr(plant, name) not in keys:
            raise ConfigError(f"plant.{name}={getattr(plant, name)!r} is not a row of data/cost_correlations.csv; "
                              f"have {sorted(keys)}")
    for name, columns in ((prices_file, ["item", "price_usd_per_t"]), ("ghg_factors.csv", ["item", "kg_co2e"]),
                          ("staffing.csv", ["unit", "workers_per_unit_per_shift"]),
                          ("plant_chemicals.csv", ["chemical", "property", "value"]),
                          ("plant_uncertainty.csv", ["parameter", "distribution", "scale", "low", "high"]),
                          ("egrid2022_states.csv", ["region", "co2e_lb_per_mwh"]), (plant.depreciation_file, ["fraction"])):
        missing = [c for c in columns if c not in table(name)]
        if missing:
            raise ConfigError(f"data table {name} lacks the columns {missing}")
    missing = sorted(PLANT_PRICES - set(table(prices_file).item))
    if missing:
        raise ConfigError(f"economics.prices_file={prices_file}: no price for {missing} (the plant needs them)")
    lookup("cepci.csv", "year", plant.cost_year, "cepci")


def plan_plant(s: Scenario) -> Plan:
    """The whole plant for a fresh PET feed: the mill that converts it with the recycle closed
    (its throughput from the conversion per pass and the purge), designed and simulated as in
    `design`; then the plant around it on BioSTEAM (plant/study.py): MSP and footprint, their
    Monte Carlo band, the tornado and the tables."""
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
    if not 0.0 < conversion <= 1.0:
        raise ConfigError(f"study=plant: the mill's conversion per pass is {conversion:.3g}; it must lie in (0, 1] "
                          "(a yield of 0 % makes no product: raise the BPR or the residence time)")
    if scale.naoh_to_stoichiometric < conversion:
        raise ConfigError(f"scaleup.naoh_to_stoichiometric={scale.naoh_to_stoichiometric} is below the conversion "
                          f"{conversion:.3g}: the mill would run out of NaOH")
    check_plant_tables(s.plant, s.economics.prices_file)
    mill_pet = mill_throughput_kg_per_h(fresh, conversion, s.plant.recycle_purge_fraction)
    mill_plan = plan_design(replace(s, scaleup=replace(scale, pet_feed_kg_per_h=mill_pet, region=None)))

    def execute(out_dir: Path) -> dict:
        from .plant.study import run as run_plant  # BioSTEAM: seconds to import, only here
        from .plant.system import MillSpec

        rec = mill_plan.execute(out_dir)
        to_cost_year = (lookup("cepci.csv", "year", s.plant.cost_year, "cepci")
                        / lookup("cepci.csv", "year", s.economics.cepci_target_year, "cepci"))
        mill = MillSpec(mill_pet, rec["yield_percent"] / 100.0, scale.naoh_to_stoichiometric,
                        rec["dem_power_w"] / 1000.0, rec["purchase_cost_usd"] * to_cost_year,
                        {"Diameter": rec["diameter_m"], "Length": rec["length_m"], "Balls": rec["ball_count"],
                         "Residence time": rec["residence_time_min"]})
        return rec | run_plant(mill, s.plant, s.economics, scale.region, rec["dem_power_se_w"] / 1000.0, out_dir)

    return Plan(mill_plan.record | {"region": scale.region, "plant_fresh_pet_kg_per_h": fresh,
                                    "plant_mill_pet_kg_per_h": mill_pet,
                                    "recycle_purge_fraction": s.plant.recycle_purge_fraction}, execute)


def plan_cheapest_mill(s: Scenario) -> Plan:
    """The cheapest mill for the feed and target yield (surrogate/optimise.py): the paper's mill
    (the scale-up as configured) and the optimum over speed, fill, ball size and L/D, both by the
    surrogate; what each knob is worth (the optimum with that knob back at the paper's value);
    then both mills confirmed by the DEM at the surrogate's residence time (optimiser.confirm),
    with the surrogate's error on each."""
    model = s.yield_model
    if model.rule != "bpr_line" and model.mode == "fixed_time":
        raise ConfigError("study=cheapest_mill: yield_model.mode=fixed_time gives no target to reach; "
                          "use yield_model.mode=target_yield")
    fast = replace(s, dem=replace(s.dem, mode="surrogate"))
    check_dem_mode(fast)
    y = yield_plan(s)
    ranges = knob_ranges(s.optimiser)
    paper = design_mill(s.scaleup)
    check_window(s.sim, mill_drum(s.mill, paper))
    check_design(s, paper)
    record = {"bpr": s.scaleup.bpr, "region": s.scaleup.region, "yield_rule": model.rule,
              "bpr_line_yield_percent": y.line_yield_percent, "optimiser_trials": s.optimiser.trials,
              "optimiser_seed": s.optimiser.seed} | y.record(s)

    def at(scale, extrapolate: bool = False):
        fit = replace(fast, scaleup=scale, dem=replace(fast.dem, allow_extrapolation=extrapolate))
        rec, design = evaluate_design(fit, y.line, y.target)
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
        dem, rates = mechanics(full, design, folder)
        rec = dem | mill_record(full, design, dem, rates, y.line)
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


def prefixed(record: dict, prefix: str) -> dict:
    return {f"{prefix}_{k}": v for k, v in record.items()}


STUDIES: dict[str, Callable[[Scenario], Plan]] = {"design": plan_design, "drum": plan_drum, "lab": plan_lab,
                                                   "yield_calibration": plan_yield_calibration, "plant": plan_plant,
                                                   "cheapest_mill": plan_cheapest_mill}


def plan(s: Scenario) -> Plan:
    """The study's plan, with the study's name and kind at the head of its record."""
    p = STUDIES[s.study.kind](s)
    return Plan({"study": s.study.name, "kind": s.study.kind, **p.record}, p.execute)
