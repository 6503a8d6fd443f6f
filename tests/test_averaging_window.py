"""A drum's averaging window: given in revolutions or seconds, flagged when it cannot give the
steady power, and ended on the standard error of its mean power: never before one revolution of
averaging, never beyond the configured window, the reason recorded, and the power of a stopped
run the same as a full run's over the same samples."""

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from helpers import DRUM_SIM, MATERIALS, PAIRS, small_drum

from ballmill.dem import Results
from ballmill.dem.results import batch_trend
from ballmill.drum import CONFIGURED, TREND_T, drum_speed_rpm, simulate_drum, window_check

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


def test_a_window_of_a_revolution_after_one_of_start_up_gives_the_steady_power(tmp_path):
    """In revolutions of the drum: the run's length follows its speed, and the window is flagged
    steady (it starts after the start-up, spans a revolution, and the power has no trend)."""
    sim = replace(DRUM_SIM, steady_after_s=None, duration_s=None, startup_revolutions=1.0, window_revolutions=1.0)
    summary = simulate_drum(small_drum(), MATERIALS, PAIRS, sim, tmp_path).summary
    turn = 60.0 / drum_speed_rpm(small_drum())
    assert summary["averaging_from_s"] == pytest.approx(sim.settle_s + turn, rel=1e-12)
    assert summary["simulated_s"] == pytest.approx(sim.settle_s + 2 * turn, abs=sim.sample_every_s)
    assert summary["window_revolutions"] == pytest.approx(1.0, abs=sim.sample_every_s / turn)
    assert summary["steady"] and summary["unsteady_reason"] == ""
    assert summary["startup_revolutions"] == pytest.approx(1.0, rel=1e-12) and abs(summary["power_trend_t"]) < TREND_T


def test_a_window_within_the_start_up_is_flagged_with_each_reason(tmp_path):
    """The test preset's window: 0.2 s of turning, then 0.4 s averaged while the charge is still
    being lifted (its power rises over the window)."""
    sim = replace(DRUM_SIM, settle_s=0.3, steady_after_s=0.2, duration_s=0.6)
    summary = simulate_drum(small_drum(), MATERIALS, PAIRS, sim, tmp_path).summary
    turn = 60.0 / drum_speed_rpm(small_drum())
    assert not summary["steady"]
    assert f"starts {0.2 / turn:.2g} revolutions after the drum starts" in summary["unsteady_reason"]
    assert f"window is {0.4 / turn:.2g} of a revolution, less than one" in summary["unsteady_reason"]
    assert summary["power_drift_fraction"] > 0.1 and summary["power_trend_t"] > 0


def window(power_w: np.ndarray) -> tuple:
    """A drum turning at 60 rpm from t = 0.1 s, averaged over its second revolution, sampled
    every 10 ms: its loads and summary, as window_check reads them."""
    t = 1.1 + 0.01 * np.arange(1, len(power_w) + 1)
    loads = pd.DataFrame({"t_s": t, "body": "drum", "power_w": power_w})
    return loads, {"speed_rpm": 60.0, "averaging_from_s": 1.1, "simulated_s": t[-1]}


def test_a_power_still_rising_over_a_whole_window_is_flagged_by_its_trend():
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 1, 100)
    rising = window(90 + 10 * np.linspace(0, 1, 100) + noise)  # +10 % over the window
    flagged = window_check(*rising, settle_s=0.1, sample_every_s=0.01)
    assert flagged["window_revolutions"] == pytest.approx(1.0) and flagged["startup_revolutions"] == pytest.approx(1.0)
    assert not flagged["steady"] and flagged["power_trend_t"] > TREND_T
    assert flagged["unsteady_reason"].startswith("the power still moves +1")
    steady = window_check(*window(95 + noise), settle_s=0.1, sample_every_s=0.01)
    assert steady["steady"] and abs(steady["power_trend_t"]) < TREND_T and steady["unsteady_reason"] == ""


def test_the_trend_of_a_line_is_its_slope_and_noise_about_a_constant_has_none():
    times = np.arange(100) * 0.01
    t_stat, drift = batch_trend(times, 100 + 5 * times)  # a straight line: no residual but round-off
    assert t_stat > 1e12 and drift == pytest.approx(5 * 0.99 / (100 + 5 * 0.495), rel=1e-12)
    wiggle = 100 + np.where(np.arange(100) % 2, 1.0, -1.0)  # each batch of ten averages to 100
    assert batch_trend(times, wiggle) == (0.0, 0.0)
    assert all(math.isnan(x) for x in batch_trend(times[:5], wiggle[:5]))  # fewer samples than batches
