"""study=yield_fit: the kinetics experiments (yield_model.experiments) fitted.  Every distinct
lab condition simulated once in the lab DEM (lab_dose.py, cached), each row's dose per kg of PET
under every measure (all collisions; impacts above each E* of yield_model.fit.thresholds_j), the
candidate models of kinetics.py fitted and cross-validated, one chosen.  The fit is kept under
<cache_dir>/yield_fit/<key>/ (rows.csv, candidates.csv, predictions.csv, fit.json), the key
hashing the table's content and what determines its doses; a design under yield_model=fitted
reads it there, and runs it first when it is missing (once: other jobs wait for it).
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import ConfigError
from ..experiments import Experiments, read_experiments
from ..files import exclusive, read_json, write_atomic, write_json
from ..kinetics import (
    TIME_SPAN,
    FittedCurve,
    candidates_table,
    choose,
    fit_candidates,
    lab_rate_column,
    lab_time_curves,
    measures,
    predict,
    rtd_table,
)
from ..lab_dose import LabCondition, check_conditions, condition_key, condition_rates, simulate_conditions
from ..plots import plot_parity, plot_residuals, plot_yield_time, save_figure
from ..scenario import Scenario
from ..yields import bpr_line_yield
from .mechanics import check_machine
from .plan import Plan

log = logging.getLogger(__name__)
FIT_METHOD = 2  # the fit's method, in its cache key: 2 carries the lab rates' errors and censors yields at 0 and 100 %


def lab_conditions(exps: Experiments) -> list[LabCondition]:
    """The lab DEM conditions of the table's rows, in the order of their dem_condition number."""
    first = exps.rows.drop_duplicates("dem_condition").sort_values("dem_condition")
    return [LabCondition(r.jar_inner_diameter_mm / 1e3, r.jar_inner_length_mm / 1e3, r.jar_material, r.ball_material,
                         r.ball_diameter_mm / 1e3, int(r.ball_count), float(r.frequency_hz))
            for r in first.itertuples()]


def fit_key(s: Scenario, exps: Experiments) -> str:
    payload = {"method": FIT_METHOD, "experiments": exps.digest, "lab": [condition_key(c, s) for c in lab_conditions(exps)],
               "fit": asdict(s.yield_model.fit), "batches": s.yield_model.dose_batches}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def fit_folder(s: Scenario, exps: Experiments) -> Path:
    return s.cache_dir / "yield_fit" / fit_key(s, exps)


def checked_experiments(s: Scenario) -> Experiments:
    """The experiments table and its lab conditions, checked (planning: nothing simulated)."""
    exps = read_experiments(s.yield_model.experiments, s.materials)
    check_conditions(lab_conditions(exps), s)
    return exps


def doses(s: Scenario, exps: Experiments, folders: list[Path]) -> pd.DataFrame:
    """The table's rows with each lab condition's dose rates per kg of balls and each row's dose per
    kg of PET (kJ/kg) under every measure."""
    cfg = s.yield_model
    rows = exps.rows.copy()
    per_pet = {}
    for m in measures(cfg.fit.thresholds_j):
        rates = [condition_rates(f, m.threshold_j or cfg.fit.thresholds_j[0], cfg.dose_batches) for f in folders]
        rate = np.array([r[m.rate] for r in rates])[rows.dem_condition]
        se = np.array([r[f"{m.rate}_se"] for r in rates])[rows.dem_condition]
        balls_kg = np.array([r["ball_mass_kg"] for r in rates])[rows.dem_condition]
        per_pet[lab_rate_column(m.threshold_j)] = rate
        per_pet[lab_rate_column(m.threshold_j, se=True)] = se
        per_pet[m.column] = rate * balls_kg / (rows.pet_mass_g.to_numpy() / 1e3) * rows.time_min.to_numpy() * 60 / 1e3
    for name in ("collision_log_share", "largest_impact_j"):  # the same under every measure
        per_pet[name] = np.array([r[name] for r in rates])[rows.dem_condition]
    return rows.assign(**per_pet, lab_dem_dir=[str(folders[i]) for i in rows.dem_condition])


def run_fit(s: Scenario, exps: Experiments) -> Path:
    """The lab DEM of the table's conditions (those missing), the doses, every candidate fitted
    and cross-validated, the choice; the fit's folder (the fit computed once)."""
    folder = fit_folder(s, exps)
    with exclusive(folder / ".lock"):
        if read_json(folder / "fit.json") is None:
            log.info("no fit of %s yet: fitting it into %s", exps.path, folder)
            started = time.perf_counter()
            rows = doses(s, exps, simulate_conditions(lab_conditions(exps), s))
            fit = s.yield_model.fit
            candidates = fit_candidates(rows, fit.models, fit.thresholds_j, fit.confidence)
            chosen = choose(candidates)
            table = candidates_table(candidates, chosen)
            predictions = pd.concat([rows[["experiment", "condition", "time_min", "yield_percent",
                                           "yield_error_percent", "bpr"]].assign(
                candidate=c.name, dose_kj_per_kg_pet=np.nan if c.measure is None else rows[c.measure.column],
                fitted_percent=predict(c.model, c.fit.params, rows[c.measure.column] if c.measure else None, rows.bpr),
                cv_predicted_percent=c.cv_predicted) for c in candidates if c.fit is not None], ignore_index=True)
            for name, frame in (("rows", rows), ("candidates", table), ("predictions", predictions)):
                write_atomic(folder / f"{name}.csv", lambda tmp, f=frame: f.to_csv(tmp, index=False))
            threshold = None if chosen.measure is None else chosen.measure.threshold_j
            runs = rows.drop_duplicates("dem_condition").sort_values("dem_condition")
            rate, se = runs[lab_rate_column(threshold)], runs[lab_rate_column(threshold, se=True)]
            write_json(folder / "fit.json", {
                "key": folder.name, "experiments": str(exps.path), "experiments_digest": exps.digest,
                "model": chosen.model, "rate": None if chosen.measure is None else chosen.measure.rate,
                "threshold_j": None if chosen.measure is None else chosen.measure.threshold_j,
                "params": chosen.fit.params, "cov": chosen.fit.cov, "cv_rmse_percent": chosen.cv_rmse_percent,
                "lab_rate_rel_se": [float(e / r) if r > 0 else None for r, e in zip(rate, se)],
                "lab_shifts": chosen.fit.shifts,
                "time_min": float(rows.time_min.iloc[0]) if rows.time_min.nunique() == 1 else None,
                "within_one_se": int(table.within_one_se.sum()), "fit": asdict(fit)})
            log.info("fit done in %.0f s: %s", time.perf_counter() - started, chosen.name)
    return folder


def fitted_curve(s: Scenario, exps: Experiments) -> FittedCurve:
    """The chosen model of the table's fit (fitted first when missing)."""
    return FittedCurve.read(run_fit(s, exps))


def is_fitted(s: Scenario, exps: Experiments) -> bool:
    return read_json(fit_folder(s, exps) / "fit.json") is not None


def target_percent(s: Scenario) -> float:
    """The yield a design under a dose rule is solved for: yield_model.target_yield_percent, else
    the BPR line's at scaleup.bpr."""
    return s.yield_model.target_yield_percent or bpr_line_yield(s.scaleup.bpr, s.yield_model)[0]


def plan_yield_fit(s: Scenario) -> Plan:
    """The experiments table checked, the lab conditions' numerics checked; the fit (run first when
    missing), its tables and figures: parity, residuals per condition, yield against time, and
    what each RTD costs against plug flow at the target."""
    exps = checked_experiments(s)
    target = target_percent(s)

    def execute(out_dir: Path) -> dict:
        check_machine(s.sim)
        folder = run_fit(s, exps)
        curve = FittedCurve.read(folder)
        rows, predictions = (pd.read_csv(folder / f"{n}.csv") for n in ("rows", "predictions"))
        candidates = pd.read_csv(folder / "candidates.csv")
        chosen = candidates[candidates.chosen].iloc[0]
        mine = predictions[predictions.candidate == chosen.candidate]
        save_figure(plot_parity(predictions, candidates), out_dir / "yield_fit_parity")
        save_figure(plot_residuals(mine), out_dir / "yield_fit_residuals")
        skipped = []
        if not curve.time_free:
            curves = lab_time_curves(curve, rows, TIME_SPAN * rows.time_min.max())
            save_figure(plot_yield_time(curves, rows), out_dir / "yield_fit_time")
            try:
                rtd_table(curve, target, s.yield_model.rtd).to_csv(out_dir / "yield_fit_rtd.csv", index=False)
            except ConfigError as exc:  # a flat or falling fit: no dose reaches the target
                skipped.append(f"yield_fit_rtd.csv (what each RTD costs at the target): {exc}")
                log.warning("yield_fit: skipped %s", skipped[-1])
        return curve.as_record() | {"fit_candidate": chosen.candidate,
                                    "fit_candidates_within_one_se": int(candidates.within_one_se.sum()),
                                    "target_yield_percent": target, "fit_skipped": "; ".join(skipped)}

    return Plan({"experiments": str(exps.path), "experiments_digest": exps.digest, "experiments_rows": len(exps.rows),
                 "experiments_conditions": int(exps.rows.condition.nunique()),
                 "lab_conditions": int(exps.rows.dem_condition.nunique()), "fit_key": fit_key(s, exps)}, execute)
