"""TPA yield of a mill: the seed's BPR line, or yield from the collision dose per kg of PET.

bpr_line:         Y = s BPR + c (the seed's lab fit, 20 min), the same in every mill.
specific_energy:  Y = a + b D, D = the energy dissipated in all collisions per kg of PET over
                  the residence time (J/kg);
impact_threshold: the same with only the collisions whose impact energy is at least E*.
a and b come from the lab DEM (`study=yield_calibration`): the lab mill's dose rate at each BPR
of the line (the BPR set by the powder mass, so the DEM, which holds no powder, is the same at
every BPR) and the line's yield there.  Both are linear in the BPR, so the fit is exact and
b carries the lab dose rate's standard error.  Under an energy rule a design either fixes the
residence time and reports the yield, or solves the residence time that gives a target yield
(a fixed point: the residence time sizes the mill, whose DEM gives the dose rate).
All yields are capped to [0, 100] %.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .config import ConfigError, YieldModelConfig
from .dose import above_threshold, dose_j_per_kg
from .scaleup import stoichiometric_naoh_kg_per_h


class NotConverged(RuntimeError):
    """The residence time's fixed point failed (no dose, or no settling within the iterations)."""


MAX_STEP = math.log(3.0)  # the residence time changes at most threefold per DEM run (bounds the mills tried)
LINE_POINTS = 27  # BPR points of the line the dose fit uses (half-unit steps over 10-23)


def line_yield(bpr: float, cfg: YieldModelConfig) -> float:
    """The BPR line, uncapped (%)."""
    return cfg.bpr_slope_percent * bpr + cfg.bpr_intercept_percent


def bpr_line_yield(bpr: float, cfg: YieldModelConfig) -> tuple[float, bool]:
    """The seed's yield (%), capped, and whether the BPR lies outside the fit (only when allowed)."""
    outside = not cfg.bpr_min <= bpr <= cfg.bpr_max
    if outside and not cfg.allow_extrapolation:
        raise ConfigError(f"scaleup.bpr={bpr} is outside the yield fit's range [{cfg.bpr_min}, {cfg.bpr_max}]; "
                          "set yield_model.allow_extrapolation=true to extrapolate")
    return cap(line_yield(bpr, cfg)), outside


def cap(y: float) -> float:
    return min(max(y, 0.0), 100.0)


def pet_fraction(basis: str, naoh_kg_per_kg_pet: float) -> float:
    """PET's share of the powder a BPR is counted on: PET + NaOH at the given NaOH:PET mass ratio
    (the mill's, so that lab and mill count alike), or PET alone."""
    return 1.0 if basis == "pet" else 1.0 / (1.0 + naoh_kg_per_kg_pet)


def stoichiometric_naoh_per_pet() -> float:
    """kg NaOH per kg PET at 2 mol per repeat unit."""
    return stoichiometric_naoh_kg_per_h(1.0)


@dataclass(frozen=True)
class DoseLine:
    """Y = a + b D (%, D in J per kg of PET), fitted on the lab DEM for one dose measure (a
    dose.py rate, above threshold_j for the impact measure)."""

    measure: str
    a_percent: float
    b_percent_per_j_per_kg: float
    b_se: float
    lab_rate_w_per_kg_balls: float
    lab_rate_se: float
    threshold_j: float | None = None
    time_free = False

    @property
    def rate(self) -> str:
        return self.measure

    def yield_percent(self, dose_j_per_kg):
        return np.clip(self.a_percent + self.b_percent_per_j_per_kg * np.asarray(dose_j_per_kg, float), 0.0, 100.0)

    def kinks_j_per_kg(self) -> list[float]:
        """The doses of 0 and 100 %, where the cap bends the line."""
        return [(y - self.a_percent) / self.b_percent_per_j_per_kg for y in (0.0, 100.0)]

    def dose_rel_se(self, target_percent: float) -> float:
        """Relative standard error of the target dose (the slope's, from the lab rate's)."""
        return self.b_se / self.b_percent_per_j_per_kg

    def dose_for(self, target_percent: float) -> float:
        """The dose (J/kg PET) that gives the target yield."""
        if target_percent <= self.a_percent:
            raise ConfigError(f"yield_model.target_yield_percent={target_percent} is at or below the dose line's "
                              f"intercept {self.a_percent:.3g} %: any dose gives it")
        return (target_percent - self.a_percent) / self.b_percent_per_j_per_kg

    def as_record(self) -> dict:
        return {"yield_measure": self.measure, "yield_a_percent": self.a_percent,
                "yield_b_percent_per_kj_per_kg": 1e3 * self.b_percent_per_j_per_kg,
                "yield_b_se_percent_per_kj_per_kg": 1e3 * self.b_se,
                "lab_rate_w_per_kg_balls": self.lab_rate_w_per_kg_balls, "lab_rate_se_w_per_kg_balls": self.lab_rate_se}


def fit_dose_line(measure: str, lab_rate_w_per_kg_balls: float, lab_rate_se: float, cfg: YieldModelConfig,
                  naoh_kg_per_kg_pet: float) -> DoseLine:
    """The BPR line re-expressed against the lab dose: at BPR B the jar holds m_balls / B of powder,
    PET a fraction f of it (at the mill's NaOH:PET ratio), so the dose per kg PET in lab_time_min
    is rate * B / f * t."""
    if lab_rate_w_per_kg_balls <= 0:
        raise ConfigError(f"yield_model: the lab DEM gives no dose for {measure} (at E* = {cfg.impact_threshold_j} J, "
                          "no lab collision reaches it): lower yield_model.impact_threshold_j")
    bpr = np.linspace(cfg.bpr_min, cfg.bpr_max, LINE_POINTS)
    y = line_yield(bpr, cfg)
    keep = (y > 0) & (y <= 100)
    dose = dose_j_per_kg(lab_rate_w_per_kg_balls * bpr[keep] / pet_fraction(cfg.lab.bpr_basis, naoh_kg_per_kg_pet),
                         cfg.lab_time_min)
    b, a = np.polyfit(dose, y[keep], 1)
    return DoseLine(measure, float(a), float(b), float(b * lab_rate_se / lab_rate_w_per_kg_balls),
                    lab_rate_w_per_kg_balls, lab_rate_se,
                    cfg.impact_threshold_j if above_threshold(measure) else None)


@dataclass
class FixedPoint:
    """The residence time that gives the target dose in the mill it sizes: the root interpolated
    inside the bracket of the mills simulated (or, unbracketed, the one simulated within the
    tolerance), how it was found, and its standard error from the measured mill-size feedback."""

    residence_time_min: float
    iterations: int
    history_min: list[float] = field(default_factory=list)
    se_min: float = 0.0
    root: str = ""
    rate_exponent: float = 0.0  # alpha of rate ~ tau^alpha at the root (the mill-size feedback)
    rate_exponent_se: float = 0.0

    def as_record(self) -> dict:
        return {"residence_time_se_min": self.se_min, "fixed_point_iterations": self.iterations,
                "fixed_point_root": self.root, "fixed_point_rate_exponent": self.rate_exponent,
                "fixed_point_rate_exponent_se": self.rate_exponent_se,
                "fixed_point_history_min": " ".join(f"{t:.6g}" for t in self.history_min)}


MIN_FEEDBACK = -0.9  # alpha below it (a rate falling almost as fast as tau grows) is taken as this


def solve_residence_time(start_min: float, dose_target_j_per_kg: float, rate_at: Callable[[float], tuple[float, float]],
                         tolerance: float, max_iterations: int, target_rel_se: float = 0.0,
                         sensitivity_step: float = 0.2) -> FixedPoint:
    """tau = D / r(tau): r(tau) (W/kg PET, with its standard error) is the DEM of the mill that tau
    sizes.  On log tau: a plain step first, then secant steps (each at most threefold up or down,
    so that a far first guess does not ask for a huge mill), and once the root is bracketed,
    regula falsi inside the bracket (a DEM's rate is a rough function of the mill).  It stops when
    the next tau moves by less than `tolerance` (relative), or the bracket is that narrow or
    narrower than twice its ends' relative standard error (no DEM run can place the root better
    than its rate's noise).  The answer is the root interpolated between the bracket's ends, else
    the simulated tau within the tolerance.  Its standard error: with r ~ tau^alpha near the root,
    tau ~ (D / r)^(1 / (1 + alpha)), so the relative errors of the mill's rate and of the target
    dose (`target_rel_se`: the lab's) add in quadrature and shrink by 1 + alpha; alpha and the
    rate's error are measured on the mills at tau (1 + sensitivity_step)^-1 and tau (1 +
    sensitivity_step) (a central difference on log axes), the same two mills whatever the path
    that found the root."""
    tried: list[tuple[float, float, float, float]] = []  # (log tau, log(next tau / tau), relative se, tau)
    for k in range(1, max_iterations + 1):
        tau = start_min if not tried else math.exp(next_log_tau(tried))
        rate, se = checked_rate(rate_at, tau)
        tried.append((math.log(tau), math.log(dose_target_j_per_kg / dose_j_per_kg(rate, tau)), se / rate, tau))
        above = [t for t in tried if t[1] > 0]
        below = [t for t in tried if t[1] <= 0]
        if above and below:
            hi, lo = max(above), min(below)
            narrow = abs(hi[0] - lo[0]) < math.log1p(max(tolerance, 2.0 * max(hi[2], lo[2])))
        else:
            narrow = False
        if abs(math.expm1(tried[-1][1])) < tolerance or narrow:
            tau, how = root_of(tried)
            alpha, alpha_se, rel = rate_exponent(tau, rate_at, sensitivity_step)
            se = tau * math.hypot(rel, target_rel_se) / (1.0 + max(alpha, MIN_FEEDBACK))
            return FixedPoint(tau, k, [t[3] for t in tried], se, how, alpha, alpha_se)
    raise NotConverged(f"yield_model: the residence time did not settle in {max_iterations} DEM runs (min: "
                       f"{', '.join(f'{t[3]:.4g}' for t in tried)}); raise yield_model.max_iterations or "
                       "yield_model.tolerance")


def checked_rate(rate_at: Callable[[float], tuple[float, float]], tau: float) -> tuple[float, float]:
    """The mill's dose rate and its standard error at tau; NotConverged where it gives no dose."""
    rate, se = rate_at(tau)
    if not rate > 0:
        raise NotConverged(f"yield_model: the mill at {tau:.4g} min gives no dose (rate {rate} W/kg PET): no "
                           "collision there reaches the threshold; lower yield_model.impact_threshold_j")
    return rate, se


def rate_exponent(tau: float, rate_at: Callable[[float], tuple[float, float]], step: float) -> tuple[float, float, float]:
    """alpha = d log r / d log tau at tau, by a central difference over the mills at tau / (1 + step)
    and tau (1 + step); its standard error from theirs; the rate's relative error there (their RMS)."""
    h = math.log1p(step)
    (r_lo, se_lo), (r_hi, se_hi) = (checked_rate(rate_at, tau * math.exp(sign * h)) for sign in (-1, 1))
    rel_lo, rel_hi = se_lo / r_lo, se_hi / r_hi
    return (math.log(r_hi / r_lo) / (2 * h), math.hypot(rel_lo, rel_hi) / (2 * h),
            math.sqrt((rel_lo**2 + rel_hi**2) / 2))


def root_of(tried: list[tuple[float, float, float, float]]) -> tuple[float, str]:
    """The fixed point from the mills tried, and how: interpolated inside the bracket, else the
    closest simulated."""
    above = [t for t in tried if t[1] > 0]
    below = [t for t in tried if t[1] <= 0]
    if above and below:
        (x0, f0, _, t0), (x1, f1, _, t1) = max(above), min(below)
        return math.exp(x0 + f0 / (f0 - f1) * (x1 - x0)), f"interpolated between {t0:.4g} and {t1:.4g} min"
    return min(tried, key=lambda t: abs(t[1]))[3], "simulated, within the tolerance (not bracketed)"


def next_log_tau(tried: list[tuple[float, float, float, float]]) -> float:
    """The next log tau to simulate: regula falsi inside the bracket (kept off its ends), else a
    secant or plain step, capped."""
    above = [t for t in tried if t[1] > 0]  # f > 0: the dose falls short, the root lies higher
    below = [t for t in tried if t[1] <= 0]
    if above and below:
        (x0, f0, *_), (x1, f1, *_) = max(above), min(below)
        share = min(0.9, max(0.1, f0 / (f0 - f1)))
        return x0 + share * (x1 - x0)
    x, f, *_ = tried[-1]
    step = f
    if len(tried) > 1 and tried[-2][1] != f:
        secant = -f * (x - tried[-2][0]) / (f - tried[-2][1])
        step = secant if secant * f > 0 else f  # a secant that turns back is noise: take the plain step
    return x + max(-MAX_STEP, min(MAX_STEP, step))
