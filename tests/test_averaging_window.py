"""A drum's averaging window that ends on the standard error of its mean power: never before
one revolution of averaging, never beyond the configured window, the reason recorded, and the
power of a stopped run the same as a full run's over the same samples."""

from dataclasses import replace

import pytest
from helpers import DRUM_SIM, MATERIALS, PAIRS, small_drum

from ballmill.dem import Results
from ballmill.drum import CONFIGURED, drum_speed_rpm, simulate_drum

SIM = replace(DRUM_SIM, settle_s=0.3, duration_s=1.6, steady_after_s=0.2)  # averaging from 0.5 s to 1.9 s


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for name, target in (("loose", 0.5), ("strict", 1e-6)):
        folder = tmp_path_factory.mktemp(name)
        out[name] = simulate_drum(small_drum(), MATERIALS, PAIRS, replace(SIM, power_se_target=target), folder)
    return out


def test_a_loose_target_stops_after_one_revolution_of_averaging(runs):
    turn = 60.0 / drum_speed_rpm(small_drum())  # 1.07 s
    summary = runs["loose"].summary
    start = summary["averaging_from_s"]
    assert start + turn <= summary["simulated_s"] < start + turn + 0.11  # first look after the revolution
    assert summary["averaging_ended_by"].startswith("standard error")


def test_an_unreachable_target_runs_the_whole_duration(runs):
    summary = runs["strict"].summary
    assert summary["simulated_s"] == pytest.approx(SIM.settle_s + SIM.duration_s, abs=SIM.sample_every_s)
    assert summary["averaging_ended_by"] == CONFIGURED


def test_the_stopped_runs_power_is_the_full_runs_over_the_same_samples(runs):
    stopped, full = runs["loose"], runs["strict"]
    until = stopped.summary["simulated_s"]
    same = Results(full.results.loads[full.results.loads.t_s <= until + 1e-9], *[None] * 3)
    assert stopped.summary["power_w"] == pytest.approx(same.mean_power_w("drum", SIM.settle_s + SIM.steady_after_s)[0],
                                                       rel=1e-12)
