"""What a run does, by `study.kind`: each study plans (checks the scenario and builds what the
run needs, in well under a second, simulating nothing) and then executes into the run's folder.
One module per study kind:

design:            feed -> scale-up -> DEM of the rotating mill -> power -> economics (design.py).
drum:              the mill group's drum as configured -> torque and power over time (drum.py).
lab:               the MM400 at every lab.frequencies_hz x lab.ball_diameters_m -> lab_summary.csv;
yield_calibration: the lab DEM of the kinetics experiments behind the energy rules (lab.py).
yield_fit:         kinetics experiments fitted, a model and dose measure chosen (yield_fit.py).
plant:             the mill and the plant around it on BioSTEAM (plant.py).
cheapest_mill:     the cheapest mill by the surrogate, confirmed by the DEM (cheapest_mill.py).
regional:          one plant for a group of states against a plant each, bales hauled (regional.py).
mechanics.py gives a design's power and dose, by DEM or surrogate, and the checks every DEM makes.

A new pipeline is one module here with its plan function, its entry in STUDIES and its name in
the choices of config.StudyConfig.kind.
"""

from __future__ import annotations

from collections.abc import Callable

from ..scenario import Scenario
from .cheapest_mill import plan_cheapest_mill
from .design import plan_design
from .drum import plan_drum
from .lab import plan_lab, plan_yield_calibration
from .mechanics import check_machine, cuda_available, mill_drum
from .plan import Plan
from .plant import plan_plant
from .regional import plan_regional
from .yield_fit import plan_yield_fit

__all__ = ["STUDIES", "Plan", "check_machine", "cuda_available", "mill_drum", "plan"]

STUDIES: dict[str, Callable[[Scenario], Plan]] = {"design": plan_design, "drum": plan_drum, "lab": plan_lab,
                                                   "yield_calibration": plan_yield_calibration,
                                                   "yield_fit": plan_yield_fit, "plant": plan_plant,
                                                   "cheapest_mill": plan_cheapest_mill, "regional": plan_regional}


def plan(s: Scenario) -> Plan:
    """The study's plan, with the study's name and kind at the head of its record."""
    p = STUDIES[s.study.kind](s)
    return Plan({"study": s.study.name, "kind": s.study.kind, **p.record}, p.execute)
