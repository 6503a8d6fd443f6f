"""The evaporator options (plant.evaporation.kind), each a function that builds the unit taking
the mother liquor's water off (outs: concentrate, condensate; `evaporated_water_fraction` of the
feed's water to the condensate) and returns it with the condensate stream that leaves the area.

- multi_effect: BioSTEAM's multiple-effect evaporator at the configured effects' pressures, its
  first body on steam, the split set by its last body's flash (the vapour fraction solved so
  that the configured share of the water leaves), bodies priced one by one (units.Evaporator);
  with `feed_preheat` the condensate heats the feed first in a process exchanger (H401).
- mvr: one body heated by its own vapour recompressed on electricity, no steam
  (units.VapourRecompressionEvaporator).
"""

from __future__ import annotations

import biosteam as bst

from ..data import table
from .units import Evaporator, VapourFraction, VapourRecompressionEvaporator


def multi_effect(ID: str, feed, cfg, cepci: float):
    if cfg.evaporation.feed_preheat:
        exchanger = bst.HXprocess("H401", ins=(feed, "hot_condensate"), outs=("preheated_liquor", "cooled_condensate"),
                                  dT=cfg.evaporation.approach_temperature_k)
        exchanger.material = table("material_factors.csv").set_index("material").shell_and_tube[cfg.brine_material]
        feed, leaving = exchanger - 0, exchanger - 1
    evaporator = Evaporator(ID, ins=feed, outs=("concentrate", "condensate"), key=cfg.evaporator_cost, cepci=cepci,
                            P=tuple(cfg.evaporation.effect_pressures_pa), V=cfg.evaporated_water_fraction,
                            V_definition="Overall")

    water = VapourFraction("Water")

    @evaporator.add_specification(run=True)
    def evaporate_the_water():  # the last body's flash sets the split: its V for the configured share of water
        evaporator.V = water(evaporator.ins[0], evaporator.P[-1], cfg.evaporated_water_fraction)

    if cfg.evaporation.feed_preheat:
        evaporator.outs[1] = exchanger.ins[1]
        return evaporator, leaving
    return evaporator, evaporator - 1


def mvr(ID: str, feed, cfg, cepci: float):
    e = cfg.evaporation
    evaporator = VapourRecompressionEvaporator(ID, ins=feed, outs=("concentrate", "condensate"), P=e.pressure_pa,
                                         water_share=cfg.evaporated_water_fraction, kwh_per_t_water=e.kwh_per_t_water,
                                         temperature_difference_k=e.temperature_difference_k,
                                         u_w_per_m2_k=e.u_w_per_m2_k, body_key=cfg.evaporator_cost,
                                         compressor_key=e.compressor_cost, cepci=cepci)
    return evaporator, evaporator - 1


EVAPORATORS = {"multi_effect": multi_effect, "mvr": mvr}
