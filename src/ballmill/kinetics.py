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
Fits are maximum likelihood with known (absolute) yield errors (scipy.optimize.least_squares on
the residuals' square roots of -2 log L): a row's yield is a normal draw about the model's
(uncapped) yield; a row at 0 or 100 % is censored (the yield measured as 0 is any yield at or
below 0: its likelihood is the normal's tail, Tobin 1958, Econometrica 26:24); and each lab DEM
run's dose rate carries its own relative error into the doses of its rows, as a factor exp(u)
on them with u ~ N(0, the rate's relative standard error) fitted beside the parameters (errors in
variables as a constrained nuisance parameter per run: its rows share it, so a run's error
weighs as the rows it doses, not as one condition among equals).  The parameters' covariance is
the model's block of (J^T J)^-1; their intervals are likelihood-ratio intervals (profile_interval).
A run with no dose under a measure (no impact reaches E*) has no rate error to carry: its rows can
only tell the yield at zero dose.  A model is chosen, with its dose measure, by
leave-one-condition-out cross-validation: each condition's rows predicted by the fit to the others; the candidates within one standard error of the lowest CV error, the one with
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
from scipy import integrate, optimize, special, stats

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
PROFILE_STEPS = 30  # points a likelihood-ratio interval's end is looked for at: the normal interval's end,
PROFILE_GROWTH = 1.5  # then each this much farther
PROFILE_XTOL = 0.02  # an interval's end to this share of its normal half-width


def predict(model: str, params: Sequence[float], dose_kj: np.ndarray, bpr: np.ndarray | None = None,
            capped: bool = True) -> np.ndarray:
    """Y (%) of a model at doses (kJ/kg PET), or BPRs for bpr_line; uncapped, the latent yield a
    measurement scatters about (the lines run below 0 and above 100 %)."""
    lo, hi = (0.0, 100.0) if capped else (-np.inf, np.inf)
    if model == "dose_linear":
        a, b = params
        return np.clip(a + b * np.asarray(dose_kj, float), lo, hi)
    if model == "saturating":
        ymax, k, d0 = params
        return ymax * -np.expm1(-k * np.maximum(0.0, np.asarray(dose_kj, float) - d0))
    s, c = params
    return np.clip(s * np.asarray(bpr, float) + c, lo, hi)


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
    """A model fitted to rows: parameters, their covariance (inf where not identified), -2 log L
    (chi^2 where no row is censored and no dose uncertain), and each lab run's fitted dose shift u."""

    model: str
    params: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    chi2: float
    rows: int
    shifts: tuple[float, ...] = ()
    intervals: tuple[tuple[float, float], ...] = ()  # likelihood-ratio intervals, where asked for

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


@dataclass(frozen=True)
class DoseErrors:
    """The doses' errors: each row's lab DEM run (an index) and each run's dose rate's relative
    standard error (nan or 0 where the run has no dose, or none is known)."""

    run: np.ndarray
    rel_se: np.ndarray

    def carried(self, x: np.ndarray) -> np.ndarray:
        """The runs whose error is carried: a known error, and a dose in some row."""
        dosed = np.array([np.any(x[self.run == r] > 0) for r in range(len(self.rel_se))], bool)
        return np.flatnonzero(dosed & np.isfinite(self.rel_se) & (self.rel_se > 0))

    def subset(self, keep: np.ndarray) -> DoseErrors:
        return DoseErrors(self.run[keep], self.rel_se)


def censored_residuals(latent: np.ndarray, y: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Signed square roots of each row's -2 log L (less its constant): (latent - y) / sigma for a
    measured yield, sqrt(-2 log Phi(z)) for a yield at 0 (z = -latent / sigma: the yield lies at or
    below 0) or at 100 % (z = (latent - 100) / sigma)."""
    out = (latent - y) / sigma
    for side, z in ((y <= 0.0, -latent / sigma), (y >= 100.0, (latent - 100.0) / sigma)):
        out = np.where(side, np.sqrt(np.maximum(-2.0 * special.log_ndtr(z), 0.0)), out)
    return out


@dataclass(frozen=True)
class Likelihood:
    """-2 log L of a model on (x, y) as least-squares residuals: the rows' (censored_residuals) and
    each carried lab run's shift u against N(0, its relative error), parameters p = model's + u's."""

    model: str
    x: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    slot: np.ndarray  # each row's shift in p[k:], len(rel) (an appended 0) where none is carried
    rel: np.ndarray

    @classmethod
    def of(cls, model: str, x, y, sigma, errors: DoseErrors | None) -> Likelihood:
        x, y, sigma = (np.asarray(v, float) for v in (x, y, sigma))
        runs = errors.carried(x) if errors is not None and model not in TIME_FREE else np.zeros(0, int)
        slot = np.full(len(x), len(runs))
        if len(runs):
            slot = np.where(np.isin(errors.run, runs), np.searchsorted(runs, errors.run), len(runs))
        return cls(model, x, y, sigma, slot, errors.rel_se[runs] if len(runs) else np.zeros(0))

    @property
    def k(self) -> int:
        return len(PARAMS[self.model])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = BOUNDS[self.model]
        n = len(self.rel)
        return np.concatenate([lo, np.full(n, -np.inf)]), np.concatenate([hi, np.full(n, np.inf)])

    def residuals(self, p: np.ndarray) -> np.ndarray:
        dose = self.x * np.exp(np.append(p[self.k:], 0.0)[self.slot])
        latent = predict(self.model, p[:self.k], dose, dose, capped=False)
        return np.concatenate([censored_residuals(latent, self.y, self.sigma), p[self.k:] / self.rel])

    def minimise(self, p0: np.ndarray, fixed: int | None = None):
        """least_squares from p0, parameter `fixed` held at its value in p0; (p, -2 log L)."""
        lo, hi = self.bounds
        p = np.clip(p0, lo + 1e-12, hi)
        free = np.arange(len(p)) != fixed

        def residuals(q):
            p[free] = q
            return self.residuals(p)

        res = optimize.least_squares(residuals, p[free], bounds=(lo[free], hi[free]), x_scale="jac", method="trf")
        p[free] = res.x
        return p, 2 * res.cost, res.jac


def fit_model(model: str, x: np.ndarray, y: np.ndarray, sigma: np.ndarray, errors: DoseErrors | None = None,
              confidence: float | None = None) -> Fit:
    """Maximum likelihood of a model on (x, y) with known yield errors sigma, yields at 0 or 100 %
    censored, and (`errors`) each lab run's dose error carried as a shift exp(u) of its rows'
    doses, u ~ N(0, its relative error); x is the dose (kJ/kg PET), or the BPR for bpr_line.
    With a confidence, each parameter's likelihood-ratio interval (profile_interval)."""
    like = Likelihood.of(model, x, y, sigma, errors)
    k, n = like.k, len(like.rel)
    best = min((like.minimise(np.concatenate([p0, np.zeros(n)])) for p0 in starts(model, like.x, like.y)),
               key=lambda r: r[1])
    p, m2ll, jac = best
    sv = np.linalg.svd(jac, compute_uv=False)
    identified = len(sv) == len(p) and sv[-1] > SINGULAR * sv[0]
    cov = np.linalg.inv(jac.T @ jac)[:k, :k] if identified else np.full((k, k), np.inf)
    intervals = ()
    if confidence is not None:
        level = stats.chi2.ppf(confidence, 1)
        intervals = tuple(profile_interval(like, p, m2ll, i, level, math.sqrt(cov[i, i])) if identified
                          else (-math.inf, math.inf) for i in range(k))
    return Fit(model, tuple(map(float, p[:k])), tuple(map(tuple, cov)), float(m2ll), len(like.y),
               tuple(map(float, p[k:])), intervals)


def profile_interval(like: Likelihood, best: np.ndarray, m2ll: float, i: int, level: float,
                     se: float) -> tuple[float, float]:
    """Parameter i's likelihood-ratio interval: where -2 log L, minimised over the others, rises
    `level` (the chi^2 quantile of 1 degree of freedom) above its minimum, or its bound (Venzon &
    Moolgavkar 1988, Appl. Statist. 37:87).  Unlike the covariance's normal interval it follows a
    skewed likelihood: the induction dose's, which bends where the first rows reach it."""
    lo_bound, hi_bound = (b[i] for b in like.bounds)

    def excess(v: float) -> float:
        return like.minimise(np.where(np.arange(len(best)) == i, v, best), fixed=i)[1] - m2ll - level

    ends = []
    for sign, bound in ((-1, lo_bound), (1, hi_bound)):
        width = math.sqrt(level) * (se if math.isfinite(se) and se > 0 else max(abs(best[i]), 1.0))
        inner = best[i]
        for j in range(PROFILE_STEPS):  # out from the normal interval's end, each step 1.5 times the last
            outer = best[i] + sign * width * PROFILE_GROWTH**j
            if sign * (outer - bound) >= 0:
                outer = bound
            if excess(outer) > 0:
                ends.append(optimize.brentq(excess, inner, outer, xtol=PROFILE_XTOL * width))
                break
            if outer == bound:
                ends.append(bound)
                break
            inner = outer
        else:
            ends.append(sign * math.inf)
    return ends[0], ends[1]


def distinct(x: np.ndarray) -> int:
    return len(np.unique(np.round(np.asarray(x, float), 12)))


def cross_validate(model: str, x: np.ndarray, y: np.ndarray, sigma: np.ndarray, groups: np.ndarray,
                   errors: DoseErrors | None = None) -> tuple[np.ndarray, str]:
    """Leave-one-condition-out predictions of every row (nan throughout, with the reason, where a
    training set has fewer distinct x than the model has parameters)."""
    predicted = np.full(len(y), np.nan)
    for g in np.unique(groups):
        out = groups == g
        if distinct(x[~out]) < len(PARAMS[model]):
            return np.full(len(y), np.nan), (f"leaving condition {g} out leaves {distinct(x[~out])} distinct doses for "
                                             f"{len(PARAMS[model])} parameters")
        fit = fit_model(model, x[~out], y[~out], sigma[~out], None if errors is None else errors.subset(~out))
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


def dose_errors(rows: pd.DataFrame, measure: Measure) -> tuple[DoseErrors | None, str]:
    """Each row's lab DEM run (dem_condition) and each run's relative rate error under a measure,
    where the rows carry the lab rates (lab_rate_*); and a note naming the runs with no dose."""
    rate, se = lab_rate_column(measure.threshold_j), lab_rate_column(measure.threshold_j, se=True)
    if not {"dem_condition", rate, se} <= set(rows.columns):
        return None, ""
    runs = rows.drop_duplicates("dem_condition").set_index("dem_condition").sort_index()
    rel = np.full(int(runs.index.max()) + 1, np.nan)
    dosed = runs[rate] > 0
    rel[runs.index[dosed]] = runs[se][dosed] / runs[rate][dosed]
    dry = list(runs.index[~dosed])
    note = (f"lab DEM runs {', '.join(map(str, dry))} give no dose under {measure.label}: their rows tell only the "
            "yield at zero dose" if dry else "")
    return DoseErrors(rows.dem_condition.to_numpy(int), rel), note


def fit_candidates(rows: pd.DataFrame, models: Sequence[str], thresholds_j: Sequence[float],
                   confidence: float = 0.95) -> list[Candidate]:
    """Every model on every dose measure (the BPR line on the BPR, where the rows share one milling
    time), fitted to all rows and cross-validated by condition.  `rows` holds yield_percent,
    yield_error_percent, condition, bpr, time_min and the dose columns of the measures; with
    dem_condition and the lab rate columns, each lab run's rate error is carried (fit_model); each
    fit's likelihood-ratio intervals at `confidence`."""
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
        errors, dry = (None, "") if c.measure is None else dose_errors(rows, c.measure)
        c.fit = fit_model(c.model, x, y, sigma, errors, confidence)
        c.cv_predicted, c.note = cross_validate(c.model, x, y, sigma, groups, errors)
        if not c.note:
            squared = (c.cv_predicted - y) ** 2
            c.cv_rmse_percent = float(np.sqrt(squared.mean()))
            c.cv_rmse_se_percent = (float(squared.std(ddof=1) / math.sqrt(len(y)) / (2 * c.cv_rmse_percent))
                                    if c.cv_rmse_percent > 0 else 0.0)
            c.note = dry
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


def candidates_table(candidates: list[Candidate], chosen: Candidate) -> pd.DataFrame:
    """One row per candidate: CV error, -2 log L, AIC, parameters with their likelihood-ratio
    intervals (fit_candidates' confidence), chosen or not."""
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
            row["note"] = c.note or (f"at its bound: {', '.join(bound)}" if bound else "")
            for name, value, se, (lo_end, hi_end) in zip(PARAMS[c.model], c.fit.params, c.fit.se, c.fit.intervals):
                row |= {name: value, f"{name}_se": se, f"{name}_lo": lo_end, f"{name}_hi": hi_end}
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
    # to quad's relative accuracy however small the yield (its absolute 1.5e-8 % would stop it short
    # in the RTD's far tail, where a small mill's dose puts it)
    value, _ = integrate.quad(lambda th: float(yield_of_dose(np.asarray(mean_dose * th))) * dist.pdf(th), lo, hi,
                              points=points, limit=200, epsabs=0.0)
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
    its dose measure (a dose.py rate, above threshold_j where it has one), with the parameters'
    covariance (which holds the lab dose rates' errors: fit_model carries them)."""

    model: str
    rate: str
    threshold_j: float | None
    params: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    time_min: float  # the experiments' milling time where they share one (the BPR line's time)
    cv_rmse_percent: float
    folder: str

    @classmethod
    def read(cls, folder: Path) -> FittedCurve:
        """The chosen model of a fit's folder (fit.json)."""
        meta = json.loads((Path(folder) / "fit.json").read_text())
        return cls(meta["model"], meta["rate"], meta["threshold_j"], tuple(meta["params"]),
                   tuple(map(tuple, meta["cov"])),
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
        """Relative standard error of the target dose: the parameters' (delta method; the lab dose
        rates' errors are in their covariance)."""
        p = np.asarray(self.params)
        steps = 1e-6 * np.maximum(np.abs(p), 1e-6)
        grad = np.array([(inverse_dose_kj(self.model, p + np.eye(len(p))[i] * steps[i], target_percent)
                          - inverse_dose_kj(self.model, p - np.eye(len(p))[i] * steps[i], target_percent))
                         / (2 * steps[i]) for i in range(len(p))])
        var = float(grad @ np.asarray(self.cov) @ grad)
        return math.sqrt(var) / inverse_dose_kj(self.model, p, target_percent)

    def as_record(self) -> dict:
        se = np.sqrt(np.diag(np.asarray(self.cov)))
        return {"fit_model": self.model, "fit_measure": self.rate, "fit_threshold_j": self.threshold_j,
                "fit_cv_rmse_percent": self.cv_rmse_percent,
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
