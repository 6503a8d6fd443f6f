"""A design's mechanics: the DEM of its mill (cached) or the surrogate's prediction, its power
and dose rates; the checks of the numerics and the machine every DEM study makes first."""

from __future__ import annotations

import logging
import math
import os
from dataclasses import replace
from pathlib import Path

from .. import yield_rules
from ..config import BallSizeConfig, ConfigError, DrumConfig, SimConfig
from ..dem import SystemSpec
from ..dose import MEASURES, dose_rates
from ..drum import DrumRun, ball_radii_as_run, dem_key, drum_spec, drum_speed_rpm, sim_in_seconds, simulate_drum
from ..liner import liner_profile
from ..plots import plot_bed, plot_drum_loads, save_figure
from ..scenario import Scenario, time_step_s
from ..surrogate.model import load as load_surrogate
from ..surrogate.model import predict_drum
from .plan import prefixed

log = logging.getLogger(__name__)
DT_WARN_FRACTION = 0.4  # LIGGGHTS and EDEM advise 20-40 % of the Rayleigh step; warn above
DENSE_BED_CONTACTS = 12  # a ball in a dense bed touches up to 12 others (plus walls)
MIN_SAMPLES = 2  # a mean power needs samples; its standard error needs many (10 batches)


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


def run_dose(run: DrumRun, mass_kg: float, threshold_j: float, batches: int) -> dict:
    """Dose rates of a drum run per kg of `mass_kg` over its averaging window (impacts of at least
    threshold_j), with the share of the window's dissipation its collision log books."""
    return dose_rates(run.results.collisions, run.summary["averaging_from_s"], run.summary["simulated_s"], mass_kg,
                      threshold_j, batches, energy=run.results.energy)


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
    if yield_rules.rule_of(s.yield_model.rule).needs_spectrum(s):
        raise ConfigError(f"dem=surrogate: yield_model.rule={s.yield_model.rule} needs the impact spectrum, which the "
                          "surrogate does not predict; use dem=full, or yield_model=specific_energy")
    if design is None:
        load_surrogate(s.dem.table)  # its table exists
    else:  # and the design lies inside its training runs, or dem.outside sends it to the DEM
        surrogate_prediction(s, mill_drum(s.mill, design))


def surrogate_prediction(s: Scenario, drum) -> dict | None:
    """The surrogate's prediction for the drum, or None where dem.outside=full sends it to the DEM
    (outside the training runs' hull, extrapolation not allowed); refused outside under dem.outside=refuse."""
    sends = s.dem.outside == "full" and not s.dem.allow_extrapolation
    p = predict_drum(load_surrogate(s.dem.table), drum, s.materials, s.interactions, s.dem.allow_extrapolation or sends)
    return None if sends and not p["inside_hull"] else p


def mechanics(s: Scenario, design, threshold_j: float, out_dir: Path | None = None) -> tuple[dict, dict]:
    """The design's mill: its record (dem_*: power, its standard error, ...) and its dose rates
    per kg of PET held up (impacts of at least threshold_j), from the DEM (dem=full, or a design
    outside the surrogate's runs with dem.outside=full, marked) or the surrogate (dem=surrogate, marked)."""
    drum, pet_kg = mill_drum(s.mill, design), pet_holdup_kg(design)
    p = surrogate_prediction(s, drum) if s.dem.mode == "surrogate" else None
    if p is None:
        run, dem_dir = run_drum(s, drum, out_dir)
        return (drum_record(run, dem_dir) | {"dem_source": "full", "dem_outside_surrogate": s.dem.mode == "surrogate"},
                run_dose(run, pet_kg, threshold_j, s.yield_model.dose_batches))
    record = prefixed(p, "dem") | {"dem_source": "surrogate", "dem_table": s.dem.table}
    unknown = {k: float("nan") for m in MEASURES for k in (m, f"{m}_se")}  # the surrogate predicts collision power
    return record, unknown | {"impact_threshold_j": threshold_j,
                              "collision_power_w_per_kg": p["collision_power_w"] / pet_kg,
                              "collision_power_w_per_kg_se": p["collision_power_se_w"] / pet_kg}
