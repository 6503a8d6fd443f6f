"""What it takes: per lever, the value at which rTPA's MSP equals virgin TPA's price and the
one at which its footprint equals virgin PTA's, the other inputs at the base (root finding on
the built plant, each lever set through the uncertainty's setters and restored after)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
from scipy.optimize import brentq

from ..config import PlantConfig
from . import uncertainty
from .model import Plant

RELATIVE_TOLERANCE = 1e-6
UNSOLVABLE = (RuntimeError, ValueError, FloatingPointError)  # what BioSTEAM raises where a plant cannot be solved
HALVINGS = 8  # tries at moving an end of the search range toward the base


def search_range(lever: str, base: float, span: float) -> tuple[float, float]:
    """[base / span, base x span], within the plant field's own range for a plant.* lever."""
    lo, hi = base / span, base * span
    ranges = {f"plant.{f.name}": f.metadata["range"] for f in dataclasses.fields(PlantConfig) if "range" in f.metadata}
    if lever in ranges:
        low, high, *_ = ranges[lever]
        lo, hi = max(lo, low if low is not None else lo), min(hi, high if high is not None else hi)
    return lo, hi


def virgin(p: Plant) -> dict[str, float]:
    """The targets: virgin TPA's price ($/kg) and virgin PTA's footprint (kg CO2e/kg)."""
    return {"msp_usd_per_kg": p.prices["tpa"], "gwp_kg_per_kg": p.cf["virgin_tpa"]}


def solvable_end(indicators, base: float, end: float) -> tuple[float, dict]:
    """The end of a search range nearest `end`, on the way to `base` (halving the log distance,
    or the distance where a sign differs), at which the plant can be solved, and its indicators;
    a plant BioSTEAM cannot solve there (a unit's infeasible specification, a recycle that does
    not converge) has its recycles emptied before the next try."""
    for _ in range(HALVINGS):
        try:
            return end, indicators(end)
        except UNSOLVABLE:
            end = math.copysign(math.sqrt(end * base), base) if end * base > 0 else 0.5 * (end + base)
    return base, indicators(base)


def break_even(p: Plant, levers: list[str], span: float) -> pd.DataFrame:
    """Per lever: its base, the value giving MSP = virgin TPA's price ($/kg) and the one giving
    footprint = virgin PTA's (kg CO2e/kg), each searched over search_range narrowed to where the
    plant can be solved (searched_low, searched_high); NaN where the target is not crossed there
    (the lever alone cannot reach it).  A lever read after the simulation (a price, a rate, a
    footprint factor: uncertainty.read_after_simulation) is searched on the base simulation, not
    simulated again; those levers go first, while the plant is still at its base."""
    known = uncertainty.setters(p, 0.0)
    targets = virgin(p)
    rows = {}

    def simulated() -> dict:
        try:
            return p.evaluate()
        except UNSOLVABLE:
            p.ps.system.empty_recycles()  # the next simulation starts clean
            raise

    p.evaluate()
    for lever in sorted(levers, key=lambda name: not uncertainty.read_after_simulation(name)):
        base, set_ = known[lever]
        evaluate = p.indicators if uncertainty.read_after_simulation(lever) else simulated

        def indicators(v: float, set_=set_, evaluate=evaluate) -> dict:
            set_(v)
            return evaluate()

        lo, hi = search_range(lever, base, span)
        lo, at_lo = solvable_end(indicators, base, lo)
        hi, at_hi = solvable_end(indicators, base, hi)
        row = {"lever": lever, "base": base, "searched_low": lo, "searched_high": hi}
        for indicator, target in targets.items():
            root = math.nan
            if (at_lo[indicator] - target) * (at_hi[indicator] - target) < 0:
                try:
                    root = brentq(lambda v, i=indicator, t=target: indicators(v)[i] - t, lo, hi,
                                  xtol=RELATIVE_TOLERANCE * abs(base))
                except UNSOLVABLE:  # a point inside the range the plant cannot be solved at
                    pass
            row[f"{indicator.split('_')[0]}_break_even"] = root
        set_(base)
        rows[lever] = row
    p.evaluate()
    out = pd.DataFrame([rows[lever] for lever in levers])
    out["msp_break_even_over_base"] = out.msp_break_even / out.base
    out["gwp_break_even_over_base"] = out.gwp_break_even / out.base
    return out


def bands(table: pd.DataFrame, draws: pd.DataFrame, base: dict[str, float], targets: dict[str, float]) -> pd.DataFrame:
    """`table` (break_even's) with each break-even's 5-95 % band over the Monte Carlo's draws
    (columns MSP, GWP and the levers drawn), to first order in the lever: along the lever the
    indicator moves by s = (target - base) / (break-even - base value) per unit, so a draw
    (lever v, indicator y) meets the target at v + (target - y) / s; a lever not drawn stays at
    its base.  Exact where the indicator is linear in the lever, as the MSP is in a price; an end
    beyond the lever's physical range (below zero) says that some draws cannot reach the target by
    that lever alone."""
    out = table.copy()
    for indicator, column in (("msp_usd_per_kg", "MSP"), ("gwp_kg_per_kg", "GWP")):
        prefix = indicator.split("_")[0]
        for q in (5, 95):
            out[f"{prefix}_break_even_p{q}"] = math.nan
        for i, row in out.iterrows():
            root = row[f"{prefix}_break_even"]
            if math.isnan(root) or root == row.base:
                continue
            slope = (targets[indicator] - base[indicator]) / (root - row.base)
            lever = draws.get(row.lever, row.base)
            at = lever + (targets[indicator] - draws[column]) / slope
            out.loc[i, [f"{prefix}_break_even_p5", f"{prefix}_break_even_p95"]] = np.percentile(at, (5, 95))
    return out
