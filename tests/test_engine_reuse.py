"""A kept engine (dem.new_engine) taken again for another system of the same shapes runs it to
the same bits as a new engine would, whatever the last system left in its fields; a system of
other shapes or other compile-time values gets a new engine."""

from dataclasses import replace

import numpy as np
import pytest

from ballmill.config import DrumConfig, InteractionConfig, MaterialConfig, SimConfig
from ballmill.dem import EngineOptions, init_taichi, new_engine
from ballmill.drum import drum_spec
from ballmill.scenario import time_step_s

DRUM = DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, ball_radius_m=0.01)  # 304 balls: one thread's launch
TEAM_DRUM = replace(DRUM, ball_radius_m=0.008)  # 594 balls: a team of two threads
SIM = SimConfig(shear_modulus_scale=1e-2, settle_s=0.05)  # the drum turns from 0.05 s, dt ~2e-5 s
PAIRS = {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}


def simulate(drum: DrumConfig, threads: int, materials=None, steps: int = 4000):
    """The engine new_engine gives and what `steps` steps of the drum leave, as numpy."""
    spec = drum_spec(drum, materials or {"steel": MaterialConfig()}, PAIRS, SIM)
    engine = new_engine(spec, EngineOptions(dt_s=time_step_s(spec, SIM)), threads=threads)
    engine.advance(steps)
    seen = engine.observe()
    return engine, {"x": seen.x, "v": seen.v, "w": seen.w, "loads": seen.loads, "book": seen.book,
                    "events": engine.drain_events(), "rebuilds": engine.rebuilds()}


def fresh(drum: DrumConfig, threads: int):
    init_taichi("cpu", "f64", threads)  # forgets the kept engine
    return simulate(drum, threads)[1]


def assert_same_bits(got: dict, want: dict):
    for name in ("x", "v", "w", "events", "loads", "book"):
        for a, b in zip(*(d[name] if isinstance(d[name], tuple) else (d[name],) for d in (got, want))):
            if isinstance(a, dict):
                assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a), name
            else:
                assert np.array_equal(a, b), name
    assert got["rebuilds"] == want["rebuilds"]


@pytest.mark.parametrize("drum, threads", [(DRUM, 1), (TEAM_DRUM, 2)], ids=["one thread", "team"])
def test_a_kept_engine_runs_another_speed_to_a_new_engines_bits(drum, threads):
    slower = replace(drum, fraction_of_critical=0.4)
    want = fresh(slower, threads)
    first, _ = simulate(drum, threads)
    kept, got = simulate(slower, threads)
    assert kept is first and kept.launch == ("team" if threads == 2 else "serial")
    assert_same_bits(got, want)


def test_a_system_of_other_shapes_or_compiled_values_gets_a_new_engine():
    first, _ = simulate(DRUM, 1, steps=10)
    assert simulate(DRUM, 1, steps=10)[0] is first
    fewer, _ = simulate(replace(DRUM, fill_fraction=0.15), 1, steps=10)  # 152 balls: fields of another size class
    assert fewer is not first and fewer.p.cap == 256
    larger, _ = simulate(replace(DRUM, fill_fraction=0.15, ball_radius_m=0.0102), 1, steps=10)  # cells of another size
    assert larger is not fewer and larger.p.cap == 256
