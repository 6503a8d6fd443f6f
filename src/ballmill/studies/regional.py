"""study=regional: one plant for a group of states against a plant each, and which states
should share one (plant/regional.py).  Every plant's mill is designed by the scale-up for its
feed and its power taken from the Bond/Rowland correlation (economics.bond_rowland_power_w),
not the DEM: the joined mills lie beyond the simulated ones (the South Atlantic's is 32 balls
across, the surrogate's runs reach 22, and its DEM would take longer than the rest of the
reproduce); the same rule for the states' own plants keeps the comparison like for like, and the
mill is about 1 % of the MSP."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from ..config import ConfigError
from ..data import table
from ..economics import bond_rowland_power_w, purchase_cost_usd
from ..scaleup import design_mill, regional_pet_feed_kg_per_h
from ..scenario import Scenario
from .plan import Plan
from .plant import conversion_per_pass, mill_throughput_kg_per_h, to_cost_year


def bond_mill(s: Scenario, fresh_kg_per_h: float, conversion: float) -> dict:
    """The mill for a fresh PET feed with the recycle closed (MillSpec's fields): PET through it
    (kg/h), its Bond/Rowland power (kW) and its price in the plant's cost year ($)."""
    pet = mill_throughput_kg_per_h(fresh_kg_per_h, conversion, s.plant.recycle_purge_fraction)
    d = design_mill(replace(s.scaleup, pet_feed_kg_per_h=pet, region=None))
    power_w = bond_rowland_power_w(d.diameter_m, d.ball_mass_kg, s.scaleup.fill_fraction, d.fraction_of_critical,
                                   2 * d.ball_radius_m)
    cost = purchase_cost_usd(pet, d.naoh_feed_kg_per_h, s.economics, d.residence_time_min) * to_cost_year(s)
    return {"pet_kg_per_h": pet, "conversion": conversion, "naoh_to_stoichiometric": s.scaleup.naoh_to_stoichiometric,
            "power_kw": power_w / 1000.0, "purchase_cost_usd": cost,
            "design": {"Diameter": d.diameter_m, "Length": d.length_m, "Balls": d.ball_count,
                       "Residence time": d.residence_time_min}}


def plan_regional(s: Scenario) -> Plan:
    """Each state's PET (NAPCOR 2018 x its population share), its own plant, one plant for all at
    each state's centre, and each state joined to its nearest larger neighbour's plant."""
    states = s.plant.regional.states
    known = set(table("population_centres.csv").code)
    unknown = [c for c in states if c not in known]
    if unknown:
        raise ConfigError(f"plant.regional.states: {unknown} have no centre in data/population_centres.csv; have "
                          f"{sorted(known)}")
    conversion = conversion_per_pass(s)
    scale = s.scaleup
    feeds = {c: regional_pet_feed_kg_per_h(c, scale.napcor_quantity, scale.operating_hours_per_year) for c in states}

    def execute(out_dir: Path) -> dict:
        from ..plant.regional import run  # BioSTEAM: seconds to import, only here

        return run(feeds, lambda fresh: bond_mill(s, fresh, conversion), s.plant, s.economics, out_dir)

    return Plan({"bpr": scale.bpr, "regional_states": ",".join(states),
                 "regional_fresh_pet_kg_per_h": sum(feeds.values())}, execute)
