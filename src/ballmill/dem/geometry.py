"""Rigid walls (in their body frame) and their prescribed motions.

A body is a set of wall primitives or triangle meshes that move together.  Walls are given
in the body frame; the body's motion maps body to world coordinates at time t:
x_world = p + Rot(a, phi(t)) (x_body - p) + d(t), with
phi(t) = omega t + Phi (sin(2 pi f t + psi) - sin psi) and d(t) = A (sin(2 pi f t + psi) - sin psi),
with t counted from the motion's start time (the body rests at its given pose before it).
That one form covers a fixed wall, a drum turning at constant speed, a jar shaken along a
line and a jar swinging on an arc about a pivot (the MM400).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

PLANE, CYLINDER, CAPSULE = 0, 1, 2


@dataclass(frozen=True)
class Plane:
    """Infinite plane through `point_m`; `normal` points into the particles' side."""

    point_m: tuple[float, float, float]
    normal: tuple[float, float, float]


@dataclass(frozen=True)
class Cylinder:
    """Inside of a cylinder (no ends): axis through `center_m` along `axis`, radius, half length (m)."""

    center_m: tuple[float, float, float]
    axis: tuple[float, float, float]
    radius_m: float
    half_length_m: float


@dataclass(frozen=True)
class Capsule:
    """Inside of a cylinder with hemispherical ends; half_length_m is that of the straight part."""

    center_m: tuple[float, float, float]
    axis: tuple[float, float, float]
    radius_m: float
    half_length_m: float


@dataclass(frozen=True)
class Mesh:
    """Triangle mesh (body frame, m): vertices (V, 3) and faces (F, 3) as nested tuples."""

    vertices_m: np.ndarray
    faces: np.ndarray

    @classmethod
    def from_stl(cls, path: str | Path, scale: float = 1.0) -> Mesh:
        """Read an STL file (any units; `scale` converts to m) with trimesh."""
        import trimesh

        mesh = trimesh.load_mesh(str(path), force="mesh")
        return cls(np.asarray(mesh.vertices, dtype=float) * scale, np.asarray(mesh.faces, dtype=np.int64))

    @property
    def triangles(self) -> np.ndarray:
        """(F, 3, 3) corner coordinates."""
        return self.vertices_m[self.faces]


@dataclass(frozen=True)
class Motion:
    """Prescribed rigid motion (see module docstring); SI units, angles in rad."""

    pivot_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    angular_velocity_rad_per_s: float = 0.0
    angle_amplitude_rad: float = 0.0
    translation_amplitude_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frequency_hz: float = 0.0
    phase_rad: float = 0.0
    start_time_s: float = 0.0  # the body rests before this time (e.g. while a charge settles)

    def place(self, t_s: float, points_m) -> np.ndarray:
        """World positions (m) at time t_s of body-frame points (..., 3): numpy twin of the engine's pose."""
        from scipy.spatial.transform import Rotation

        tau = max(t_s - self.start_time_s, 0.0)
        osc = np.sin(2 * np.pi * self.frequency_hz * tau + self.phase_rad) - np.sin(self.phase_rad)
        angle = self.angular_velocity_rad_per_s * tau + self.angle_amplitude_rad * osc
        axis = np.asarray(self.axis, float) / np.linalg.norm(self.axis)
        rot = Rotation.from_rotvec(angle * axis).as_matrix()
        pivot = np.asarray(self.pivot_m, float)
        return pivot + (np.asarray(points_m, float) - pivot) @ rot.T + np.asarray(self.translation_amplitude_m) * osc


@dataclass(frozen=True)
class Body:
    """Walls moving together; `motions` holds one Motion per replica (or one for all)."""

    name: str
    material: str
    walls: tuple = ()
    motions: tuple[Motion, ...] = field(default_factory=lambda: (Motion(),))

    def motion(self, replica: int) -> Motion:
        """The body's motion in that replica."""
        return self.motions[replica if len(self.motions) > 1 else 0]
