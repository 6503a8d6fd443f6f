"""Scale-up and economics against hand-computed numbers and the paper's reported values."""

import math
from dataclasses import replace

import pytest

from ballmill.config import ConfigError, EconomicsConfig, ScaleupConfig, YieldModelConfig
from ballmill.economics import bond_rowland_power_w, electricity, margin_usd_per_t_tpa, purchase_cost_usd
from ballmill.scaleup import design_mill, regional_pet_feed_kg_per_h, stoichiometric_naoh_kg_per_h
from ballmill.yields import bpr_line_yield

ECON = EconomicsConfig()
LINE = YieldModelConfig()
PAPER = ScaleupConfig(naoh_feed_kg_per_h=400.0)


def test_stoichiometric_naoh_is_two_moles_per_repeat_unit():
    assert stoichiometric_naoh_kg_per_h(1000.0) == pytest.approx(1000 * 2 * 40.00 / 192.17)  # 416.3 kg/h


def test_paper_mill_by_hand():
    d = design_mill(PAPER)
    holdup = 1400 * 20 / 60  # kg of PET + NaOH in the mill
    balls = 19 * holdup
    volume = balls / 7900 / 0.6 / 0.3
    assert d.holdup_kg == pytest.approx(holdup)
    assert d.ball_count == round(balls / (7900 * 4 / 3 * math.pi * 0.08**3))  # 523
    assert d.mill_volume_m3 == pytest.approx(volume)
    assert d.diameter_m == pytest.approx((4 * volume / (1.5 * math.pi)) ** (1 / 3))
    assert d.length_m == pytest.approx(1.5 * d.diameter_m)
    assert d.fraction_of_critical == pytest.approx(15 / (42.3 / math.sqrt(d.diameter_m - 0.16)))


def test_fraction_of_critical_rule_fixes_the_diameter():
    d = design_mill(replace(PAPER, shape_rule="fraction_of_critical", fraction_of_critical=0.7))
    assert d.diameter_m == pytest.approx(0.16 + (42.3 * 0.7 / 15) ** 2)
    assert d.fraction_of_critical == pytest.approx(0.7)


def test_purchase_cost_reproduces_the_paper_within_one_percent():
    cost = purchase_cost_usd(1000.0, 400.0, ECON)
    assert cost == pytest.approx(64640 * (1000 / 907.18474) ** 0.64 * 816.0 / 468.2)
    assert cost == pytest.approx(119_719, rel=0.01)


def test_yield_fit_is_capped_and_refuses_extrapolation_unless_allowed():
    assert bpr_line_yield(19, LINE) == (pytest.approx(74.87), False)
    assert bpr_line_yield(20, LINE)[0] == pytest.approx(81.25)
    assert bpr_line_yield(23, LINE)[0] == 100.0
    with pytest.raises(ConfigError, match=r"scaleup.bpr=25 .*\[10.0, 23.0\]"):
        bpr_line_yield(25, LINE)
    assert bpr_line_yield(25, replace(LINE, allow_extrapolation=True)) == (100.0, True)


def test_margin_per_tonne_tpa_matches_the_paper_within_two_dollars():
    m = margin_usd_per_t_tpa(ECON)
    assert m["pet_t_per_t_tpa"] == pytest.approx(192.17 / 166.13)
    assert m["margin_usd_per_t_tpa"] == pytest.approx(978, abs=2)


def test_electricity_cost_by_hand():
    e = electricity(23_143.0, 1000.0, ECON)
    assert e["electricity_usd_per_t_pet"] == pytest.approx(23.143 * 0.07)  # 1.62 $/t, the paper's BPR 19
    assert e["electricity_usd_per_yr"] == pytest.approx(23.143 * 0.07 * 7920)


def test_regional_feed_is_national_collection_times_population_share():
    fl = regional_pet_feed_kg_per_h("FL", "bottles_collected", 7920)
    assert fl == pytest.approx(1813e6 * 0.45359237 * 21_299_325 / 327_167_434 / 7920)
    assert fl == pytest.approx(6760, rel=1e-3)
    with pytest.raises(ValueError, match="scaleup.region='XX'"):
        regional_pet_feed_kg_per_h("XX", "bottles_collected", 7920)


def test_bond_rowland_power_by_hand():
    kwb = 4.879 * 2.0**0.3 * (3.2 - 0.9) * 0.7 * (1 - 0.1 / 2 ** (9 - 7)) + 1.102 * (100 - 25) / 50.8
    assert bond_rowland_power_w(2.0, 10_000.0, 0.3, 0.7, 0.1) == pytest.approx(kwb * 10 * 1000)


def test_holdup_scaling_prices_a_longer_residence_time_as_a_larger_capacity():
    holdup = replace(ECON, capacity_scaling="holdup")
    assert purchase_cost_usd(1000.0, 400.0, holdup, 20.0) == purchase_cost_usd(1000.0, 400.0, ECON)
    assert purchase_cost_usd(1000.0, 400.0, holdup, 80.0) == pytest.approx(
        purchase_cost_usd(4000.0, 400.0, ECON))
    assert purchase_cost_usd(1000.0, 400.0, ECON, 80.0) == purchase_cost_usd(1000.0, 400.0, ECON)


def test_a_mill_without_a_set_speed_runs_at_its_fraction_of_critical():
    d = design_mill(replace(ScaleupConfig(), speed_rpm=None, fraction_of_critical=0.6))
    assert d.speed_rpm == pytest.approx(0.6 * 42.3 / (d.diameter_m - 0.16) ** 0.5)
    assert d.fraction_of_critical == pytest.approx(0.6)
    with pytest.raises(ConfigError, match="shape_rule=fraction_of_critical sizes the diameter from scaleup.speed_rpm"):
        design_mill(replace(ScaleupConfig(), speed_rpm=None, shape_rule="fraction_of_critical"))


def test_a_graded_charge_scales_up_by_mass_fraction():
    from ballmill.config import BallSizeConfig

    cfg = ScaleupConfig(pet_feed_kg_per_h=1000.0, charge=[BallSizeConfig(0.1, mass_fraction=0.4),
                                                          BallSizeConfig(0.16, mass_fraction=0.6)])
    d = design_mill(cfg)
    assert d.charge_diameters_m == (0.16, 0.1)  # largest first
    masses = [n * 7900.0 * math.pi / 6 * size**3 for size, n in zip(d.charge_diameters_m, d.charge_counts)]
    assert sum(masses) == pytest.approx(d.ball_mass_kg, rel=0.01)
    assert masses[0] / sum(masses) == pytest.approx(0.6, abs=0.01)
    assert d.ball_count == sum(d.charge_counts)
    assert d.ball_radius_m == pytest.approx((0.6 * 0.16 + 0.4 * 0.1) / 2)  # mass-weighted mean
    rec = d.as_record()
    assert rec["charge_160mm_balls"] == d.charge_counts[0] and "charge_counts" not in rec
    mono = design_mill(ScaleupConfig(pet_feed_kg_per_h=1000.0))
    assert "charge_80mm_balls" not in mono.as_record() and mono.ball_radius_m == 0.08
    with pytest.raises(ConfigError, match="mass_fraction"):
        ScaleupConfig(charge=[BallSizeConfig(0.1, count=10)]).__post_init__()
