"""study=drum: the mill group's drum as configured, its torque, power and dose rates per kg of balls."""

from __future__ import annotations

from pathlib import Path

from ..config import ConfigError
from ..dose import with_basis
from ..drum import charge_fill, charge_mass_kg, drum_spec, mean_ball_diameter_m
from ..economics import bond_rowland_power_w
from ..lab import wall_interaction
from ..scenario import Scenario
from .mechanics import check_numerics, check_window, drum_record, run_dose, run_drum
from .plan import Plan


def plan_drum(s: Scenario) -> Plan:
    """The mill group's drum as configured: torque, power, and dose rates per kg of balls."""
    if s.dem.mode != "full":
        raise ConfigError("dem=surrogate: study=drum is the DEM of the mill group's drum; the surrogate serves "
                          "study=design, plant and cheapest_mill")
    check_window(s.sim, s.mill)
    check_numerics(drum_spec(s.mill, s.materials, s.interactions, s.sim), s.sim, "mill")

    def execute(out_dir: Path) -> dict:
        run, dem_dir = run_drum(s, s.mill, out_dir)
        balls = charge_mass_kg(s.mill, s.materials[s.mill.ball_material].density_kg_per_m3)
        wall = wall_interaction(s.interactions, s.mill)
        rates = run_dose(run, balls, s.yield_model.impact_threshold_j, s.yield_model.dose_batches)
        return (drum_record(run, dem_dir) | with_basis(rates, "balls")
                | {"experiment": s.study.experiment, "ball_mass_kg": balls, "wall_restitution": wall.restitution,
                   "wall_friction": wall.static_friction, "liner": s.mill.liner.kind,
                   "bond_rowland_power_w": bond_rowland_power_w(
                       s.mill.inner_diameter_m, balls, charge_fill(s.mill), run.summary["speed_rpm"]
                       / run.summary["critical_speed_rpm"], mean_ball_diameter_m(s.mill))})

    return Plan({}, execute)
