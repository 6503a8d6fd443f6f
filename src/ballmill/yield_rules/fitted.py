"""fitted: the model and dose measure a kinetics experiments table chooses (kinetics.py,
studies/yield_fit.py: fitted first when missing, cached by the table's hash)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..kinetics import lab_time_curves
from ..studies.yield_fit import checked_experiments, fitted_curve, is_fitted
from .base import CurvePlan, YieldRule


class Fitted(YieldRule):
    name = "fitted"

    def plan(self, s, design) -> CurvePlan:
        exps = checked_experiments(s)
        return CurvePlan(lambda: fitted_curve(s, exps), {}, is_fitted(s, exps))

    def lab_time_curves(self, s, curve, rec, until_min):
        """Each experimental condition at its lab dose rate; the experiments as points (the rows of
        the curve's fit)."""
        rows = pd.read_csv(Path(curve.folder) / "rows.csv")
        return lab_time_curves(curve, rows, until_min), rows

    def longest_lab_time_min(self, s, curve) -> float:
        return float(pd.read_csv(Path(curve.folder) / "rows.csv").time_min.max())
