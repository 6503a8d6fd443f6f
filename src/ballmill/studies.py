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
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from .config import MM400_GEOMETRY, ConfigError, DrumConfig, SimConfig
from .dem import SimulationError, SystemSpec
from .drum import dem_key, drum_spec, simulate_drum
from .economics import bond_rowland_power_w, evaluate, margin_usd_per_t_tpa, purchase_cost_usd, yield_percent
from .lab import conditions, mm400_spec, simulate_mm400, summarise, wall_interaction
from .plots import plot_bed, plot_drum_loads, save_figure
from .scaleup import design_mill
from .scenario import Scenario, time_step_s

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


def plan_drum(s: Scenario, drum: DrumConfig | None = None, record: dict | None = None, economics=None) -> Plan:
    """The drum DEM (cached by dem_key under cache_dir) and its figures; economics if a design."""
    drum = drum or s.mill
    sim = s.sim
    if sim.steady_after_s >= sim.duration_s:
        raise ConfigError(f"sim.steady_after_s={sim.steady_after_s} leaves no samples to average in "
                          f"sim.duration_s={sim.duration_s}: make it shorter than the duration")
    if sim.sample_every_s > (sim.duration_s - sim.steady_after_s) / MIN_SAMPLES:
        raise ConfigError(f"sim.sample_every_s={sim.sample_every_s} gives fewer than {MIN_SAMPLES} samples in the "
                          f"averaging window of {sim.duration_s - sim.steady_after_s:g} s: sample more often")
    check_numerics(drum_spec(drum, s.materials, s.interactions, sim), sim, "mill")
    dem_dir = s.cache_dir / "dem" / dem_key(drum, s.materials, s.interactions, sim)

    def execute(out_dir: Path) -> dict:
        check_machine(sim)
        run = simulate_drum(drum, s.materials, s.interactions, sim, dem_dir)
        out = {f"dem_{k}": v for k, v in run.summary.items()} | {"dem_dir": str(dem_dir)}
        run.results.loads.to_csv(out_dir / "loads.csv", index=False)
        save_figure(plot_drum_loads(run.results.loads, steady_after_s=sim.settle_s + sim.steady_after_s),
                    out_dir / "drum_loads")
        if len(run.results.trajectories):
            save_figure(plot_bed(run.results.trajectories, drum.ball_radius_m, drum.inner_diameter_m / 2),
                        out_dir / "bed")
        if economics:
            out |= economics(run.summary["power_w"])
        return out

    return Plan(record or {}, execute)


def plan_design(s: Scenario) -> Plan:
    """Scale-up of the feed to a mill, whose DEM power gives the electricity; costs and margin."""
    scale, econ = s.scaleup, s.economics
    yield_percent(scale.bpr, econ)  # an out-of-range BPR is refused here
    design = design_mill(scale)
    purchase_cost_usd(design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, econ)  # the data tables exist
    margin_usd_per_t_tpa(econ)
    drum = replace(s.mill, inner_diameter_m=design.diameter_m, inner_length_m=design.length_m,
                   ball_radius_m=design.ball_radius_m, ball_count=design.ball_count, speed_rpm=design.speed_rpm)

    def economics(power_w: float) -> dict:
        return evaluate(power_w, scale.bpr, design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, econ) | {
            "bond_rowland_power_w": bond_rowland_power_w(design.diameter_m, design.ball_mass_kg, scale.fill_fraction,
                                                         design.fraction_of_critical, 2 * design.ball_radius_m)}

    record = {"bpr": scale.bpr, "region": scale.region, "shape_rule": scale.shape_rule, **design.as_record()}
    return plan_drum(s, drum, record, economics)


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
        summary = summarise(traj, collisions, lab, conds).assign(
            balls=lab.balls_per_jar, **{k: getattr(lab, k) for k in MM400_GEOMETRY})
        if summary.mean_speed_m_per_s.isna().any():
            raise SimulationError(f"lab: no ball speed after lab.settle_s={lab.settle_s} s of "
                                  f"lab.duration_s={lab.duration_s} s: lengthen the run")
        summary.to_csv(out_dir / "lab_summary.csv", index=False)
        return {}

    return Plan({"balls": lab.balls_per_jar, "wall_restitution": pair.restitution,
                 "wall_friction": pair.static_friction, "conditions": len(conds),
                 "observations": s.study.observations}, execute)


STUDIES: dict[str, Callable[[Scenario], Plan]] = {"design": plan_design, "drum": plan_drum, "lab": plan_lab}


def plan(s: Scenario) -> Plan:
    """The study's plan, with the study's name and kind at the head of its record."""
    p = STUDIES[s.study.kind](s)
    return Plan({"study": s.study.name, "kind": s.study.kind, **p.record}, p.execute)
