"""Material properties, pair (interaction) properties and the restitution-to-damping map.

Hertz-Mindlin (no slip) as in EDEM: 1/E* = (1-v1^2)/E1 + (1-v2^2)/E2,
1/G* = (2-v1)/G1 + (2-v2)/G2, E = 2G(1+v).  Walls have infinite mass and radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from scipy.integrate import solve_ivp
from scipy.optimize import brentq


@dataclass(frozen=True)
class Material:
    """An elastic solid: density (kg/m3), shear modulus (Pa), Poisson ratio (-)."""

    name: str
    density_kg_per_m3: float
    shear_modulus_pa: float
    poisson_ratio: float

    @property
    def youngs_modulus_pa(self) -> float:
        return 2.0 * self.shear_modulus_pa * (1.0 + self.poisson_ratio)


@dataclass(frozen=True)
class Interaction:
    """Pair properties of two materials (EDEM interaction table row).

    restitution: normal coefficient of restitution (0, 1]; static_friction: Coulomb mu_s;
    rolling_friction: EDEM type-A coefficient mu_r (torque = mu_r * F_n * R).
    """

    restitution: float
    static_friction: float
    rolling_friction: float


def effective_youngs_modulus(a: Material, b: Material) -> float:
    """E* (Pa) of a Hertz contact between materials a and b."""
    return 1.0 / (
        (1 - a.poisson_ratio**2) / a.youngs_modulus_pa
        + (1 - b.poisson_ratio**2) / b.youngs_modulus_pa
    )


def effective_shear_modulus(a: Material, b: Material) -> float:
    """G* (Pa) of a Mindlin contact between materials a and b."""
    return 1.0 / (
        (2 - a.poisson_ratio) / a.shear_modulus_pa + (2 - b.poisson_ratio) / b.shear_modulus_pa
    )


def rayleigh_timestep(radius_m: float, material: Material) -> float:
    """Rayleigh critical time step (s): pi R sqrt(rho/G) / (0.1631 v + 0.8766)."""
    return (
        math.pi
        * radius_m
        * math.sqrt(material.density_kg_per_m3 / material.shear_modulus_pa)
        / (0.1631 * material.poisson_ratio + 0.8766)
    )


def hertz_contact_time(m_eff: float, r_eff: float, e_star: float, speed: float) -> float:
    """Duration (s) of an elastic Hertz impact at normal speed (m/s): 2.868 (m*^2/(R* E*^2 v))^0.2."""
    return 2.868 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2


def hertz_max_overlap(m_eff: float, r_eff: float, e_star: float, speed: float) -> float:
    """Maximum overlap (m) of an elastic Hertz impact: (15 m* v^2 / (16 E* sqrt(R*)))^0.4."""
    return (15.0 * m_eff * speed**2 / (16.0 * e_star * math.sqrt(r_eff))) ** 0.4


def edem_damping_ratio(restitution: float) -> float:
    """EDEM closed form -beta = -ln e / sqrt(ln^2 e + pi^2) (misses e for a Hertz spring)."""
    log_e = math.log(restitution)
    return -log_e / math.sqrt(log_e**2 + math.pi**2)


def achieved_restitution(damping_ratio: float) -> float:
    """Restitution of a Hertz + Tsuji-damped impact whose force may not pull.

    In units where overlap, time and speed are scaled out, the impact obeys
    s'' = -max(0, s^1.5 + sqrt(5) z s^0.25 s'), s(0) = 0, s'(0) = 1, for the damping
    force 2 sqrt(5/6) z sqrt(S_n m*) v_n.  The result is independent of impact speed.
    """
    c = math.sqrt(5.0) * damping_ratio

    def force(s, v):
        s = max(s, 0.0)
        return s**1.5 + c * s**0.25 * v

    def rhs(_, y):
        return [y[1], -max(force(y[0], y[1]), 0.0)]

    def separated(_, y):  # contact force vanishes while unloading
        return force(y[0], y[1]) if y[1] < 0 else 1.0

    separated.terminal, separated.direction = True, -1

    def left(_, y):  # overlap back to zero
        return y[0]

    left.terminal, left.direction = True, -1
    sol = solve_ivp(
        rhs, (0.0, 50.0), [1e-12, 1.0], events=[separated, left], rtol=1e-11, atol=1e-13,
        max_step=0.01,
    )
    return float(-sol.y[1, -1])


@lru_cache(maxsize=256)
def damping_ratio_for_restitution(restitution: float) -> float:
    """Damping ratio z >= 0 that yields `restitution` exactly for a non-pulling Hertz contact."""
    if not 0.0 < restitution <= 1.0:
        raise ValueError(f"restitution={restitution} outside the allowed range (0, 1]")
    if restitution >= 1.0:
        return 0.0
    return brentq(lambda z: achieved_restitution(z) - restitution, 0.0, 50.0, xtol=1e-12)

