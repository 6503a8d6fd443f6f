"""The plant's mass and energy balance: unit models in a chain, every stream in kg/h.

    bale PET -> shredder -> mill (PET + 2 NaOH -> Na2TPA + EG, conversion X per pass)
      -> dissolver (water) -> filter 1: unreacted PET, back to the mill less a purge
      -> acidifier (Na2TPA + H2SO4 -> TPA + Na2SO4; excess NaOH neutralised)
      -> filter 2 with washing -> dryer -> rTPA
      -> mother liquor: evaporator-crystalliser (water off, Na2SO4 crystals)
      -> EG column: EG product and a residue (EG lost, TPA lost, excess acid)

Recycle: the mill takes M = F / (1 - (1 - p)(1 - X)) of PET for a fresh feed F and a purge p of
the unreacted PET, so that F = (PET in the product) + (PET purged).  Reactions are written in
moles (streams.py), so the element balances close to round-off.  Utilities: electricity of the
shredder (the mill's comes from the DEM), steam of the dryer, the evaporator (multiple effect)
and the EG column, cooling water for their condensers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..config import ConfigError, PlantConfig
from .streams import Stream, kg, mol

LATENT_HEAT_J_PER_KG = 2.257e6  # water at 100 C (steam tables)
WATER_CP_J_PER_KG_K = 4186.0
LIQUOR_DENSITY_KG_PER_M3 = 1000.0  # dilute aqueous streams


@dataclass
class Flowsheet:
    """Streams (kg/h), utilities and the sizes the equipment costs need."""

    streams: dict[str, Stream]
    mill_pet_kg_per_h: float
    mill_naoh_kg_per_h: float
    utilities: dict[str, float] = field(default_factory=dict)
    sizes: dict[str, float] = field(default_factory=dict)

    INPUTS = ("bale PET", "NaOH", "dissolution water", "sulfuric acid", "wash water")
    OUTPUTS = ("purged PET", "rTPA", "dryer vapour", "evaporated water", "Na2SO4 crystals", "EG", "EG column residue")


def mill_throughput_kg_per_h(fresh_pet_kg_per_h: float, conversion: float, purge: float) -> float:
    """PET through the mill for a fresh feed, a conversion per pass and a purge of the unreacted PET."""
    return fresh_pet_kg_per_h / (1.0 - (1.0 - purge) * (1.0 - conversion))


def flowsheet(fresh_pet_kg_per_h: float, conversion: float, naoh_to_stoichiometric: float,
              cfg: PlantConfig) -> Flowsheet:
    """The balance of the whole plant for a fresh PET feed and the mill's conversion per pass (0-1]."""
    if not 0.0 < conversion <= 1.0:
        raise ConfigError(f"plant: the mill's conversion per pass is {conversion:.3g}; it must lie in (0, 1] "
                          "(a yield of 0 % makes no product: raise the BPR or the residence time)")
    if naoh_to_stoichiometric < conversion:
        raise ConfigError(f"scaleup.naoh_to_stoichiometric={naoh_to_stoichiometric} is below the conversion "
                          f"{conversion:.3g}: the mill would run out of NaOH")
    f = fresh_pet_kg_per_h
    m = mill_throughput_kg_per_h(f, conversion, cfg.recycle_purge_fraction)
    pet = {"pet": m}
    n_pet = mol(pet, "pet")
    n_react = conversion * n_pet
    n_naoh_feed = 2.0 * naoh_to_stoichiometric * n_pet
    n_naoh_left = n_naoh_feed - 2.0 * n_react
    unreacted = (1.0 - conversion) * m
    s: dict[str, Stream] = {}
    s["bale PET"] = {"pet": f}
    s["recycled PET"] = {"pet": (1.0 - cfg.recycle_purge_fraction) * unreacted}
    s["NaOH"] = {"naoh": kg("naoh", n_naoh_feed)}
    s["mill product"] = {"pet": unreacted, "na2tpa": kg("na2tpa", n_react), "eg": kg("eg", n_react),
                         "naoh": kg("naoh", n_naoh_left)}
    s["dissolution water"] = {"water": cfg.dissolution_water_kg_per_kg_na2tpa * kg("na2tpa", n_react)}
    s["unreacted PET"] = {"pet": unreacted}
    s["purged PET"] = {"pet": cfg.recycle_purge_fraction * unreacted}
    liquor = {k: v for k, v in s["mill product"].items() if k != "pet"} | s["dissolution water"]
    s["sodium terephthalate liquor"] = liquor
    n_acid = cfg.h2so4_to_stoichiometric * (n_react + n_naoh_left / 2.0)
    s["sulfuric acid"] = {"h2so4": kg("h2so4", n_acid)}
    n_salt = n_react + n_naoh_left / 2.0
    slurry = {"tpa": kg("tpa", n_react), "na2so4": kg("na2so4", n_salt), "eg": liquor["eg"],
              "h2so4": kg("h2so4", n_acid - n_salt),
              "water": liquor["water"] + kg("water", n_naoh_left)}  # 2 NaOH + H2SO4 -> Na2SO4 + 2 H2O
    s["acidified slurry"] = slurry
    tpa_out = cfg.tpa_recovery * slurry["tpa"]
    s["wash water"] = {"water": cfg.wash_water_kg_per_kg_tpa * tpa_out}
    s["TPA cake"] = {"tpa": tpa_out, "water": cfg.cake_water_kg_per_kg_tpa * tpa_out}
    s["rTPA"] = {"tpa": tpa_out}
    s["dryer vapour"] = {"water": s["TPA cake"]["water"]}
    mother = {"tpa": slurry["tpa"] - tpa_out, "na2so4": slurry["na2so4"], "eg": slurry["eg"], "h2so4": slurry["h2so4"],
              "water": slurry["water"] + s["wash water"]["water"] - s["TPA cake"]["water"]}
    s["mother liquor"] = mother
    s["evaporated water"] = {"water": mother["water"]}
    s["Na2SO4 crystals"] = {"na2so4": mother["na2so4"]}
    s["EG"] = {"eg": cfg.eg_recovery * mother["eg"]}
    s["EG column residue"] = {"eg": mother["eg"] - s["EG"]["eg"], "tpa": mother["tpa"], "h2so4": mother["h2so4"]}
    out = Flowsheet(s, m, s["NaOH"]["naoh"])
    steam = {"dryer": cfg.dryer_steam_kg_per_kg_water * s["dryer vapour"]["water"],
             "evaporator": s["evaporated water"]["water"] / cfg.evaporator_steam_economy,
             "EG column": cfg.eg_column_steam_kg_per_kg_eg * mother["eg"]}
    steam_kg_per_h = sum(steam.values())
    out.utilities = {
        "shredder_electricity_kw": cfg.shredding_energy_kwh_per_t * f / 1000.0,
        "steam_kg_per_h": steam_kg_per_h, **{f"steam_{k.replace(' ', '_').lower()}_kg_per_h": v for k, v in steam.items()},
        "cooling_water_t_per_h": steam_kg_per_h * LATENT_HEAT_J_PER_KG
        / (WATER_CP_J_PER_KG_K * cfg.cooling_water_rise_k) / 1000.0,
        "process_water_t_per_h": (s["dissolution water"]["water"] + s["wash water"]["water"]) / 1000.0,
    }
    liquid_m3_per_h = sum(liquor.values()) / LIQUOR_DENSITY_KG_PER_M3
    slurry_m3_per_h = (sum(slurry.values()) + s["sulfuric acid"]["h2so4"]) / LIQUOR_DENSITY_KG_PER_M3
    area = cfg.evaporator_u_w_per_m2_k * cfg.evaporator_delta_t_k  # W per m2 of heating surface
    out.sizes = {  # in the units of data/equipment_costs.csv's size_si_unit
        "shredder": f / 1000.0,  # t/h of bale PET
        "dissolver": liquid_m3_per_h * cfg.tank_residence_time_h,  # m3
        "PET filter": unreacted / cfg.filter_flux_kg_per_m2_h,  # m2
        "acidifier": slurry_m3_per_h * cfg.tank_residence_time_h,  # m3
        "TPA filter": tpa_out / cfg.filter_flux_kg_per_m2_h,  # m2
        "dryer": s["dryer vapour"]["water"],  # kg/h of water evaporated
        # every effect evaporates its share with the same temperature drop: total area = W L / (U dT)
        "evaporator": s["evaporated water"]["water"] / 3600.0 * LATENT_HEAT_J_PER_KG / area,  # m2
        "Na2SO4 crystallizer": mother["na2so4"],  # kg/h of crystals
        "EG still": steam["EG column"] / 3600.0 * LATENT_HEAT_J_PER_KG / area,  # m2 of reboiler
    }
    return out
