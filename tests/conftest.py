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
