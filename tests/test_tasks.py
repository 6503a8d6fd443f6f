"""tasks.py, the Quickstart's two commands: how `reproduce` runs its units two at a time."""

import importlib.util
import subprocess
import sys
import threading
from pathlib import Path

import pytest

spec = importlib.util.spec_from_file_location("tasks", Path(__file__).resolve().parents[1] / "tasks.py")
tasks = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tasks)


def test_units_run_two_at_a_time_in_list_order_each_told_to_take_one_core():
    """Each of the first four units waits until a second one runs beside it (a barrier, not a
    sleep: however slow the machine, two at a time or the barrier times out), and none sees a
    third."""
    lock, running, most, started, envs = threading.Lock(), [0], [0], [], []
    pair = threading.Barrier(2, timeout=60)

    def unit(name, env):
        with lock:
            started.append(name)
            envs.append(env["BALLMILL_LOCAL_JOBS"])
            running[0] += 1
            most[0] = max(most[0], running[0])
        if name != "u4":  # the fifth has no partner left
            pair.wait()
        with lock:
            running[0] -= 1

    tasks.in_two_streams([(f"u{k}", unit) for k in range(5)])
    assert sorted(started) == [f"u{k}" for k in range(5)] and started[2:] == ["u2", "u3", "u4"]
    assert most[0] == 2 and envs == ["2"] * 5


def test_after_a_failed_unit_no_other_starts_and_the_exit_names_the_command():
    """The slow unit ends only once the streams have recorded the other's failure (an event, not
    a sleep), so the last unit is taken up after it, whichever stream frees first."""
    started, recorded = [], threading.Event()

    class Failure(subprocess.CalledProcessError):
        def __del__(self):  # the streams' handler is done with it: the failure is recorded
            recorded.set()

    def fails(name, env):
        started.append(name)
        raise Failure(3, ["ballmill", "run", "+sweep=fig4"])

    def slow(name, env):
        started.append(name)
        assert recorded.wait(timeout=60)

    with pytest.raises(SystemExit, match=r"fig4: ballmill run \+sweep=fig4 exited with 3"):
        tasks.in_two_streams([("slow", slow), ("fig4", fails), ("later", slow)])
    assert sorted(started) == ["fig4", "slow"]


def test_a_tagged_command_prints_each_line_behind_its_tag_and_fails_loudly(capfd):
    tasks.sh(sys.executable, "-c", "print('a'); print('b')", tag="lab")
    assert capfd.readouterr().out.splitlines()[1:] == ["[lab] a", "[lab] b"]
    with pytest.raises(subprocess.CalledProcessError):
        tasks.sh(sys.executable, "-c", "raise SystemExit(4)", tag="lab")
