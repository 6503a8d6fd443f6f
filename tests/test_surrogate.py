"""The DEM surrogate: scaling carried by the dimensionless form, the fit and its honesty about
error (on the shipped DEM training table), refusal outside the training hull, and the optimiser."""

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from ballmill.config import ConfigError, DrumConfig, InteractionConfig, MaterialConfig, SurrogateConfig
from ballmill.surrogate.model import Surrogate, error_table, predict_drum
from ballmill.surrogate.optimise import minimise
from ballmill.surrogate.space import INPUTS, OUTPUTS, groups
from ballmill.surrogate.training import design

MATERIALS = {"steel": MaterialConfig(density_kg_per_m3=7800.0)}
PAIRS = {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}


def synthetic_table(noise: float = 0.02, seed: int = 0) -> pd.DataFrame:
    """The training design with smooth known outputs, each with a relative standard error `noise`."""
    table = design(SurrogateConfig())
    rng = np.random.default_rng(seed)
    phi, fill = table.fraction_of_critical, table.fill_fraction
    truth = {"power_number": 0.8 * phi * (1 - 0.9 * fill) * table.friction**0.1,
             "collision_power_number": 0.5 * phi**1.5 * (1.2 - table.restitution) * (1 + 0.01 * table.diameter_to_ball)}
    for name, value in truth.items():
        table[name] = value * (1 + noise * rng.standard_normal(len(table)))
        table[f"{name}_se"] = noise * value
    return table.assign(status="ok")


@pytest.fixture(scope="module")
def synthetic():
    table = synthetic_table()
    return table, Surrogate.fit(table[table.split == "train"])


def test_geometrically_similar_mills_scale_as_d_to_the_2_5_times_length(synthetic):
    _, model = synthetic
    small = DrumConfig(inner_diameter_m=1.6, inner_length_m=2.4, ball_radius_m=0.08, fill_fraction=0.3,
                       fraction_of_critical=0.5)
    big = replace(small, inner_diameter_m=3.2, inner_length_m=4.8, ball_radius_m=0.16)
    assert groups(small, PAIRS) == pytest.approx(groups(big, PAIRS))
    p_small, p_big = (predict_drum(model, d, MATERIALS, PAIRS)["power_w"] for d in (small, big))
    assert p_big / p_small == pytest.approx(2**2.5 * 2, rel=0.02)  # ball count rounds


def test_a_smooth_response_is_learnt_within_its_noise(synthetic):
    table, _ = synthetic
    _, summary = error_table(table, folds=4)
    held = summary[summary.set == "held out"].set_index("output")
    assert (held.median_error < 0.03).all(), held
    fit = summary[summary.set == "training fit"].set_index("output")
    assert (fit.within_2_se > 0.9).all(), fit


def test_a_training_with_nothing_held_out_reports_its_fit_and_cross_validation(synthetic):
    table, _ = synthetic
    runs, summary = error_table(table[table.split == "train"], folds=4)  # `ballmill surrogate holdout=0`
    assert set(summary.set) == {"training fit", "cross-validation"} and set(runs.split) == set(summary.set)


def test_outside_the_training_box_is_refused_naming_the_input(synthetic):
    table, model = synthetic
    x = np.array(table.loc[table.split == "train", list(INPUTS)].median())
    x[INPUTS.index("fill_fraction")] = 0.6
    with pytest.raises(ConfigError, match=r"fill_fraction=0\.6 is outside the training runs' range"):
        model.predict(x)
    assert np.isfinite(model.predict(x, extrapolate=True).to_numpy()).all()


def test_a_corner_of_the_box_outside_the_hull_is_refused(synthetic):
    table, model = synthetic
    train = table[table.split == "train"][list(INPUTS)].to_numpy()
    corner = train.max(axis=0)  # each input at its largest training value: inside the box, outside the hull
    with pytest.raises(ConfigError, match="outside the hull of the training runs"):
        model.predict(corner)


def test_held_out_points_lie_inside_the_training_hull(synthetic):
    table, model = synthetic
    held = table[table.split == "holdout"]
    assert len(held) == SurrogateConfig().holdout
    assert model.inside(held[list(INPUTS)].to_numpy()).all()


def bowl(knobs):
    """A cost with a known minimum at x = 0.3, y = 0.7, infeasible where x + y > 1.2."""
    value = (knobs["x"] - 0.3) ** 2 + 2 * (knobs["y"] - 0.7) ** 2 + 1.0
    return value, knobs["x"] + knobs["y"] - 1.2


def test_the_optimiser_finds_a_known_minimum_and_respects_the_constraint():
    best, value, _ = minimise(bowl, {"x": (0.0, 1.0), "y": (0.0, 1.0)}, trials=200, seed=3)
    assert best["x"] == pytest.approx(0.3, abs=0.05)
    assert best["y"] == pytest.approx(0.7, abs=0.05)
    assert value == pytest.approx(1.0, abs=0.005)
    assert best["x"] + best["y"] <= 1.2


def test_the_same_seed_gives_the_same_optimum():
    first = minimise(bowl, {"x": (0.0, 1.0), "y": (0.0, 1.0)}, trials=40, seed=7)
    again = minimise(bowl, {"x": (0.0, 1.0), "y": (0.0, 1.0)}, trials=40, seed=7)
    assert first[0] == again[0] and first[1] == again[1]


def test_no_feasible_trial_is_a_clear_error():
    with pytest.raises(ConfigError, match="none of 20 trials was feasible"):
        minimise(lambda k: (1.0, 1.0), {"x": (0.0, 1.0)}, trials=20, seed=0)


def test_power_number_definition():
    """P / (M g omega D/2): a 1 t charge in a 2 m mill at 30 rpm drawing 10 kW."""
    from ballmill.surrogate.space import power_scale_w

    assert 1e4 / power_scale_w(1000.0, 2.0, 30.0) == pytest.approx(1e4 / (1000 * 9.81 * math.pi * 1.0))
    assert set(OUTPUTS) == {"power_number", "collision_power_number"}


# On the shipped training table (DEM runs), the errors measured (docs/validation.md) and the bounds
# asserted, a quarter above them (room for the GP's fit to move between library versions; the
# speed's fraction of critical read 10 % high moves the held-out power number to 1.6 % median and
# 2.9 % p90, which bounds of three times the errors let through):
#   held out          power number 0.89 % median, 1.39 % p90; collision power number 1.56 %, 3.08 %
#   cross-validation  power number 1.92 %, 4.71 %;           collision power number 2.83 %, 9.44 %
#   training fit within 2 DEM standard errors: 98.4 % (power), 100 % (collision power)
BOUNDS = {("held out", "power_number"): (0.011, 0.0175), ("held out", "collision_power_number"): (0.0195, 0.0385),
          ("cross-validation", "power_number"): (0.024, 0.059),
          ("cross-validation", "collision_power_number"): (0.035, 0.118)}


@pytest.fixture(scope="module")
def shipped():
    from ballmill.surrogate.model import table_path

    table = pd.read_csv(table_path("surrogate_training.csv"))
    return table, error_table(table, folds=5)


def test_the_shipped_table_records_where_it_came_from(shipped):
    table, _ = shipped
    assert {"source", "year", "dem_key", "shear_modulus_scale", "split"} <= set(table.columns)
    assert (table.status == "ok").mean() > 0.9
    assert table.source.str.contains("ballmill surrogate").all()


def test_the_surrogate_reproduces_its_training_runs_within_their_standard_error(shipped):
    _, (_, summary) = shipped
    fit = summary[summary.set == "training fit"].set_index("output")
    print(fit.to_string())
    assert (fit.within_2_se >= 0.95).all(), fit  # measured 63 and 64 of 64 runs; 61 asked


def test_the_held_out_and_cross_validated_errors_are_within_the_measured_bounds(shipped):
    _, (_, summary) = shipped
    print(summary.to_string())
    errors = summary.set_index(["set", "output"])
    for key, (median, p90) in BOUNDS.items():
        assert errors.at[key, "median_error"] < median, errors
        assert errors.at[key, "p90_error"] < p90, errors


def run_plan(tmp_path, overrides):
    from ballmill.scenario import compose, load
    from ballmill.studies import plan

    p = plan(load(compose("config", [f"cache_dir={tmp_path / 'cache'}", *overrides])))
    return p.record | p.execute(tmp_path)


def test_a_design_by_the_surrogate_is_marked_and_carries_its_uncertainty(tmp_path):
    rec = run_plan(tmp_path, ["dem=surrogate"])
    assert rec["dem_source"] == "surrogate" and rec["dem_inside_hull"]
    assert 0 < rec["dem_power_se_w"] < 0.2 * rec["dem_power_w"]
    assert rec["yield_percent"] == pytest.approx(6.38 * 19 - 46.35)


def test_a_design_outside_the_runs_is_refused_naming_the_way_out_or_sent_to_the_dem(tmp_path):
    """DC's mill (0.35 of critical with a diameter of 7 balls) lies outside the hull: refused by
    default, the message naming dem.outside=full; with it, the DEM runs that mill and says so."""
    dc = ["dem=surrogate", "scaleup.region=DC", "scaleup.pet_feed_kg_per_h=null", "sim=test"]
    with pytest.raises(ConfigError, match=r"outside the hull .* use dem=full, dem.outside=full"):
        run_plan(tmp_path, dc)
    rec = run_plan(tmp_path, [*dc, "dem.outside=full"])
    assert rec["dem_source"] == "full" and rec["dem_outside_surrogate"] and rec["dem_power_w"] > 0
    inside = run_plan(tmp_path, ["dem=surrogate", "dem.outside=full"])  # BPR 19 at 1000 kg/h: inside
    assert inside["dem_source"] == "surrogate"


def test_the_cheapest_mill_is_no_dearer_than_the_papers_and_knobs_are_ranked(tmp_path):
    """Each knob's worth is the optimum's cost rise with that knob back at the paper's value:
    every one a rise, none above the paper's whole extra cost (13.3 %; the four together 11.9 %),
    and ranked as measured: speed 4.8 % and fill 4.5 % first (too close to order), then L/D
    1.9 %, then ball size 0.7 %."""
    rec = run_plan(tmp_path, ["study=cheapest_mill", "optimiser.trials=30", "optimiser.confirm=false",
                              "economics.capacity_scaling=holdup"])
    assert rec["optimum_annualised_cost_usd_per_yr"] <= rec["paper_annualised_cost_usd_per_yr"]
    assert rec["optimum_dem_inside_hull"]
    worth = {k: rec[f"knob_{k}_cost_increase_fraction"] for k in
             ("fraction_of_critical", "fill_fraction", "ball_radius_m", "length_to_diameter")}
    paper_extra = rec["paper_annualised_cost_usd_per_yr"] / rec["optimum_annualised_cost_usd_per_yr"] - 1
    assert all(0 < w <= paper_extra for w in worth.values()), (worth, paper_extra)
    assert min(worth["fraction_of_critical"], worth["fill_fraction"]) > worth["length_to_diameter"] \
        > worth["ball_radius_m"], worth
    assert len(pd.read_csv(tmp_path / "trials.csv")) == 30


def test_a_counted_charge_has_the_fill_of_its_ball_count():
    """A scale-up mill gives its balls as a count: its fill, not the mill group's default, is the input."""
    from ballmill.drum import ball_count

    drum = DrumConfig(inner_diameter_m=1.4, inner_length_m=2.8, ball_radius_m=0.0645, fill_fraction=0.43)
    counted = replace(drum, ball_count=ball_count(drum), fill_fraction=0.3)
    assert groups(counted, PAIRS)["fill_fraction"] == pytest.approx(0.43, rel=2e-3)
