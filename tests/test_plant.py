"""The whole plant: element balances, the recycle loop, the discounted cash flow against a
textbook example and an annuity, the mill section against the paper's mill costs, and the
Monte Carlo's limits."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from ballmill.config import EconomicsConfig, PlantConfig
from ballmill.economics import electricity
from ballmill.plant import uncertainty
from ballmill.plant.dcf import cash_flows, minimum_selling_price, npv_usd
from ballmill.plant.flowsheet import Flowsheet, flowsheet, mill_throughput_kg_per_h
from ballmill.plant.model import MILL, Mill, evaluate
from ballmill.plant.streams import ELEMENTS, elements, molar_mass_kg_per_mol

PLANT = PlantConfig()
ECON = EconomicsConfig()
MILL_19 = Mill(1313.6, 0.7487, 1.0, 50_000.0, 150_000.0)


@pytest.mark.parametrize("conversion, purge", [(0.7487, 0.05), (0.7487, 1.0), (1.0, 1.0), (0.3, 0.5)])
def test_element_balances_close_over_the_whole_flowsheet(conversion, purge):
    fs = flowsheet(1000.0, conversion, 1.0, replace(PLANT, recycle_purge_fraction=purge))
    into = [elements(fs.streams[s]) for s in Flowsheet.INPUTS]
    out = [elements(fs.streams[s]) for s in Flowsheet.OUTPUTS]
    for e in ELEMENTS:
        total_in, total_out = sum(x[e] for x in into), sum(x[e] for x in out)
        assert total_out == pytest.approx(total_in, rel=1e-9, abs=1e-12)
    assert sum(elements(fs.streams["bale PET"]).values()) > 0


def test_recycle_fresh_feed_is_the_products_pet_equivalent_plus_the_purge():
    fs = flowsheet(1000.0, 0.6, 1.0, replace(PLANT, recycle_purge_fraction=0.1))
    tpa_mol = fs.streams["rTPA"]["tpa"] / molar_mass_kg_per_mol("tpa") / PLANT.tpa_recovery
    pet_equivalent = tpa_mol * molar_mass_kg_per_mol("pet")
    assert 1000.0 == pytest.approx(pet_equivalent + fs.streams["purged PET"]["pet"], rel=1e-12)
    assert fs.mill_pet_kg_per_h == pytest.approx(mill_throughput_kg_per_h(1000.0, 0.6, 0.1))
    assert fs.mill_pet_kg_per_h == pytest.approx(1000.0 + fs.streams["recycled PET"]["pet"])


def test_npv_reproduces_the_textbook_example():
    """Gitman, Principles of Managerial Finance (Brief, 3rd ed. 2003, p. 346), as numpy-financial
    documents it: 40,000 invested, 5,000 / 8,000 / 12,000 / 30,000 back, 8 %: NPV 3,065.22."""
    assert npv_usd(np.array([-40_000, 5_000, 8_000, 12_000, 30_000]), 0.08) == pytest.approx(3065.22, abs=0.005)


def test_msp_without_tax_is_the_capital_recovery_annuity():
    cfg = replace(PLANT, tax_rate=0.0, construction_fractions=[1.0], working_capital_fraction=0.0, plant_life_yr=20)
    fixed, opex, q, r = 1e7, 2e6, 5000.0, cfg.discount_rate
    crf = r / (1 - (1 + r) ** -20)
    assert minimum_selling_price(q, opex, fixed, 0.0, cfg) == pytest.approx((opex + fixed * crf) / q, rel=1e-12)


def test_npv_at_the_msp_is_zero():
    plant = evaluate(MILL_19, PLANT, ECON)
    flows = cash_flows(plant.msp_usd_per_t, plant.rtpa_t_per_yr, sum(plant.opex.values()),
                       plant.capital["fixed_capital_usd"], plant.capital["working_capital_usd"], PLANT)
    assert abs(npv_usd(flows, PLANT.discount_rate)) < 1e-6 * plant.capital["fixed_capital_usd"]
    assert 0.5 < plant.msp_usd_per_t / 1000 < 5.0  # $/kg rTPA: the order of virgin TPA's price (1.14)


def test_full_conversion_without_recycle_keeps_the_mills_own_costs():
    mill = Mill(1000.0, 1.0, 1.0, 38_000.0, 119_904.0)
    plant = evaluate(mill, replace(PLANT, recycle_purge_fraction=1.0), ECON)
    assert plant.flows.streams["bale PET"]["pet"] == 1000.0 == plant.flows.mill_pet_kg_per_h
    assert plant.opex["electricity_mill"] == pytest.approx(electricity(38_000.0, 1000.0, ECON)["electricity_usd_per_yr"],
                                                          rel=1e-12)
    assert plant.equipment.set_index("unit").purchase_cost_usd[MILL] == 119_904.0


def test_monte_carlo_without_spread_returns_the_deterministic_msp(monkeypatch):
    flat = pd.DataFrame({"parameter": ["prices.naoh", "plant.staff", "dem.power"], "low_factor": [1.0, 1.0, np.nan],
                         "high_factor": [1.0, 1.0, np.nan], "distribution": ["triangular", "triangular", "normal"]})
    monkeypatch.setattr(uncertainty, "table", lambda name: flat)
    cfg = replace(PLANT, monte_carlo_draws=20)
    draws = uncertainty.monte_carlo(MILL_19, 0.0, cfg, ECON)
    assert np.allclose(draws, evaluate(MILL_19, PLANT, ECON).msp_usd_per_t / 1000, rtol=1e-12)


def test_monte_carlo_is_seeded_and_tornado_ranks_swings():
    cfg = replace(PLANT, monte_carlo_draws=30)
    a = uncertainty.monte_carlo(MILL_19, 1000.0, cfg, ECON)
    assert np.array_equal(a, uncertainty.monte_carlo(MILL_19, 1000.0, cfg, ECON))
    assert a.std() > 0
    t = uncertainty.tornado(MILL_19, 1000.0, PLANT, ECON)
    assert t.swing_usd_per_kg.is_monotonic_decreasing and len(t) == len(uncertainty.table("plant_uncertainty.csv"))
