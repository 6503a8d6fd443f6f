"""tasks.py, the Quickstart's two commands: how `reproduce` runs its units two at a time."""

import importlib.util
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

import ballmill

spec = importlib.util.spec_from_file_location("tasks", Path(__file__).resolve().parents[1] / "tasks.py")
tasks = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tasks)


def test_units_run_two_at_a_time_in_list_order_each_told_to_take_one_core():
    """Each of the first four units waits until a second one runs beside it (a barrier, not a
    sleep: however slow the machine, two at a time or the barrier times out), and none sees a
    third."""
    lock, running, most, started = threading.Lock(), [0], [0], []
    pair = threading.Barrier(2, timeout=60)

    def unit(name, ballmill):
        with lock:
            started.append(name)
            running[0] += 1
            most[0] = max(most[0], running[0])
        if name != "u4":  # the fifth has no partner left
            pair.wait()
        with lock:
            running[0] -= 1

    streams = []
    tasks.in_two_streams([(f"u{k}", lambda ballmill, k=k: unit(f"u{k}", ballmill)) for k in range(5)],
                         start=lambda env: streams.append(Stream(env)) or streams[-1])
    assert sorted(started) == [f"u{k}" for k in range(5)] and started[2:] == ["u2", "u3", "u4"]
    assert most[0] == 2
    assert [(s.env["BALLMILL_LOCAL_JOBS"], s.closed) for s in streams] == [("2", True)] * 2


class Stream:
    """A stand-in for a stream's process: what it ran, its environment, whether it was closed."""

    def __init__(self, env):
        self.env, self.ran, self.closed = env, [], False

    def __call__(self, tag, *args):
        self.ran.append((tag, *args))

    def close(self):
        self.closed = True


def test_after_a_failed_unit_no_other_starts_and_the_exit_names_the_command():
    """The slow unit ends only once the streams have recorded the other's failure (an event, not
    a sleep), so the last unit is taken up after it, whichever stream frees first."""
    started, recorded = [], threading.Event()

    class Failure(subprocess.CalledProcessError):
        def __del__(self):  # the streams' handler is done with it: the failure is recorded
            recorded.set()

    def fails(ballmill):
        started.append("fig4")
        raise Failure(3, ["ballmill", "run", "+sweep=fig4"])

    def slow(name):
        def unit(ballmill):
            started.append(name)
            assert recorded.wait(timeout=60)
        return unit

    with pytest.raises(SystemExit, match=r"fig4: ballmill run \+sweep=fig4 exited with 3"):
        tasks.in_two_streams([("slow", slow("slow")), ("fig4", fails), ("later", slow("later"))],
                             last=("report", slow("report")), start=Stream)
    assert sorted(started) == ["fig4", "slow"]


def test_a_streams_process_runs_commands_in_turn_tags_their_lines_and_reports_a_failure(capfd, monkeypatch):
    """One process, three commands: the version, an unknown command (exit status 2, as `ballmill`
    gives it) and the version again, which still runs; then the last unit runs in it too."""
    monkeypatch.setattr(tasks, "BIN", Path(sys.executable).parent)
    runner = tasks.Runner(dict(os.environ))
    try:
        runner("lab", "--version")
        with pytest.raises(subprocess.CalledProcessError) as failed:
            runner("lab", "nonsense")
        runner("plant", "--version")
    finally:
        runner.close()
    assert failed.value.returncode == 2 and failed.value.cmd == ["ballmill", "nonsense"]
    lines = capfd.readouterr().out.splitlines()
    assert lines[:2] == ["[lab] + ballmill --version", f"[lab] ballmill {ballmill.__version__}"]
    assert lines[-2:] == ["[plant] + ballmill --version", f"[plant] ballmill {ballmill.__version__}"]
    assert runner.proc.returncode == 0


def test_the_last_unit_runs_after_every_other_in_one_of_the_streams():
    streams, done = [], []

    def report(ballmill):
        assert sorted(done) == ["u0", "u1", "u2"]
        ballmill("report")

    tasks.in_two_streams([(f"u{k}", lambda ballmill, k=k: done.append(f"u{k}")) for k in range(3)],
                         last=("report", report), start=lambda env: streams.append(Stream(env)) or streams[-1])
    assert [ran for s in streams for ran in s.ran] == [("report", "report")]
