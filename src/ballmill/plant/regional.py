"""One plant for a group of states against a plant each (study=regional).

Each state's bales leave from its centre of population; a plant at another state's centre pays
their haulage (plant/haulage.py) as a dearer, dirtier bale: the bales' price and factor rise by
the feed-weighted haul (km) x the truck's $ and kg CO2e per tonne-km, so the MSP's solution
carries it like any input.  The states' own plants haul nothing between states (their in-state
collection is in the bale's price and factor, alike for all).  Sites: each state's centre.
Sharing: each state joined to the nearest state with more PET, at that state's centre, against
the two plants apart (their rTPA-weighted MSP and footprint).  Scale: the fresh PET feed at
which one plant, hauling nothing, meets virgin TPA's price (and virgin PTA's footprint, if any
feed does), root found on the log of the feed."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pandas as pd
from scipy.optimize import brentq

from ..plots import plot_regional, save_figure
from . import haulage
from .model import inputs, plant
from .system import MillSpec
from .what_it_takes import virgin

log = logging.getLogger(__name__)
SCALE_XTOL = 1e-10  # on the natural log of the feed: the MSP at the root within ~1e-10 $/kg of the target


def hauled(cfg, econ, km: float) -> object:
    """cfg with the bales dearer and dirtier by a haul of `km` (feed-weighted mean, road km)."""
    prices, cf = inputs(cfg, econ)
    return replace(cfg, prices_usd_per_t={**cfg.prices_usd_per_t,
                                          "pet_bale": prices["pet_bale"] * 1000.0 + km * haulage.usd_per_t_km()},
                   ghg_kg_co2e={**cfg.ghg_kg_co2e, "pet_bale": cf["pet_bale"] + km * haulage.kg_co2e_per_t_km() / 1000.0})


def evaluate(feeds: dict[str, float], site: str, mill: Callable[[float], dict], cfg, econ) -> dict:
    """The plant at `site` for the states' summed feeds (kg/h of PET), their bales hauled there."""
    total = sum(feeds.values())
    km = sum(f * haulage.road_km(c, site) for c, f in feeds.items()) / total
    p = plant(MillSpec(**mill(total)), hauled(cfg, econ, km), econ, site, name="regional")
    result = p.evaluate()
    return {"site": site, "fresh_pet_kg_per_h": total, "haul_km": km, "haul_usd_per_t_bales": km * haulage.usd_per_t_km(),
            "haul_kg_co2e_per_t_bales": km * haulage.kg_co2e_per_t_km(), "rtpa_kg_per_h": p.rtpa.F_mass, **result}


def scale(mill: Callable[[float], dict], cfg, econ, low: float, high: float) -> pd.DataFrame:
    """Per indicator (MSP $/kg, footprint kg CO2e/kg): the fresh PET feed (kg/h) in [low, high]
    at which a plant on the US grid, hauling nothing, meets virgin TPA's price or PTA's footprint
    (NaN where the feeds do not cross it), and the indicator at the root and at both ends.  Where
    the root's value is off the target the indicator steps there (staff or units in parallel)."""
    built = {}

    def at(log_feed: float) -> dict:
        if log_feed not in built:
            built[log_feed] = plant(MillSpec(**mill(math.exp(log_feed))), cfg, econ, None, name="scale").evaluate()
        return built[log_feed]

    targets = virgin(plant(MillSpec(**mill(low)), cfg, econ, None, name="scale"))
    ends = math.log(low), math.log(high)
    rows = []
    for indicator, target in targets.items():
        gap = [at(x)[indicator] - target for x in ends]
        root = (brentq(lambda x, k=indicator, t=target: at(x)[k] - t, *ends, xtol=SCALE_XTOL)
                if gap[0] * gap[1] < 0 else math.nan)
        rows.append({"indicator": indicator, "target": target, "break_even_fresh_pet_kg_per_h": math.exp(root),
                     "at_break_even": math.nan if math.isnan(root) else at(root)[indicator],
                     "low_fresh_pet_kg_per_h": low, "at_low": gap[0] + target,
                     "high_fresh_pet_kg_per_h": high, "at_high": gap[1] + target})
    return pd.DataFrame(rows)


def weighted(rows: list[dict]) -> dict:
    """rTPA-weighted MSP and footprint of plants apart."""
    kg = sum(r["rtpa_kg_per_h"] for r in rows)
    return {k: sum(r[k] * r["rtpa_kg_per_h"] for r in rows) / kg for k in ("msp_usd_per_kg", "gwp_kg_per_kg")}


def run(feeds: dict[str, float], mill: Callable[[float], dict], cfg, econ, out_dir: Path) -> dict:
    """states.csv (each state's own plant and its joined one), sites.csv (the plant for all at
    each state's centre), scale.csv (the feeds that meet virgin TPA), the figure, and the
    record's regional_* and break_even_* columns."""
    started = time.perf_counter()
    own = {c: evaluate({c: f}, c, mill, cfg, econ) for c, f in feeds.items()}
    apart = weighted(list(own.values()))
    sites = pd.DataFrame([evaluate(feeds, c, mill, cfg, econ) for c in feeds]).sort_values("msp_usd_per_kg")
    rows = []
    for c, f in feeds.items():
        larger = [o for o in feeds if feeds[o] > f]
        if not larger:
            rows.append({"state": c, "fresh_pet_kg_per_h": f, **{f"own_{k}": own[c][k] for k in
                                                                   ("msp_usd_per_kg", "gwp_kg_per_kg")}})
            continue
        partner = min(larger, key=lambda o: haulage.road_km(c, o))
        joined = evaluate({c: f, partner: feeds[partner]}, partner, mill, cfg, econ)
        pair = weighted([own[c], own[partner]])
        rows.append({"state": c, "fresh_pet_kg_per_h": f, "own_msp_usd_per_kg": own[c]["msp_usd_per_kg"],
                     "own_gwp_kg_per_kg": own[c]["gwp_kg_per_kg"], "partner": partner,
                     "road_km": haulage.road_km(c, partner), "apart_msp_usd_per_kg": pair["msp_usd_per_kg"],
                     "apart_gwp_kg_per_kg": pair["gwp_kg_per_kg"], "joined_msp_usd_per_kg": joined["msp_usd_per_kg"],
                     "joined_gwp_kg_per_kg": joined["gwp_kg_per_kg"],
                     "share": joined["msp_usd_per_kg"] < pair["msp_usd_per_kg"]})
    states = pd.DataFrame(rows)
    states.to_csv(out_dir / "states.csv", index=False)
    scales = scale(mill, cfg, econ, *cfg.regional.scale_fresh_pet_kg_per_h).set_index("indicator")
    scales.to_csv(out_dir / "scale.csv")
    sites.to_csv(out_dir / "sites.csv", index=False)
    best = sites.iloc[0]
    prices, cf = inputs(cfg, econ)
    tpa_usd_per_kg, tpa_kg_co2e = prices["tpa"], cf["virgin_tpa"]
    save_figure(plot_regional(states, best.to_dict(), apart, tpa_usd_per_kg, tpa_kg_co2e), out_dir / "regional")
    record = {"regional_site": best.site, "regional_haul_km": best.haul_km,
              "regional_haul_usd_per_t_bales": best.haul_usd_per_t_bales,
              "regional_haul_kg_co2e_per_t_bales": best.haul_kg_co2e_per_t_bales,
              "regional_msp_usd_per_kg": best.msp_usd_per_kg, "regional_gwp_kg_per_kg": best.gwp_kg_per_kg,
              "apart_msp_usd_per_kg": apart["msp_usd_per_kg"], "apart_gwp_kg_per_kg": apart["gwp_kg_per_kg"],
              "break_even_fresh_pet_kg_per_h": scales.at["msp_usd_per_kg", "break_even_fresh_pet_kg_per_h"],
              "break_even_gwp_fresh_pet_kg_per_h": scales.at["gwp_kg_per_kg", "break_even_fresh_pet_kg_per_h"],
              "regional_sharing_states": ",".join(states.state[states.share.fillna(False).astype(bool)]),
              "haul_usd_per_t_km": haulage.usd_per_t_km(), "haul_kg_co2e_per_t_km": haulage.kg_co2e_per_t_km(),
              "virgin_tpa_usd_per_kg": tpa_usd_per_kg, "virgin_tpa_gwp_kg_per_kg": tpa_kg_co2e,
              "regional_s": time.perf_counter() - started}
    log.info("regional: one plant at %s %.3f $/kg, %.2f kg CO2e/kg; %d apart %.3f $/kg, %.2f kg CO2e/kg (%.0f s)",
             best.site, best.msp_usd_per_kg, best.gwp_kg_per_kg, len(feeds), apart["msp_usd_per_kg"],
             apart["gwp_kg_per_kg"], record["regional_s"])
    return record
