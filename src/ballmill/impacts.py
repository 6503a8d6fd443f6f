"""Impact statistics from a collision log: how often balls hit, and how hard.

What mechanochemistry cares about: per pair type (ball-ball, and ball-wall per wall body),
collisions per second, the normal impact energy (1/2 m* v_n^2 at first touch) and the energy
dissipated per collision, their mean and 90th percentile, and the specific dissipated power
(W per kg of balls).  Only collisions that started after `after_s` and have ended count, so a
contact that lasts the whole window (a ball resting in the bed) is not in the log.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

ENERGY_BINS_J = np.logspace(-12, 4, 97)  # 6 bins per decade, 1 pJ to 10 kJ


def pair_type(collisions: pd.DataFrame) -> pd.Series:
    """'ball_ball' or 'ball_wall_<body>' per row."""
    wall = "ball_wall_" + collisions.body.astype(str)
    return wall.where(collisions.kind == "ball-wall", "ball_ball")


def impact_statistics(collisions: pd.DataFrame, after_s: float, until_s: float, ball_mass_kg: float) -> dict:
    """Flat dict of statistics over collisions starting in (after_s, until_s]."""
    window = max(until_s - after_s, 1e-12)
    c = collisions[(collisions.t_start_s > after_s) & (collisions.t_start_s <= until_s)]
    out = {"collisions_per_s": len(c) / window,
           "dissipated_power_from_log_w": float(c.dissipated_j.sum()) / window}
    out["specific_dissipated_power_w_per_kg"] = out["dissipated_power_from_log_w"] / ball_mass_kg
    for tag, g in c.groupby(pair_type(c)) if len(c) else ():
        out[f"{tag}_collisions_per_s"] = len(g) / window
        for col, name in (("impact_energy_j", "impact_energy"), ("dissipated_j", "dissipated")):
            out[f"{tag}_{name}_mean_j"] = float(g[col].mean())
            out[f"{tag}_{name}_p90_j"] = float(g[col].quantile(0.9))
    return out


def energy_spectrum(collisions: pd.DataFrame, after_s: float, column: str = "impact_energy_j",
                    weight: str | None = None) -> pd.DataFrame:
    """Histogram on log bins per pair type: bin edges (J), count, fraction and cumulative fraction
    (of the collisions, or of the sum of column `weight`, e.g. the energy dissipated)."""
    c = collisions[collisions.t_start_s > after_s]
    rows = []
    for tag, g in c.groupby(pair_type(c)) if len(c) else ():
        counts, _ = np.histogram(g[column], ENERGY_BINS_J)
        if weight:
            sums, _ = np.histogram(g[column], ENERGY_BINS_J, weights=g[weight])
            frac = sums / max(float(g[weight].sum()), 1e-300)
        else:
            frac = counts / max(len(g), 1)
        rows.append(pd.DataFrame({"pair_type": tag, "energy_lo_j": ENERGY_BINS_J[:-1], "energy_hi_j": ENERGY_BINS_J[1:],
                                  "count": counts, "fraction": frac, "cumulative_fraction": np.cumsum(frac)}))
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(
        columns=["pair_type", "energy_lo_j", "energy_hi_j", "count", "fraction", "cumulative_fraction"])
