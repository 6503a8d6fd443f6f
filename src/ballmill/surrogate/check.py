"""The surrogate against the DEM on any finished sweep: each job's mill (from its record and
resolved config) predicted by the surrogate, beside the power and collision power its DEM gave."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from ..scaleup import MillDesign
from ..scenario import compose, load
from .model import Surrogate, predict_drum


def job_prediction(rec: dict, model: Surrogate) -> dict:
    """The surrogate's power and collision power for a job's final mill (the DEM's beside them)."""
    from ..studies import mill_drum

    resolved = OmegaConf.load(Path(rec["job_dir"]) / "config_resolved.yaml")
    s = load(OmegaConf.merge(compose("config", []), resolved))  # groups added since the sweep ran: defaults
    design = MillDesign(**{f.name: rec[f.name] for f in fields(MillDesign)})
    p = predict_drum(model, mill_drum(s, design), s.materials, s.interactions, extrapolate=True)
    collision_dem = rec.get("collision_power_w_per_kg_pet", np.nan) * design.pet_feed_kg_per_h \
        * design.residence_time_min / 60
    return {"job": Path(rec["job_dir"]).name, "balls": p["balls"], "fraction_of_critical": p["fraction_of_critical"],
            "diameter_to_ball": p["diameter_to_ball"], "inside_hull": p["inside_hull"],
            "dem_power_w": rec["dem_power_w"], "dem_power_se_w": rec.get("dem_power_se_w", np.nan),
            "surrogate_power_w": p["power_w"], "surrogate_power_se_w": p["power_se_w"],
            "power_error": p["power_w"] / rec["dem_power_w"] - 1,
            "dem_collision_power_w": collision_dem, "surrogate_collision_power_w": p["collision_power_w"],
            "collision_power_error": p["collision_power_w"] / collision_dem - 1}


def compare_sweep(sweep_dir: Path, model: Surrogate) -> pd.DataFrame:
    """One row per finished job of the sweep whose power came from the DEM."""
    from ..report import collect

    jobs = collect(sweep_dir)
    jobs = jobs[(jobs.status == "ok") & (jobs.get("dem_source", pd.Series("full", index=jobs.index))
                                         .fillna("full") == "full")]
    return pd.DataFrame([job_prediction(rec, model) for rec in jobs.to_dict("records")])

