"""The whole plant on BioSTEAM: element balances, the recycle, purchase costs against their
cited correlations worked by hand, NREL's capital and operating factors, the MSP against a
closed-form annuity, the staffing rule, the footprint's sum and grid factor, and the Monte
Carlo against an analytic mean."""

import math
from dataclasses import replace

import biosteam as bst
import numpy as np
import pandas as pd
import pytest

from ballmill.config import EconomicsConfig, EvaporationConfig, HeatConfig, PlantConfig, SodiumConfig
from ballmill.plant import haulage, uncertainty, units
from ballmill.plant.correlations import price
from ballmill.plant.model import plant
from ballmill.plant.options import options_table, pareto_front
from ballmill.plant.regional import hauled
from ballmill.plant.study import CONFIG_VARIANTS, TEA_FIELDS, variants
from ballmill.plant.system import MillSpec, fresh_pet_kg_per_h
from ballmill.plant.units import VapourFraction
from ballmill.plant.what_it_takes import bands, break_even

CEPCI_2021 = 708.8  # data/cepci.csv: the plant's cost year
MILL = MillSpec(1313.6, 0.7487, 1.0, 35.0, 130_000.0, {})  # the BPR 19 mill at 1000 kg/h of fresh PET
ECON = EconomicsConfig()


@pytest.fixture(scope="module")
def built():
    """The base plant, evaluated once and only read: a test that changes a plant builds its own."""
    p = plant(MILL, PlantConfig(), ECON)
    p.base = p.evaluate()
    return p


def own_plant(name: str, cfg=None):
    """A plant of its own, evaluated, for a test that changes it."""
    p = plant(MILL, cfg or PlantConfig(), ECON, name=name)
    p.evaluate()
    return p


def test_elements_balance_over_the_whole_plant(built):
    s = built.ps.system
    chemicals = built.ps.units["CT"].ins[2]  # BioSTEAM books the tower's chemicals as water that stays in it
    for element in ("C", "H", "O", "Na", "S", "N"):
        into = sum(f.get_atomic_flow(element) for f in s.feeds if f is not chemicals)
        out = sum(f.get_atomic_flow(element) for f in s.products)
        assert out == pytest.approx(into, rel=1e-7), element  # the recycle converges to 1e-9


def test_the_recycle_closes_at_the_designed_mill_throughput(built):
    mill = built.ps.units["R201"]
    assert mill.ins[0].imass["PET"] == pytest.approx(MILL.pet_kg_per_h, rel=1e-8)
    fresh = fresh_pet_kg_per_h(MILL.pet_kg_per_h, MILL.conversion, 0.05)  # 1000 kg/h of clean PET
    assert fresh == pytest.approx(1000.0, rel=1e-4)
    assert built.ps.streams["bales"].F_mass == pytest.approx(fresh / (0.8 * 0.98), rel=1e-9)  # 80 % PET, 2 % fines


def test_each_separation_meets_its_configured_recovery(built):
    """The share of its key chemical each separating unit sends where its config says."""
    u, cfg = built.ps.units, PlantConfig()

    def share(unit, out, chemical):
        return unit.outs[out].imol[chemical] / sum(s.imol[chemical] for s in unit.ins)

    assert share(u["F401"], 0, "EthyleneGlycol") == pytest.approx(cfg.eg_stripper_recovery, rel=1e-9)
    assert share(u["E401"], 1, "Water") == pytest.approx(cfg.evaporated_water_fraction, rel=1e-9)
    assert share(u["D402"], 0, "Water") == pytest.approx(cfg.eg_column_water_recovery, rel=1e-9)
    assert share(u["D402"], 1, "EthyleneGlycol") == pytest.approx(cfg.eg_column_eg_recovery, rel=1e-9)
    assert share(u["S301"], 0, "TerephthalicAcid") == pytest.approx(cfg.tpa_recovery, rel=1e-9)
    assert share(u["S201"], 0, "PET") == 1.0
    assert share(u["S202"], 1, "PET") == pytest.approx(cfg.recycle_purge_fraction, rel=1e-9)
    assert u["S401"].outs[0].imass["Na2SO4"] == pytest.approx(u["C401"].crystals_kg_per_h, rel=1e-9)
    for dryer in ("D301", "D401"):
        assert u[dryer].outs[0].imass["Water"] / u[dryer].outs[0].F_mass == pytest.approx(cfg.dry_moisture, rel=1e-6)


def test_the_base_plant_worked_by_hand(built):
    """The base plant's money and carbon from its unit table and stream table, typed here.
    Installed cost ($): the units' purchase cost x bare-module factor (E401 3,555,828, S301
    1,169,911, S201 552,832, D301 485,644, D402 417,069, S401 375,120, H401 293,678, R201 299,000,
    D401 247,288, T601 233,385, T602 205,831, CT 129,756, T201 101,588, R301 100,113, F401 47,659,
    U102 21,279, the three pumps 58,926, U101 6,205) = 8,301,112 of which ISBL (less T601, T602,
    CT) 7,732,140; fixed capital 1.6 x (8,301,112 + 0.175 x 7,732,140) = 15,446,778.
    Fixed operating: 0.007 x FCI + 0.03 x ISBL + 1.9 x 25 x 65,460 x 1.15 = 3,901,982 $/yr.
    Per kg rTPA (834.90 kg/h): NaOH 546.81 kg/h x 0.608 = 0.3982 $; EG 251.75 kg/h x 0.961 x 0.7
    = -0.2028 $; footprint: bales 1275.51 x 0.16, NaOH 546.81 x 2.05, acid 683.84 x 0.04447, steam
    10,985.36 MJ/h x 0.0863928, 361.19 kWh x 0.4181, landfilled 275.51 + 23.58 + 260.53 kg x 0.07,
    CO2 of the treated organics 75.27, EG -251.75 x 2.2938 and the water (10,268 kg fed, 1,077
    make-up, x 0.00042013; 10,119.9 treated x 0.0002851) = 2.396 kg CO2e/kg.  The MSP, 1.5875 $/kg
    (typed: the annuity test checks the cash flow's arithmetic), pins the whole."""
    t, rtpa = built.tea, 834.90
    installed = (3_555_828 + 1_169_911 + 552_832 + 485_644 + 417_069 + 375_120 + 293_678 + 299_000 + 247_288
                 + 233_385 + 205_831 + 129_756 + 101_588 + 100_113 + 47_659 + 21_279 + 58_926 + 6_205)
    isbl = installed - 233_385 - 205_831 - 129_756
    fci = 1.6 * (installed + 0.175 * isbl)
    assert (installed, round(fci)) == (8_301_112, 15_446_778)  # the units' costs rounded to $1 each
    assert t.FCI == pytest.approx(fci, rel=2e-6)
    assert t.FOC == pytest.approx(0.007 * fci + 0.03 * isbl + 1.9 * 25 * 65_460 * 1.15, rel=2e-6)
    assert built.rtpa.F_mass == pytest.approx(rtpa, rel=1e-5)
    record = built.record(built.base["msp_usd_per_kg"])
    assert record["msp_naoh_usd_per_kg"] == pytest.approx(546.81 * 0.608 / rtpa, rel=1e-4)
    assert record["msp_eg_usd_per_kg"] == pytest.approx(-251.75 * 0.961 * 0.7 / rtpa, rel=1e-4)
    carbon = (1275.51 * 0.16 + 546.81 * 2.05 + 683.84 * 0.04447 + 10_985.36 * 0.0863928 + 361.19 * 0.4181
              + (275.51 + 23.58 + 260.53) * 0.07 + 75.27 - 251.75 * 2.2938
              + (8601.9 + 1666.46 + 1077.41) * 0.00042013 + 10_119.86 * 0.0002851) / rtpa
    assert built.base["gwp_kg_per_kg"] == pytest.approx(carbon, rel=1e-5)
    assert built.base["gwp_kg_per_kg"] == pytest.approx(2.396, abs=5e-4)
    assert built.base["msp_usd_per_kg"] == pytest.approx(1.5875, abs=5e-5)


def test_correlations_give_their_textbook_prices():
    """Worked by hand, brought from each correlation's index to CEPCI 2021 (708.8):
    Seider's forced-circulation body of 18.67 m2 = 200.96 ft2: exp(8.0369 + 0.6994 ln 200.96
    - 0.00004 ln^2 200.96) = 126,093 $ at CE 567 -> 157,627 $;
    Seider's FC crystallizer at 800 kg/h = 21.164 short ton/day: 39575 x 21.164^0.56 = 218,655 -> 273,339 $;
    Towler's vacuum drum filter of 100 m2: -73000 + 93000 x 100^0.3 = 297,240 $ at 532.9 -> 395,353 $."""
    assert price("forced_circulation_evaporator_seider_2017", 18.67, CEPCI_2021).usd == pytest.approx(157_627, rel=1e-4)
    assert price("forced_circulation_crystallizer_seider_2017", 800.0, CEPCI_2021).usd == pytest.approx(273_339,
                                                                                                         rel=1e-4)
    assert price("vacuum_drum_filter_towler_2010", 100.0, CEPCI_2021).usd == pytest.approx(395_353, rel=1e-4)
    split = price("vacuum_drum_filter_towler_2010", 300.0, CEPCI_2021)  # above the 180 m2 range: two of 150 m2
    assert split.parallel == 2 and split.usd == pytest.approx(2 * price("vacuum_drum_filter_towler_2010", 150.0,
                                                                        CEPCI_2021).usd)


def test_the_large_units_are_priced_by_their_correlations(built):
    u = built.ps.units
    ft2 = [max(150.0, 10.7639 * a) for a in u["E401"]._As]  # a body below the 150 ft2 range is priced at 150
    bodies = sum(math.exp(8.0369 + 0.6994 * math.log(a) - 0.00004 * math.log(a) ** 2) for a in ft2) * CEPCI_2021 / 567
    assert u["E401"].purchase_costs["Evaporators"] == pytest.approx(2.1 * bodies, rel=1e-9)  # stainless 316 (Seider)
    assert u["C401"].purchase_cost == 0.0  # the last body is the crystallizer
    separate = plant(MILL, replace(PlantConfig(), crystallizer="separate", brine_material="carbon_steel"), ECON,
                     name="crystallizer")
    separate.evaluate()
    crystals = separate.ps.units["C401"].crystals_kg_per_h * 24 / 907.18474
    assert separate.ps.units["C401"].purchase_cost == pytest.approx(39575 * crystals**0.56 * CEPCI_2021 / 567,
                                                                    rel=1e-5)  # 6-digit unit factor
    area = u["S201"].design_results["Individual area"]  # ft2: BioSTEAM prices Seider's rotary-drum vacuum filter
    vessel = math.exp(11.796 - 0.1905 * math.log(area) + 0.0554 * math.log(area) ** 2) * CEPCI_2021 / 567
    assert u["S201"].purchase_costs["Vessels"] == pytest.approx(vessel * u["S201"].parallel["self"], rel=1e-9)
    assert u["R201"].purchase_cost == MILL.purchase_cost_usd
    assert u["R201"].installed_cost == pytest.approx(2.3 * MILL.purchase_cost_usd, rel=1e-12)


def test_a_cost_factor_scales_its_units_purchase_cost(built):
    p = own_plant("cost_factor")
    tank = p.ps.units["T201"]
    tank.cost_factor = 1.5
    p.evaluate()
    assert tank.purchase_cost == pytest.approx(1.5 * built.ps.units["T201"].purchase_cost, rel=1e-9)
    tank.cost_factor = 1.0
    assert p.evaluate()["msp_usd_per_kg"] == pytest.approx(built.base["msp_usd_per_kg"], rel=1e-9)


def test_capital_and_fixed_costs_follow_nrels_factors(built):
    """Direct cost = installed + 17.5 % of ISBL (warehouse 4, site 9, piping 4.5); depreciable =
    1.5 x direct (prorateable 10, field 10, construction 20, contingency 10 %); fixed capital +=
    10 % of direct; yearly: 0.7 % of fixed capital, 3 % of ISBL, labour with a 90 % burden."""
    t = built.tea
    osbl = sum(u.installed_cost for u in t.units if isinstance(u, (bst.StorageTank, bst.CoolingTower)))
    isbl = t.installed_equipment_cost - osbl
    direct = t.installed_equipment_cost + 0.175 * isbl
    assert t.TDC == pytest.approx(1.5 * direct, rel=1e-12)
    assert t.FCI == pytest.approx(1.6 * direct, rel=1e-12)
    # 0.25 + 0.25 (filters) + 0.5 (centrifuge) + 2 x 0.5 (dryers) + 1/6 (crystallizer) + 0.25 (evaporator)
    # + 3 x 0.5 (mill, dissolver, acidifier) + 0.25 (column) + 0.25 (stripper) + 0.25 (granulator)
    # + 0.5 (bale floor) + 0.25 (cooling tower) = 5.417 operators per shift x 4.5 = 24.4 -> 25
    assert t.staff == 25
    labour = 25 * 65460 * 1.15
    assert t.FOC == pytest.approx(0.007 * t.FCI + 0.03 * isbl + 1.9 * labour, rel=1e-12)


def test_msp_without_tax_is_the_capital_recovery_annuity():
    """No tax, start-up or debt: NPV = 0 at price P when P Q - C (yearly, 30 years from the start
    year) pays back the fixed capital spent 8/60/32 % in the three years before (compounded to
    the last of them, year 0) and the working capital lent at year 0 and returned in year 30."""
    cfg = replace(PlantConfig(), tax_rate=0.0, startup_months=0.0, loan_fraction=0.0)
    p = plant(MILL, cfg, ECON, name="annuity")
    msp = p.evaluate()["msp_usd_per_kg"]
    t, r = p.tea, 0.10
    q = p.rtpa.F_mass * t.operating_hours
    byproducts = sum(s.cost for s in t.products if s is not p.rtpa) * t.operating_hours
    cost = t.AOC - byproducts
    spent = t.FCI * (0.08 * (1 + r) ** 2 + 0.60 * (1 + r) + 0.32) + t.working_capital * (1 - (1 + r) ** -30)
    annuity = r / (1 - (1 + r) ** -30)
    assert msp == pytest.approx((cost + spent * annuity) / q, rel=1e-6)


def test_footprint_adds_up_and_takes_the_states_grid(built):
    parts = built.footprint()
    assert parts.pop("total") == pytest.approx(sum(parts.values()), rel=1e-9)
    s = built.ps.streams
    assert parts["NaOH"] == pytest.approx(s["NaOH"].F_mass * 2.05 / s["rTPA"].F_mass, rel=1e-9)  # GREET 2023
    assert parts["EG_credit"] == pytest.approx(-s["EG"].F_mass * 2.2938 / s["rTPA"].F_mass, rel=1e-9)
    florida = plant(MILL, PlantConfig(), ECON, region="FL", name="florida")
    florida.evaluate()
    kwh = florida.ps.system.power_utility.rate
    # GREET 2023 US 0.4181 kg/kWh x Florida's eGRID2022 818.562 / US 827.52 lb/MWh = 0.413574 kg/kWh
    assert florida.footprint()["electricity"] == pytest.approx(kwh * 0.413574 / florida.rtpa.F_mass, rel=1e-5)


def test_staffing_counts_units_in_parallel():
    """At ten times the mill the dissolver and the acidifier run as five tanks each and each
    rotary filter as two: 5.417 + 2 x 4 x 0.5 (tanks) + 2 x 1 x 0.25 (filters) = 9.917 operators
    per shift x 4.5 = 44.6 -> 45."""
    big = plant(replace(MILL, pet_kg_per_h=10 * MILL.pet_kg_per_h, power_kw=350.0), PlantConfig(), ECON, name="big")
    big.evaluate()
    u = big.ps.units
    assert [u[k].parallel["self"] for k in ("T201", "R301", "S201", "S301")] == [5, 5, 2, 2]
    assert big.tea.staff == 45


def test_monte_carlo_mean_of_one_uniform_price_is_the_msp_at_its_mean(monkeypatch):
    """MSP is affine in the NaOH price (a variable cost, no loss in any year at these prices),
    so the mean over a uniform NaOH price is the MSP at its midpoint, 669 $/t."""
    one = pd.DataFrame([{"parameter": "price.naoh", "distribution": "uniform", "scale": "absolute", "low": 426.0,
                         "high": 912.0, "basis": "", "source": "", "year": 2026, "url": ""}])
    monkeypatch.setattr(uncertainty, "ranges", lambda p: one)
    p = own_plant("monte_carlo")
    m = uncertainty.model(p, 0.0)
    draws, _ = uncertainty.monte_carlo(m, 64, seed=3)
    again, _ = uncertainty.monte_carlo(uncertainty.model(p, 0.0), 64, seed=3)
    assert draws["price.naoh"].equals(again["price.naoh"])
    assert np.allclose(draws.MSP, again.MSP, rtol=1e-9)
    at_mean = own_plant("naoh_at_mean")
    at_mean.ps.streams["NaOH"].price = 0.669
    assert draws.MSP.mean() == pytest.approx(at_mean.evaluate()["msp_usd_per_kg"], rel=2e-4)
    assert draws.MSP.std() > 0.05  # the NaOH price moves the MSP by about 0.3 $/kg over its range


def test_the_tornados_ends_are_the_plant_at_those_values():
    """Its ends against a plant set by hand, and every end against BioSTEAM's own method, which
    simulates every point (the tornado skips those that move only what is read after it)."""
    m = uncertainty.model(own_plant("tornado"), 1.0)
    t = uncertainty.tornado(m).set_index("parameter")
    high = own_plant("naoh_high")
    high.ps.streams["NaOH"].price = 0.912
    assert t.loc["price.naoh", "msp_high_usd_per_kg"] == pytest.approx(high.evaluate()["msp_usd_per_kg"], rel=1e-9)
    assert t.msp_swing_usd_per_kg.is_monotonic_decreasing
    _, lower, upper = m.single_point_sensitivity()
    for ours, theirs in (("msp_low_usd_per_kg", lower.iloc[:, 0]), ("msp_high_usd_per_kg", upper.iloc[:, 0]),
                         ("gwp_low_kg_per_kg", lower.iloc[:, 1]), ("gwp_high_kg_per_kg", upper.iloc[:, 1])):
        theirs.index = [q.name for q in m.parameters]
        assert np.allclose(t[ours], theirs[t.index], rtol=2e-8, atol=0.0), ours  # 5e-9 apart: the recycle to 1e-9


def test_a_warm_vapour_fraction_is_the_cold_one_after_the_feed_moves(monkeypatch):
    """The solver's secant from its last root (no fallback to Brent's method) gives the root
    Brent's method finds from scratch."""
    feed = bst.Stream(None, Water=1000.0, EthyleneGlycol=60.0, thermo=own_plant("flash").ps.streams["EG"].thermo)
    warm = VapourFraction("EthyleneGlycol")
    warm(feed, 20_000.0, 0.95)
    feed.imol["Water"] *= 1.07
    with monkeypatch.context() as m:
        m.setattr(units, "brentq", lambda *args, **kwargs: pytest.fail("the warm solver fell back to Brent's method"))
        V = warm(feed, 20_000.0, 0.9)
    assert V == pytest.approx(VapourFraction("EthyleneGlycol")(feed, 20_000.0, 0.9), abs=1e-10)
    flash = bst.MultiStream(None, thermo=feed.thermo)
    flash.copy_flow(feed)
    flash.vle(P=20_000.0, V=V)
    assert flash.imol["g", "EthyleneGlycol"] / feed.imol["EthyleneGlycol"] == pytest.approx(0.9, abs=1e-10)


def test_variants_undo_one_choice_each(built):
    v = variants(own_plant("variants")).set_index("variant")
    virgin_eg = plant(MILL, replace(PlantConfig(), eg_price_fraction=1.0), ECON, name="virgin_eg").evaluate()
    assert v.loc["EG credited at the virgin price", "msp_usd_per_kg"] == pytest.approx(virgin_eg["msp_usd_per_kg"],
                                                                                       rel=1e-9)
    # those the built plant prices with a TEA of its own: each the plant rebuilt with that choice
    for name, change in ((n, c) for n, c in CONFIG_VARIANTS.items() if not callable(c) and set(c) <= TEA_FIELDS):
        rebuilt = plant(MILL, replace(PlantConfig(), **change), ECON, name="rebuilt").evaluate()
        assert v.loc[name, ["msp_usd_per_kg", "gwp_kg_per_kg"]].tolist() == pytest.approx(
            [rebuilt["msp_usd_per_kg"], rebuilt["gwp_kg_per_kg"]], rel=1e-9), name
    assert "20 staff at every scale" in v.index and len(v) == 1 + len(CONFIG_VARIANTS) + 5
    assert v.loc["base", "msp_usd_per_kg"] == pytest.approx(built.base["msp_usd_per_kg"], rel=1e-9)
    assert np.isfinite(v.msp_usd_per_kg).all() and np.isfinite(v.gwp_kg_per_kg).all()


def test_vapour_recompression_runs_on_its_electricity_and_is_priced_by_its_correlations():
    """30 kWh per tonne of water evaporated and no steam; the body's area is the latent heat over
    U dT = 2000 x 6 W/m2; in stainless 316 (x 2.1), the body by Seider's forced-circulation
    correlation, the compressor by Seider's centrifugal one, exp(9.1553 + 0.63 ln hp), CE 567."""
    p = own_plant("mvr", replace(PlantConfig(), evaporation=EvaporationConfig(kind="mvr")))
    e = p.ps.units["E401"]
    water = e.outs[1].imass["Water"]
    assert water / e.ins[0].imass["Water"] == pytest.approx(0.95, rel=1e-9)
    assert e.power_utility.rate == pytest.approx(30.0 * e.outs[1].F_mass / 1000.0, rel=1e-12)
    assert not e.heat_utilities
    area = e.outs[1].Hvap / 3.6 / (2000.0 * 6.0)
    assert e.design_results["Area"] == pytest.approx(area, rel=1e-12)
    body = price("forced_circulation_evaporator_seider_2017", area, CEPCI_2021).usd
    hp = e.power_utility.rate * 1.34102
    assert e.purchase_costs["Evaporators"] == pytest.approx(2.1 * body, rel=1e-9)
    compressor = math.exp(9.1553 + 0.63 * math.log(hp)) * CEPCI_2021 / 567
    assert e.purchase_costs["Compressor"] == pytest.approx(2.1 * compressor, rel=1e-9)  # stainless, the whole unit


def test_an_electric_boiler_makes_all_the_steam_on_electricity(built):
    """Steam heat / 0.99 in electricity, none bought; 185 $/kW (2023, CE 797.9) installed."""
    p = own_plant("electric", replace(PlantConfig(), heat=HeatConfig(kind="electric_boiler")))
    boiler = p.ps.units["B601"]
    steam_kw = sum(h.duty for h in built.ps.system.heat_utilities if h.agent.ID.endswith("steam")) / 3600.0
    assert boiler.design_results["Steam heat"] == pytest.approx(steam_kw, rel=1e-6)
    assert boiler.power_utility.rate == pytest.approx(steam_kw / 0.99, rel=1e-6)
    assert sum(h.flow for h in p.ps.system.heat_utilities if h.agent.ID.endswith("steam")) == pytest.approx(0.0,
                                                                                                            abs=1e-6)
    assert boiler.installed_cost == pytest.approx(185.0 * steam_kw * CEPCI_2021 / 797.9, rel=1e-6)
    assert p.footprint()["steam"] == pytest.approx(0.0, abs=1e-9)


def test_a_residue_boiler_burns_the_sorted_out_plastics_for_steam():
    """The residue's heat (31.96 MJ/kg of the non-PET, 22.5 of PET) x 0.8 makes steam, the rest is
    bought; its carbon leaves as fossil CO2 and nothing is landfilled from sorting; the boiler
    16,939.86 x (kg/h steam at 2257 kJ/kg)^0.6 at CE 551 (Humbird et al. 2011), installed x 1.8."""
    p = own_plant("residue", replace(PlantConfig(), heat=HeatConfig(kind="residue_boiler")))
    boiler, fuel = p.ps.units["B601"], p.ps.streams["sorting_residue"]
    fuel_kw = (fuel.imass["Polyolefin"] * 31.96 + fuel.imass["PET"] * 22.5) / 3.6
    made = boiler.design_results["Steam heat"]
    assert made == pytest.approx(min(0.8 * fuel_kw, boiler.steam_kw()), rel=1e-9)
    carbon = 2 * fuel.imol["Polyolefin"] + 10 * fuel.imol["PET"]
    assert p.ps.streams["boiler_CO2"].imol["CO2"] == pytest.approx(carbon, rel=1e-12)
    parts = p.footprint()
    assert parts["boiler_CO2"] == pytest.approx(carbon * 44.0095 / p.rtpa.F_mass, rel=1e-6)
    assert "sorting_residue" not in parts
    assert boiler.purchase_cost == pytest.approx(16_939.86 * (made * 3600 / 2257) ** 0.6 * CEPCI_2021 / 551, rel=1e-5)


def test_prices_and_factors_are_replaced_one_by_one_from_the_config():
    cfg = replace(PlantConfig(), prices_usd_per_t={"naoh": 700.0}, ghg_kg_co2e={"naoh": 1.25})
    p = own_plant("overrides", cfg)
    s = p.ps.streams
    record = p.record(p.evaluate()["msp_usd_per_kg"])
    assert record["msp_naoh_usd_per_kg"] == pytest.approx(s["NaOH"].F_mass * 0.700 / s["rTPA"].F_mass, rel=1e-12)
    assert record["gwp_naoh_kg_per_kg"] == pytest.approx(s["NaOH"].F_mass * 1.25 / s["rTPA"].F_mass, rel=1e-12)



def test_a_price_or_factor_of_ones_own_keeps_the_tables_relative_band():
    """data/plant_uncertainty.csv: bales 75-300 $/t about the table's 150, the US grid 0.4181-0.48
    kg CO2e/kWh about 0.4181, acid 48-192 about 96: at 400 $/t, 0.011 (outside their bands) and
    100 $/t (inside) the bands are 200-800 $/t, 0.011-0.012629 (x 0.48 / 0.4181) and 50-200 $/t;
    a parameter not overridden (EG) keeps its absolute band."""
    cfg = replace(PlantConfig(), prices_usd_per_t={"pet_bale": 400.0, "h2so4": 100.0},
                  ghg_kg_co2e={"electricity_us": 0.011})
    p = own_plant("own band", cfg)
    rows = uncertainty.ranges(p).set_index("parameter")
    m = uncertainty.model(p, 0.0)
    bounds = {q.name: q.bounds for q in m.parameters}
    assert bounds["price.pet_bale"] == pytest.approx((200.0, 800.0), rel=1e-12)
    assert bounds["ghg.electricity_us"] == pytest.approx((0.011, 0.011 * 0.48 / 0.4181), rel=1e-12)
    assert bounds["price.h2so4"] == pytest.approx((48.0 * 100.0 / 96.0, 192.0 * 100.0 / 96.0), rel=1e-12)
    assert rows.loc["price.eg", "scale"] == "absolute" and bounds["price.eg"] == pytest.approx((673.0, 1249.0))

def test_salt_splitting_returns_naoh_and_acid_for_its_electricity_steam_and_membranes():
    """Na2SO4 -> 2 NaOH + H2SO4 at 4.72 kWh/kg NaOH; membrane area = 2 n_Na2SO4 x Faraday / 0.364
    / 500 A/m2, priced 1,200 $/m2 (2009, CE 521.9) x 2 for the stack; the products' water (at
    8 wt %) evaporated in three effects: its latent heat / 3 on steam; NaOH and H2SO4 credited at
    the bought prices and factors."""
    p = own_plant("bpmed", replace(PlantConfig(), sodium=SodiumConfig(kind="bpmed")))
    u, s = p.ps.units["U401"], p.ps.streams
    n = s["Na2SO4"].imol["Na2SO4"]  # kmol/h
    naoh = s["recovered_NaOH"]
    assert naoh.imol["NaOH"] == pytest.approx(2 * n, rel=1e-12)
    assert u.power_utility.rate == pytest.approx(4.72 * naoh.F_mass, rel=1e-12)
    area = 2 * n * 1000 / 3600 * 96485.332 / 0.364 / 500.0
    assert u.design_results["Membrane area"] == pytest.approx(area, rel=1e-9)
    assert u.purchase_cost == pytest.approx(2 * 1200 * area * CEPCI_2021 / 521.9, rel=1e-9)
    water = s["splitting_condensate"].imol["Water"]
    products = naoh.F_mass + s["recovered_H2SO4"].F_mass
    assert s["splitting_water"].F_mass == pytest.approx(products * (1 / 0.08 - 1) + 2 * n * 18.01528
                                                        - s["Na2SO4"].imass["Water"], rel=1e-9)
    assert u.heat_utilities[0].unit_duty == pytest.approx(water * 40_650 / 3, rel=2e-3)  # 40.65 kJ/mol at 100 C
    parts = p.footprint()
    assert parts["recovered_NaOH_credit"] == pytest.approx(-naoh.F_mass * 2.05 / p.rtpa.F_mass, rel=1e-9)


def test_what_it_takes_finds_the_values_that_meet_virgin_tpa(monkeypatch):
    """The wage at which the MSP is virgin TPA's 1.143 $/kg and the NaOH factor at which the
    footprint is virgin PTA's 1.60 kg CO2e/kg: plants built at those values meet them.  Both are
    read after the simulation, so the search simulates the plant only at its base, before and
    after."""
    p = own_plant("levers")
    simulate, simulations = type(p.ps.system).simulate, []
    with monkeypatch.context() as m:
        m.setattr(type(p.ps.system), "simulate", lambda system, **kw: simulations.append(system) or simulate(system, **kw))
        t = break_even(p, ["plant.operator_wage_usd_per_yr", "ghg.naoh"], 10.0).set_index("lever")
    assert simulations == [p.ps.system] * 2
    wage, naoh = t.loc["plant.operator_wage_usd_per_yr", "msp_break_even"], t.loc["ghg.naoh", "gwp_break_even"]
    assert np.isnan(t.loc["ghg.naoh", "msp_break_even"])  # a factor moves no money
    at_wage = own_plant("at_wage", replace(PlantConfig(), operator_wage_usd_per_yr=wage))
    assert at_wage.evaluate()["msp_usd_per_kg"] == pytest.approx(1.143, rel=1e-6)
    at_factor = own_plant("at_factor", replace(PlantConfig(), ghg_kg_co2e={"naoh": naoh}))
    assert at_factor.evaluate()["gwp_kg_per_kg"] == pytest.approx(1.60, rel=1e-6)


def test_landfilled_salt_pays_the_tip_fee_and_the_landfills_factor():
    """EREF's 59.56 $/t and Manfredi's 0.07 kg CO2e/kg on every kg of dried salt."""
    p = own_plant("landfilled", replace(PlantConfig(), sodium=SodiumConfig(kind="landfilled")))
    salt, rtpa = p.ps.streams["landfilled_salt"], p.rtpa.F_mass
    assert salt.F_mass == pytest.approx(p.ps.streams["Na2SO4"].F_mass, rel=1e-12)
    record = p.record(p.evaluate()["msp_usd_per_kg"])
    assert record["msp_landfilled_salt_usd_per_kg"] == pytest.approx(salt.F_mass * 0.05956 / rtpa, rel=1e-9)
    assert record["gwp_landfilled_salt_kg_per_kg"] == pytest.approx(salt.F_mass * 0.07 / rtpa, rel=1e-9)


def test_the_pareto_front_keeps_the_points_nothing_beats_in_both():
    """(cost, footprint): a (1, 5), b (2, 3), c (3, 1) trade one for the other: on the front;
    d (2, 4) is beaten by b (2, 3: as cheap, cleaner); e (4, 4) by b; f (3, 1) ties c exactly:
    neither beats the other, both stay; g (1, 6) is beaten by a (as cheap, cleaner)."""
    cost = [1, 2, 3, 2, 4, 3, 1]
    footprint = [5, 3, 1, 4, 4, 1, 6]
    assert pareto_front(cost, footprint).tolist() == [True, True, True, False, False, True, False]


def test_each_option_combination_is_the_plant_with_those_options(built):
    """The combination that takes one option alone is that option's variant row; the front holds
    the cheapest and the cleanest combination."""
    table = options_table(built, ["evaporation", "heat", "sodium", "naoh_dosing"])
    assert len(table) == 2 * 3 * 3 * 2
    rows = variants(built).set_index("variant")
    one = {"evaporation by vapour recompression (plant/evaporation=mvr)": ("mvr", "bought_steam", "salt", "whole_feed"),
           "NaOH dosed only on the PET that converts": ("multi_effect", "bought_steam", "salt", "converting_pet"),
           "Na2SO4 split back to NaOH and H2SO4 (plant/sodium=bpmed)": ("multi_effect", "bought_steam", "bpmed",
                                                                        "whole_feed")}
    for variant, options in one.items():
        row = table.set_index(["evaporation", "heat", "sodium", "naoh_dosing"]).loc[options]
        assert row.msp_usd_per_kg == pytest.approx(rows.at[variant, "msp_usd_per_kg"], rel=1e-9), variant
        assert row.gwp_kg_per_kg == pytest.approx(rows.at[variant, "gwp_kg_per_kg"], rel=1e-9), variant
    assert table.on_front[table.msp_usd_per_kg.idxmin()] and table.on_front[table.gwp_kg_per_kg.idxmin()]
    assert (table.below_virgin_price == (table.msp_usd_per_kg < 1.143)).all()  # data/prices.csv: tpa 1143 $/t


def test_a_truck_costs_and_emits_per_tonne_km_what_its_sources_give():
    """ATRI 2022: 2.251 $ per truck-mile over 18.14 t of bales = 2.251 / 1.609344 / 18.14 = 0.077106 $/t-km;
    EPA: 0.169 kg CO2e per short ton-mile / (0.90718474 t x 1.609344 km) = 0.115756 kg/t-km."""
    assert haulage.usd_per_t_km() == pytest.approx(0.077106, rel=1e-5)
    assert haulage.kg_co2e_per_t_km() == pytest.approx(0.115756, rel=1e-5)


def test_road_distance_is_the_great_circle_times_the_circuity():
    """DC (38.910168, -77.013993) to MD (39.136636, -76.802227): 0.226468 deg of latitude = 25.182 km
    north, 0.211766 deg of longitude x cos(39.0234 deg) = 18.294 km east: 31.126 km on the sphere
    (flat over so short a span), x 1.2 = 37.35 km of road."""
    assert haulage.road_km("DC", "MD") == pytest.approx(37.35, rel=2e-4)
    assert haulage.great_circle_km(0.0, 0.0, 0.0, 90.0) == pytest.approx(6371.0088 * math.pi / 2, rel=1e-12)


def test_hauled_bales_cost_and_emit_their_haul():
    """100 km of haul: the bale (150 $/t, 0.16 kg CO2e/kg) costs 150 + 100 x 0.077106 = 157.711 $/t
    and emits 0.16 + 100 x 0.115756 / 1000 = 0.171576 kg CO2e/kg."""
    cfg = hauled(PlantConfig(), ECON, 100.0)
    assert cfg.prices_usd_per_t["pet_bale"] == pytest.approx(157.711, rel=1e-5)
    assert cfg.ghg_kg_co2e["pet_bale"] == pytest.approx(0.171576, rel=1e-5)


def test_the_eg_price_and_the_conversion_per_pass_as_levers():
    """The EG price at which the MSP meets virgin TPA's gives it in a plant built at that price;
    the conversion per pass of the same mill cannot: even all the PET converted in one pass
    (factor 1 / 0.7487, the setter caps it at 1) leaves the MSP and footprint above virgin's."""
    p = own_plant("eg_and_conversion")
    t = break_even(p, ["price.eg", "yield.conversion"], 10.0).set_index("lever")
    eg = t.loc["price.eg", "msp_break_even"]
    assert np.isnan(t.loc["price.eg", "gwp_break_even"])  # the EG credit's carbon is its factor's, not its price's
    at_eg = own_plant("at_eg", replace(PlantConfig(), prices_usd_per_t={"eg": eg}))
    assert at_eg.evaluate()["msp_usd_per_kg"] == pytest.approx(1.143, rel=1e-6)
    assert t.loc["yield.conversion", ["msp_break_even", "gwp_break_even"]].isna().all()
    full = own_plant("full_conversion")
    full.ps.units["R201"].conversion = 1.0
    at_full = full.evaluate()
    assert at_full["msp_usd_per_kg"] > 1.143 and at_full["gwp_kg_per_kg"] > 1.60


def test_the_feed_at_which_a_plant_meets_virgin_tpas_price(tmp_path):
    """study=regional at BPR 20: the fresh PET feed whose plant (Bond/Rowland mill, US grid, no
    haul) sells rTPA at virgin TPA's 1.143 $/kg lies between the two states' feeds whose own
    plants bracket that price; no feed from 100 to 50,000 kg/h meets PTA's 1.60 kg CO2e/kg."""
    from ballmill.scenario import compose, load
    from ballmill.studies.regional import plan_regional

    s = load(compose("config", ["study=regional", "scaleup.pet_feed_kg_per_h=null", "scaleup.region=FL",
                                "scaleup.naoh_feed_kg_per_h=null", "scaleup.bpr=20", "plant.monte_carlo_draws=0"]))
    record = plan_regional(s).execute(tmp_path)
    scales = pd.read_csv(tmp_path / "scale.csv").set_index("indicator")
    feed = record["break_even_fresh_pet_kg_per_h"]
    assert scales.at["msp_usd_per_kg", "at_break_even"] == pytest.approx(1.143, rel=1e-6)
    states = pd.read_csv(tmp_path / "states.csv").sort_values("fresh_pet_kg_per_h")
    dearer = states[states.own_msp_usd_per_kg > 1.143].fresh_pet_kg_per_h.max()
    cheaper = states[states.own_msp_usd_per_kg < 1.143].fresh_pet_kg_per_h.min()
    assert dearer < feed < cheaper  # Maryland's 1,918 kg/h and Virginia's 2,703
    assert math.isnan(record["break_even_gwp_fresh_pet_kg_per_h"])
    assert (scales.loc["gwp_kg_per_kg", ["at_low", "at_high"]] > 1.60).all()


def test_reused_condensate_dissolves_the_salt_and_only_the_surplus_is_treated():
    """Fresh water tops the condensate's water up to 8 kg per kg Na2TPA (none when the condensate
    suffices); treatment is charged 0.3676 $/kg on the COD of the surplus condensate and the
    column's water, EG's 2.5 mol O2 per mol: 2.5 x 31.998 / 62.068 = 1.28883 kg/kg; the EG the
    condensate brings back leaves as product instead."""
    base = own_plant("no_reuse")
    p = own_plant("reuse", replace(PlantConfig(), condensate_reuse=True))
    s = p.ps.streams
    na2tpa = p.ps.units["R201"].outs[0].imass["Na2TPA"]
    assert s["dissolution_water"].F_mass + s["reused_condensate"].imass["Water"] == pytest.approx(8.0 * na2tpa, rel=1e-6)
    assert s["wash_water"].F_mass == pytest.approx(base.ps.streams["wash_water"].F_mass, rel=1e-6)  # the wash stays fresh
    eg = s["surplus_condensate"].imass["EthyleneGlycol"] + s["column_water"].imass["EthyleneGlycol"]
    treated = s["treated_water"]
    assert -treated.price * treated.F_mass == pytest.approx(0.3676 * 1.28883 * eg, rel=1e-4)
    assert s["EG"].F_mass > base.ps.streams["EG"].F_mass + 0.5 * s["reused_condensate"].imass["EthyleneGlycol"]


def test_the_heat_of_neutralisation_warms_the_liquor_by_55_8_kj_per_mol_of_naoh():
    """CODATA: H+ + OH- -> H2O releases 55.815 kJ/mol; the TPA salt's proton transfer is taken as
    none.  The acidifier's outlet carries that heat (same flows as without it, kJ/h) and the
    plant buys less steam."""
    base = own_plant("no_neutralisation")
    p = own_plant("neutralisation", replace(PlantConfig(), neutralisation_heat=True))
    acidifier = p.ps.units["R301"]
    heat_kw = 55.815 * acidifier.ins[0].imol["NaOH"] / 3.6  # kmol/h x kJ/mol -> kW
    assert acidifier.heat_released_kw == pytest.approx(heat_kw, rel=1e-9)
    warmed = acidifier.outs[0].H - base.ps.units["R301"].outs[0].H
    assert warmed == pytest.approx(heat_kw * 3600.0, rel=1e-3)
    steam = [sum(h.duty for h in q.ps.system.heat_utilities if h.duty > 0) / 3600.0 for q in (base, p)]
    assert 0.0 < steam[0] - steam[1] < heat_kw


def test_a_break_evens_band_follows_the_draws_to_first_order():
    """NaOH 608 $/t at MSP 1.0 $/kg, break-even 971 for 1.143: s = 0.143 / 363 $/kg per $/t.  Draws on
    that line (whatever their NaOH price) all meet 1.143 at 971; draws 0.01 $/kg dearer at
    971 - 0.01 / s = 945.62; the grid factor, not drawn, from its base 0.4181 with s = (1.60 - 2.0) /
    (0.2 - 0.4181) kg per kWh factor: draws 0.01 cleaner meet 1.60 at 0.2 + 0.01 / s = 0.205453."""
    table = pd.DataFrame({"lever": ["price.naoh", "ghg.electricity_us"], "base": [608.0, 0.4181],
                          "msp_break_even": [971.0, math.nan], "gwp_break_even": [math.nan, 0.2]})
    s = 0.143 / 363.0
    naoh = np.array([500.0, 608.0, 700.0, 800.0])
    on_line = pd.DataFrame({"price.naoh": naoh, "MSP": 1.0 + s * (naoh - 608.0), "GWP": 2.0})
    base, targets = {"msp_usd_per_kg": 1.0, "gwp_kg_per_kg": 2.0}, {"msp_usd_per_kg": 1.143, "gwp_kg_per_kg": 1.60}
    out = bands(table, on_line, base, targets).set_index("lever")
    assert out.loc["price.naoh", ["msp_break_even_p5", "msp_break_even_p95"]].tolist() == pytest.approx([971.0] * 2)
    dearer = on_line.assign(MSP=on_line.MSP + 0.01, GWP=2.0 - 0.01)
    out = bands(table, dearer, base, targets).set_index("lever")
    assert out.loc["price.naoh", "msp_break_even_p95"] == pytest.approx(971.0 - 0.01 / s, rel=1e-12)
    assert out.loc["ghg.electricity_us", "gwp_break_even_p5"] == pytest.approx(
        0.2 + 0.01 / ((1.60 - 2.0) / (0.2 - 0.4181)), rel=1e-12)
    assert math.isnan(out.loc["ghg.electricity_us", "msp_break_even_p5"])


def test_a_heat_exchanger_network_buys_less_steam_for_the_heat_it_moves(built):
    """The network matches hot streams that cooling water would cool with cold streams that steam
    would heat: the heat its exchangers move is at most the smaller of the hot and the cold
    duties of the streams it matches (kW), the steam saved is that heat over the steam's transfer
    efficiency, the network's exchangers are in the installed cost, and a second evaluation gives
    the same MSP (the Monte Carlo re-evaluates in place)."""
    p = own_plant("hxn", replace(PlantConfig(), heat_integration=True))
    msp = p.tea.solve_price(p.rtpa)
    assert p.evaluate()["msp_usd_per_kg"] == pytest.approx(msp, abs=1e-9)
    hxn = p.ps.units["HXN"]
    matched = [hu for hu, cycle in zip(hxn.original_heat_utils, hxn.stream_life_cycles)
               if any(isinstance(stage.unit, bst.HXprocess) for stage in cycle.life_cycle)]
    hot = -sum(hu.unit_duty for hu in matched if hu.duty < 0) / 3600.0
    cold = sum(hu.unit_duty for hu in matched if hu.duty > 0) / 3600.0
    moved = sum(hx.Q for hx in hxn.new_HXs) / 3600.0
    assert 0.0 < moved <= min(hot, cold) * (1 + 1e-6)

    def steam(q):  # agent -> kW bought
        duty = {}
        for h in q.ps.system.heat_utilities:
            if h.agent.ID.endswith("_steam"):
                duty[h.agent.ID] = duty.get(h.agent.ID, 0.0) + h.duty / 3600.0
        return duty

    before, after = steam(built), steam(p)
    saved = {ID: before[ID] - after.get(ID, 0.0) for ID in before}
    assert sum(saved.values()) > 0.0  # MJ/h less steam bought
    heat = sum(kw * bst.HeatUtility.get_agent(ID).heat_transfer_efficiency for ID, kw in saved.items())
    assert heat == pytest.approx(moved, rel=1e-6)
    others = sum(u.installed_cost for u in p.tea.units if u is not hxn)
    assert hxn in p.tea.units and hxn.installed_cost > 0.0
    assert p.tea.installed_equipment_cost == pytest.approx(others + hxn.installed_cost, rel=1e-12)


def test_a_lever_end_the_plant_cannot_be_solved_at_is_moved_toward_the_base(monkeypatch):
    """NaOH 60.8-6080 $/t about 608 with the plant unsolvable below 200 $/t: 60.8 fails, then
    sqrt(60.8 x 608) = 192.27 fails, sqrt(192.27 x 608) = 341.90 solves; no price of NaOH alone
    meets virgin TPA's (NaOH free leaves ~1.19 $/kg), so the search ends without a root and without
    an error."""
    p = own_plant("unsolvable")
    base, set_naoh = uncertainty.setters(p, 0.0)["price.naoh"]
    at = {"v": base}
    indicators = p.indicators  # a price is searched on the base simulation: its failure stands in for BioSTEAM's

    def set_(v):
        at["v"] = v
        set_naoh(v)

    def fragile():
        if at["v"] < 200.0:
            raise RuntimeError("S401: permeate moisture content is infeasible")
        return indicators()

    monkeypatch.setattr(uncertainty, "setters", lambda plant, se: {"price.naoh": (base, set_)})
    monkeypatch.setattr(p, "indicators", fragile)
    row = break_even(p, ["price.naoh"], 10.0).iloc[0]
    assert row.searched_low == pytest.approx(math.sqrt(math.sqrt(60.8 * 608.0) * 608.0), rel=1e-12)
    assert row.searched_high == pytest.approx(6080.0) and math.isnan(row.msp_break_even)
