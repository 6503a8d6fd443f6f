"""Taichi start-up in one place: arch, precision and threads come from the caller; the engine
kept since the last start (engine.new_engine)."""

from __future__ import annotations

import os
import sys

import taichi as ti
from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext

from .transfer import forget_field_sets

ARCHS = {"cpu": ti.cpu, "cuda": ti.cuda}
PRECISIONS = {"f64": ti.f64, "f32": ti.f32}
LOCAL_JOBS_ENV = "BALLMILL_LOCAL_JOBS"  # jobs a sweep runs at once on this machine (set by the sweep)
# Taichi's compiled-kernel cache (~/.cache/taichi): its default cap, 100 MB, is less than the
# kernels of the engine's size classes that the test suite and the reproduce command compile,
# and at that cap each process evicts a quarter of it (least recently used), so that a suite
# run after a few reproduce runs compiled 438 kernels again (16 min 54 s instead of ~11).
OFFLINE_CACHE_BYTES = 1 << 30


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
        "offline_cache_max_size_of_files": OFFLINE_CACHE_BYTES,
        "log_level": ti.WARN,
    }
    if arch == "cpu":
        kwargs["cpu_max_num_threads"] = cpu_threads(threads)
    ASTTransformerContext.get_pos_info = brief_position
    _KEPT.clear()
    forget_field_sets()
    ti.reset()
    ti.init(**kwargs)
    actual = ti.lang.impl.current_cfg().arch
    if arch == "cuda" and actual != ti.cuda:
        raise RuntimeError(
            "sim.arch=cuda was asked for but Taichi found no CUDA device; use sim.arch=cpu here"
        )


_KEPT: dict = {}  # the engine new_engine keeps (engine.py), by the settings Taichi was started with


def kept_engine(settings: tuple):
    """The engine kept for these settings, if Taichi runs with them and has not restarted since."""
    return _KEPT.get(settings)


def keep_engine(settings: tuple, engine) -> None:
    _KEPT.clear()
    _KEPT[settings] = engine


FULL_POSITION = ASTTransformerContext.get_pos_info


def brief_position(context: ASTTransformerContext, node) -> str:
    """Where a node of a kernel being compiled stands, as Taichi tags each node: its file, line
    and function, and, in an error's message, Taichi's excerpt of the line with the node marked.
    Taichi formats that excerpt (textwrap) for every node, ~0.45 s of a run's ~0.85 s of turning
    the engine's kernels into Taichi's IR, paid again in every run, since every run restarts
    Taichi; a run of the small test drum took 3.3 s instead of 3.8 s, its results the same."""
    if sys.exc_info()[0] is not None:
        return FULL_POSITION(context, node)
    return f'File "{context.file}", line {node.lineno + context.lineno_offset}, in {context.func.func.__name__}:\n'


def cpu_threads(threads: int) -> int:
    """Threads for Taichi: `threads`, or for 0 the cores this process may run on (Taichi's own
    default counts the machine's) shared among the LOCAL_JOBS_ENV jobs a sweep runs at once here
    (a team of threads spins at its barriers: two 2-thread teams on 2 cores ran ~4x slower each)."""
    if threads > 0:
        return threads
    return max(1, len(os.sched_getaffinity(0)) // max(1, int(os.environ.get(LOCAL_JOBS_ENV, "1"))))


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
