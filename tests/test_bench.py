"""The benchmark's machine check (the benchmark itself is a command, not a test)."""

import math
import os

from ballmill.bench import core_balance


def test_core_balance_is_the_slowest_cores_speed_over_the_fastests_and_nan_on_one_core():
    cores = os.sched_getaffinity(0)
    if len(cores) > 1:
        assert 0.0 < core_balance(200_000) <= 1.0
    try:
        os.sched_setaffinity(0, {min(cores)})
        assert math.isnan(core_balance(200_000))
    finally:
        os.sched_setaffinity(0, cores)
