"""What a yield rule is (YieldRule) and what a dose rule's plan gives (CurvePlan)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class CurvePlan:
    """A dose rule's curve as planning leaves it: what makes it (the lab DEM or the fit, run first
    when missing), where it comes from (record columns), and whether it is made already."""

    source: Callable
    folder: dict
    ready: bool


class YieldRule:
    """A yield rule: its name, whether it is a dose rule, and what a design asks of it."""

    name: str = ""
    dose: bool = True

    def plan(self, s, design) -> CurvePlan:
        """Check what planning can (simulating nothing) and say how the curve is made."""
        raise NotImplementedError

    def needs_spectrum(self, s) -> bool:
        """Whether the mill's impact spectrum is needed before the curve is known (dem=surrogate
        predicts the collision power alone)."""
        return False

    def longest_lab_time_min(self, s, curve) -> float:
        """The longest milling time of the lab experiments behind the curve (min)."""
        return s.yield_model.lab_time_min

    def lab_time_curves(self, s, curve, rec: dict, until_min: float) -> tuple[pd.DataFrame, pd.DataFrame | None]:
        """The lab's yield against time beside the mill's (series, time_min, yield_percent), and
        the experiments as points (None: none)."""
        raise NotImplementedError

    def label(self, rec: dict) -> str:
        """The rule's name in tables and legends."""
        return self.name


def lab_line(label: str, yield_percent: Callable, rate_w_per_kg_pet: float, until_min: float) -> pd.DataFrame:
    """A lab condition's yield against time at its dose rate per kg of PET."""
    t = np.linspace(0.0, until_min, 200)
    return pd.DataFrame({"series": label, "time_min": t, "yield_percent": yield_percent(rate_w_per_kg_pet * t * 60)})
