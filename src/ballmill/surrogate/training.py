"""The surrogate's training data: drum DEMs on a space-filling design of the dimensionless groups.

Training points: a scrambled Sobol sequence over the box of SurrogateConfig.bounds.  Held-out
points: a Latin hypercube (another seed) kept where it lies inside the training points' hull,
the region the surrogate answers for.  Each point is a drum of 80 mm balls (D from D/d), run
like any other (cached under <cache_dir>/dem/<key>: an interrupted training resumes with the
finished runs), at the surrogate's protocol (sim=surrogate: settled, then turned for its
start-up and window revolutions, revolution_sim); the power number and collision power number are averaged over the window with their standard
errors.  The table carries the resolved settings and its source in columns and a JSON beside it.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from scipy.stats import qmc

from ..config import ConfigError, SimConfig, SurrogateBounds, SurrogateConfig
from ..dem import SimulationError
from ..dose import dose_rates
from ..drum import ball_count, dem_key, drum_speed_rpm, sim_in_seconds, simulate_drum
from ..files import write_atomic, write_json
from ..scenario import Scenario
from .space import INPUTS, drum_at, power_scale_w

log = logging.getLogger(__name__)
SOURCE = "ballmill drum DEM (Hertz-Mindlin, sim=surrogate); regenerate with `ballmill surrogate`"
HOLDOUT_DRAWS = 20  # Latin-hypercube candidates per held-out point wanted (most fall outside the hull in 6-D)


def box(bounds: SurrogateBounds) -> tuple[np.ndarray, np.ndarray]:
    """Low and high ends of every input, in INPUTS order."""
    return np.array([getattr(bounds, k)[0] for k in INPUTS]), np.array([getattr(bounds, k)[1] for k in INPUTS])


def inside_hull(points: np.ndarray, training: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Which points lie in the convex hull of the training points (all scaled to the unit box)."""
    from scipy.spatial import Delaunay

    return Delaunay((training - lo) / (hi - lo)).find_simplex((points - lo) / (hi - lo)) >= 0


def design(cfg: SurrogateConfig) -> pd.DataFrame:
    """The points to simulate: `points` Sobol points (split=train), then up to `holdout`
    Latin-hypercube points inside their hull (split=holdout)."""
    lo, hi = box(cfg.bounds)
    train = qmc.scale(qmc.Sobol(len(INPUTS), scramble=True, seed=cfg.seed).random(cfg.points), lo, hi)
    frames = [pd.DataFrame(train, columns=INPUTS).assign(split="train")]
    if cfg.holdout:
        candidates = qmc.scale(qmc.LatinHypercube(len(INPUTS), seed=cfg.seed + 1).random(cfg.holdout * HOLDOUT_DRAWS),
                               lo, hi)
        held = candidates[inside_hull(candidates, train, lo, hi)][:cfg.holdout]
        frames.append(pd.DataFrame(held, columns=INPUTS).assign(split="holdout"))
    return pd.concat(frames, ignore_index=True).rename_axis("point").reset_index()


def revolution_sim(sim: SimConfig, speed_rpm: float) -> SimConfig:
    """A drum's run at the preset's start-up and window, 100 samples a revolution (in seconds)."""
    return sim_in_seconds(replace(sim, sample_every_s=60.0 / speed_rpm / 100), speed_rpm)


def simulate_point(s: Scenario, cfg: SurrogateConfig, point: dict) -> dict:
    """One design point's DEM (cached) and its dimensionless outputs with standard errors."""
    drum, pairs = drum_at(point, cfg.ball_radius_m, s.mill, s.interactions)
    speed = drum_speed_rpm(drum)
    sim = revolution_sim(s.sim, speed)
    key = dem_key(drum, s.materials, pairs, sim)
    started = time.time()
    try:
        run = simulate_drum(drum, s.materials, pairs, sim, s.cache_dir / "dem" / key, s.cache_dir / "beds")
    except (SimulationError, ConfigError) as exc:  # recorded: the other points carry on
        return {**point, "dem_key": key, "status": f"failed: {exc}"}
    n = ball_count(drum)
    mass = n * s.materials[drum.ball_material].density_kg_per_m3 * 4 / 3 * math.pi * drum.ball_radius_m**3
    scale = power_scale_w(mass, drum.inner_diameter_m, speed)
    rates = dose_rates(run.results.collisions, run.summary["averaging_from_s"], run.summary["simulated_s"], mass,
                       s.yield_model.impact_threshold_j, s.yield_model.dose_batches)
    collision = rates["collision_power_w_per_kg"] * mass
    out = {
        **point, "balls": n, "ball_mass_kg": mass, "diameter_m": drum.inner_diameter_m,
        "length_m": drum.inner_length_m, "speed_rpm": speed, "power_w": run.summary["power_w"],
        "power_se_w": run.summary["power_se_w"], "power_number": run.summary["power_w"] / scale,
        "power_number_se": run.summary["power_se_w"] / scale, "collision_power_number": collision / scale,
        "collision_power_number_se": rates["collision_power_w_per_kg_se"] * mass / scale,
        "impact_power_share": rates["impact_power_w_per_kg"] / max(rates["collision_power_w_per_kg"], 1e-300),
        "impact_threshold_j": rates["impact_threshold_j"], "dem_key": key, "status": "ok",
        "wall_time_s": time.time() - started,
    }
    return out


def train_table(s: Scenario, cfg: SurrogateConfig) -> pd.DataFrame:
    """Simulate every design point (cfg.jobs at a time, one Taichi thread each) into one table."""
    points = design(cfg).to_dict("records")
    sim = replace(s.sim, threads=1 if cfg.jobs > 1 else s.sim.threads)
    log.info("surrogate training: %d runs (%d held out), %d at a time", len(points),
             sum(p["split"] == "holdout" for p in points), cfg.jobs)
    rows = []
    for row in Parallel(n_jobs=cfg.jobs, return_as="generator_unordered")(
            delayed(simulate_point)(replace(s, sim=sim), cfg, p) for p in points):
        rows.append(row)
        log.info("surrogate training: %d of %d runs done (point %d: %s, %.0f s)", len(rows), len(points),
                 row["point"], row["status"], row.get("wall_time_s", 0.0))
    table = pd.DataFrame(rows).sort_values("point")
    return table.assign(source=SOURCE, year=time.gmtime().tm_year, url="", ball_radius_m=cfg.ball_radius_m,
                        settle_s=s.sim.settle_s, startup_revolutions=s.sim.startup_revolutions,
                        window_revolutions=s.sim.window_revolutions, shear_modulus_scale=s.sim.shear_modulus_scale)


def write_table(table: pd.DataFrame, s: Scenario, cfg: SurrogateConfig, out_dir: Path) -> Path:
    """surrogate_training.csv and, beside it, the settings that produced it (JSON)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "surrogate_training.csv"
    write_atomic(path, lambda tmp: table.to_csv(tmp, index=False))
    write_json(out_dir / "surrogate_training.json", {
        "command": "ballmill surrogate", "options": asdict(cfg), "sim": asdict(s.sim), "dem": asdict(s.dem),
        "materials": {k: asdict(v) for k, v in s.materials.items()},
        "interactions": {k: asdict(v) for k, v in s.interactions.items()}, "mill": asdict(s.mill),
        "source": SOURCE})
    return path
