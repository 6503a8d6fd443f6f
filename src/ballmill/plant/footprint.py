"""Cradle-to-gate greenhouse-gas footprint of rTPA (kg CO2e per kg), on BioSTEAM's impact
indicators, from data/ghg_factors.csv and the states' grids (data/egrid2022_states.csv).

Boundary: cut-off for the bales (the bottles' first life is not charged, their collection and
sorting are), system expansion for the co-products (EG, Na2SO4 credited with the product they
displace), so all of the rest is rTPA's; `allocation_kg_per_kg` gives mass and economic
allocation beside it.  Inputs carry their factor per kg, steam per MJ of heat, electricity per
kWh; the landfilled solids plant.landfill's factor, the treated water its treatment's, and the
CO2 of the wastewater's oxidised organics (fossil carbon) counts in full.  A state's
electricity is GREET's US life-cycle factor scaled by the state's eGRID output rate over the
US rate (stack rates alone leave out the fuel chain and the losses).
"""

from __future__ import annotations

import biosteam as bst

from ..data import lookup, table

KEY = "GWP"
FILE = "ghg_factors.csv"
STEAM = ("low_pressure_steam", "medium_pressure_steam", "high_pressure_steam")
INPUTS = {"bales": "pet_bale", "NaOH": "naoh", "sulfuric_acid": "h2so4", "dissolution_water": "process_water",
          "wash_water": "process_water", "cooling_tower_makeup_water": "process_water",
          "splitting_water": "process_water"}  # and each steam agent
LANDFILLED = ("sorting_residue", "grinding_fines", "purged_PET", "residue", "landfilled_salt")  # plastics and salt
WASTES = {**dict.fromkeys(LANDFILLED, "landfill"), "treated_water": "wastewater", "treatment_CO2": "fossil_co2",
          "boiler_CO2": "fossil_co2"}
CREDITS = {"EG": "eg", "Na2SO4": "na2so4", "recovered_NaOH": "naoh", "recovered_H2SO4": "h2so4"}


def factors() -> dict[str, float]:
    """item -> kg CO2e per its unit (data/ghg_factors.csv)."""
    return {r.item: float(r.kg_co2e) for r in table(FILE).itertuples()}


def electricity_kg_per_kwh(region: str | None, us_life_cycle: float) -> float:
    """A state's life-cycle grid factor (US's when region is None)."""
    if region is None:
        return us_life_cycle
    rate = lookup("egrid2022_states.csv", "region", region, "co2e_lb_per_mwh")
    return us_life_cycle * rate / lookup("egrid2022_states.csv", "region", "US", "co2e_lb_per_mwh")


def characterize(streams: dict[str, bst.Stream], cf: dict[str, float], region: str | None,
                 landfill: str) -> None:
    """Set the factors on the plant's streams and BioSTEAM's utilities (wastes and credits as
    products: a waste's burden is a negative credit); the landfilled solids take the factor
    `landfill` (a row of data/ghg_factors.csv)."""
    if KEY not in bst.settings.impact_indicators:
        bst.settings.define_impact_indicator(KEY, "kg*CO2e")
    for ID, item in INPUTS.items():
        if ID in streams:
            streams[ID].set_CF(KEY, cf[item])
    for ID, item in WASTES.items():
        if ID in streams and streams[ID].isproduct():  # a residue burnt on site is no waste
            streams[ID].set_CF(KEY, -cf[landfill if ID in LANDFILLED else item])
    for ID, item in CREDITS.items():
        if ID in streams and streams[ID].isproduct():
            streams[ID].set_CF(KEY, cf[item])
    for agent in STEAM:
        bst.HeatUtility.set_CF(agent, KEY, cf["steam"], basis="MJ")
    bst.PowerUtility.set_CF(KEY, consumption=electricity_kg_per_kwh(region, cf["electricity_us"]))


def breakdown_kg_per_kg(system: bst.System, streams: dict[str, bst.Stream], product: bst.Stream) -> dict[str, float]:
    """kg CO2e per kg of `product` by contributor (inputs, steam, electricity, wastes, credits
    negative) and their sum, the footprint."""
    kg_per_yr = product.F_mass * system.operating_hours
    parts: dict[str, float] = {}
    for ID in (*INPUTS, *WASTES):
        if ID in streams and KEY in streams[ID].characterization_factors:
            sign = 1.0 if ID in INPUTS else -1.0
            parts[ID] = parts.get(ID, 0.0) + sign * system.get_material_impact(streams[ID], KEY)
    parts["steam"] = sum(system.get_net_heat_utility_impact(agent, KEY) for agent in STEAM)
    parts["electricity"] = system.get_net_electricity_impact(KEY)
    for ID in CREDITS:
        if ID in streams and streams[ID].isproduct():
            parts[f"{ID}_credit"] = -system.get_material_impact(streams[ID], KEY)
    out = {k: v / kg_per_yr for k, v in parts.items()}
    out["total"] = system.get_net_impact(KEY) / kg_per_yr
    return out


def allocation_kg_per_kg(parts: dict[str, float], products: dict[str, tuple[float, float]]) -> dict[str, float]:
    """rTPA's footprint (kg CO2e/kg) when the burdens (`parts` of breakdown_kg_per_kg less its
    credits) are shared among the `products` (name -> (kg/h, $/kg); rTPA's first) by mass and by
    value, instead of crediting the co-products."""
    burden = sum(v for k, v in parts.items() if k != "total" and not k.endswith("_credit"))
    (rtpa_kg, rtpa_usd), *_ = products.values()
    mass = sum(kg for kg, _ in products.values())
    value = sum(kg * usd for kg, usd in products.values())
    return {"mass": burden * rtpa_kg / mass, "economic": burden * rtpa_kg * rtpa_usd / value}
