"""Yield rules (yield_model.rule), registered by name: how a design gets its mill's yield.

The BPR line's yield follows the BPR alone.  A dose rule has a yield curve (kinetics.YieldCurve:
yield against the dose per kg of PET on one of dose.py's rates) that the lab DEM or a fit makes,
and solves the residence time whose dose reaches the target yield (studies/design.py).  Adding a
rule: a module here whose class is a YieldRule, one entry in RULES below, and
conf/yield_model/<name>.yaml setting `rule: <name>` (docs/how-to/extend.md).
"""

from __future__ import annotations

from ..config import ConfigError
from .base import CurvePlan, YieldRule
from .bpr_line import BprLine
from .dose_line import DoseLineRule
from .fitted import Fitted

__all__ = ["RULES", "CurvePlan", "DoseLineRule", "YieldRule", "dose_lines", "rule_of"]

RULES: dict[str, YieldRule] = {r.name: r for r in (
    BprLine(),
    DoseLineRule("specific_energy", "collision_power_w_per_kg"),
    DoseLineRule("impact_threshold", "impact_power_w_per_kg"),
    Fitted(),
)}


def rule_of(name: str) -> YieldRule:
    if name not in RULES:
        raise ConfigError(f"yield_model.rule={name!r} is not one of {list(RULES)}")
    return RULES[name]


def dose_lines() -> list[DoseLineRule]:
    """The rules calibrated on the lab DEM as a dose line (study=yield_calibration fits each)."""
    return [r for r in RULES.values() if isinstance(r, DoseLineRule)]
