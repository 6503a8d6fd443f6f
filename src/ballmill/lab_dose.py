"""The yield model's lab calibration: the MM400 of the kinetics experiments behind the BPR line,
simulated at physical steel stiffness, and its dose rates per kg of balls.

The nominal condition (yield_model.lab: frequency, balls per jar, ball size, jar material)
calibrates the dose line; the same run holds every alternative of the sensitivity study
(yield_model.lab.frequencies_hz x ball_diameters_m x one or two balls).  The result is kept
in <cache_dir>/yield_calibration/<key>/ (collisions.parquet, conditions.csv,
calibration.json), the key hashing what determines it; designs under an energy rule read it
there, and run it first when it is missing (once: other jobs wait for it and reuse it).
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from dataclasses import asdict, replace
from pathlib import Path

import pandas as pd

from .config import MM400_GEOMETRY, ConfigError, SimConfig
from .dose import dose_rates
from .files import exclusive, read_json, write_atomic, write_json
from .lab import conditions, jar_ball_mass_kg, simulate_mm400, wall_interaction
from .scenario import Scenario
from .yields import MEASURE, DoseLine, fit_dose_line

log = logging.getLogger(__name__)
BALLS = (1, 2)  # the MM400 jar holds one or two balls of these sizes


def lab_sim(s: Scenario) -> SimConfig:
    """The lab DEM's numerics: physical stiffness, 20 % of the Rayleigh step, seed 0 (the
    backend, precision and threads of the run)."""
    return SimConfig(arch=s.sim.arch, precision=s.sim.precision, threads=s.sim.threads)


def calibration_key(s: Scenario) -> str:
    payload = {"lab": asdict(s.yield_model.lab), "jar": {k: getattr(s.lab, k) for k in MM400_GEOMETRY},
               "materials": {k: asdict(v) for k, v in s.materials.items()},
               "interactions": {k: asdict(v) for k, v in s.interactions.items()}, "precision": s.sim.precision}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def calibration_folder(s: Scenario) -> Path:
    return s.cache_dir / "yield_calibration" / calibration_key(s)


def kinetics_mills(s: Scenario):
    """(MM400 config, its conditions) per ball count: every frequency x ball size of the study."""
    k = s.yield_model.lab
    freqs = sorted({*k.frequencies_hz, k.frequency_hz})
    sizes = sorted({*k.ball_diameters_m, k.ball_diameter_m})
    for balls in BALLS:
        cfg = replace(s.lab, wall_material=k.jar_material, balls_per_jar=balls, frequencies_hz=freqs,
                      ball_diameters_m=sizes, duration_s=k.duration_s, settle_s=k.settle_s)
        if k.settle_s >= k.duration_s:
            raise ConfigError(f"yield_model.lab.settle_s={k.settle_s} leaves nothing of yield_model.lab.duration_s="
                              f"{k.duration_s} to measure: make it shorter than the duration")
        pair = wall_interaction(s.interactions, cfg)
        yield cfg, conditions(cfg, [pair.restitution], [pair.static_friction])


def calibrated(s: Scenario) -> bool:
    """Whether the lab calibration of these conditions exists."""
    return read_json(calibration_folder(s) / "calibration.json") is not None


def simulate_kinetics_lab(s: Scenario) -> Path:
    """Run the lab DEM (unless its folder holds the finished result) and keep it; the folder."""
    folder = calibration_folder(s)
    with exclusive(folder / ".lock"):  # another job computing it: wait, then reuse
        if not calibrated(s):
            log.info("no lab calibration for these yield_model.lab conditions yet: running it into %s", folder)
            started = time.perf_counter()
            run_kinetics_lab(s, folder)
            log.info("lab calibration done in %.0f s", time.perf_counter() - started)
    return folder


def run_kinetics_lab(s: Scenario, folder: Path) -> None:
    """The lab DEM of every condition, its tables written into `folder`."""
    k = s.yield_model.lab
    rows, logs = [], []
    for cfg, conds in kinetics_mills(s):
        _, collisions = simulate_mm400(cfg, conds, s.materials, s.interactions, lab_sim(s))
        for i, c in enumerate(conds):
            replica = len(rows)
            rows.append({"replica": replica, "balls": cfg.balls_per_jar, "frequency_hz": c.frequency_hz,
                         "ball_diameter_m": c.ball_diameter_m,
                         "ball_mass_kg": jar_ball_mass_kg(cfg, c.ball_diameter_m, s.materials),
                         "nominal": (cfg.balls_per_jar, c.frequency_hz, c.ball_diameter_m)
                         == (k.balls_per_jar, k.frequency_hz, k.ball_diameter_m)})
            logs.append(collisions[collisions.replica == i].assign(replica=replica))
    write_atomic(folder / "collisions.parquet", lambda tmp: pd.concat(logs).to_parquet(tmp, index=False))
    write_atomic(folder / "conditions.csv", lambda tmp: pd.DataFrame(rows).to_csv(tmp, index=False))
    write_json(folder / "calibration.json", {"key": calibration_key(s), "lab": asdict(k), "settle_s": k.settle_s,
                                             "duration_s": k.duration_s, "sim": asdict(lab_sim(s))})


def lab_rates(s: Scenario, threshold_j: float) -> pd.DataFrame:
    """Dose rates per kg of balls of every lab condition (simulated first when missing)."""
    folder = simulate_kinetics_lab(s)
    meta = read_json(folder / "calibration.json")
    conds = pd.read_csv(folder / "conditions.csv")
    collisions = pd.read_parquet(folder / "collisions.parquet")
    rows = [c | dose_rates(collisions[collisions.replica == c["replica"]], meta["settle_s"], meta["duration_s"],
                           c["ball_mass_kg"], threshold_j, s.yield_model.dose_batches)
            for c in conds.to_dict("records")]
    return pd.DataFrame(rows).assign(calibration_dir=str(folder))


def lab_dose_line(s: Scenario) -> DoseLine:
    """The energy rule's dose line, fitted at the nominal lab condition."""
    cfg = s.yield_model
    nominal = lab_rates(s, cfg.impact_threshold_j).query("nominal").iloc[0]
    if cfg.rule == "impact_threshold" and cfg.impact_threshold_j > nominal.largest_impact_j:
        raise ConfigError(f"yield_model.impact_threshold_j={cfg.impact_threshold_j} J is above every impact of the lab "
                          f"calibration (largest {nominal.largest_impact_j:.3g} J): give at most that")
    measure = MEASURE[cfg.rule]
    return fit_dose_line(measure, float(nominal[measure]), float(nominal[f"{measure}_se"]), cfg)
