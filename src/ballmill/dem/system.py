"""What a DEM system is made of: materials, pair properties, particles, bodies, domain."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import Body
from .materials import Interaction, Material, rayleigh_timestep


@dataclass
class SystemSpec:
    """A complete DEM system in SI units.

    Particles are sorted by replica (independent copies that never touch each other; a
    single system has one).  `interactions[r]` maps a sorted material-name pair to its
    Interaction for replica r (one dict is shared by all replicas).
    """

    materials: dict[str, Material]
    interactions: list[dict[tuple[str, str], Interaction]]
    position_m: np.ndarray
    radius_m: np.ndarray
    material: np.ndarray  # index into material_names
    bodies: list[Body]
    domain_lo_m: tuple[float, float, float]
    domain_hi_m: tuple[float, float, float]
    replica: np.ndarray | None = None
    velocity_m_per_s: np.ndarray | None = None
    angular_velocity_rad_per_s: np.ndarray | None = None
    gravity_m_per_s2: tuple[float, float, float] = (0.0, 0.0, -9.81)
    material_names: list[str] = field(default_factory=list)

    def __post_init__(self):
        n = len(self.radius_m)
        self.position_m = np.asarray(self.position_m, float).reshape(n, 3)
        self.radius_m = np.asarray(self.radius_m, float)
        self.material = np.asarray(self.material, np.int64)
        self.replica = np.zeros(n, np.int64) if self.replica is None else np.asarray(self.replica, np.int64)
        zeros = np.zeros((n, 3))
        self.velocity_m_per_s = zeros.copy() if self.velocity_m_per_s is None else np.asarray(self.velocity_m_per_s, float)
        spins = self.angular_velocity_rad_per_s
        self.angular_velocity_rad_per_s = zeros.copy() if spins is None else np.asarray(spins, float).reshape(n, 3)
        self.velocity_m_per_s = self.velocity_m_per_s.reshape(n, 3)
        self.material_names = self.material_names or list(self.materials)
        if np.any(np.diff(self.replica) < 0):
            raise ValueError("particles must be sorted by replica")
        if np.any(self.radius_m <= 0):
            raise ValueError("particle radius must be > 0 m")
        for body in self.bodies:
            if body.material not in self.materials:
                raise ValueError(f"body {body.name!r}: unknown material {body.material!r}; known: {sorted(self.materials)}")
            if len(body.motions) not in (1, self.n_replicas):
                raise ValueError(f"body {body.name!r}: give 1 or {self.n_replicas} motions, not {len(body.motions)}")
        if len(self.interactions) not in (1, self.n_replicas):
            raise ValueError(f"give 1 or {self.n_replicas} interaction tables, not {len(self.interactions)}")

    @property
    def n_particles(self) -> int:
        return len(self.radius_m)

    @property
    def n_replicas(self) -> int:
        return int(self.replica.max()) + 1 if len(self.replica) else 1

    def interaction(self, replica: int, a: str, b: str) -> Interaction:
        table = self.interactions[replica if len(self.interactions) > 1 else 0]
        key = tuple(sorted((a, b)))
        if key not in table:
            raise ValueError(f"no interaction given for materials {key[0]}-{key[1]}")
        return table[key]

    def rayleigh_timestep_s(self) -> float:
        """Smallest Rayleigh time step over the particles (s)."""
        names = self.material_names
        return min(
            rayleigh_timestep(float(self.radius_m[self.material == m].min()), self.materials[names[m]])
            for m in np.unique(self.material)
        )
