"""The surrogate: one Gaussian process per output, fitted to the training table's DEM runs.

Why a Gaussian process (scikit-learn's GaussianProcessRegressor): the training set is tens of
expensive, noisy runs of smooth responses; a GP interpolates them with a predictive standard
deviation for every answer, takes each run's own standard error as its noise (alpha), and is
smooth, so an optimiser can follow it.  Gradient boosting would need far more runs, is
piecewise constant and gives no uncertainty of its own.  Each output is modelled as the log of
the dimensionless number (positive; errors relative), inputs scaled to the training box;
kernel: constant x anisotropic Matern 5/2 + a white-noise term for scatter the standard errors
miss.  Predictions outside the hull of the training inputs are refused unless asked for.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import ConfigError
from ..data import DATA_DIR
from .space import INPUTS, OUTPUTS

# what a refused design can do instead (config.DemConfig)
WAY_OUT = "use dem=full, dem.outside=full (the DEM for the designs outside only), or dem.allow_extrapolation=true"

RESTARTS = 4  # optimiser restarts of the kernel's hyperparameters


@dataclass
class Surrogate:
    """GPs of log(output) over the unit-scaled training box, with the hull of the training inputs."""

    lo: np.ndarray
    hi: np.ndarray
    points: np.ndarray  # training inputs, unit-scaled
    gps: dict  # output -> (GaussianProcessRegressor, mean of log y, std of log y)
    hull: object  # scipy.spatial.Delaunay of the training inputs

    @classmethod
    def fit(cls, table: pd.DataFrame, seed: int = 0) -> Surrogate:
        from scipy.spatial import Delaunay
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        runs = table[table.status == "ok"]
        x = runs[list(INPUTS)].to_numpy(float)
        lo, hi = x.min(axis=0), x.max(axis=0)
        u = (x - lo) / (hi - lo)
        gps = {}
        for name in OUTPUTS:
            y = np.log(runs[name].to_numpy(float))
            rel_se = runs[f"{name}_se"].to_numpy(float) / runs[name].to_numpy(float)
            mean, std = y.mean(), y.std()
            kernel = (ConstantKernel(1.0, (1e-2, 1e2)) * Matern(np.ones(len(INPUTS)), (1e-2, 1e2), nu=2.5)
                      + WhiteKernel(1e-3, (1e-8, 1.0)))
            gp = GaussianProcessRegressor(kernel, alpha=(rel_se / std) ** 2, n_restarts_optimizer=RESTARTS,
                                          random_state=seed)
            with warnings.catch_warnings():  # an input without effect runs its length scale to the bound: fine
                warnings.simplefilter("ignore", ConvergenceWarning)
                gps[name] = (gp.fit(u, (y - mean) / std), mean, std)
        return cls(lo, hi, u, gps, Delaunay(u))

    def check(self, x: np.ndarray) -> None:
        """Refuse (ConfigError naming the input) points outside the hull of the training inputs."""
        u = (np.atleast_2d(x) - self.lo) / (self.hi - self.lo)
        for row, ui in zip(np.atleast_2d(x), u):
            for name, value, v, lo, hi in zip(INPUTS, row, ui, self.lo, self.hi):
                if not 0.0 <= v <= 1.0:
                    raise ConfigError(f"dem=surrogate: {name}={value:.4g} is outside the training runs' range "
                                      f"[{lo:.4g}, {hi:.4g}]; {WAY_OUT}")
            if self.hull.find_simplex(ui) < 0:
                name = INPUTS[int(np.argmax(np.abs(ui - 0.5)))]
                raise ConfigError(f"dem=surrogate: the design lies outside the hull of the training runs (each input "
                                  f"within its range, but {name}={row[INPUTS.index(name)]:.4g} with the others is "
                                  f"a corner they do not cover); {WAY_OUT}")

    def predict(self, x: np.ndarray, extrapolate: bool = False) -> pd.DataFrame:
        """Each output and its standard error (`<output>_se`) at points x (rows in INPUTS order)."""
        x = np.atleast_2d(np.asarray(x, float))
        if not extrapolate:
            self.check(x)
        u = (x - self.lo) / (self.hi - self.lo)
        out = {}
        for name, (gp, mean, std) in self.gps.items():
            mu, sd = gp.predict(u, return_std=True)
            value = np.exp(mu * std + mean)
            out[name], out[f"{name}_se"] = value, value * sd * std
        return pd.DataFrame(out)

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Which points (rows) lie inside the hull of the training inputs."""
        return self.hull.find_simplex((np.atleast_2d(x) - self.lo) / (self.hi - self.lo)) >= 0


def table_path(name: str) -> Path:
    """A training table: a data/ table by name, else a path."""
    path = DATA_DIR / name
    return path if path.is_file() else Path(name)


@cache
def _load(path: str, mtime: float) -> Surrogate:
    return Surrogate.fit(pd.read_csv(path).query("split == 'train'"))


def load(name: str) -> Surrogate:
    """The surrogate fitted to a training table (fitted once per process and file version)."""
    path = table_path(name)
    if not path.is_file():
        raise ConfigError(f"dem.table={name}: no such data/ table or file; make one with `ballmill surrogate`")
    return _load(str(path.resolve()), path.stat().st_mtime)


def relative_errors(table: pd.DataFrame, predicted: pd.DataFrame) -> pd.DataFrame:
    """|predicted / DEM - 1| per run and output, and the error in DEM standard errors."""
    out = table[["point", "split"]].reset_index(drop=True).copy()
    for name in OUTPUTS:
        dem = table[name].to_numpy(float)
        out[f"{name}_dem"], out[f"{name}_dem_se"] = dem, table[f"{name}_se"].to_numpy(float)
        out[f"{name}_predicted"] = predicted[name].to_numpy()
        out[f"{name}_error"] = np.abs(predicted[name].to_numpy() / dem - 1)
        out[f"{name}_in_se"] = np.abs(predicted[name].to_numpy() - dem) / table[f"{name}_se"].to_numpy(float)
    return out


def cross_validation(table: pd.DataFrame, folds: int, seed: int = 0) -> pd.DataFrame:
    """k-fold errors over the training runs (each predicted by a surrogate fitted without its fold;
    points a fold's model cannot reach inside its hull are predicted by extrapolation, and marked)."""
    from sklearn.model_selection import KFold

    train = table[(table.split == "train") & (table.status == "ok")].reset_index(drop=True)
    parts = []
    for fit_rows, test_rows in KFold(folds, shuffle=True, random_state=seed).split(train):
        model = Surrogate.fit(train.iloc[fit_rows], seed)
        test = train.iloc[test_rows]
        x = test[list(INPUTS)].to_numpy(float)
        parts.append(relative_errors(test, model.predict(x, extrapolate=True)).assign(
            inside_hull=model.inside(x)))
    return pd.concat(parts, ignore_index=True).assign(split="cross-validation")


def error_table(table: pd.DataFrame, folds: int, seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-run errors (training fit, k-fold, held-out) and their summary: median and 90th
    percentile of the relative error per output, and the share of runs within one and two DEM
    standard errors."""
    ok = table[table.status == "ok"]
    model = Surrogate.fit(ok[ok.split == "train"], seed)
    runs = [relative_errors(ok[ok.split == s], model.predict(ok[ok.split == s][list(INPUTS)].to_numpy(float),
                                                             extrapolate=True)).assign(split=label)
            for s, label in (("train", "training fit"), ("holdout", "held out")) if (ok.split == s).any()]
    runs = pd.concat([*runs, cross_validation(table, folds, seed)], ignore_index=True)
    rows = []
    for (split, name) in ((sp, o) for sp in ("training fit", "cross-validation", "held out") for o in OUTPUTS):
        part = runs[runs.split == split]
        if part.empty:
            continue
        err, in_se = part[f"{name}_error"], part[f"{name}_in_se"]
        rows.append({"set": split, "output": name, "runs": len(part), "median_error": err.median(),
                     "p90_error": err.quantile(0.9), "within_1_se": (in_se <= 1).mean(),
                     "within_2_se": (in_se <= 2).mean()})
    return runs, pd.DataFrame(rows)


def describe(summary: pd.DataFrame) -> str:
    """The error summary as a Markdown table (percentages)."""
    lines = ["| set | output | runs | median error | 90th percentile | within 1 SE | within 2 SE |",
             "|---|---|---|---|---|---|---|"]
    for r in summary.itertuples():
        lines.append(f"| {r.set} | {r.output} | {r.runs} | {100 * r.median_error:.1f} % | {100 * r.p90_error:.1f} % | "
                     f"{100 * r.within_1_se:.0f} % | {100 * r.within_2_se:.0f} % |")
    return "\n".join(lines)


def predict_drum(model: Surrogate, drum, materials, interactions, extrapolate: bool = False) -> dict:
    """A drum's shaft power and collision power (W) with standard errors, from the surrogate."""
    from ..drum import ball_count, drum_speed_rpm
    from .space import groups, power_scale_w

    if drum.liner.kind != "smooth" or drum.charge:
        raise ConfigError(f"dem=surrogate knows smooth drums with balls of one size, not mill.liner.kind="
                          f"{drum.liner.kind}{' or a graded mill.charge' if drum.charge else ''}: use dem=full")
    x = groups(drum, interactions)
    p = model.predict(np.array([[x[k] for k in INPUTS]]), extrapolate).iloc[0]
    n = ball_count(drum)
    mass = n * materials[drum.ball_material].density_kg_per_m3 * 4 / 3 * np.pi * drum.ball_radius_m**3
    scale = power_scale_w(mass, drum.inner_diameter_m, drum_speed_rpm(drum))
    return {"balls": n, "ball_mass_kg": mass, **x, "power_w": p.power_number * scale,
            "power_se_w": p.power_number_se * scale, "collision_power_w": p.collision_power_number * scale,
            "collision_power_se_w": p.collision_power_number_se * scale,
            "inside_hull": bool(model.inside(np.array([[x[k] for k in INPUTS]]))[0])}
