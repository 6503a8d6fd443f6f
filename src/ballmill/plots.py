"""Figures: functions take tables and return matplotlib Figures; they compute no physics."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd


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


def plot_fig3b(table: pd.DataFrame):
    """Paper Fig. 3b: annual electricity cost by BPR (bars), TPA yield (secondary axis)."""
    t = table.sort_values("bpr")
    fig, ax = plt.subplots(figsize=(7, 4))
    labels = [f"{b:g}" for b in t.bpr]
    ax.bar(labels, t.electricity_usd_per_yr / 1000, color="C0", label="electricity")
    ax.set_xlabel("ball-to-powder ratio (BPR)")
    ax.set_ylabel("electricity cost (k$/yr)")
    ax2 = ax.twinx()
    ax2.plot(labels, t.yield_percent, "o-", color="C3", label="yield")
    ax2.set_ylabel("TPA yield (%)")
    ax2.set_ylim(0, 105)
    ax.set_title(f"{t.pet_feed_kg_per_h.iloc[0]:.0f} kg/h PET: electricity cost and yield")
    fig.legend(loc="upper left", bbox_to_anchor=(0.12, 0.88))
    return fig


def plot_fig4(table: pd.DataFrame):
    """Paper Fig. 4: purchase cost per unit feed by state (bars), electricity $/t PET (secondary)."""
    t = table.sort_values("pet_feed_kg_per_h")
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(t.region, t.purchase_cost_usd_per_kg_per_h, color="C2", label="purchase cost")
    ax.set_ylabel("purchase cost per unit feed ($ per kg/h PET)")
    ax.set_xlabel("state (ordered by PET feed)")
    ax2 = ax.twinx()
    ax2.plot(t.region, t.electricity_usd_per_t_pet, "o-", color="C1", label="electricity")
    ax2.set_ylabel("electricity ($/t PET)")
    ax2.set_ylim(0, None)
    ax.set_title("South Atlantic states, NAPCOR 2018 PET split by population, BPR 20")
    fig.legend(loc="upper right", bbox_to_anchor=(0.88, 0.88))
    return fig


def plot_score_surface(surface: pd.DataFrame, best: dict):
    """Calibration score over the restitution x friction grid (log colour), best pair marked."""
    grid = surface.pivot(index="wall_restitution", columns="wall_friction", values="score")
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    mesh = ax.pcolormesh(grid.columns, grid.index, np.log10(grid.to_numpy()), shading="nearest", cmap="viridis_r")
    fig.colorbar(mesh, ax=ax, label="log10 score (mean squared relative error)")
    ax.plot(best["wall_friction"], best["wall_restitution"], "r*", ms=14, label="best")
    ax.set_xlabel("ball-wall static friction")
    ax.set_ylabel("ball-wall restitution")
    ax.legend(loc="upper right")
    ax.set_title("MM400 calibration: simulated vs tracked")
    return fig


def plot_score_history(trials: pd.DataFrame, grid_best: float | None = None):
    """Score of each Optuna trial and the best so far (log scale), beside the grid's best."""
    fig, ax = plt.subplots(figsize=(5.5, 3.5))
    ax.semilogy(trials.trial, trials.score, "o", ms=4, color="0.6", label="trial")
    ax.semilogy(trials.trial, trials.best_score, "-", color="C0", label="best so far")
    if grid_best is not None:
        ax.axhline(grid_best, color="C3", ls="--", lw=1, label="grid's best")
    ax.set_xlabel("trial")
    ax.set_ylabel("score (lower is better)")
    ax.legend(frameon=False)
    fig.tight_layout()
    return fig


def plot_lab_validation(simulated: pd.DataFrame, observed: pd.DataFrame | None = None):
    """Paper Fig. 3a: mean ball speed vs frequency per ball size and count; simulation lines,
    tracked videos as markers."""
    fig, ax = plt.subplots(figsize=(6.5, 4))
    groups = simulated.groupby(["balls", "ball_diameter_m"])
    for k, ((balls, d), g) in enumerate(groups):
        g = g.sort_values("frequency_hz")
        label = f"{balls} x {d * 1e3:.1f} mm"
        ax.plot(g.frequency_hz, g.mean_speed_m_per_s, "-", color=f"C{k}", label=f"DEM {label}")
        o = None if observed is None else observed[(observed.balls == balls)
                                                   & ((observed.ball_diameter_m - d).abs() < 1e-9)]
        if o is not None and len(o):
            ax.plot(o.frequency_hz, o.mean_speed_m_per_s, "o", mfc="none", color=f"C{k}", label=f"tracked {label}")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("mean ball speed, frame to frame (m/s)")
    ax.legend(fontsize=8)
    ax.set_title("MM400: mean ball speed")
    return fig


def plot_impact_spectra(spectra: pd.DataFrame):
    """Cumulative distribution of normal impact energy, one panel per pair kind, one curve per
    case; `spectra` is energy_spectrum's table with a `case` column."""
    kinds = [("ball_ball", "ball-ball"), ("ball_wall", "ball-wall")]
    fig, axes = plt.subplots(1, 2, sharey=True, sharex=True, figsize=(10, 4))
    hit = spectra[spectra["count"] > 0]
    for ax, (prefix, title) in zip(axes, kinds):
        for case, g in spectra[spectra.pair_type.str.startswith(prefix)].groupby("case", sort=False):
            g = g.groupby("energy_hi_j", as_index=False)["count"].sum()  # walls of all bodies together
            ax.plot(g.energy_hi_j, np.cumsum(g["count"]) / max(g["count"].sum(), 1), lw=1.2, label=str(case))
        ax.set_xscale("log")
        if len(hit):
            ax.set_xlim(hit.energy_lo_j.min(), hit.energy_hi_j.max())
        ax.set_xlabel("normal impact energy (J)")
        ax.set_title(title)
        ax.grid(True, which="major", lw=0.3)
    axes[0].set_ylabel("fraction of collisions below")
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle("Impact-energy spectra (collisions in the averaging window)")
    return fig


def plot_bed(trajectories: pd.DataFrame, radii_m: np.ndarray, profile_m: np.ndarray, omega_rad_per_s: float,
             start_s: float, shape: dict | None = None):
    """Side view of the drum (along its axis) at four recorded instants, balls coloured by speed,
    so cascading and cataracting can be told apart at a glance; the shell's profile (lifters) as
    turned at that instant, and the charge's toe and shoulder where `shape` gives them.  The
    balls are one ellipse collection (radii in data units), rasterised inside an SVG: a
    3,767-ball mill's figure took 1.8 s and 9.6 MB as separate circles."""
    from matplotlib.collections import EllipseCollection
    from matplotlib.patches import Polygon

    times = sorted(trajectories.t_s.unique())
    times = [times[k] for k in np.linspace(0, len(times) - 1, min(4, len(times))).round().astype(int)]
    fig, axes = plt.subplots(1, len(times), figsize=(3.2 * len(times), 3.4), squeeze=False)
    speed = np.sqrt(trajectories.vx_m_per_s**2 + trajectories.vy_m_per_s**2 + trajectories.vz_m_per_s**2)
    vmax = float(speed.quantile(0.99)) or 1.0
    big_r = float(np.hypot(*profile_m.T).max())
    for ax, t in zip(axes[0], times):
        g = trajectories[trajectories.t_s == t].sort_values("y_m")
        diameters = 2 * radii_m[g.particle.to_numpy()]
        balls = EllipseCollection(diameters, diameters, 0.0, units="xy", offsets=np.c_[g.x_m, g.z_m],
                                  offset_transform=ax.transData, cmap="viridis", edgecolor="none", rasterized=True)
        balls.set_array(np.sqrt(g.vx_m_per_s**2 + g.vy_m_per_s**2 + g.vz_m_per_s**2).to_numpy())
        balls.set_clim(0.0, vmax)
        ax.add_collection(balls)
        a = omega_rad_per_s * max(t - start_s, 0.0)  # the drum turns about +y: clockwise in this view
        turned = profile_m @ np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        ax.add_patch(Polygon(turned, closed=True, fill=False, lw=1.0, color="k"))
        for key, mark in (("charge_toe_deg", "v"), ("charge_shoulder_deg", "^")):
            if shape and key in shape:  # Morrell's angles: x mirrored
                angle = np.radians(shape[key])
                ax.plot(-big_r * np.cos(angle), big_r * np.sin(angle), mark, color="tab:red", ms=6)
        ax.set_xlim(-1.05 * big_r, 1.05 * big_r)
        ax.set_ylim(-1.05 * big_r, 1.05 * big_r)
        ax.set_aspect("equal")
        ax.set_axis_off()
        ax.set_title(f"t = {t:.2f} s", fontsize=9)
    fig.colorbar(balls, ax=axes[0].tolist(), label="ball speed (m/s)", shrink=0.8)
    title = "Charge seen along the drum axis"
    if shape and "charge_regime" in shape:
        title += (f": {shape['charge_regime']}, toe {shape['charge_toe_deg']:.0f} deg, "
                  f"shoulder {shape['charge_shoulder_deg']:.0f} deg (red)")
    fig.suptitle(title, fontsize=9)
    return fig


def plot_measured_power(frame: pd.DataFrame):
    """DEM power against the wall's friction, one line per wall restitution, beside each
    measurement and its +-10 % band."""
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    runs = frame.drop_duplicates(["wall restitution", "wall friction"])
    for e, g in runs.groupby("wall restitution"):
        g = g.sort_values("wall friction")
        ax.errorbar(g["wall friction"], g["DEM W"], yerr=2 * g["DEM SE W"], marker="o", capsize=3,
                    label=f"DEM, wall restitution {e:g}")
    for (m, w), style in zip(frame.groupby("measurement")["measured W"].first().items(), ("-", "--", ":", "-.")):
        ax.axhline(w, color="k", ls=style, lw=1, label=f"measured: {m}")
        ax.axhspan(0.9 * w, 1.1 * w, color="0.85", alpha=0.4)
    ax.set_xlabel("ball-wall static friction")
    ax.set_ylabel("mill power (W)")
    ax.set_title(", ".join(frame.experiment.unique()), fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_scaleup_rule(table: pd.DataFrame):
    """Residence time, purchase cost and electricity per tonne of PET against BPR, one line per
    yield rule (`rule` column)."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    panels = [("residence_time_min", "residence time (min)"), ("purchase_cost_usd", "mill purchase cost ($)"),
              ("electricity_usd_per_t_pet", "electricity ($/t PET)")]
    for k, (rule, g) in enumerate(table.sort_values("bpr").groupby("rule", sort=False)):
        for ax, (col, _) in zip(axes, panels):
            ax.plot(g.bpr, g[col], "o-", color=f"C{k}", ms=3, label=rule)
    for ax, (_, label) in zip(axes, panels):
        ax.set_xlabel("ball-to-powder ratio (BPR)")
        ax.set_ylabel(label)
        ax.set_yscale("log")
        ax.grid(True, which="major", lw=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{table.pet_feed_kg_per_h.iloc[0]:.0f} kg/h PET: the mill each yield rule asks for (same yield per BPR)")
    fig.tight_layout()
    return fig


def plot_dissipation_spectra(spectra: pd.DataFrame, thresholds_j=()):
    """Share of the collision dissipation below each impact energy, one curve per `case` (all
    pair types together), with the thresholds E* marked."""
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for case, g in spectra.groupby("case", sort=False):
        g = g.groupby("energy_hi_j", as_index=False)["fraction"].sum()
        ax.plot(g.energy_hi_j, np.cumsum(g.fraction) / max(g.fraction.sum(), 1e-300), lw=1.4, label=str(case))
    for e in thresholds_j:
        ax.axvline(e, color="0.6", lw=0.8, ls="--")
    hit = spectra[spectra["count"] > 0]
    if len(hit):
        ax.set_xlim(hit.energy_lo_j.min(), hit.energy_hi_j.max())
    ax.set_xscale("log")
    ax.set_xlabel("normal impact energy (J)")
    ax.set_ylabel("share of dissipation in collisions below")
    ax.grid(True, which="major", lw=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Where the collision energy goes (dashed: E* of the threshold rules)")
    return fig


def best_per_model(predictions: pd.DataFrame, candidates: pd.DataFrame) -> list[str]:
    """The chosen candidate, then each other model's lowest CV error candidate."""
    ranked = candidates.dropna(subset=["cv_rmse_percent"]).sort_values("cv_rmse_percent")
    chosen = candidates[candidates.chosen].candidate.tolist()
    return chosen + [g.candidate.iloc[0] for m, g in ranked.groupby("model", sort=False)
                     if g.candidate.iloc[0] not in chosen and m != candidates[candidates.chosen].model.iloc[0]]


def plot_parity(predictions: pd.DataFrame, candidates: pd.DataFrame):
    """Observed yield against the fit (left) and against the leave-one-condition-out prediction
    (right): the chosen candidate and each other model's best, error bars the yields' errors."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), sharey=True)
    for k, name in enumerate(best_per_model(predictions, candidates)):
        g = predictions[predictions.candidate == name]
        cv = candidates.set_index("candidate").cv_rmse_percent[name]
        for ax, col in zip(axes, ("fitted_percent", "cv_predicted_percent")):
            ax.errorbar(g[col], g.yield_percent, yerr=g.yield_error_percent, fmt="os^dv"[k % 5], ms=4, capsize=2,
                        color=f"C{k}", label=f"{name} (CV RMSE {cv:.3g} %)", alpha=0.8)
    for ax, label in zip(axes, ("fitted yield (%)", "cross-validated prediction (%)")):
        ax.plot([0, 100], [0, 100], color="0.6", lw=0.8)
        ax.set_xlim(0, 100)
        ax.set_ylim(0, 100)
        ax.set_xlabel(label)
        ax.grid(True, lw=0.3)
    axes[0].set_ylabel("measured yield (%)")
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("Kinetics fit: parity (chosen model first)")
    fig.tight_layout()
    return fig


def plot_residuals(predictions: pd.DataFrame):
    """Measured minus cross-validated yield per experimental condition, with the yields' errors."""
    fig, ax = plt.subplots(figsize=(7, 3.5))
    g = predictions.assign(residual=predictions.yield_percent - predictions.cv_predicted_percent)
    ax.errorbar(g.condition + 0.02 * (g.time_min - g.time_min.mean()) / max(g.time_min.std(), 1.0), g.residual,
                yerr=g.yield_error_percent, fmt="o", ms=4, capsize=2)
    ax.axhline(0, color="0.6", lw=0.8)
    ax.set_xticks(sorted(g.condition.unique()))
    ax.set_xlabel("experimental condition")
    ax.set_ylabel("measured - CV prediction (%)")
    ax.grid(True, lw=0.3)
    ax.set_title(f"Residuals per condition: {g.candidate.iloc[0]}", fontsize=9)
    fig.tight_layout()
    return fig


def plot_yield_time(curves: pd.DataFrame, points: pd.DataFrame | None = None):
    """Yield against (mean residence) time, one line per `series`; the experiments as points."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, (series, g) in enumerate(curves.groupby("series", sort=False)):
        ax.plot(g.time_min, g.yield_percent, color=f"C{k}", lw=1.3, ls="--" if series.startswith("lab") else "-",
                label=series)
    if points is not None:
        ax.errorbar(points.time_min, points.yield_percent, yerr=points.yield_error_percent, fmt="ko", ms=4,
                    capsize=2, label="experiments")
    ax.set_xlabel("milling time, or the mill's mean residence time (min)")
    ax.set_ylabel("TPA yield (%)")
    ax.set_ylim(0, 102)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7)
    ax.set_title("Yield against time: the lab's conditions and the mill")
    fig.tight_layout()
    return fig


MSP_GROUPS = {  # cost categories of the MSP breakdown ($/kg rTPA), as stacked in the figures
    "capital and return": ["msp_capital_usd_per_kg"],
    "PET bales": ["msp_bales_usd_per_kg"],
    "NaOH + H2SO4": ["msp_naoh_usd_per_kg", "msp_sulfuric_acid_usd_per_kg"],
    "steam, power, water": ["msp_steam_usd_per_kg", "msp_electricity_usd_per_kg", "msp_dissolution_water_usd_per_kg",
                            "msp_wash_water_usd_per_kg", "msp_cooling_tower_chemicals_usd_per_kg",
                            "msp_splitting_water_usd_per_kg"],
    "disposal, wastewater": ["msp_sorting_residue_usd_per_kg", "msp_grinding_fines_usd_per_kg",
                             "msp_purged_pet_usd_per_kg", "msp_residue_usd_per_kg", "msp_treated_water_usd_per_kg",
                             "msp_landfilled_salt_usd_per_kg"],
    "labour, maintenance, insurance": ["msp_fixed_operating_usd_per_kg"],
    "co-products": ["msp_eg_usd_per_kg", "msp_na2so4_usd_per_kg", "msp_recovered_naoh_usd_per_kg",
                    "msp_recovered_h2so4_usd_per_kg"],
}
GWP_GROUPS = {  # contributors to the footprint (kg CO2e/kg rTPA)
    "NaOH": ["gwp_naoh_kg_per_kg"],
    "H2SO4, water, bales": ["gwp_sulfuric_acid_kg_per_kg", "gwp_dissolution_water_kg_per_kg", "gwp_wash_water_kg_per_kg",
                            "gwp_cooling_tower_makeup_water_kg_per_kg", "gwp_bales_kg_per_kg",
                            "gwp_splitting_water_kg_per_kg"],
    "steam": ["gwp_steam_kg_per_kg"],
    "electricity": ["gwp_electricity_kg_per_kg"],
    "residues, wastewater, CO2 of burnt carbon": [
        "gwp_sorting_residue_kg_per_kg", "gwp_grinding_fines_kg_per_kg", "gwp_purged_pet_kg_per_kg",
        "gwp_residue_kg_per_kg", "gwp_treated_water_kg_per_kg", "gwp_treatment_co2_kg_per_kg", "gwp_boiler_co2_kg_per_kg",
        "gwp_landfilled_salt_kg_per_kg"],
    "co-product credits": ["gwp_eg_credit_kg_per_kg", "gwp_na2so4_credit_kg_per_kg", "gwp_recovered_naoh_credit_kg_per_kg",
                           "gwp_recovered_h2so4_credit_kg_per_kg"],
}


def stacked(ax, t: pd.DataFrame, groups: dict[str, list[str]], total: str, band: str, unit: str, yardstick: str):
    """One panel: `groups` stacked per case (negative below zero), the total with its 5-95 %
    band, and the virgin product's value as a dashed line."""
    x = np.arange(len(t))
    up, down = np.zeros(len(t)), np.zeros(len(t))
    for k, (name, cols) in enumerate(groups.items()):
        v = t[[c for c in cols if c in t]].sum(axis=1).to_numpy()
        ax.bar(x, v, bottom=np.where(v >= 0, up, down), color=f"C{k}", label=name, width=0.7)
        up, down = up + np.maximum(v, 0), down + np.minimum(v, 0)
    lo, hi = t[band.format(5)], t[band.format(95)]
    ax.vlines(x, lo, hi, colors="k", lw=1.2, label="5-95 % band")  # the base may lie outside its band
    ax.plot(x, t[total], "ko", ms=4, label="base")
    ax.plot(x, t[band.format(50)], "w^", mec="k", ms=5, label="median")
    ax.axhline(t[yardstick].iloc[0], color="0.3", ls="--", lw=1, label="virgin TPA")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylabel(unit)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)


def plot_msp(table: pd.DataFrame, by: str, label: str):
    """Minimum selling price (left) and cradle-to-gate footprint (right) of rTPA per case:
    each broken down, with its Monte Carlo band and median and the virgin TPA's value."""
    t = table.sort_values(by if by != "region" else "plant_fresh_pet_kg_per_h")
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 6))
    stacked(left, t, MSP_GROUPS, "msp_usd_per_kg", "msp_p{}_usd_per_kg", "$ per kg rTPA", "virgin_tpa_usd_per_kg")
    stacked(right, t, GWP_GROUPS, "gwp_total_kg_per_kg", "gwp_p{}_kg_per_kg", "kg CO2e per kg rTPA",
            "virgin_tpa_gwp_kg_per_kg")
    for ax, title in ((left, "Minimum selling price"), (right, "Cradle-to-gate footprint")):
        ax.set_xticks(np.arange(len(t)), [f"{v:g}" if isinstance(v, float) else str(v) for v in t[by]])
        ax.set_xlabel(label)
        ax.set_title(title)
    fig.tight_layout()
    return fig


def plot_options_front(fronts: dict[str, pd.DataFrame], virgin_usd_per_kg: float, virgin_kg_per_kg: float):
    """MSP against footprint of every option combination (options.csv), one panel per case, the
    Pareto front drawn through its points, virgin TPA's price and virgin PTA's footprint as lines."""
    n = len(fronts)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.6 * rows), squeeze=False)
    for ax, (label, t) in zip(axes.flat, fronts.items()):
        front = t[t.on_front].sort_values("gwp_kg_per_kg")
        ax.scatter(t.gwp_kg_per_kg, t.msp_usd_per_kg, s=10, color="0.6", label="option combination")
        ax.plot(front.gwp_kg_per_kg, front.msp_usd_per_kg, "o-", color="C3", ms=4, label="Pareto front")
        ax.axhline(virgin_usd_per_kg, color="k", ls="--", lw=0.8, label="virgin TPA price")
        ax.axvline(virgin_kg_per_kg, color="k", ls=":", lw=0.8, label="virgin PTA footprint")
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("kg CO2e per kg rTPA")
        ax.set_ylabel("MSP ($/kg rTPA)")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=6)
    fig.tight_layout()
    return fig


def plot_regional(states: pd.DataFrame, regional: dict, apart: dict, virgin_usd_per_kg: float,
                  virgin_kg_per_kg: float):
    """Per state (study=regional's states.csv): its own plant's MSP (left) and footprint (right)
    and those of the plant it would share with its nearest larger neighbour, its bales hauled; the
    one plant for all (its best site), the plants apart (rTPA-weighted) and virgin TPA as lines."""
    t = states.sort_values("fresh_pet_kg_per_h")
    x = np.arange(len(t))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for ax, key, unit in ((axes[0], "msp_usd_per_kg", "MSP ($/kg rTPA)"), (axes[1], "gwp_kg_per_kg",
                                                                           "kg CO2e per kg rTPA")):
        ax.bar(x - 0.2, t[f"own_{key}"], 0.4, color="C0", label="its own plant")
        if f"joined_{key}" in t:
            ax.bar(x + 0.2, t[f"joined_{key}"], 0.4, color="C2", label="shared with its nearest larger neighbour")
        ax.axhline(regional[key], color="C3", lw=1.2, label=f"one plant for all, at {regional['site']}")
        ax.axhline(apart[key], color="C1", ls="-.", lw=1, label="a plant each (rTPA-weighted)")
        ax.axhline(virgin_usd_per_kg if key.startswith("msp") else virgin_kg_per_kg, color="k", ls="--", lw=0.8,
                   label="virgin TPA")
        labels = [s if pd.isna(p) else f"{s}\n->{p}" for s, p in zip(t.state, t.get("partner", t.state))]
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_ylabel(unit)
    axes[0].set_yscale("log")
    axes[0].legend(fontsize=7)
    axes[0].set_title("Minimum selling price")
    axes[1].set_title("Cradle-to-gate footprint")
    fig.tight_layout()
    return fig


def plot_tornado(tornado: pd.DataFrame, base_usd_per_kg: float, rows: int = 20):
    """MSP at each input's low and high end, the others at base (the `rows` largest swings,
    largest on top)."""
    t = tornado.head(rows).iloc[::-1]
    fig, ax = plt.subplots(figsize=(7, 0.3 * len(t) + 1.2))
    y = np.arange(len(t))
    ax.barh(y, t.msp_low_usd_per_kg - base_usd_per_kg, left=base_usd_per_kg, color="C0", label="input at low end")
    ax.barh(y, t.msp_high_usd_per_kg - base_usd_per_kg, left=base_usd_per_kg, color="C3", label="input at high end")
    ax.axvline(base_usd_per_kg, color="k", lw=0.8)
    ax.set_yticks(y, t.parameter, fontsize=7)
    ax.set_xlabel("MSP of rTPA ($/kg)")
    ax.legend(fontsize=7)
    ax.set_title("One at a time: how far each input moves the MSP")
    fig.tight_layout()
    return fig


def plot_surrogate_parity(runs: pd.DataFrame, outputs: tuple[str, ...]):
    """Surrogate against DEM, one panel per output, one marker per set (training fit,
    cross-validation, held out); the 10 % band shaded."""
    fig, axes = plt.subplots(1, len(outputs), figsize=(5 * len(outputs), 4.5))
    for ax, name in zip(np.atleast_1d(axes), outputs):
        for (split, part), marker in zip(runs.groupby("split", sort=False), "o^s"):
            ax.errorbar(part[f"{name}_dem"], part[f"{name}_predicted"], xerr=part[f"{name}_dem_se"], fmt=marker,
                        ms=4, alpha=0.7, label=split)
        lo, hi = runs[f"{name}_dem"].min() * 0.9, runs[f"{name}_dem"].max() * 1.1
        line = np.array([lo, hi])
        ax.fill_between(line, 0.9 * line, 1.1 * line, color="0.9", label="10 %")
        ax.plot(line, line, "k-", lw=0.8)
        ax.set(xlabel=f"{name.replace('_', ' ')}, DEM", ylabel="surrogate", xlim=(lo, hi), ylim=(lo, hi))
    np.atleast_1d(axes)[0].legend()
    fig.tight_layout()
    return fig


def plot_cheapest_mill(table: pd.DataFrame):
    """Annualised mill cost per case: the paper's mill against the cheapest (surrogate bars, DEM
    confirmations as markers where they ran)."""
    by = "region" if table["region"].notna().any() else "bpr"
    t = table.sort_values("paper_annualised_cost_usd_per_yr")
    x = np.arange(len(t))
    fig, ax = plt.subplots(figsize=(max(5, 0.8 * len(t) + 2), 4))
    for offset, label in ((-0.2, "paper"), (0.2, "optimum")):
        ax.bar(x + offset, t[f"{label}_annualised_cost_usd_per_yr"] / 1e3, 0.4, label=f"{label} mill (surrogate)")
        if f"{label}_dem_annualised_cost_usd_per_yr" in t:
            ax.plot(x + offset, t[f"{label}_dem_annualised_cost_usd_per_yr"] / 1e3, "k_", ms=14, mew=2)
    ax.plot([], [], "k_", ms=14, mew=2, label="DEM confirmation")
    ax.set_xticks(x, t[by].astype(str))
    ax.set(ylabel="annualised mill cost (k$/yr)", xlabel=by)
    ax.legend()
    fig.tight_layout()
    return fig


# Figures a study's report may name (study.report.figure): each draws one from the sweep's records.
FIGURES = {"fig3b": plot_fig3b, "fig4": plot_fig4, "scaleup_rule": lambda t: plot_scaleup_rule(with_rule_labels(t)),
           "plant_msp": lambda t: plot_msp(t, "bpr", "ball-to-powder ratio (BPR)"),
           "plant_states": lambda t: plot_msp(t, "region", "state (by PET feed)"), "cheapest_mill": plot_cheapest_mill}


def with_rule_labels(table: pd.DataFrame) -> pd.DataFrame:
    """A `rule` column: the yield rule, with E* for the threshold rule."""
    return table.assign(rule=[rule_label(r) for r in table.to_dict("records")])


def rule_label(rec: dict) -> str:
    from . import yield_rules  # the rules' modules import the studies, which import this one

    return yield_rules.rule_of(rec.get("yield_rule", "bpr_line")).label(rec)
