"""The surrogate's inputs and outputs: a drum as dimensionless groups, and back.

Inputs: fraction of critical speed phi, fill fraction J, length / diameter L/D, diameter /
ball diameter D/d, and the restitution e and sliding friction mu of the ball-ball and
ball-wall contacts (steel on steel in an industrial mill: one pair for both).
Outputs, per unit of the mill's gravitational power scale M g omega D/2 (M the ball mass):
the power number P / (M g omega D/2) and the collision power number (energy dissipated in
collisions per second, over the same scale).  Geometrically similar mills at the same groups
share these numbers (Hertz stiffness aside: the runs are at sim=surrogate, a hundredth of steel's
stiffness, which puts the power 1.6-1.7 % below steel's), so at a fixed phi the power grows as M sqrt(g D) g ~ D^2.5 L
(Bond; Hogg & Fuerstenau 1972), which the dimensionless form carries without being learnt.
"""

from __future__ import annotations

import math
from dataclasses import replace

from ..config import ConfigError, DrumConfig, InteractionConfig
from ..scaleup import critical_speed_rpm

G = 9.81  # m/s^2
INPUTS = ("fraction_of_critical", "fill_fraction", "length_to_diameter", "diameter_to_ball", "restitution",
          "friction")
OUTPUTS = ("power_number", "collision_power_number")


def contact_pairs(drum: DrumConfig) -> tuple[str, ...]:
    """The interaction keys of the ball-ball and ball-wall contacts ('a-b', sorted names)."""
    return tuple(dict.fromkeys("-".join(sorted(p)) for p in ((drum.ball_material,) * 2,
                                                              (drum.ball_material, drum.wall_material))))


def groups(drum: DrumConfig, interactions: dict[str, InteractionConfig]) -> dict[str, float]:
    """The surrogate's inputs for a drum (its speed explicit or as a fraction of critical).
    The ball-ball and ball-wall pairs must share restitution and friction (one pair for both)."""
    pairs = [interactions[k] for k in contact_pairs(drum)]
    if len({(p.restitution, p.static_friction) for p in pairs}) > 1:
        raise ConfigError(f"dem=surrogate: interactions {' and '.join(contact_pairs(drum))} differ; the surrogate "
                          "knows one restitution and friction for ball-ball and ball-wall contacts: use dem=full")
    d = 2 * drum.ball_radius_m
    phi = (drum.fraction_of_critical if drum.speed_rpm is None
           else drum.speed_rpm / critical_speed_rpm(drum.inner_diameter_m, d))
    return {"fraction_of_critical": phi, "fill_fraction": bed_fill(drum),
            "length_to_diameter": drum.inner_length_m / drum.inner_diameter_m,
            "diameter_to_ball": drum.inner_diameter_m / d, "restitution": pairs[0].restitution,
            "friction": pairs[0].static_friction}


def bed_fill(drum: DrumConfig) -> float:
    """The ball bed's share of the drum volume: the configured fill, or that of its ball count
    (at the bed porosity) when the count is given (as the scale-up gives it)."""
    if drum.ball_count is None:
        return drum.fill_fraction
    ball = 4 / 3 * math.pi * drum.ball_radius_m**3
    return drum.ball_count * ball / (1 - drum.bed_porosity) / (math.pi / 4 * drum.inner_diameter_m**2
                                                                * drum.inner_length_m)


def drum_at(point: dict[str, float], ball_radius_m: float, base: DrumConfig,
            interactions: dict[str, InteractionConfig]) -> tuple[DrumConfig, dict[str, InteractionConfig]]:
    """The drum (and pair table) of a point of the input space, with balls of ball_radius_m."""
    diameter = point["diameter_to_ball"] * 2 * ball_radius_m
    drum = replace(base, inner_diameter_m=diameter, inner_length_m=point["length_to_diameter"] * diameter,
                   ball_radius_m=ball_radius_m, fill_fraction=point["fill_fraction"], ball_count=None, speed_rpm=None,
                   fraction_of_critical=point["fraction_of_critical"], geometry="analytic")
    pairs = dict(interactions)
    for key in contact_pairs(drum):
        pairs[key] = replace(pairs[key], restitution=point["restitution"], static_friction=point["friction"])
    return drum, pairs


def power_scale_w(ball_mass_kg: float, diameter_m: float, speed_rpm: float) -> float:
    """M g omega D/2 (W): the power that lifts the charge's mass through the mill's radius per radian."""
    return ball_mass_kg * G * speed_rpm * 2 * math.pi / 60 * diameter_m / 2
