"""Throughput of the DEM engine on the reference drum (a benchmark, not a test).

Reference: inner D 0.4 m, L 0.2 m, flat smooth ends, 10 mm steel balls filling 30 % of the
volume at bed porosity 0.4 (~8,600 balls), 70 % of critical speed, E = 2e8 Pa, v 0.3,
rho 7900, e 0.5, mu 0.5, mu_r 0.01, dt 20 % of Rayleigh; settle, then rotate.
Other sizes scale D and L by (N / 8600)^(1/3), so a larger bed is also deeper; `longN` keeps
the reference's cross-section and makes the drum longer to hold N balls, so the bed is as deep
as the reference's and a ball has as many neighbours: what size alone costs.  `bpr19` is the
paper's mill at BPR 19 instead:
D 1.743 m, L 2.614 m, 523 balls of 160 mm, 15 rpm, physical steel (G 77 GPa), dt 1.74e-5 s.
Cases of `large_from` balls or more (the 100,000-ball drums) are timed over shorter
`large_settle_s` / `large_rotate_s`, and the reference drum is run again over those same
windows right after each: what size costs an engine is its rate on the large drum over its
rate on the reference in the same state of settling and turning (`size_ratios`; a bed's
contacts per ball, and so the work of a particle-step, change as it settles and starts to
turn).  The `scaling` cases run on one thread as well (thread scaling); each row carries
the launch used, the memory the engine took per particle and the share of each phase of a
step (`Engine.profile`), the cores' balance measured just before our run (`core_balance`:
on a shared machine one core can run slower than the other, and a team of threads, whose
barriers wait for the slower core, can then fall below one thread's rate) and the share of
the timed steps that the team's pacer gave to one thread for that reason
(`one_thread_share`, dem/team.py).
Figures are printed as a table and written as JSON (`json=PATH`) with the machine they were
measured on (CPU model and cache sizes: whether a bed fits in the last-level cache decides
how the rate holds up with size); `peer=liggghts`, `lammps` or `both` (= `liggghts,lammps`)
runs the same drums in the peers (1 and 2 MPI ranks) right after ours and adds the ratios.

`mm400=true`: the MM400 batch instead, a 10 x 10 grid of ball-wall restitution x friction, one
17.6 mm ball per jar at 25 Hz, 2 s each, all replicas in one launch.
"""

from __future__ import annotations

import os
import platform
import re
import resource
import subprocess
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .config import BenchConfig, ConfigError, DrumConfig, InteractionConfig, MaterialConfig, SimConfig
from .dem import Engine, init_taichi
from .drum import ball_count, drum_spec
from .files import write_json
from .peer import PEERS, peer_rates, require_peers
from .scenario import engine_options, time_step_s

REFERENCE = DrumConfig(inner_diameter_m=0.4, inner_length_m=0.2, ball_radius_m=0.005)
STEEL_E2E8 = MaterialConfig(shear_modulus_pa=2e8 / 2.6)  # E = 2G(1+v) = 2e8 Pa
PAIRS = {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}
BPR19 = DrumConfig(inner_diameter_m=1.743, inner_length_m=2.614, ball_radius_m=0.08, ball_count=523, speed_rpm=15.0)


CASE = re.compile(r"(long)?([0-9]+)")  # a ball count N of the scaled drum, or longN


def case_balls(case: str) -> int:
    """The ball count a drum case asks for (bpr19: its 523); ConfigError for a case that is none."""
    if case == "bpr19":
        return BPR19.ball_count
    match = CASE.fullmatch(case)
    if not match or int(match[2]) < 2:
        raise ConfigError(f"cases: {case!r} is neither a ball count (an integer >= 2), longN nor bpr19")
    return int(match[2])


def checked_case(case: str) -> int:
    """The case's ball count, once its drum is known to hold them (else a ConfigError naming it)."""
    drum, material = case_drum(case)
    try:
        drum_spec(drum, {"steel": material}, PAIRS, SimConfig())
    except ConfigError as exc:
        raise ConfigError(f"cases: {case!r}: {exc}") from None
    return case_balls(case)


def case_drum(case: str) -> tuple[DrumConfig, MaterialConfig]:
    """The drum and ball material of a case: bpr19; N, the reference scaled in D and L to hold N
    balls; longN, the reference's cross-section made longer to hold N balls."""
    if case == "bpr19":
        return BPR19, MaterialConfig()
    k = case_balls(case) / ball_count(REFERENCE)
    if case.startswith("long"):
        return replace(REFERENCE, inner_length_m=REFERENCE.inner_length_m * k), STEEL_E2E8
    k **= 1 / 3
    return replace(REFERENCE, inner_diameter_m=REFERENCE.inner_diameter_m * k,
                   inner_length_m=REFERENCE.inner_length_m * k), STEEL_E2E8


def bench(case: str, arch: str, threads: int, settle_s: float, rotate_s: float, profile_steps: int,
          precision: str = "f64", skin: float = 0.5, peer: str | None = None, scaling: bool = False,
          rounds: int = 1) -> dict:
    """Throughput of one drum case (`case_drum`); with `scaling`, the same run on one thread as
    well.  `rounds` repeats every run (ours, then the peers') one after the other: rates and
    ratios are medians over the rounds, each ratio taken within its round (this machine's
    speed drifts over minutes)."""
    drum, material = case_drum(case)
    sim = SimConfig(arch=arch, threads=threads, precision=precision, settle_s=settle_s, startup_revolutions=None,
                    window_revolutions=None, steady_after_s=0.0, duration_s=rotate_s,
                    sample_every_s=min(0.05, rotate_s / 2), neighbour_skin=skin, max_overlap_fraction=0.1)
    spec = drum_spec(drum, {"steel": material}, PAIRS, sim)
    by_round = []
    for r in range(rounds):
        rates = {"particle_steps_per_s_1_thread": bench_run(spec, sim, 1)[1]} if scaling else {}
        rates["core_balance"] = core_balance()
        engine, rates["particle_steps_per_s"], res, steps_per_rebuild, rates["one_thread_share"] = \
            bench_run(spec, sim, threads)
        if r == 0:  # what the engine did, from the first round
            first = {"launch": engine.launch, "dt_s": engine.dt, "steps_per_rebuild": steps_per_rebuild,
                     "contacts_per_particle": engine.contacts_per_particle(),
                     "engine_bytes_per_particle": engine.field_bytes() / spec.n_particles}
            phases = engine.profile(profile_steps)
            power, se = res.mean_power_w("drum", after_s=settle_s + 0.3 * rotate_s)
            peer_args = (spec, drum, material, PAIRS["steel-steel"], engine.dt, settle_s, rotate_s, engine.nl.skin)
        by_round.append(rates | peer_rates(peer_names(peer), *peer_args))
    table = pd.DataFrame(by_round)
    ours = table.pop("particle_steps_per_s")
    for k in list(table.columns):
        if k.endswith("_ranks"):
            table[f"ratio_to_{k}"] = ours / table[k]
            if scaling and k.endswith("_1_ranks"):  # per core
                table[f"ratio_1_thread_to_{k}"] = table["particle_steps_per_s_1_thread"] / table[k]
    if scaling:
        table["thread_scaling"] = ours / table["particle_steps_per_s_1_thread"]
    total = sum(phases.values())
    return {
        "case": case, "balls": spec.n_particles, "arch": arch, "threads": threads or "all", "precision": precision,
        "skin_fraction": skin, "settle_s": settle_s, "rotate_s": rotate_s, "rounds": rounds,
        "particle_steps_per_s": float(ours.median()), **table.median().to_dict(), **first,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "power_w": power, "power_se_w": se, **{f"share_{k.replace(' ', '_')}": v / total for k, v in phases.items()},
        **({f"{k}_by_round": v.tolist() for k, v in [("particle_steps_per_s", ours), *table.items()]}
           if rounds > 1 else {}),
    }


def size_ratios(row: dict, reference: dict) -> dict:
    """A large case's per-particle rate over the reference drum's, both timed over the same
    windows: ours (`size_ratio`) and each peer's (`size_ratio_<peer>_<n>_ranks`)."""
    peers = [k for k in row if k.endswith("_ranks") and not k.startswith("ratio_")]
    return {"reference_particle_steps_per_s": reference["particle_steps_per_s"],
            "reference_one_thread_share": reference["one_thread_share"],
            "size_ratio": row["particle_steps_per_s"] / reference["particle_steps_per_s"],
            **{f"size_ratio_{k}": row[k] / reference[k] for k in peers}}


# one pinned one-thread loop: python -c SPIN <core> <iterations> prints its seconds
SPIN = ("import os, sys, time; os.sched_setaffinity(0, {int(sys.argv[1])}); t = time.perf_counter(); "
        "sum(i * i % 7 for i in range(int(sys.argv[2]))); print(time.perf_counter() - t)")


def core_balance(iterations: int = 4_000_000) -> float:
    """The speed of this process's slowest core over its fastest (1: equal), all busy at once:
    one pinned loop per core (~0.25 s each here); nan with a single core."""
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2:
        return float("nan")
    loops = [subprocess.Popen([sys.executable, "-c", SPIN, str(c), str(iterations)], stdout=subprocess.PIPE, text=True)
             for c in cores]
    seconds = [float(p.communicate()[0]) for p in loops]
    return min(seconds) / max(seconds)


def bench_run(spec, sim: SimConfig, threads: int) -> tuple[Engine, float, object, float, float]:
    """Settle, then time the rotation on `threads` threads: (engine, particle-steps/s, results,
    steps per list build during the rotation, share of its steps a team's pacer ran on one thread)."""
    init_taichi(sim.arch, sim.precision, threads)
    # E = 2e8 Pa lets the bed sink ~3-6 % of a radius under its own weight: allow 10 %.
    engine = Engine(spec, replace(engine_options(sim, time_step_s(spec, sim)), collision_log=False))
    engine.run(sim.settle_s, sim.sample_every_s, label="settle")
    one_thread0 = engine.pacer.steps["serial"] if engine.pacer else 0
    builds0, t0 = engine.rebuilds(), time.perf_counter()
    res = engine.run(sim.duration_s, sim.sample_every_s, label="rotate")
    steps = round(sim.duration_s / engine.dt)
    rate = spec.n_particles * steps / (time.perf_counter() - t0)
    one_thread = (engine.pacer.steps["serial"] - one_thread0) / steps if engine.pacer else 0.0
    return engine, rate, res, steps / max(engine.rebuilds() - builds0, 1), one_thread


def machine() -> dict:
    """The CPU the figures come from: model, cores this process may use, and each data cache
    level's size per instance (bytes; from Linux's /proc and /sys, only the cores elsewhere)."""
    cpuinfo = Path("/proc/cpuinfo")
    lines = cpuinfo.read_text().splitlines() if cpuinfo.exists() else []
    model = next((line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")), platform.machine())
    caches = {}
    for index in sorted(Path("/sys/devices/system/cpu/cpu0/cache").glob("index*")):
        if (index / "type").read_text().strip() != "Instruction":
            size = (index / "size").read_text().strip()
            scale = {"K": 1024, "M": 1024**2}.get(size[-1], 1)
            caches[f"L{(index / 'level').read_text().strip()}_bytes"] = int(size.rstrip("KM")) * scale
    return {"cpu": model, "cores": len(os.sched_getaffinity(0)), **caches}


def _cell(value) -> str:
    if isinstance(value, list):
        return " ".join(_cell(v) for v in value)
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def peer_names(peer: str | None) -> tuple[str, ...]:
    """bench's peer option: one peer, or both (`both` or `liggghts,lammps`)."""
    return () if peer is None else tuple(PEERS) if peer == "both" else tuple(peer.split(","))


def bench_mm400(threads: int, duration_s: float) -> dict:
    """Wall time of the 10 x 10 MM400 grid (physical stiffness), one replica per pair."""
    from .lab import conditions, simulate_mm400
    from .scenario import compose, load

    s = load(compose("config", ["sim=lab", "lab.frequencies_hz=[25.0]", "lab.ball_diameters_m=[0.0176]",
                                f"lab.duration_s={duration_s}", f"sim.threads={threads}"]))
    conds = conditions(s.lab, np.linspace(0.3, 0.95, 10), np.linspace(0.05, 0.5, 10))
    t0 = time.perf_counter()
    simulate_mm400(s.lab, conds, s.materials, s.interactions, s.sim)  # logs its particle-steps per second
    return {"replicas": len(conds), "simulated_s_each": duration_s, "wall_s": time.perf_counter() - t0}


def main(opts: BenchConfig) -> None:
    """Run the cases of `ballmill bench`, print a table and write opts.json."""
    balls = {case: checked_case(case) for case in opts.cases}  # every case before any run
    require_peers(peer_names(opts.peer))  # before our own runs, not after
    here, rows = machine(), []
    if opts.mm400:
        rows.append(bench_mm400(opts.threads, opts.mm400_duration_s))
    else:
        for c in opts.cases:
            large = balls[c] >= opts.large_from
            times = (opts.large_settle_s, opts.large_rotate_s) if large else (opts.settle_s, opts.rotate_s)
            args = (opts.arch, opts.threads, *times, opts.profile_steps, opts.precision, opts.skin, opts.peer)
            row = bench(c, *args, scaling=c in opts.scaling, rounds=opts.rounds)
            if large:
                row |= size_ratios(row, bench(str(ball_count(REFERENCE)), *args, rounds=opts.rounds))
            rows.append(row)
            # after each case, so that a case that fails later loses none of those before
            write_json(opts.json, {"options": asdict(opts), "machine": here, "rows": rows, "complete": False})
    keys = list(dict.fromkeys(k for r in rows for k in r))
    print("\n" + " | ".join(keys))
    for r in rows:
        print(" | ".join(_cell(r.get(k, "")) for k in keys))
    print("machine: " + ", ".join(f"{k} {v}" for k, v in here.items()))
    write_json(opts.json, {"options": asdict(opts), "machine": here, "rows": rows, "complete": True})
