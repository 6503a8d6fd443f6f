import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from helpers import DRUM_SIM, MATERIALS, PAIRS, small_drum  # importable once the path above is set

from ballmill.dem.runtime import LOCAL_JOBS_ENV
from ballmill.drum import simulate_drum

pytest_plugins = ["pytester"]  # tests/test_ci_skips.py runs sessions of its own


class SkipsFailCI:
    """On CI (the variable CI set), a skipped test fails the run: it is a check that was asked
    for and could not run.  The one skip allowed is the CUDA comparison's (tests/test_cuda.py),
    on a machine with no CUDA device."""

    allowed = frozenset({"test_cuda.py"})

    def __init__(self):
        self.skipped = []

    def record(self, report):
        if report.skipped and not hasattr(report, "wasxfail") and \
                Path(report.nodeid.split("::")[0]).name not in self.allowed:
            self.skipped.append(report.nodeid)

    pytest_runtest_logreport = pytest_collectreport = record

    def pytest_sessionfinish(self, session):
        if self.skipped and session.exitstatus == pytest.ExitCode.OK:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    def pytest_terminal_summary(self, terminalreporter):
        if self.skipped:
            terminalreporter.write_line(f"CI: {len(self.skipped)} skipped, which fails the run (only "
                                        f"{', '.join(sorted(self.allowed))} may skip): {', '.join(self.skipped)}",
                                        red=True)


# The test files that take longest on 2 cores (the suite's --durations, commit 9692359: 250-380 s for
# the first two, 40-210 s for the rest), longest first.  The workers take whole files in
# collection order (tasks.py test: --no-loadscope-reorder), so these start first and the two
# workers end together whatever the draw; xdist's own order, files with the most tests first, once
# started the LIGGGHTS comparison's 250 s when a worker had 760 s behind it, and that worker ended
# 126 s after the other (another time 2 s: the suite took 952.8 s, this order 949.9 s, ends 11 s apart).
LONGEST_FIRST = ("test_commands.py", "test_peer_torque.py", "test_sweeps.py", "test_docs.py", "test_launchers.py",
                 "test_bad_input.py", "test_checkpoint.py", "test_kinetics.py", "test_yield_model.py",
                 "test_neighbour_list.py", "test_calibrate.py", "test_install.py", "test_plant.py")


def pytest_collection_modifyitems(items):
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: the rest as collected


def pytest_configure(config):
    # a test left to pick its threads (sim.threads=0), and the commands it starts, take this
    # worker's share of the cores, as a sweep's jobs do: xdist's workers are jobs run at once
    os.environ.setdefault(LOCAL_JOBS_ENV, os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if os.environ.get("CI"):
        config.pluginmanager.register(SkipsFailCI(), "skips_fail_ci")


@pytest.fixture(scope="session")
def analytic_drum_run(tmp_path_factory):
    """(summary, folder) of the small analytic drum at DRUM_SIM, shared by the tests that read it."""
    folder = tmp_path_factory.mktemp("analytic_drum")
    return simulate_drum(small_drum("analytic"), MATERIALS, PAIRS, DRUM_SIM, folder).summary, folder
