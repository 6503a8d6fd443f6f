"""The benchmark's machine checks (the benchmark itself is a command, not a test)."""

import math
import os
import subprocess
import sys

import pytest
from helpers import floor_system
from test_contact_physics import STEEL

import ballmill.bench
from ballmill.bench import REFERENCE, case_drum, core_balance, machine, peer_names
from ballmill.cli import compose_command, options
from ballmill.dem import Engine, EngineOptions, init_taichi, memory_estimate_bytes
from ballmill.drum import ball_count
from ballmill.files import read_json


def test_core_balance_is_the_slowest_cores_speed_over_the_fastests_and_nan_on_one_core(monkeypatch):
    """One pinned loop per core, all started before any is waited for; two cores whose loops take
    0.3 s and 0.6 s: the slower runs at half the faster's speed."""
    launched, seconds = [], {0: "0.3\n", 1: "0.6\n"}

    class Loop:
        def __init__(self, cmd, **kwargs):
            assert cmd[2] == ballmill.bench.SPIN and int(cmd[4]) == 1000
            self.core = int(cmd[3])
            launched.append(self.core)

        def communicate(self):
            assert len(launched) == 2  # every loop runs at once
            return seconds[self.core], ""

    monkeypatch.setattr(ballmill.bench.os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr(ballmill.bench.subprocess, "Popen", Loop)
    assert core_balance(1000) == 0.5 and launched == [0, 1]
    monkeypatch.setattr(ballmill.bench.os, "sched_getaffinity", lambda pid: {3})
    assert math.isnan(core_balance(1000)) and launched == [0, 1]


def test_a_spin_loop_runs_on_the_core_it_is_given():
    core = max(os.sched_getaffinity(0))
    probe = ballmill.bench.SPIN.replace("print(time.perf_counter() - t)", "print(sorted(os.sched_getaffinity(0)))")
    out = subprocess.run([sys.executable, "-c", probe, str(core), "10"], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"[{core}]"


def test_the_figures_name_the_machine_they_come_from():
    here = machine()
    assert here["cpu"] and here["cores"] == len(os.sched_getaffinity(0))
    if os.path.isdir("/sys/devices/system/cpu/cpu0/cache"):  # Linux: every data cache level, in bytes
        assert here["L1_bytes"] >= 4096 and here["L2_bytes"] > here["L1_bytes"]


def test_both_peers_are_asked_for_as_both_or_by_name():
    for asked in ("peer=both", "peer=liggghts,lammps"):
        opts = compose_command("bench", [asked])
        assert peer_names(opts.peer) == ("liggghts", "lammps")
    assert peer_names(compose_command("bench", ["peer=lammps"]).peer) == ("lammps",)
    assert compose_command("bench", ["cases=[8640,bpr19]"]).cases == ["8640", "bpr19"]  # a list stays a list


def test_a_long_case_holds_its_balls_in_the_reference_drums_cross_section():
    scaled, long = case_drum("100000")[0], case_drum("long100000")[0]
    assert ball_count(scaled) == ball_count(long) == 100_000
    assert long.inner_diameter_m == REFERENCE.inner_diameter_m  # as deep a bed as the reference's
    assert math.isclose(scaled.inner_diameter_m / REFERENCE.inner_diameter_m,
                        scaled.inner_length_m / REFERENCE.inner_length_m)
    assert math.isclose(long.inner_length_m, 2.315, rel_tol=1e-3)


def test_a_case_that_fails_keeps_the_cases_before_it(tmp_path, monkeypatch):
    def bench(case, *args, **kwargs):  # the drums stand in: a peer that fails on the second case
        if case == "bpr19":
            raise RuntimeError("liggghts failed")
        return {"case": case, "particle_steps_per_s": 1e7}

    monkeypatch.setattr(ballmill.bench, "bench", bench)
    out = tmp_path / "bench.json"
    with pytest.raises(RuntimeError, match="liggghts failed"):
        ballmill.bench.main(options(compose_command("bench", ["cases=[1000,bpr19]", f"json={out}"]), "bench"))
    written = read_json(out)
    assert written["complete"] is False and [r["case"] for r in written["rows"]] == ["1000"]


def test_a_large_case_is_compared_with_the_reference_drum_over_the_same_windows(tmp_path, monkeypatch):
    runs = []

    def bench(case, arch, threads, settle_s, rotate_s, *args, **kwargs):  # the drums stand in
        runs.append((case, settle_s, rotate_s))
        rate = 8e6 if case == "long100000" else 1e7
        return {"case": case, "particle_steps_per_s": rate, "one_thread_share": 0.0, "lammps_2_ranks": rate / 2,
                "ratio_to_lammps_2_ranks": 2.0}

    monkeypatch.setattr(ballmill.bench, "bench", bench)
    out = tmp_path / "bench.json"
    ballmill.bench.main(options(compose_command("bench", ["cases=[8640,long100000]", f"json={out}"]), "bench"))
    opts = compose_command("bench", [])
    large = (opts.large_settle_s, opts.large_rotate_s)
    assert runs == [("8640", opts.settle_s, opts.rotate_s), ("long100000", *large), ("8640", *large)]
    rows = read_json(out)["rows"]
    assert "size_ratio" not in rows[0]
    assert rows[1]["size_ratio"] == pytest.approx(0.8) and rows[1]["size_ratio_lammps_2_ranks"] == pytest.approx(0.8)
    assert rows[1]["reference_particle_steps_per_s"] == 1e7 and "size_ratio_ratio_to_lammps_2_ranks" not in rows[1]


def test_the_engines_field_bytes_are_counted_from_the_fields_declared():
    """Three balls on a floor (64 particle slots): an engine with 2 more neighbour-list slots a
    particle and 200 more buffered collisions holds, by hand from the fields' declarations,
    64 x 2 x 105 B (partner, reverse slot and new partner, i32; record name, u8; a contact's
    start, i32, normal speed and dissipated energy, f64, history, force on i and torque on j,
    3 x f64 each) plus 200 x 32 B (4 x i32 and 2 x f64) more; each within the estimate that
    admits a run (it counts the records' padding as well).  The bench's bytes per particle are
    these over the balls (the resident memory it read before was a difference of two readings
    that the allocator's reuse can make negative: -2009 B on the reference drum)."""
    init_taichi("cpu", "f64")
    spec = floor_system(STEEL, 0.01, [[0.0, 0.0, -1.0]] * 3)
    small, large = (Engine(spec, EngineOptions(dt_s=1e-6, max_contacts_per_particle=k, event_capacity=events))
                    for k, events in ((4, 100), (6, 300)))
    slot = 3 * 4 + 1 + 4 + 2 * 8 + 3 * 3 * 8
    assert slot == 105 and large.field_bytes() - small.field_bytes() == 64 * 2 * slot + 200 * (4 * 4 + 2 * 8)
    for engine, k, events in ((small, 4, 100), (large, 6, 300)):
        assert 0 < engine.field_bytes() <= memory_estimate_bytes(3, k, events, 1)
