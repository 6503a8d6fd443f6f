"""The surrogate against the DEM on any finished sweep: each job's mill (from its record and
resolved config) predicted by the surrogate, beside the power and collision power its DEM gave."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from ..config import DrumConfig, material_tables, to_object
from ..scaleup import MillDesign
from .model import Surrogate, predict_drum


def job_prediction(rec: dict, model: Surrogate) -> dict:
    """The surrogate's power and collision power for a job's final mill (the DEM's beside them)."""
    from ..studies import mill_drum

    resolved = OmegaConf.load(Path(rec["job_dir"]) / "config_resolved.yaml")
    mill = to_object(resolved.mill, DrumConfig, "mill")  # fields added since the sweep ran: their defaults
    materials, interactions = material_tables(resolved)
    design = MillDesign.from_record(rec)
    p = predict_drum(model, mill_drum(mill, design), materials, interactions, extrapolate=True)
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
    """One row per finished job of the sweep whose power came from the DEM (a design's mill: a
    lab or calibration study has none)."""
    from ..report import collect

    jobs = collect(sweep_dir)

    def column(name: str, missing) -> pd.Series:
        return jobs.get(name, pd.Series(missing, index=jobs.index))

    jobs = jobs[(jobs.status == "ok") & (column("dem_source", "full").fillna("full") == "full")
                & column("dem_power_w", np.nan).notna() & column("pet_feed_kg_per_h", np.nan).notna()]
    return pd.DataFrame([job_prediction(rec, model) for rec in jobs.to_dict("records")])

