"""specific_energy and impact_threshold: the BPR line re-expressed against the lab DEM's dose
(yields.fit_dose_line) at the nominal lab condition, on one of dose.py's rates: all collisions,
or impacts of at least yield_model.impact_threshold_j."""

from __future__ import annotations

from ..dose import above_threshold
from ..lab_dose import calibrated, calibration_folder, check_conditions, lab_dose_line, nominal_condition
from .base import CurvePlan, YieldRule, lab_line


class DoseLineRule(YieldRule):
    """A dose line on one of dose.py's rates per kg (`measure`)."""

    def __init__(self, name: str, measure: str):
        self.name, self.measure = name, measure

    def plan(self, s, design) -> CurvePlan:
        check_conditions([nominal_condition(s)], s)
        ratio = design.naoh_feed_kg_per_h / design.pet_feed_kg_per_h
        return CurvePlan(lambda: lab_dose_line(s, ratio, self.measure), {"calibration_dir": str(calibration_folder(s))},
                         calibrated(s))

    def needs_spectrum(self, s) -> bool:
        return above_threshold(self.measure)

    def lab_time_curves(self, s, curve, rec, until_min):
        """The nominal lab condition at the design's BPR (its powder at the mill's NaOH:PET ratio)."""
        ratio = rec["naoh_feed_kg_per_h"] / rec["pet_feed_kg_per_h"]
        rate = curve.lab_rate_w_per_kg_balls * s.scaleup.bpr * (1 + ratio)  # W per kg of PET at this BPR
        return lab_line(f"lab (nominal), BPR {s.scaleup.bpr:g}", curve.yield_percent, rate, until_min), None

    def label(self, rec: dict) -> str:
        return f"{self.name} {1e3 * rec['impact_threshold_j']:g} mJ" if above_threshold(self.measure) else self.name
