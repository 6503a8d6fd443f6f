"""On CI a skipped test fails the run, except the CUDA comparison's skip (tests/conftest.py):
sessions of a stand-in suite under the suite's conftest, a passing test beside a skipped one."""

import sys
from pathlib import Path

import pytest

CONFTEST = (Path(__file__).parent / "conftest.py").read_text()
PASS_AND_SKIP = """
import pytest

def test_runs():
    pass

@pytest.mark.skip(reason="not asked for")
def test_skipped():
    pass
"""


@pytest.mark.parametrize("module, ci, code", [
    ("test_peer", True, pytest.ExitCode.TESTS_FAILED),  # a check asked for that could not run
    ("test_cuda", True, pytest.ExitCode.OK),  # no CUDA device
    ("test_peer", False, pytest.ExitCode.OK),  # not on CI: a skip is a skip
])
def test_on_ci_a_skip_fails_the_run_unless_it_is_the_cuda_comparisons(pytester, monkeypatch, module, ci, code):
    if ci:
        monkeypatch.setenv("CI", "true")
    else:
        monkeypatch.delenv("CI", raising=False)
    monkeypatch.delitem(sys.modules, module, raising=False)  # the suite's own test_cuda, imported by name
    pytester.makeconftest(CONFTEST)
    pytester.makepyfile(**{module: PASS_AND_SKIP})
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, skipped=1)
    assert result.ret == code
    if code != pytest.ExitCode.OK:
        result.stdout.fnmatch_lines([f"CI: 1 skipped, which fails the run*{module}.py::test_skipped"])
