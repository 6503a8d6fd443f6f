"""The cheapest mill: speed, fill, ball size and L/D for a feed and a target yield.

Annualised cost = capital recovery factor x installed mill cost + electricity per year, the
factor over plant.plant_life_yr at plant.discount_rate, installed = purchase cost (the
economics group's correlation; with capacity_scaling=holdup it grows with the charge held) x
plant.mill_bare_module_factor, as the plant installs it.  Each trial is a scale-up at the trial's knobs evaluated as
`study=design` does, by the surrogate (milliseconds; under an energy rule the residence time
is solved for the target yield).  Optuna's TPE sampler (seeded: the same seed, the same
optimum) searches; trials outside the surrogate's hull, or whose mill cannot be built, are
infeasible (Optuna's constraints), so the optimum lies where the DEM was sampled.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace

import numpy_financial as npf
import pandas as pd

from ..config import ConfigError, OptimiserConfig, PlantConfig, ScaleupConfig

log = logging.getLogger(__name__)
KNOBS = ("fraction_of_critical", "fill_fraction", "ball_radius_m", "length_to_diameter")


def knob_ranges(opt: OptimiserConfig) -> dict[str, tuple[float, float]]:
    """Each knob's [low, high]; the ball at least min_ball_to_feed x the feed's particle size."""
    ranges = {k: tuple(getattr(opt, k)) for k in KNOBS}
    smallest = opt.min_ball_to_feed * opt.feed_particle_size_m / 2
    lo, hi = ranges["ball_radius_m"]
    if smallest > hi:
        raise ConfigError(f"optimiser.ball_radius_m={list(ranges['ball_radius_m'])}: the feed's "
                          f"{opt.feed_particle_size_m:g} m particles need balls of radius >= {smallest:g} m "
                          "(optimiser.min_ball_to_feed x size / 2)")
    ranges["ball_radius_m"] = (max(lo, smallest), hi)
    return ranges


def knob_scaleup(scale: ScaleupConfig, knobs: dict[str, float]) -> ScaleupConfig:
    """The scale-up at the knobs: fixed L/D, the speed a fraction of the mill's critical speed."""
    return replace(scale, **knobs, shape_rule="length_to_diameter", speed_rpm=None)


def design_knobs(scale: ScaleupConfig, design) -> dict[str, float]:
    """The knobs of a designed mill (the paper's: 15 rpm, 30 % fill, 80 mm balls, L/D 1.5)."""
    return {"fraction_of_critical": design.fraction_of_critical, "fill_fraction": scale.fill_fraction,
            "ball_radius_m": design.ball_radius_m, "length_to_diameter": design.length_m / design.diameter_m}


def annualised_cost_usd_per_yr(record: dict, plant: PlantConfig) -> float:
    """Capital recovered over the plant's life (installed mill) + the mill's electricity per year."""
    recovery = -npf.pmt(plant.discount_rate, plant.plant_life_yr, 1.0)
    return recovery * record["purchase_cost_usd"] * plant.mill_bare_module_factor + record["electricity_usd_per_yr"]


def minimise(objective: Callable[[dict[str, float]], tuple[float, float]], ranges: dict[str, tuple[float, float]],
             trials: int, seed: int) -> tuple[dict[str, float], float, pd.DataFrame]:
    """The feasible minimum of objective(knobs) -> (value, violation), violation <= 0 feasible, by
    Optuna's seeded multivariate TPE; the best knobs, value and every trial."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)

    def run(trial: optuna.Trial) -> float:
        knobs = {k: trial.suggest_float(k, lo, hi) for k, (lo, hi) in ranges.items()}
        value, violation = objective(knobs)
        trial.set_constraint("violation", violation)
        trial.set_user_attr("violation", violation)
        return value

    sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, n_startup_trials=min(trials // 5, 40))
    study = optuna.create_study(sampler=sampler)
    study.optimize(run, n_trials=trials)
    table = pd.DataFrame([{**t.params, "value": t.value, "violation": t.user_attrs["violation"],
                           "seconds": t.duration.total_seconds()} for t in study.trials])
    feasible = table[table.violation <= 0]
    if feasible.empty:
        raise ConfigError(f"optimiser: none of {trials} trials was feasible (inside the surrogate's training runs "
                          "and buildable); widen the surrogate's bounds or narrow optimiser.*")
    best = feasible.value.idxmin()
    return {k: float(table.at[best, k]) for k in ranges}, float(table.at[best, "value"]), table
