"""The MSP's uncertainty: a seeded Monte Carlo over data/plant_uncertainty.csv and a
one-at-a-time sensitivity (tornado).

Each row scales one input by a factor drawn from a triangular distribution (low, 1, high);
`dem.power` is drawn from a normal distribution with the DEM power's standard error, and
`yield.conversion` scales the mill's conversion per pass (capped at 1).  The DEM is never
rerun: every draw re-evaluates the plant around the same built mill (model.evaluate).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from ..config import EconomicsConfig, PlantConfig
from ..data import lookup, table
from .model import Mill, evaluate

UNCERTAINTY_FILE = "plant_uncertainty.csv"


def msp_with(factors: dict[str, float], mill: Mill, power_se_w: float, cfg: PlantConfig,
             econ: EconomicsConfig) -> float:
    """The MSP ($/kg) with inputs scaled by `factors` (parameter -> factor; dem.power -> standard
    deviations of the power)."""
    plant_fields, econ_fields, prices = {}, {}, {}
    for name, f in factors.items():
        group, _, key = name.partition(".")
        if group == "plant":
            value = getattr(cfg, key) * f
            plant_fields[key] = round(value) if isinstance(getattr(cfg, key), int) else value
        elif group == "economics":
            econ_fields[key] = getattr(econ, key) * f
        elif group == "prices":
            prices[key] = lookup("prices.csv", "item", key, "price_usd_per_t") * f
    mill = replace(mill, power_w=max(0.0, mill.power_w + factors.get("dem.power", 0.0) * power_se_w),
                   conversion=min(1.0, mill.conversion * factors.get("yield.conversion", 1.0)))
    plant = evaluate(mill, replace(cfg, **plant_fields), replace(econ, **econ_fields), prices)
    return plant.msp_usd_per_t / 1000.0


def monte_carlo(mill: Mill, power_se_w: float, cfg: PlantConfig, econ: EconomicsConfig) -> np.ndarray:
    """MSP ($/kg) of cfg.monte_carlo_draws draws (seeded by cfg.seed)."""
    rows = table(UNCERTAINTY_FILE)
    rng = np.random.default_rng(cfg.seed)
    draws = {}
    for r in rows.itertuples():
        if r.distribution == "normal":
            draws[r.parameter] = rng.standard_normal(cfg.monte_carlo_draws)
        elif r.low_factor == r.high_factor:
            draws[r.parameter] = np.full(cfg.monte_carlo_draws, r.low_factor)
        else:
            draws[r.parameter] = rng.triangular(r.low_factor, 1.0, r.high_factor, cfg.monte_carlo_draws)
    return np.array([msp_with({k: v[i] for k, v in draws.items()}, mill, power_se_w, cfg, econ)
                     for i in range(cfg.monte_carlo_draws)])


def tornado(mill: Mill, power_se_w: float, cfg: PlantConfig, econ: EconomicsConfig) -> pd.DataFrame:
    """MSP ($/kg) at each input's low and high end (two standard errors for the DEM power), the
    others at their base values; largest swing first."""
    rows = []
    for r in table(UNCERTAINTY_FILE).itertuples():
        lo, hi = (-2.0, 2.0) if r.distribution == "normal" else (r.low_factor, r.high_factor)
        rows.append({"parameter": r.parameter, "low_factor": lo, "high_factor": hi,
                     "msp_low_usd_per_kg": msp_with({r.parameter: lo}, mill, power_se_w, cfg, econ),
                     "msp_high_usd_per_kg": msp_with({r.parameter: hi}, mill, power_se_w, cfg, econ)})
    out = pd.DataFrame(rows)
    out["swing_usd_per_kg"] = (out.msp_high_usd_per_kg - out.msp_low_usd_per_kg).abs()
    return out.sort_values("swing_usd_per_kg", ascending=False, ignore_index=True)
