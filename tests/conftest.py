import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from helpers import DRUM_SIM, MATERIALS, PAIRS, small_drum  # importable once the path above is set

from ballmill.drum import simulate_drum


@pytest.fixture(scope="session")
def analytic_drum_run(tmp_path_factory):
    """(summary, folder) of the small analytic drum at DRUM_SIM, shared by the tests that read it."""
    folder = tmp_path_factory.mktemp("analytic_drum")
    return simulate_drum(small_drum("analytic"), MATERIALS, PAIRS, DRUM_SIM, folder).summary, folder
