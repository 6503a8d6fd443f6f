"""Figures: functions take tables and return matplotlib Figures; they compute no physics."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402


def save_figure(fig, stem: str | Path) -> None:
    """Write stem.png and stem.svg, then close the figure."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "svg"):
        fig.savefig(stem.with_suffix(f".{ext}"), dpi=150, bbox_inches="tight")
    plt.close(fig)


def plot_drum_loads(loads: pd.DataFrame, steady_after_s: float):
    """Torque about the axis and power of the drum over time; the steady window shaded."""
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax1.plot(loads.t_s, loads.torque_axis_nm, lw=0.8)
    ax1.set_ylabel("torque on drum about axis (N m)")
    ax2.plot(loads.t_s, loads.power_w / 1000, lw=0.8, color="C1")
    ax2.set_ylabel("power (kW)")
    ax2.set_xlabel("time (s)")
    for ax in (ax1, ax2):
        ax.axvspan(steady_after_s, loads.t_s.max(), color="0.9", zorder=0)
    fig.suptitle("Rotating drum: loads from DEM (shaded: averaging window)")
    return fig
