"""The lab DEM of the kinetics experiments: the MM400 at each lab condition (jar bore and length,
jar and ball materials, balls, ball size, frequency), simulated at physical steel stiffness and
kept under <cache_dir>/lab_dem/<key>/ (collisions.parquet, energy.parquet, condition.json), the
key hashing what determines the run; its dose rates per kg of balls.

Two users: the energy rules' calibration (the nominal condition of yield_model.lab and every
alternative of its sensitivity study: frequencies_hz x ball_diameters_m x one or two balls, and
each jar bore and length; its table in <cache_dir>/yield_calibration/<key>/) and the fit of an
experiments table (each distinct condition of its rows, kinetics.py).  Both run what is missing
first (once: other jobs wait for it and reuse it).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .config import MM400_GEOMETRY, ConfigError, KineticsLabConfig, MM400Config, SimConfig
from .dose import MEASURES, above_threshold, dose_rates
from .files import exclusive, read_json, read_parquet, write_atomic, write_json
from .lab import Condition, jar_ball_mass_kg, jar_inner_length_m, jar_volume_ml, run_mm400, wall_interaction
from .scenario import Scenario
from .yields import DoseLine, fit_dose_line

log = logging.getLogger(__name__)
BALLS = (1, 2)  # the MM400 jar holds one or two balls of these sizes
# the lab group's fields that set a lab run besides the condition: the jar's motion and the camera rate
MOTION = ("amplitude_m", "pivot_radius_m", "camera_fps")


@dataclass(frozen=True)
class LabCondition:
    """One lab DEM run: the jar (bore, length end to end, hemispherical ends), its materials, the
    balls and the shaking frequency."""

    jar_inner_diameter_m: float
    jar_inner_length_m: float
    jar_material: str
    ball_material: str
    ball_diameter_m: float
    balls: int
    frequency_hz: float

    def jar(self, lab: MM400Config, k: KineticsLabConfig) -> MM400Config:
        """The lab group's MM400 holding this condition's jar and balls, run for the kinetics' time."""
        return replace(lab, jar_inner_diameter_m=self.jar_inner_diameter_m, wall_material=self.jar_material,
                       jar_volume_ml=jar_volume_ml(self.jar_inner_diameter_m, self.jar_inner_length_m),
                       ball_material=self.ball_material, balls_per_jar=self.balls, frequencies_hz=[self.frequency_hz],
                       ball_diameters_m=[self.ball_diameter_m], duration_s=k.duration_s, settle_s=k.settle_s)


def lab_sim(sim: SimConfig) -> SimConfig:
    """The lab DEM's numerics: physical stiffness, 20 % of the Rayleigh step, seed 0 (the
    backend, precision and threads of the run)."""
    return SimConfig(arch=sim.arch, precision=sim.precision, threads=sim.threads)


def condition_key(c: LabCondition, s: Scenario) -> str:
    """Hash of what determines a lab run: the condition, the jar's motion, the materials and
    pairs it uses, the kinetics' durations and the engine's precision."""
    k = s.yield_model.lab
    payload = {"condition": asdict(c), "motion": {f: getattr(s.lab, f) for f in MOTION},
               "durations": [k.duration_s, k.settle_s], "starts": k.starts, "precision": s.sim.precision,
               "materials": {m: asdict(s.materials[m]) for m in sorted({c.jar_material, c.ball_material})},
               "interactions": {key: asdict(v) for key, v in s.interactions.items()
                                if set(key.split("-")) <= {c.jar_material, c.ball_material}}}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def condition_folder(c: LabCondition, s: Scenario) -> Path:
    return s.cache_dir / "lab_dem" / condition_key(c, s)


def check_conditions(conds: list[LabCondition], s: Scenario) -> None:
    """What planning can check of lab runs: a window to measure, materials and pairs that exist,
    balls that fit (simulates nothing)."""
    from .lab import mm400_spec

    k = s.yield_model.lab
    if k.settle_s >= k.duration_s:
        raise ConfigError(f"yield_model.lab.settle_s={k.settle_s} leaves nothing of yield_model.lab.duration_s="
                          f"{k.duration_s} to measure: make it shorter than the duration")
    for c in conds:
        if c.jar_inner_length_m < c.jar_inner_diameter_m:
            raise ConfigError(f"a lab jar {c.jar_inner_length_m} m long is shorter than its bore {c.jar_inner_diameter_m} "
                              "m (yield_model.lab.jar_inner_lengths_m, lab.jar_inner_diameter_m): give lengths end to "
                              "end, at least the bore")
        jar = c.jar(s.lab, k)
        pair = wall_interaction(s.interactions, jar)
        mm400_spec(jar, [Condition(c.frequency_hz, c.ball_diameter_m, pair.restitution, pair.static_friction)],
                   s.materials, s.interactions, lab_sim(s.sim))


def simulate_conditions(conds: list[LabCondition], s: Scenario) -> list[Path]:
    """The lab run of each condition (those missing simulated first); their cache folders."""
    folders = [condition_folder(c, s) for c in conds]
    with exclusive(s.cache_dir / "lab_dem" / ".lock"):  # another job computing them: wait, then reuse
        missing = [(c, f) for c, f in zip(conds, folders) if read_json(f / "condition.json") is None]
        if missing:
            log.info("lab DEM of %d kinetics conditions not yet in %s: running them", len(missing),
                     s.cache_dir / "lab_dem")
            started = time.perf_counter()
            for c, folder in missing:
                simulate_condition(c, folder, s)
            log.info("lab DEM done in %.0f s", time.perf_counter() - started)
    return folders


def simulate_condition(c: LabCondition, folder: Path, s: Scenario) -> None:
    """One condition from yield_model.lab.starts starts (replicas of one run, each drawing its own
    small initial velocity; alone in its run, so that its time step and its starts are the
    condition's own); its tables into its folder (condition.json, the mark of a finished run, last)."""
    k = s.yield_model.lab
    jar = c.jar(s.lab, k)
    pair = wall_interaction(s.interactions, jar)
    runs = [Condition(c.frequency_hz, c.ball_diameter_m, pair.restitution, pair.static_friction, start)
            for start in range(k.starts)]
    res = run_mm400(jar, runs, s.materials, s.interactions, lab_sim(s.sim), frames_per_sample(jar))
    for name, frame in (("collisions", res.collisions), ("energy", res.energy)):
        write_atomic(folder / f"{name}.parquet", lambda tmp, f=frame: f.to_parquet(tmp, index=False))
    write_json(folder / "condition.json", {"key": condition_key(c, s), "condition": asdict(c), "starts": k.starts,
                                           "settle_s": k.settle_s, "duration_s": k.duration_s,
                                           "ball_mass_kg": jar_ball_mass_kg(jar, c.ball_diameter_m, s.materials),
                                           "sim": asdict(lab_sim(s.sim))})


def frames_per_sample(jar: MM400Config) -> int:
    """The longest sampling, in camera frames, that keeps the samples booked_j reads: the frames
    nearest the settling's end (the first, for none) and the run's end.  The kinetics read only
    the collision log and those two samples; at the camera rate (6,402 samples for 3 s) a run
    spends most of its time reading samples, not stepping.  A time halfway between two frames
    keeps both (which one is nearer is then the round-off's to decide)."""
    frames = []
    for t in (jar.settle_s, jar.duration_s):
        x = t * jar.camera_fps
        below = math.floor(x)
        frames += [below, below + 1] if abs(x - below - 0.5) < 1e-6 else [round(x)]
    return math.gcd(*(max(f, 1) for f in frames))


def condition_rates(folder: Path, threshold_j: float, batches: int) -> dict:
    """Dose rates per kg of balls of one cached lab condition, its starts pooled (their mean), above
    `threshold_j` for the impact measures, with the share of the window's dissipation the log
    books.  A rate's standard error is its batch means', or the spread of its starts' rates where
    larger (a ball may slide in place from one start and bounce end to end from another)."""
    meta = read_json(folder / "condition.json")
    collisions, energy = (read_parquet(folder / f"{n}.parquet") for n in ("collisions", "energy"))
    window, mass, starts = (meta["settle_s"], meta["duration_s"]), meta["ball_mass_kg"], meta["starts"]
    pooled = dose_rates(collisions, *window, mass * starts, threshold_j, batches, energy=energy)
    if starts > 1:
        each = [dose_rates(collisions[collisions.replica == r], *window, mass, threshold_j, batches)
                for r in range(starts)]
        for m in MEASURES:
            spread = float(np.std([e[m] for e in each], ddof=1) / np.sqrt(starts))
            pooled[f"{m}_se"] = max(pooled[f"{m}_se"], spread)
    return pooled | {"ball_mass_kg": mass, "starts": starts}


# The energy rules' calibration: the nominal condition and its alternatives.


def nominal_condition(s: Scenario) -> LabCondition:
    k = s.yield_model.lab
    return LabCondition(s.lab.jar_inner_diameter_m, jar_inner_length_m(s.lab), k.jar_material, s.lab.ball_material,
                        k.ball_diameter_m, k.balls_per_jar, k.frequency_hz)


def calibration_conditions(s: Scenario) -> list[LabCondition]:
    """The nominal condition first, then every alternative: frequencies x ball sizes x one or two
    balls, and each jar bore and length at the nominal condition."""
    k, nominal = s.yield_model.lab, nominal_condition(s)
    freqs = sorted({*k.frequencies_hz, k.frequency_hz})
    sizes = sorted({*k.ball_diameters_m, k.ball_diameter_m})
    grid = [replace(nominal, frequency_hz=f, ball_diameter_m=d, balls=b) for b in BALLS for f in freqs for d in sizes]
    jars = [replace(nominal, jar_inner_diameter_m=bore) for bore in k.jar_inner_diameters_m]
    jars += [replace(nominal, jar_inner_length_m=length) for length in k.jar_inner_lengths_m]
    return list(dict.fromkeys([nominal, *grid, *jars]))


def calibration_key(s: Scenario) -> str:
    payload = {"lab": asdict(s.yield_model.lab), "jar": {k: getattr(s.lab, k) for k in (*MM400_GEOMETRY, *MOTION)},
               "conditions": [condition_key(c, s) for c in calibration_conditions(s)]}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def calibration_folder(s: Scenario) -> Path:
    return s.cache_dir / "yield_calibration" / calibration_key(s)


def calibrated(s: Scenario) -> bool:
    """Whether the lab calibration of these conditions exists."""
    return read_json(calibration_folder(s) / "calibration.json") is not None


def simulate_kinetics_lab(s: Scenario) -> Path:
    """The calibration's lab runs (those missing simulated first) and its table; the folder."""
    folder = calibration_folder(s)
    if not calibrated(s):
        log.info("no lab calibration for these yield_model.lab conditions yet: running it into %s", folder)
        started = time.perf_counter()
        conds = calibration_conditions(s)
        dirs = simulate_conditions(conds, s)
        nominal = conds[0]
        rows = [asdict(c) | {"nominal": c == nominal, "lab_dem_dir": str(d)} for c, d in zip(conds, dirs)]
        write_atomic(folder / "conditions.csv", lambda tmp: pd.DataFrame(rows).to_csv(tmp, index=False))
        k = s.yield_model.lab
        write_json(folder / "calibration.json", {"key": calibration_key(s), "lab": asdict(k), "settle_s": k.settle_s,
                                                 "duration_s": k.duration_s, "sim": asdict(lab_sim(s.sim))})
        log.info("lab calibration done in %.0f s", time.perf_counter() - started)
    return folder


def lab_rates(s: Scenario, threshold_j: float) -> pd.DataFrame:
    """Dose rates per kg of balls of every calibration condition (simulated first when missing)."""
    folder = simulate_kinetics_lab(s)
    conds = pd.read_csv(folder / "conditions.csv")
    rows = [c | condition_rates(Path(c["lab_dem_dir"]), threshold_j, s.yield_model.dose_batches)
            for c in conds.to_dict("records")]
    return pd.DataFrame(rows).assign(calibration_dir=str(folder))


def lab_dose_line(s: Scenario, naoh_kg_per_kg_pet: float, measure: str) -> DoseLine:
    """A dose rule's line on one of dose.py's rates (`measure`), fitted at the nominal lab
    condition, the lab's powder at the mill's NaOH:PET ratio."""
    cfg = s.yield_model
    nominal = lab_rates(s, cfg.impact_threshold_j).query("nominal").iloc[0]
    if above_threshold(measure) and cfg.impact_threshold_j > nominal.largest_impact_j:
        raise ConfigError(f"yield_model.impact_threshold_j={cfg.impact_threshold_j} J is above every impact of the lab "
                          f"calibration (largest {nominal.largest_impact_j:.3g} J): give at most that")
    return fit_dose_line(measure, float(nominal[measure]), float(nominal[f"{measure}_se"]), cfg, naoh_kg_per_kg_pet)

