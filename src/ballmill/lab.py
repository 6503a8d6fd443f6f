"""The Retsch MM400 vibratory mill: a capsule jar swinging on a short arc, 1-2 steel balls.

Many conditions (frequency x ball size x wall restitution x wall friction) run as replicas of
one Taichi system; tables use the vocabulary of columns.py.  Statistics follow the paper's video analysis: ball speed is the
displacement between consecutive camera frames (2134 fps) in the camera's view (x along the
jar axis, z up), beside the true instantaneous speed; a collision in the video is a run of
frames where the velocity jumps by more than a threshold, counted the same way on tracked data.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .columns import add_frame_velocities
from .config import ConfigError, InteractionConfig, MM400Config, SimConfig
from .dem import Body, Capsule, Interaction, Motion, Recorder, Results, SystemSpec, new_engine
from .scenario import engine_materials, engine_options, time_step_s

JAR_AXIS = (1.0, 0.0, 0.0)  # the jar lies horizontally along x; it swings about a vertical axis


def jar_half_length_m(cfg: MM400Config) -> float:
    """Half length of the straight part of a capsule of the given volume and diameter (m)."""
    r = cfg.jar_inner_diameter_m / 2
    straight = (cfg.jar_volume_ml * 1e-6 - 4 / 3 * math.pi * r**3) / (math.pi * r**2)
    if straight < 0:
        raise ConfigError(f"lab.jar_inner_diameter_m={cfg.jar_inner_diameter_m}: a sphere of that size exceeds "
                          f"lab.jar_volume_ml={cfg.jar_volume_ml}")
    return straight / 2


def jar_inner_length_m(cfg: MM400Config) -> float:
    """The jar's inner length end to end (m)."""
    return 2 * jar_half_length_m(cfg) + cfg.jar_inner_diameter_m


def jar_volume_ml(bore_m: float, length_m: float) -> float:
    """Inner volume of a capsule jar of a bore and a length end to end (hemispherical ends), mL."""
    r = bore_m / 2
    return (math.pi * r**2 * (length_m - bore_m) + 4 / 3 * math.pi * r**3) * 1e6


def jar_capsule(cfg: MM400Config) -> Capsule:
    """The jar in its body frame: centred at the origin, axis along x."""
    return Capsule((0.0, 0.0, 0.0), JAR_AXIS, cfg.jar_inner_diameter_m / 2, jar_half_length_m(cfg))


def jar_motion(cfg: MM400Config, frequency_hz: float) -> Motion:
    """Swing about a vertical axis through a pivot pivot_radius_m behind the jar."""
    return Motion(pivot_m=(0.0, -cfg.pivot_radius_m, 0.0), axis=(0.0, 0.0, 1.0),
                  angle_amplitude_rad=cfg.amplitude_m / cfg.pivot_radius_m, frequency_hz=frequency_hz)


@dataclass(frozen=True)
class Condition:
    frequency_hz: float
    ball_diameter_m: float
    wall_restitution: float
    wall_friction: float
    replicate: int = 0  # another start of the same condition (its place in the batch draws other velocities)


def conditions(cfg: MM400Config, restitutions, frictions) -> list[Condition]:
    return [Condition(*c) for c in itertools.product(cfg.frequencies_hz, cfg.ball_diameters_m, restitutions, frictions)]


def jar_ball_mass_kg(cfg: MM400Config, ball_diameter_m: float, materials) -> float:
    """Mass of the balls in one jar (kg)."""
    return cfg.balls_per_jar * materials[cfg.ball_material].density_kg_per_m3 * math.pi / 6 * ball_diameter_m**3


def wall_interaction(interactions: dict[str, InteractionConfig], cfg) -> InteractionConfig:
    """The ball-wall entry of an 'a-b' keyed interaction table (either order) for a jar or drum
    config (its ball_material and wall_material)."""
    for key in (f"{cfg.ball_material}-{cfg.wall_material}", f"{cfg.wall_material}-{cfg.ball_material}"):
        if key in interactions:
            return interactions[key]
    raise ConfigError(f"interactions: no entry '{cfg.ball_material}-{cfg.wall_material}' for the wall")


def mm400_system(cfg: MM400Config, conds: list[Condition], materials, interactions, seed: int) -> SystemSpec:
    """One replica per condition; balls start near the jar's bottom with tiny random speeds."""
    radius_jar, half = cfg.jar_inner_diameter_m / 2, jar_half_length_m(cfg)
    rng = np.random.default_rng(seed)
    pos, rad, rep = [], [], []
    for k, c in enumerate(conds):
        r = c.ball_diameter_m / 2
        if r >= radius_jar:
            raise ConfigError(f"lab.ball_diameters_m: {c.ball_diameter_m} m balls do not fit a "
                              f"{cfg.jar_inner_diameter_m} m jar")
        xs = [0.0] if cfg.balls_per_jar == 1 else [-1.02 * r, 1.02 * r]
        for x in xs:
            beyond = max(0.0, abs(x) - half)  # into the hemispherical end
            if beyond >= radius_jar - r:
                raise ConfigError(f"lab: two {c.ball_diameter_m} m balls do not fit side by side in the jar")
            pos.append((x, 0.0, -math.sqrt((radius_jar - r) ** 2 - beyond**2) + 1e-5))
            rad.append(r)
            rep.append(k)
    names = sorted(materials)
    tables = []
    for c in conds:
        table = dict(interactions)
        table[tuple(sorted((cfg.ball_material, cfg.wall_material)))] = Interaction(
            c.wall_restitution, c.wall_friction, interactions[tuple(sorted((cfg.ball_material, cfg.wall_material)))]
            .rolling_friction)
        tables.append(table)
    reach = cfg.pivot_radius_m + half + radius_jar
    box = half + radius_jar + 2 * cfg.amplitude_m * reach / cfg.pivot_radius_m + 0.01
    return SystemSpec(
        materials=materials, interactions=tables, material_names=names, position_m=np.array(pos),
        radius_m=np.array(rad), material=np.full(len(rad), names.index(cfg.ball_material)), replica=np.array(rep),
        velocity_m_per_s=rng.normal(0, 0.01, (len(rad), 3)),
        bodies=[Body("jar", cfg.wall_material, (jar_capsule(cfg),),
                     tuple(jar_motion(cfg, c.frequency_hz) for c in conds))],
        domain_lo_m=(-box, -box, -box), domain_hi_m=(box, box, box),
    )


def mm400_spec(cfg: MM400Config, conds: list[Condition], materials, interactions: dict[str, InteractionConfig],
               sim: SimConfig) -> SystemSpec:
    """The engine's system for these conditions (checks materials and that the balls fit)."""
    mats, pairs = engine_materials(materials, interactions, sim.shear_modulus_scale, cfg.ball_material,
                                   cfg.wall_material)
    return mm400_system(cfg, conds, mats, pairs, sim.seed)


def run_mm400(cfg: MM400Config, conds: list[Condition], materials, interactions: dict[str, InteractionConfig],
              sim: SimConfig, frames_per_sample: int = 1) -> Results:
    """Run every condition (a replica each) for cfg.duration_s, sampling every `frames_per_sample`
    camera frames.  The time step fits a whole number of times in a frame whatever the sampling,
    so only the samples' own tables (trajectories, energy, loads) depend on it."""
    spec = mm400_spec(cfg, conds, materials, interactions, sim)
    frame = 1.0 / cfg.camera_fps
    dt = frame / math.ceil(frame / time_step_s(spec, sim))  # a whole number of steps per camera frame
    engine = new_engine(spec, engine_options(sim, dt), sim.arch, sim.precision, sim.threads, sim.seed)
    return engine.run(cfg.duration_s, frame * frames_per_sample, Recorder(engine, trajectory_every=1), label="mm400")


def simulate_mm400(cfg: MM400Config, conds: list[Condition], materials, interactions: dict[str, InteractionConfig],
                   sim: SimConfig):
    """Run every condition for cfg.duration_s, sampling at the camera rate: (trajectories, collisions)."""
    res = run_mm400(cfg, conds, materials, interactions, sim)
    return res.trajectories, res.collisions


def video_collisions(speeds: pd.DataFrame, threshold_m_per_s: float) -> int:
    """Collisions seen in a video: runs of consecutive frames whose velocity jumps by more than
    the threshold (a collision between two frames spreads over two differences), per ball;
    `speeds` has the frame_* columns of columns.add_frame_velocities."""
    hits = 0
    for _, g in speeds.groupby([k for k in ("replica", "particle") if k in speeds], sort=False):
        above = (g.frame_jump_m_per_s.to_numpy() > threshold_m_per_s).astype(int)
        hits += int((np.diff(np.r_[0, above]) == 1).sum())
    return hits


def summarise(track: pd.DataFrame, collisions: pd.DataFrame, cfg: MM400Config, conds: list[Condition]) -> pd.DataFrame:
    """One row per condition: frame-to-frame speed (mean, 10/50/90th percentiles), mean true speed,
    collision rates, impact speed and energy."""
    track = track[track.t_s > cfg.settle_s]
    fs = add_frame_velocities(track, cfg.camera_fps)
    span = track.t_s.max() - track.t_s.min()
    rows = []
    for k, c in enumerate(conds):
        g = fs[fs.replica == k]
        col = collisions[(collisions.replica == k) & (collisions.t_start_s > cfg.settle_s)] if len(collisions) else collisions
        rows.append({
            **c.__dict__, "replica": k,
            "mean_speed_m_per_s": float(g.frame_speed_m_per_s.mean()),
            **{f"speed_p{q}_m_per_s": float(g.frame_speed_m_per_s.quantile(q / 100)) for q in (10, 50, 90)},
            "mean_true_speed_m_per_s": float(np.sqrt(g.vx_m_per_s**2 + g.vy_m_per_s**2 + g.vz_m_per_s**2)
                                             [g.frame_speed_m_per_s.notna()].mean()),
            "video_collisions_per_s": video_collisions(g, cfg.collision_speed_jump_m_per_s) / span,
            "ball_wall_collisions_per_s": float((col.kind == "ball-wall").sum() / span) if len(col) else 0.0,
            "ball_ball_collisions_per_s": float((col.kind == "ball-ball").sum() / span) if len(col) else 0.0,
            "mean_impact_speed_m_per_s": float(col.impact_speed_m_per_s.mean()) if len(col) else float("nan"),
            "mean_impact_energy_j": float(col.impact_energy_j.mean()) if len(col) else float("nan"),
            "impact_energy_p90_j": float(col.impact_energy_j.quantile(0.9)) if len(col) else float("nan"),
        })
    return pd.DataFrame(rows)
