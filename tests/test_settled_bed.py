"""Settled beds: a drum run at one speed keeps its charge at rest; a run of the same drum and
charge at another speed and duration (and another launch) starts from it and ends with the
bits it has on its own."""

import logging
from dataclasses import replace

import pandas as pd
from helpers import MATERIALS, PAIRS, small_drum

from ballmill.config import SimConfig
from ballmill.drum import simulate_drum

SIM = SimConfig(shear_modulus_scale=1e-2, settle_s=0.12, startup_revolutions=None, window_revolutions=None,
                steady_after_s=0.05, duration_s=0.2, sample_every_s=0.01, trajectory_every=5)


def test_a_run_from_another_speeds_settled_bed_ends_with_its_own_bits(tmp_path, caplog):
    beds = tmp_path / "beds"
    first = simulate_drum(replace(small_drum(), fraction_of_critical=0.5), MATERIALS, PAIRS, SIM, tmp_path / "first",
                          beds)
    assert len(list(beds.glob("*.npz"))) == 1
    faster, longer = replace(small_drum(), fraction_of_critical=0.8), replace(SIM, duration_s=0.25)
    with caplog.at_level(logging.INFO):  # another launch than the bed's: bits do not depend on it
        reused = simulate_drum(faster, MATERIALS, PAIRS, replace(longer, launch="parallel"), tmp_path / "reused", beds)
    assert "starting from the settled bed" in caplog.text
    alone = simulate_drum(faster, MATERIALS, PAIRS, longer, tmp_path / "alone")
    assert reused.summary == alone.summary
    for table in ("loads", "energy", "collisions", "trajectories"):
        pd.testing.assert_frame_equal(getattr(reused.results, table), getattr(alone.results, table), check_exact=True)
    assert reused.summary["speed_rpm"] == 1.6 * first.summary["speed_rpm"]
    assert reused.summary["simulated_s"] > first.summary["simulated_s"]


def test_another_charge_settles_on_its_own(tmp_path, caplog):
    beds = tmp_path / "beds"
    with caplog.at_level(logging.INFO):
        simulate_drum(small_drum(), MATERIALS, PAIRS, SIM, tmp_path / "first", beds)
        assert "saved the settled bed" in caplog.text
        caplog.clear()
        simulate_drum(small_drum(), MATERIALS, PAIRS, replace(SIM, seed=SIM.seed + 1), tmp_path / "other", beds)
    assert "saved the settled bed" in caplog.text and "starting from the settled bed" not in caplog.text
    assert len(list(beds.glob("*.npz"))) == 2


def test_a_bed_saved_on_a_sample_step_keeps_that_sample(tmp_path, monkeypatch, caplog):
    import ballmill.drum as drum_module

    made = drum_module.settled_bed

    def on_a_sample(drum, materials, interactions, sim, dt, beds_dir):
        bed = made(drum, materials, interactions, sim, dt, beds_dir)
        per_sample = round(sim.sample_every_s / dt)
        return bed and replace(bed, step=bed.step // per_sample * per_sample)

    monkeypatch.setattr(drum_module, "settled_bed", on_a_sample)
    beds = tmp_path / "beds"
    simulate_drum(small_drum(), MATERIALS, PAIRS, SIM, tmp_path / "first", beds)
    with caplog.at_level(logging.INFO):
        reused = simulate_drum(small_drum(), MATERIALS, PAIRS, replace(SIM, duration_s=0.25), tmp_path / "reused",
                               beds)
    assert "starting from the settled bed" in caplog.text  # else the comparison below compares two fresh runs
    alone = simulate_drum(small_drum(), MATERIALS, PAIRS, replace(SIM, duration_s=0.25), tmp_path / "alone")
    pd.testing.assert_frame_equal(reused.results.loads, alone.results.loads, check_exact=True)
