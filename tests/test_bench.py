"""The benchmark's machine checks (the benchmark itself is a command, not a test)."""

import math
import os

from ballmill.bench import core_balance, machine, peer_names
from ballmill.cli import compose_command


def test_core_balance_is_the_slowest_cores_speed_over_the_fastests_and_nan_on_one_core():
    cores = os.sched_getaffinity(0)
    if len(cores) > 1:
        assert 0.0 < core_balance(200_000) <= 1.0
    try:
        os.sched_setaffinity(0, {min(cores)})
        assert math.isnan(core_balance(200_000))
    finally:
        os.sched_setaffinity(0, cores)


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
