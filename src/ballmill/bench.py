"""Throughput of the DEM engine on the reference drum (a benchmark, not a test).

Reference: inner D 0.4 m, L 0.2 m, flat smooth ends, 10 mm steel balls filling 30 % of the
volume at bed porosity 0.4 (~8,600 balls), 70 % of critical speed, E = 2e8 Pa, v 0.3,
rho 7900, e 0.5, mu 0.5, mu_r 0.01, dt 20 % of Rayleigh; settle, then rotate.
Other sizes scale D and L by (N / 8600)^(1/3).  `bpr19` is the paper's mill at BPR 19 instead:
D 1.743 m, L 2.614 m, 523 balls of 160 mm, 15 rpm, physical steel (G 77 GPa), dt 1.74e-5 s.
Figures are printed as a table and written as JSON (`--json`); `--peer liggghts` runs the same
drums in LIGGGHTS (1 and 2 MPI ranks) right after ours and adds the ratios.

`--lab`: the MM400 batch instead, a 10 x 10 grid of ball-wall restitution x friction, one
17.6 mm ball per jar at 25 Hz, 2 s each, all replicas in one launch.
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .config import DrumConfig, InteractionConfig, MaterialConfig, SimConfig
from .dem import Engine, init_taichi
from .drum import ball_count, build_materials, drum_system, engine_options, time_step_s
from .peer import liggghts_rates

REFERENCE = DrumConfig(inner_diameter_m=0.4, inner_length_m=0.2, ball_radius_m=0.005)
STEEL_E2E8 = MaterialConfig(shear_modulus_pa=2e8 / 2.6)  # E = 2G(1+v) = 2e8 Pa
PAIRS = {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}
BPR19 = DrumConfig(inner_diameter_m=1.743, inner_length_m=2.614, ball_radius_m=0.08, ball_count=523, speed_rpm=15.0)


def scaled_drum(n_balls: int) -> DrumConfig:
    k = (n_balls / ball_count(REFERENCE)) ** (1 / 3)
    return replace(REFERENCE, inner_diameter_m=0.4 * k, inner_length_m=0.2 * k)


def bench(case: str, arch: str, threads: int, settle_s: float, rotate_s: float, profile_steps: int,
          precision: str = "f64", skin: float = 0.5, peer: str | None = None) -> dict:
    """Throughput of one drum case: a ball count (the scaled reference drum) or 'bpr19'."""
    drum, material = (BPR19, MaterialConfig()) if case == "bpr19" else (scaled_drum(int(case)), STEEL_E2E8)
    sim = SimConfig(arch=arch, threads=threads, precision=precision, settle_s=settle_s, duration_s=rotate_s,
                    sample_every_s=0.05, neighbour_skin=skin, max_overlap_fraction=0.1)
    mats, pairs = build_materials({"steel": material}, PAIRS)
    spec = drum_system(drum, mats, pairs, sim)
    init_taichi(arch, precision, threads)
    # E = 2e8 Pa lets the bed sink ~3-6 % of a radius under its own weight: allow 10 %.
    engine = Engine(spec, replace(engine_options(sim, time_step_s(spec, sim)), collision_log=False))
    engine.run(settle_s, sim.sample_every_s, label="settle")
    builds0, t0 = engine.rebuilds(), time.perf_counter()
    res = engine.run(rotate_s, sim.sample_every_s, label="rotate")
    wall = time.perf_counter() - t0
    steps = round(rotate_s / engine.dt)
    builds = engine.rebuilds() - builds0
    contacts = engine.contacts_per_particle()
    phases = engine.profile(profile_steps)
    total = sum(phases.values())
    power, se = res.mean_power_w("drum", after_s=settle_s + 0.3 * rotate_s)
    rate = spec.n_particles * steps / wall
    peers = {}
    if peer == "liggghts":
        peers = liggghts_rates(spec, drum, material, PAIRS["steel-steel"], engine.dt, settle_s, rotate_s,
                               engine.nl.skin)
        peers |= {f"ratio_to_{k}": rate / v for k, v in list(peers.items())}
    return {
        "case": case, "balls": spec.n_particles, "arch": arch, "threads": threads or "all", "precision": precision,
        "mode": "serial" if engine.serial else "parallel", "dt_s": engine.dt, "skin_fraction": skin,
        "particle_steps_per_s": rate, "steps_per_rebuild": steps / max(builds, 1),
        "contacts_per_particle": contacts, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "power_w": power, "power_se_w": se, **{f"share_{k.replace(' ', '_')}": v / total for k, v in phases.items()},
        **peers,
    }


def bench_lab(threads: int, duration_s: float) -> dict:
    """Wall time of the 10 x 10 MM400 grid (physical stiffness), one replica per pair."""
    from .cli import compose
    from .lab import conditions, simulate_mm400

    lab, sim, materials, interactions, _ = compose([
        "lab.frequencies_hz=[25.0]", "lab.ball_diameters_m=[0.0176]", f"lab.duration_s={duration_s}",
        f"sim.threads={threads}"])
    conds = conditions(lab, np.linspace(0.3, 0.95, 10), np.linspace(0.05, 0.5, 10))
    t0 = time.perf_counter()
    simulate_mm400(lab, conds, materials, interactions, sim)  # logs its particle-steps per second
    return {"replicas": len(conds), "simulated_s_each": duration_s, "wall_s": time.perf_counter() - t0}


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog="ballmill bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--balls", nargs="+", default=["1000", str(ball_count(REFERENCE)), "bpr19"],
                        help="cases: ball counts of the scaled reference drum, or bpr19")
    parser.add_argument("--arch", default="cpu", choices=["cpu", "cuda"])
    parser.add_argument("--precision", default="f64", choices=["f64", "f32"])
    parser.add_argument("--threads", type=int, default=0, help="CPU threads (0: all cores)")
    parser.add_argument("--skin", type=float, default=0.5, help="neighbour skin / largest ball radius")
    parser.add_argument("--settle", type=float, default=0.3, help="settling time (s)")
    parser.add_argument("--rotate", type=float, default=1.0, help="timed rotation (s)")
    parser.add_argument("--profile-steps", type=int, default=50)
    parser.add_argument("--lab", action="store_true", help="the MM400 10 x 10 grid instead of the drum")
    parser.add_argument("--lab-duration", type=float, default=2.0, help="simulated time per MM400 replica (s)")
    parser.add_argument("--peer", choices=["liggghts"], help="run the same drums in LIGGGHTS (1 and 2 MPI ranks)")
    parser.add_argument("--json", default="outputs/bench/bench.json", help="where the figures are written")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if args.lab:
        rows = [bench_lab(args.threads, args.lab_duration)]
    else:
        rows = [bench(c, args.arch, args.threads, args.settle, args.rotate, args.profile_steps, args.precision,
                      args.skin, args.peer) for c in args.balls]
    keys = list(rows[0])
    print("\n" + " | ".join(keys))
    for r in rows:
        print(" | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k]) for k in keys))
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"argv": argv, "rows": rows}, indent=2))
