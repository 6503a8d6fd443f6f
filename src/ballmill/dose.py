"""The impact-energy dose that milling gives the powder, from a DEM run's collision log.

Per kg of PET held up in the mill (or any other mass: the caller says which):
- the specific collision power: energy dissipated in collisions per second (W/kg), and the
  frequency of collisions (1/(s kg));
- the same counting only collisions whose normal impact energy (1/2 m* v_n^2 at first touch)
  is at least a threshold E* (J).
A collision counts in the window when it starts there and has ended: the log books a contact's
whole loss at its start, and one still open when the run ends is not in it.  That bias is
measured, not corrected: given the run's energy book, `collision_log_share` is the dissipation
the log books in the window over the dissipation the engine's energy balance counts there
(1: none missing).  Standard errors are those of the window's batch means: the window is cut
into `batches` equal parts and the spread of their rates gives the error.
The dose of a run is a dose rate times the milling (residence) time.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

MEASURES = ("collision_power_w_per_kg", "collision_frequency_per_s_per_kg", "impact_power_w_per_kg",
            "impact_frequency_per_s_per_kg")


def above_threshold(measure: str) -> bool:
    """Whether a measure counts only the impacts of at least E* (its spectrum's, not the power's)."""
    return measure.startswith("impact_")


def dose_rates(collisions: pd.DataFrame, after_s: float, until_s: float, mass_kg: float, threshold_j: float,
               batches: int = 10, energy: pd.DataFrame | None = None) -> dict:
    """Dose rates per kg of `mass_kg` over collisions starting in (after_s, until_s], each with
    its standard error (`<measure>_se`), the threshold used and, given the run's energy table,
    the share of the window's dissipation the log books."""
    window = until_s - after_s
    if window <= 0 or mass_kg <= 0:
        raise ValueError(f"dose: empty window ({after_s:g} s to {until_s:g} s) or mass {mass_kg:g} kg")
    c = collisions[(collisions.t_start_s > after_s) & (collisions.t_start_s <= until_s)]
    strong = (c.impact_energy_j >= threshold_j).to_numpy()
    part = np.minimum(((c.t_start_s.to_numpy() - after_s) / window * batches).astype(int), batches - 1)
    per_batch = window / batches * mass_kg  # s kg of one batch

    def rate(weights: np.ndarray) -> tuple[float, float]:
        sums = np.bincount(part, weights=weights, minlength=batches) / per_batch
        return float(weights.sum() / (window * mass_kg)), float(sums.std(ddof=1) / np.sqrt(batches))

    dissipated = c.dissipated_j.to_numpy(dtype=float)
    values = {
        "collision_power_w_per_kg": rate(dissipated),
        "collision_frequency_per_s_per_kg": rate(np.ones(len(c))),
        "impact_power_w_per_kg": rate(np.where(strong, dissipated, 0.0)),
        "impact_frequency_per_s_per_kg": rate(strong.astype(float)),
    }
    out = {"impact_threshold_j": threshold_j, "largest_impact_j": float(c.impact_energy_j.max()) if len(c) else 0.0}
    for name, (value, se) in values.items():
        out[name], out[f"{name}_se"] = value, se
    if energy is not None:
        out["collision_log_share"] = float(dissipated.sum()) / booked_j(energy, after_s, until_s)
    return out


def booked_j(energy: pd.DataFrame, after_s: float, until_s: float) -> float:
    """Energy dissipated (normal, tangential, rolling; all replicas) between the samples nearest
    after_s and until_s, from the energy table's cumulative book (J)."""
    lost = energy.groupby("t_s")[["dissipated_normal_j", "dissipated_tangential_j", "dissipated_rolling_j"]].sum()
    total = lost.sum(axis=1)
    times = total.index.to_numpy()
    return float(total.iloc[abs(times - until_s).argmin()] - total.iloc[abs(times - after_s).argmin()])


def dose_j_per_kg(rate_w_per_kg: float, minutes: float) -> float:
    """The dose (J/kg) of milling `minutes` at a dose rate (W/kg)."""
    return rate_w_per_kg * 60.0 * minutes


def with_basis(rates: dict, basis: str) -> dict:
    """Rename per-kg measures to say per kg of what (e.g. 'pet': collision_power_w_per_kg_pet)."""
    return {(k.replace("_per_kg", f"_per_kg_{basis}") if k.startswith(MEASURES) else k): v for k, v in rates.items()}
