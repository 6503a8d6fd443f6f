"""Taichi start-up in one place: arch, precision and threads come from the caller."""

from __future__ import annotations

import os

import taichi as ti

ARCHS = {"cpu": ti.cpu, "cuda": ti.cuda}
PRECISIONS = {"f64": ti.f64, "f32": ti.f32}


def init_taichi(arch: str = "cpu", precision: str = "f64", threads: int = 0, seed: int = 0) -> None:
    """(Re)start Taichi.  `threads` = 0 uses every core this process may run on (CPU only).

    A CUDA request never falls back to the CPU silently: it raises instead.
    """
    if arch not in ARCHS:
        raise ValueError(f"sim.arch={arch!r} is not one of {sorted(ARCHS)}")
    if precision not in PRECISIONS:
        raise ValueError(f"sim.precision={precision!r} is not one of {sorted(PRECISIONS)}")
    kwargs = {
        "arch": ARCHS[arch],
        "default_fp": PRECISIONS[precision],
        "fast_math": False,
        "random_seed": seed,
        "offline_cache": True,
        "log_level": ti.WARN,
    }
    if arch == "cpu":  # Taichi's own default counts the machine's cores, not those this process may use
        kwargs["cpu_max_num_threads"] = threads if threads > 0 else len(os.sched_getaffinity(0))
    ti.reset()
    ti.init(**kwargs)
    actual = ti.lang.impl.current_cfg().arch
    if arch == "cuda" and actual != ti.cuda:
        raise RuntimeError(
            "sim.arch=cuda was asked for but Taichi found no CUDA device; use sim.arch=cpu here"
        )


def available_memory_bytes() -> float:
    """Memory the machine can give now (MemAvailable of /proc/meminfo; else the free pages)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
