"""The steam's source (plant.heat.kind), each a function that adds what makes the steam (or
nothing) to the flowsheet; the units keep asking for the steam agents they need.

- bought_steam: bought at its price (data/prices.csv), natural gas's factor (ghg_factors.csv).
- electric_boiler: an electrode boiler on the grid makes all of it (units.ElectricBoiler).
- residue_boiler: a boiler burns the sorted-out plastics (instead of the landfill) and makes
  what their heat covers; the rest is bought (units.ResidueBoiler).
"""

from __future__ import annotations

import biosteam as bst

from ..data import table
from .units import ElectricBoiler, ResidueBoiler

LHV = "lower_heating_value_mj_per_kg"


def bought_steam(streams: dict, cfg, cepci: float) -> None:
    """Nothing to add: the steam is bought."""


def electric_boiler(streams: dict, cfg, cepci: float) -> None:
    ElectricBoiler("B601", key="electric_boiler", cepci=cepci, efficiency=cfg.heat.electric_efficiency)


def residue_boiler(streams: dict, cfg, cepci: float) -> None:
    """The sorting residue is the boiler's fuel; its flue gas (CO2 of fossil plastics) leaves as treatment_CO2 does."""
    chemicals = table("plant_chemicals.csv").query("property == @LHV")
    lhv = {r.chemical: float(r.value) for r in chemicals.itertuples()}
    residue = streams["sorting_residue"]
    residue.price = 0.0
    ResidueBoiler("B601", ins=(residue, bst.Stream("boiler_air")), outs=(bst.Stream("boiler_water"),
                                                                           bst.Stream("boiler_CO2")),
                  key="solid_fuel_boiler_humbird_2011", cepci=cepci, efficiency=cfg.heat.boiler_efficiency,
                  lhv_mj_per_kg=lhv)


SOURCES = {"bought_steam": bought_steam, "electric_boiler": electric_boiler, "residue_boiler": residue_boiler}
