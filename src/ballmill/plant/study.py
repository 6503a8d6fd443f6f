"""The plant study's outputs for one designed mill: the plant's record (MSP, footprint and
their breakdowns), its Monte Carlo band, and the tables a process engineer reads (streams,
units with their cross-checked prices, tornado, rank correlations, the variants that undo one
modelling choice each, and the Monte Carlo draws).
"""

from __future__ import annotations

import logging
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import EvaporationConfig, HeatConfig, SodiumConfig
from . import uncertainty
from .correlations import price
from .model import Plant, plant
from .options import options_table
from .system import MillSpec
from .tea import PlantTEA, cepci
from .what_it_takes import bands, break_even, virgin

log = logging.getLogger(__name__)
BAND = (5, 50, 95)  # percentiles of the Monte Carlo reported beside the base value


def variants(p: Plant) -> pd.DataFrame:
    """The MSP and footprint with one modelling choice undone (or one option taken) at a time:
    what each moves.  A choice of the config rebuilds the plant, or, where only the TEA reads it
    (TEA_FIELDS), prices the built plant with a TEA of its own; the evaporator's pricing varies
    the built plant (restored after); the footprint's boundary and the wastewater's CO2 are read
    from the base's breakdown."""
    cfg, base = p.cfg, p.evaluate()
    priced = {name: own_tea(p, change) for name, change in CONFIG_VARIANTS.items()
              if not callable(change) and set(change) <= TEA_FIELDS}
    evap = p.ps.units["E401"]
    bodies = evap.baseline_purchase_costs["Evaporators"] / evap.cost_factor
    total = sum(evap.baseline_purchase_costs.values()) / evap.cost_factor
    one_body = price(cfg.evaporator_cost, sum(evap.body_areas_m2()), cepci(cfg.cost_year)).usd
    pricings = {"evaporator as one body of the summed area": one_body,
                "evaporator bodies at BioSTEAM's own price": evap.design_results.get("BioSTEAM bodies")}  # multi_effect
    rows = [{"variant": "base", **base}]
    for name, new_bodies in ((k, v * evap.material_factor) for k, v in pricings.items() if v is not None):
        saved, evap.cost_factor = evap.cost_factor, (total - bodies + new_bodies) / total
        rows.append({"variant": name, **p.evaluate()})
        evap.cost_factor = saved
    for name, change in CONFIG_VARIANTS.items():
        kw = change(p.prices) if callable(change) else change
        rows.append({"variant": name, **(priced[name] if name in priced else
                                         plant(p.mill, replace(cfg, **kw), p.econ, p.region, name="variant").evaluate())})
    record = p.record(p.evaluate()["msp_usd_per_kg"])
    rows += [{"variant": "fossil CO2 of the oxidised wastewater organics left out", **base,
              "gwp_kg_per_kg": base["gwp_kg_per_kg"] - record["gwp_treatment_co2_kg_per_kg"]},
             {"variant": "mass allocation instead of system expansion", **base,
              "gwp_kg_per_kg": record["gwp_mass_allocation_kg_per_kg"]},
             {"variant": "economic allocation (virgin prices) instead of system expansion", **base,
              "gwp_kg_per_kg": record["gwp_economic_allocation_kg_per_kg"]}]
    out = pd.DataFrame(rows)
    out["msp_change_usd_per_kg"] = out.msp_usd_per_kg - base["msp_usd_per_kg"]
    out["gwp_change_kg_per_kg"] = out.gwp_kg_per_kg - base["gwp_kg_per_kg"]
    return out


def own_tea(p: Plant, change: dict) -> dict[str, float]:
    """The MSP of the simulated plant `p` priced by a TEA with `change` made to its config (fields
    of TEA_FIELDS only), and its footprint (which no TEA field moves); p keeps its own TEA."""
    tea = PlantTEA(p.ps.system, replace(p.cfg, **change), p.econ.hours_per_year, p.cfg.cost_year)
    try:
        return {"msp_usd_per_kg": tea.solve_price(p.rtpa), "gwp_kg_per_kg": p.footprint()["total"]}
    finally:
        p.ps.system._TEA = p.tea  # BioSTEAM points a system at its newest TEA


# the plant config's fields read by its TEA alone (tea.py), not by the units or the footprint
TEA_FIELDS = frozenset({"staffing", "staff", "maintenance_basis", "maintenance_fraction", "contingency",
                        "working_capital_fraction", "startup_months", "loan_fraction"})
# variant -> the plant config's fields it changes (or a function of the prices, $/kg, giving them)
CONFIG_VARIANTS = {
    "EG stripper recovering 69 % (V summed over the salts too)": {"eg_stripper_recovery": 0.6933},
    "20 staff at every scale": {"staffing": "fixed", "staff": 20},
    "EG credited at the virgin price": {"eg_price_fraction": 1.0},
    "Na2SO4 sold (USGS 2008-2011 price)": lambda prices: {"na2so4_usd_per_t": prices["na2so4_sale"] * 1000.0},
    "Na2SO4 landfilled (plant/sodium=landfilled)": {"sodium": SodiumConfig(kind="landfilled")},
    "NaOH dosed only on the PET that converts": {"naoh_dosing": "converting_pet"},
    "crystallizer priced beside the evaporator's last body": {"crystallizer": "separate"},
    "units in brine of carbon steel": {"brine_material": "carbon_steel"},
    "landfilled plastics and salt at the organic-waste factor": {"landfill": "landfill"},
    "maintenance 6 % of the fixed capital": {"maintenance_basis": "fixed_capital", "maintenance_fraction": 0.06},
    "contingency 20 % of the direct cost": {"contingency": 0.20},
    "working capital 15 % of the fixed capital": {"working_capital_fraction": 0.15},
    "bales all PET, nothing lost in granulating": {"bale_pet_fraction": 1.0, "flake_loss_fraction": 0.0},
    "no start-up period": {"startup_months": 0.0},
    "no debt (all equity)": {"loan_fraction": 0.0},
    "fine powder instead of flake (pulveriser)": {"feed_form": "powder"},
    "the evaporator's feed not preheated by its condensate": {"evaporation": EvaporationConfig(feed_preheat=False)},
    "evaporation by vapour recompression (plant/evaporation=mvr)": {"evaporation": EvaporationConfig(kind="mvr")},
    "steam from an electric boiler (plant/heat=electric_boiler)": {"heat": HeatConfig(kind="electric_boiler")},
    "steam from the sorted-out plastics (plant/heat=residue_boiler)": {"heat": HeatConfig(kind="residue_boiler")},
    "Na2SO4 split back to NaOH and H2SO4 (plant/sodium=bpmed)": {"sodium": SodiumConfig(kind="bpmed")},
    "the evaporator's condensate dissolving the Na2TPA (plant.condensate_reuse)": {"condensate_reuse": True},
    "the acidifier's heat of neutralisation into the liquor (plant.neutralisation_heat)": {"neutralisation_heat": True},
    "heat integrated by a heat-exchanger network (plant.heat_integration)": {"heat_integration": True},
}


def run(mill: MillSpec, cfg, econ, region: str | None, power_se_kw: float, out_dir: Path) -> dict:
    """The plant around `mill` into `out_dir` (tables) and a record (plant_*, msp_*, gwp_*)."""
    started = time.perf_counter()
    p = plant(mill, cfg, econ, region)
    base = p.evaluate()
    record = p.record(base["msp_usd_per_kg"]) | {"plant_design_warnings": len(p.warnings)}
    p.stream_table().to_csv(out_dir / "streams.csv")
    p.units_table().to_csv(out_dir / "units.csv", index=False)
    (out_dir / "design_warnings.txt").write_text("\n".join(p.warnings) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the base case's design warnings are recorded; its variants' would repeat them
        variants(p).to_csv(out_dir / "variants.csv", index=False)
        takes = None
        if cfg.what_it_takes:
            own = plant(mill, cfg, econ, region, name="what_it_takes")  # its levers leave the base plant as it is
            takes = break_even(own, cfg.what_it_takes, cfg.what_it_takes_span)
        if cfg.options_front:
            front_started = time.perf_counter()
            options_table(p, cfg.options_front).to_csv(out_dir / "options.csv", index=False)
            record["plant_options_s"] = time.perf_counter() - front_started
        m = uncertainty.model(p, power_se_kw)
        uncertainty.tornado(m).to_csv(out_dir / "tornado.csv", index=False)
        if cfg.monte_carlo_draws:
            draws, seconds = uncertainty.monte_carlo(m, cfg.monte_carlo_draws, cfg.seed)
            draws.to_parquet(out_dir / "monte_carlo.parquet")
            uncertainty.rank_correlations(m).to_csv(out_dir / "rank_correlations.csv", index=False)
            for column, name in (("MSP", "msp_p{}_usd_per_kg"), ("GWP", "gwp_p{}_kg_per_kg")):
                record |= {name.format(q): v for q, v in zip(BAND, np.percentile(draws[column], BAND))}
            record["monte_carlo_s"] = seconds
            if takes is not None:
                takes = bands(takes, draws, base, virgin(p))
        if takes is not None:
            takes.to_csv(out_dir / "what_it_takes.csv", index=False)
        p.evaluate()
    record["plant_s"] = time.perf_counter() - started
    log.info("plant: MSP %.3f $/kg rTPA, %.2f kg CO2e/kg (%d draws) in %.0f s", base["msp_usd_per_kg"],
             base["gwp_kg_per_kg"], cfg.monte_carlo_draws, record["plant_s"])
    return record
