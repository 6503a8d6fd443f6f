"""Yield models of mechanochemical kinetics: yield against the collision dose per kg of PET (and
so against time, the dose being a dose rate x the milling time), their fit to kinetics
experiments, the choice between them, and the continuous mill's residence-time distribution.
Numbers in, numbers out: the experiments' doses come from the lab DEM (lab_dose.py), the study
that runs it is studies/yield_fit.py.

Models (Y in %, D the dose in kJ per kg of PET):
  dose_linear: Y = a + b D, capped to [0, 100] (the linear correlation of yield with DEM energy
               that Anglou et al. 2024 propose; linear in time at a fixed dose rate);
  saturating:  Y = Ymax (1 - exp(-k max(0, D - D0))), first order in the dose after an
               induction dose D0 (Ymax <= 100);
  bpr_line:    Y = s BPR + c, capped (the seed's line: it knows no time, so only where every
               experiment has one milling time).
Fits are weighted least squares (scipy.optimize.least_squares), each row weighted by 1 / its
yield error squared, the errors taken as known (absolute): the parameters' covariance is
(J^T J)^-1 of the weighted residuals, their intervals normal.  A model is chosen, with its dose
measure, by leave-one-condition-out cross-validation: each condition's rows predicted by the
fit to the others; the candidates within one standard error of the lowest CV error, the one with
the fewest parameters, then the first listed of those whose AIC (chi^2 + 2 k) is within 2 of
the lowest (Hastie, Tibshirani & Friedman, The Elements of Statistical Learning, 2nd ed., 7.10:
the one-standard-error rule; Burnham & Anderson, Model Selection and Multimodel Inference, 2nd
ed., 2002, 2.6: AICs closer than 2 are no evidence either way).

Residence-time distributions, in theta = t / mean residence time: plug (every particle stays the
mean time), tanks_in_series (Gamma with shape n, mean 1; n -> infinity is plug flow) and
axial_dispersion (inverse Gaussian with mean 1 and variance 2 / Pe, the first-passage form
Phi(t) = L / sqrt(4 pi E t^3) exp(-(L - u t)^2 / (4 E t)) of Nomura 2012, Powder Technol.
222:37).  Each depends on t / tau alone, so a mill's mean yield depends on its mean dose
(rate x tau) alone: an RTD turns a target yield into a target mean dose.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd
from scipy import integrate, optimize, stats

from .config import ConfigError, RtdConfig

PARAMS = {"dose_linear": ("a_percent", "b_percent_per_kj_per_kg"),
          "saturating": ("ymax_percent", "k_per_kj_per_kg", "d0_kj_per_kg"),
          "bpr_line": ("slope_percent", "intercept_percent")}
TIME_FREE = ("bpr_line",)  # models that know no milling time
SINGULAR = 1e-10  # smallest singular value of the weighted Jacobian, relative to its largest, of an identified fit
TIE = 1e-3  # CV errors closer than this (percentage points: rounding, not evidence) are equal
AIC_TIE = 2.0  # AICs closer than this are equal (Burnham & Anderson 2002)
TAIL = 1e-12  # the RTD's probability left out below when it is averaged over
TAIL_STDS = 60.0  # and above this many standard deviations past its mean
TIME_SPAN = 1.5  # the yield-against-time curves run to this multiple of the longest time shown


def predict(model: str, params: Sequence[float], dose_kj: np.ndarray, bpr: np.ndarray | None = None) -> np.ndarray:
    """Y (%) of a model at doses (kJ/kg PET), or BPRs for bpr_line."""
    if model == "dose_linear":
        a, b = params
        return np.clip(a + b * np.asarray(dose_kj, float), 0.0, 100.0)
    if model == "saturating":
        ymax, k, d0 = params
        return ymax * -np.expm1(-k * np.maximum(0.0, np.asarray(dose_kj, float) - d0))
    s, c = params
    return np.clip(s * np.asarray(bpr, float) + c, 0.0, 100.0)


def inverse_dose_kj(model: str, params: Sequence[float], target_percent: float) -> float:
    """The dose (kJ/kg PET) that gives a yield in plug flow; a ConfigError when none does."""
    if model == "dose_linear":
        a, b = params
        if not b > 0 or target_percent <= a:
            raise ConfigError(f"yield_model.target_yield_percent={target_percent} is not reached by a growing dose "
                              f"under Y = {a:.4g} + {b:.4g} D: any dose gives it, or none")
        return (target_percent - a) / b
    if model == "saturating":
        ymax, k, d0 = params
        if not target_percent < ymax or not k > 0:
            raise ConfigError(f"yield_model.target_yield_percent={target_percent} is not below the fitted Ymax "
                              f"{ymax:.4g} % (k = {k:.3g} per kJ/kg): no dose reaches it; lower the target")
        return d0 - math.log1p(-target_percent / ymax) / k
    raise ConfigError("the BPR line knows no dose: its yield follows the BPR alone")


@dataclass(frozen=True)
class Fit:
    """A model fitted to rows: parameters, their covariance (inf where not identified), chi^2."""

    model: str
    params: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    chi2: float
    rows: int

    @property
    def se(self) -> np.ndarray:
        return np.sqrt(np.diag(np.asarray(self.cov)))

    @property
    def identified(self) -> bool:
        return bool(np.all(np.isfinite(self.se)))

    @property
    def aic(self) -> float:
        return self.chi2 + 2 * len(self.params)


def starts(model: str, x: np.ndarray, y: np.ndarray) -> list[list[float]]:
    """Starting points of the search: a straight line through the data, and for the saturating
    model a grid of plateaus, rate constants and induction doses."""
    slope, intercept = np.polyfit(x, y, 1) if np.ptp(x) > 0 else (0.0, float(np.mean(y)))
    if model != "saturating":
        return [[intercept, slope] if model == "dose_linear" else [slope, intercept]]
    top = float(np.clip(1.05 * y.max(), 1.0, 100.0))
    scale = float(np.median(x[x > 0])) if np.any(x > 0) else 1.0
    return [[ymax, k / scale, d0] for ymax in (top, 100.0) for k in (0.3, 1.0, 3.0)
            for d0 in (0.0, 0.5 * float(x.min()))]


BOUNDS = {"dose_linear": ([-np.inf, -np.inf], [np.inf, np.inf]),
          "saturating": ([1e-9, 0.0, 0.0], [100.0, np.inf, np.inf]),
          "bpr_line": ([-np.inf, -np.inf], [np.inf, np.inf])}


def fit_model(model: str, x: np.ndarray, y: np.ndarray, sigma: np.ndarray) -> Fit:
    """Weighted least squares of a model on (x, y) with known errors sigma; x is the dose (kJ/kg
    PET), or the BPR for bpr_line."""
    x, y, sigma = (np.asarray(v, float) for v in (x, y, sigma))

    def residuals(p):
        return (predict(model, p, x, x) - y) / sigma

    best = None
    for p0 in starts(model, x, y):
        lo, hi = BOUNDS[model]
        p0 = np.clip(p0, np.asarray(lo) + 1e-12, hi)
        res = optimize.least_squares(residuals, p0, bounds=(lo, hi), x_scale="jac", method="trf")
        if best is None or res.cost < best.cost:
            best = res
    jac = best.jac
    sv = np.linalg.svd(jac, compute_uv=False)
    if len(sv) < len(best.x) or sv[-1] <= SINGULAR * sv[0]:
        cov = np.full((len(best.x), len(best.x)), np.inf)
    else:
        cov = np.linalg.inv(jac.T @ jac)
    return Fit(model, tuple(map(float, best.x)), tuple(map(tuple, cov)), float(2 * best.cost), len(y))


def distinct(x: np.ndarray) -> int:
    return len(np.unique(np.round(np.asarray(x, float), 12)))


def cross_validate(model: str, x: np.ndarray, y: np.ndarray, sigma: np.ndarray,
                   groups: np.ndarray) -> tuple[np.ndarray, str]:
    """Leave-one-condition-out predictions of every row (nan throughout, with the reason, where a
    training set has fewer distinct x than the model has parameters)."""
    predicted = np.full(len(y), np.nan)
    for g in np.unique(groups):
        out = groups == g
        if distinct(x[~out]) < len(PARAMS[model]):
            return np.full(len(y), np.nan), (f"leaving condition {g} out leaves {distinct(x[~out])} distinct doses for "
                                             f"{len(PARAMS[model])} parameters")
        fit = fit_model(model, x[~out], y[~out], sigma[~out])
        predicted[out] = predict(model, fit.params, x[out], x[out])
    return predicted, ""


@dataclass(frozen=True)
class Measure:
    """A dose measure: the dose.py rate it uses, and its threshold E* (None: all collisions)."""

    rate: str
    threshold_j: float | None

    @property
    def label(self) -> str:
        return "all collisions" if self.threshold_j is None else f"impacts >= {1e3 * self.threshold_j:g} mJ"

    @property
    def column(self) -> str:
        """The experiments' dose column of this measure."""
        return f"dose_{stem(self.threshold_j)}_kj_per_kg_pet"


def stem(threshold_j: float | None) -> str:
    """A measure's name in column names: all (collisions), or its E* (0.01j)."""
    return "all" if threshold_j is None else f"{threshold_j:g}j"


def lab_rate_column(threshold_j: float | None, se: bool = False) -> str:
    """The experiments' column of a measure's lab dose rate per kg of balls (or its standard error)."""
    return f"lab_rate_{stem(threshold_j)}{'_se' if se else ''}_w_per_kg_balls"


def measures(thresholds_j: Sequence[float]) -> list[Measure]:
    return [Measure("collision_power_w_per_kg", None),
            *(Measure("impact_power_w_per_kg", float(e)) for e in thresholds_j)]


@dataclass
class Candidate:
    """One model on one dose measure: its fit to every row, its CV predictions and errors."""

    model: str
    measure: Measure | None  # None for bpr_line
    fit: Fit | None = None
    cv_predicted: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cv_rmse_percent: float = math.nan
    cv_rmse_se_percent: float = math.nan
    note: str = ""

    @property
    def name(self) -> str:
        return self.model if self.measure is None else f"{self.model}, {self.measure.label}"


def fit_candidates(rows: pd.DataFrame, models: Sequence[str], thresholds_j: Sequence[float]) -> list[Candidate]:
    """Every model on every dose measure (the BPR line on the BPR, where the rows share one milling
    time), fitted to all rows and cross-validated by condition.  `rows` holds yield_percent,
    yield_error_percent, condition, bpr, time_min and the dose columns of the measures."""
    y, sigma, groups = (rows[c].to_numpy(float) for c in ("yield_percent", "yield_error_percent", "condition"))
    out = []
    for model in models:
        if model in TIME_FREE:
            out.append(Candidate(model, None))
        else:
            out += [Candidate(model, m) for m in measures(thresholds_j)]
    for c in out:
        if c.model in TIME_FREE and rows.time_min.nunique() > 1:
            c.note = "not applicable: the experiments have several milling times and the BPR line knows none"
            continue
        x = rows.bpr.to_numpy(float) if c.measure is None else rows[c.measure.column].to_numpy(float)
        if distinct(x) < len(PARAMS[c.model]):
            c.note = f"not identifiable: {distinct(x)} distinct doses for {len(PARAMS[c.model])} parameters"
            continue
        c.fit = fit_model(c.model, x, y, sigma)
        c.cv_predicted, c.note = cross_validate(c.model, x, y, sigma, groups)
        if not c.note:
            squared = (c.cv_predicted - y) ** 2
            c.cv_rmse_percent = float(np.sqrt(squared.mean()))
            c.cv_rmse_se_percent = (float(squared.std(ddof=1) / math.sqrt(len(y)) / (2 * c.cv_rmse_percent))
                                    if c.cv_rmse_percent > 0 else 0.0)
    return out


def choose(candidates: list[Candidate]) -> Candidate:
    """The lowest CV error's one-standard-error set; in it the fewest parameters, then the first
    listed of those within AIC_TIE of the lowest AIC."""
    ranked = [c for c in candidates if math.isfinite(c.cv_rmse_percent)]
    if not ranked:
        reasons = "; ".join(f"{c.name}: {c.note}" for c in candidates)
        raise ConfigError(f"yield_model.experiments: no candidate model can be cross-validated ({reasons})")
    best = min(ranked, key=lambda c: c.cv_rmse_percent)
    within = [c for c in ranked if c.cv_rmse_percent <= best.cv_rmse_percent + best.cv_rmse_se_percent + TIE]
    fewest = min(len(c.fit.params) for c in within)
    simplest = [c for c in within if len(c.fit.params) == fewest]
    lowest = min(c.fit.aic for c in simplest)
    return next(c for c in simplest if c.fit.aic <= lowest + AIC_TIE)


def candidates_table(candidates: list[Candidate], chosen: Candidate, confidence: float) -> pd.DataFrame:
    """One row per candidate: CV error, chi^2, AIC, parameters with their intervals, chosen or not."""
    z = stats.norm.ppf(0.5 + confidence / 2)
    best = min((c.cv_rmse_percent for c in candidates if math.isfinite(c.cv_rmse_percent)), default=math.nan)
    rows = []
    for c in candidates:
        row = {"candidate": c.name, "model": c.model, "measure": None if c.measure is None else c.measure.rate,
               "threshold_j": None if c.measure is None else c.measure.threshold_j,
               "cv_rmse_percent": c.cv_rmse_percent, "cv_rmse_se_percent": c.cv_rmse_se_percent,
               "within_one_se": bool(c.cv_rmse_percent <= best + chosen.cv_rmse_se_percent + TIE),
               "chosen": c is chosen, "note": c.note}
        if c.fit is not None:
            row |= {"chi2": c.fit.chi2, "aic": c.fit.aic, "parameters": len(c.fit.params), "identified": c.fit.identified}
            lo, hi = BOUNDS[c.model]
            bound = [n for n, v, a, b in zip(PARAMS[c.model], c.fit.params, lo, hi) if np.isclose(v, a) or np.isclose(v, b)]
            row["note"] = c.note or (f"at its bound: {', '.join(bound)} (its interval is approximate)" if bound else "")
            for name, value, se in zip(PARAMS[c.model], c.fit.params, c.fit.se):
                row |= {name: value, f"{name}_se": se, f"{name}_lo": value - z * se, f"{name}_hi": value + z * se}
        rows.append(row)
    return pd.DataFrame(rows)


# Residence-time distributions


def rtd_distribution(rtd: RtdConfig):
    """The RTD in theta = t / mean residence time as a scipy distribution of mean 1 (None: plug)."""
    if rtd.kind == "tanks_in_series":
        return stats.gamma(a=rtd.tanks, scale=1.0 / rtd.tanks)
    if rtd.kind == "axial_dispersion":
        return stats.invgauss(mu=2.0 / rtd.peclet, scale=rtd.peclet / 2.0)
    return None


def mean_yield(yield_of_dose: Callable[[np.ndarray], np.ndarray], mean_dose: float, rtd: RtdConfig,
               kinks: Sequence[float] = ()) -> float:
    """The yield averaged over the RTD at a mean dose (any unit yield_of_dose takes): each
    particle's dose is mean_dose x theta.  `kinks`: doses where the yield is not smooth."""
    dist = rtd_distribution(rtd)
    if dist is None or mean_dose <= 0:
        return float(yield_of_dose(np.asarray(mean_dose)))
    lo, hi = dist.ppf(TAIL), 1.0 + TAIL_STDS * dist.std()  # the upper quantile fails for a narrow inverse Gaussian
    points = [1.0, *(k / mean_dose for k in kinks if lo < k / mean_dose < hi)]
    value, _ = integrate.quad(lambda th: float(yield_of_dose(np.asarray(mean_dose * th))) * dist.pdf(th), lo, hi,
                              points=points, limit=200)
    return value


def mean_dose_for(yield_of_dose, plug_dose: float, target_percent: float, rtd: RtdConfig,
                  kinks: Sequence[float] = ()) -> float:
    """The mean dose whose RTD-averaged yield is the target (plug flow: the plug dose itself)."""
    if rtd_distribution(rtd) is None:
        return plug_dose
    hi = plug_dose
    for _ in range(60):  # the mean yield grows with the mean dose towards the yield at large doses
        if mean_yield(yield_of_dose, hi, rtd, kinks) >= target_percent:
            break
        hi *= 2.0
    else:
        raise ConfigError(f"yield_model.target_yield_percent={target_percent}: under yield_model.rtd.kind={rtd.kind} "
                          "no mean dose reaches it (a share of the powder leaves early): lower the target")
    return optimize.brentq(lambda d: mean_yield(yield_of_dose, d, rtd, kinks) - target_percent, 0.0, hi,
                           xtol=1e-9 * hi, rtol=1e-12)


class YieldCurve(Protocol):
    """What a design needs of a yield model (FittedCurve; yields.DoseLine, the calibration's line):
    yield against the dose per kg of PET (J/kg) on one dose rate of dose.py (above threshold_j
    for the impact measure), its inverse, where it bends, the target dose's relative error."""

    rate: str
    threshold_j: float | None
    time_free: bool

    def yield_percent(self, dose_j_per_kg): ...

    def dose_for(self, target_percent: float) -> float: ...

    def kinks_j_per_kg(self) -> list[float]: ...

    def dose_rel_se(self, target_percent: float) -> float: ...

    def as_record(self) -> dict: ...


@dataclass(frozen=True)
class FittedCurve:
    """A fit's chosen model as a design uses it: yield against the dose per kg of PET (J/kg) on
    its dose measure (a dose.py rate, above threshold_j where it has one), with what its target
    dose's error needs: the parameters' covariance and the lab dose rates' relative error."""

    model: str
    rate: str
    threshold_j: float | None
    params: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    lab_rate_rel_se: float
    time_min: float  # the experiments' milling time where they share one (the BPR line's time)
    cv_rmse_percent: float
    folder: str

    @classmethod
    def read(cls, folder: Path) -> FittedCurve:
        """The chosen model of a fit's folder (fit.json)."""
        meta = json.loads((Path(folder) / "fit.json").read_text())
        return cls(meta["model"], meta["rate"], meta["threshold_j"], tuple(meta["params"]),
                   tuple(map(tuple, meta["cov"])), meta["lab_rate_rel_se"],
                   math.nan if meta["time_min"] is None else meta["time_min"], meta["cv_rmse_percent"], str(folder))

    @property
    def time_free(self) -> bool:
        return self.model in TIME_FREE

    def yield_percent(self, dose_j_per_kg):
        return predict(self.model, self.params, np.asarray(dose_j_per_kg, float) / 1e3)

    def yield_at_bpr(self, bpr: float) -> float:
        return float(predict(self.model, self.params, None, np.asarray(bpr)))

    def dose_for(self, target_percent: float) -> float:
        """The dose (J/kg PET) that gives the target in plug flow."""
        return 1e3 * inverse_dose_kj(self.model, self.params, target_percent)

    def kinks_j_per_kg(self) -> list[float]:
        """Doses where the yield is not smooth: the caps of a line, the induction dose."""
        if self.model == "dose_linear":
            a, b = self.params
            return [1e3 * (0.0 - a) / b, 1e3 * (100.0 - a) / b] if b else []
        return [1e3 * self.params[2]] if self.model == "saturating" else []

    def dose_rel_se(self, target_percent: float) -> float:
        """Relative standard error of the target dose: the parameters' (delta method) and the lab
        dose rates' (every experiment's dose scales with them)."""
        p = np.asarray(self.params)
        steps = 1e-6 * np.maximum(np.abs(p), 1e-6)
        grad = np.array([(inverse_dose_kj(self.model, p + np.eye(len(p))[i] * steps[i], target_percent)
                          - inverse_dose_kj(self.model, p - np.eye(len(p))[i] * steps[i], target_percent))
                         / (2 * steps[i]) for i in range(len(p))])
        var = float(grad @ np.asarray(self.cov) @ grad)
        return math.hypot(math.sqrt(var) / inverse_dose_kj(self.model, p, target_percent), self.lab_rate_rel_se)

    def as_record(self) -> dict:
        se = np.sqrt(np.diag(np.asarray(self.cov)))
        return {"fit_model": self.model, "fit_measure": self.rate, "fit_threshold_j": self.threshold_j,
                "fit_cv_rmse_percent": self.cv_rmse_percent, "fit_lab_rate_rel_se": self.lab_rate_rel_se,
                "fit_dir": self.folder,
                **{f"fit_{n}": v for n, v in zip(PARAMS[self.model], self.params)},
                **{f"fit_{n}_se": float(e) for n, e in zip(PARAMS[self.model], se)}}


def curve_mean_yield(curve: YieldCurve, mean_dose_j_per_kg: float, rtd: RtdConfig) -> float:
    """A yield curve's yield averaged over the RTD at a mean dose."""
    return mean_yield(curve.yield_percent, mean_dose_j_per_kg, rtd, curve.kinks_j_per_kg())


def curve_dose_for(curve: YieldCurve, target_percent: float, rtd: RtdConfig) -> float:
    """The mean dose (J/kg PET) whose RTD-averaged yield is the target."""
    return mean_dose_for(curve.yield_percent, curve.dose_for(target_percent), target_percent, rtd,
                         curve.kinks_j_per_kg())


def rtd_table(curve: FittedCurve, target: float, rtd: RtdConfig) -> pd.DataFrame:
    """What each RTD of the sensitivity lists costs against plug flow at the target: the mean
    dose it needs / plug flow's (tau scales with it, less the mill-size feedback), and the yield
    plug flow's dose gives under it."""
    plug = curve.dose_for(target)
    cases = [RtdConfig(kind="plug")]
    cases += [replace(rtd, kind="tanks_in_series", tanks=n) for n in rtd.sensitivity_tanks]
    cases += [replace(rtd, kind="axial_dispersion", peclet=pe) for pe in rtd.sensitivity_peclets]
    rows = []
    for c in cases:
        rows.append({"rtd": c.kind, "tanks": c.tanks if c.kind == "tanks_in_series" else None,
                     "peclet": c.peclet if c.kind == "axial_dispersion" else None, "target_yield_percent": target,
                     "dose_factor": curve_dose_for(curve, target, c) / plug,
                     "yield_at_plug_dose_percent": curve_mean_yield(curve, plug, c)})
    return pd.DataFrame(rows)


def lab_time_curves(curve: FittedCurve, rows: pd.DataFrame, until_min: float) -> pd.DataFrame:
    """The chosen model's yield against time for each experimental condition (its dose rate per
    kg of PET from the lab DEM), long: series, time_min, yield_percent."""
    t = np.linspace(0.0, until_min, 200)
    out = []
    for _, g in rows.groupby("condition", sort=True):
        r = g.iloc[0]
        rate = r[lab_rate_column(curve.threshold_j)] * (r.bpr * (r.pet_mass_g + r.naoh_mass_g) / r.pet_mass_g)
        label = f"lab: {r.frequency_hz:g} Hz, {r.ball_count} x {r.ball_diameter_mm:g} mm, BPR {r.bpr:.3g}"
        out.append(pd.DataFrame({"series": label, "time_min": t, "yield_percent": curve.yield_percent(rate * t * 60)}))
    return pd.concat(out, ignore_index=True)
