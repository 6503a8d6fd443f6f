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

from . import uncertainty
from .correlations import price
from .model import Plant, plant
from .system import MillSpec
from .tea import cepci

log = logging.getLogger(__name__)
BAND = (5, 50, 95)  # percentiles of the Monte Carlo reported beside the base value


def variants(p: Plant) -> pd.DataFrame:
    """The MSP and footprint with one modelling choice undone at a time (the plant restored
    after each): what each choice moves."""
    u, s, cfg, tea = p.ps.units, p.ps.streams, p.cfg, p.tea
    evap = u["E401"]
    bodies = evap.baseline_purchase_costs["Evaporators"] / evap.cost_factor
    total = sum(evap.baseline_purchase_costs.values()) / evap.cost_factor
    one_body = price(cfg.evaporator_cost, sum(evap._As), cepci(cfg.cost_year)).usd

    def evap_factor(new_bodies):
        return lambda: setattr(evap, "cost_factor", (total - bodies + new_bodies) / total)

    def set_(obj, **kw):
        return lambda: [setattr(obj, k, v) for k, v in kw.items()]

    cases = {
        "evaporator as one body of the summed area": evap_factor(one_body),
        "evaporator bodies at BioSTEAM's own price": evap_factor(evap.design_results["BioSTEAM bodies"]),
        "20 staff at every scale": set_(cfg, staffing="fixed", staff=20),
        "EG credited at the virgin price": set_(s["EG"], price=p.prices["eg"]),
        "Na2SO4 sold (USGS 2008-2011 price)": set_(s["Na2SO4"], price=p.prices["na2so4_sale"]),
        "Na2SO4 landfilled": set_(s["Na2SO4"], price=-p.prices["disposal"]),
        "bales all PET, nothing lost in granulating": set_(cfg, bale_pet_fraction=1.0, flake_loss_fraction=0.0),
        "no start-up period": set_(tea, startup_months=0.0),
        "no debt (all equity)": set_(tea, finance_fraction=0.0),
    }
    base = p.evaluate()
    rows = [{"variant": "base", **base}]
    for name, apply in cases.items():
        saved = (evap.cost_factor, replace(cfg), s["EG"].price, s["Na2SO4"].price, tea.startup_months,
                 tea.finance_fraction)
        apply()
        rows.append({"variant": name, **p.evaluate()})
        evap.cost_factor, old, s["EG"].price, s["Na2SO4"].price, tea.startup_months, tea.finance_fraction = saved
        for k in ("staffing", "staff", "bale_pet_fraction", "flake_loss_fraction"):
            setattr(cfg, k, getattr(old, k))
    powder = plant(p.mill, replace(cfg, feed_form="powder"), p.econ, p.region, name="powder")
    rows.append({"variant": "fine powder instead of flake (pulveriser)", **powder.evaluate()})
    p.evaluate()
    out = pd.DataFrame(rows)
    out["msp_change_usd_per_kg"] = out.msp_usd_per_kg - base["msp_usd_per_kg"]
    out["gwp_change_kg_per_kg"] = out.gwp_kg_per_kg - base["gwp_kg_per_kg"]
    return out


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
        m = uncertainty.model(p, power_se_kw)
        uncertainty.tornado(m).to_csv(out_dir / "tornado.csv", index=False)
        if cfg.monte_carlo_draws:
            draws, seconds = uncertainty.monte_carlo(m, cfg.monte_carlo_draws, cfg.seed)
            draws.to_parquet(out_dir / "monte_carlo.parquet")
            uncertainty.rank_correlations(m).to_csv(out_dir / "rank_correlations.csv", index=False)
            for column, name in (("MSP", "msp_p{}_usd_per_kg"), ("GWP", "gwp_p{}_kg_per_kg")):
                record |= {name.format(q): v for q, v in zip(BAND, np.percentile(draws[column], BAND))}
            record["monte_carlo_s"] = seconds
        p.evaluate()
    record["plant_s"] = time.perf_counter() - started
    log.info("plant: MSP %.3f $/kg rTPA, %.2f kg CO2e/kg (%d draws) in %.0f s", base["msp_usd_per_kg"],
             base["gwp_kg_per_kg"], cfg.monte_carlo_draws, record["plant_s"])
    return record
