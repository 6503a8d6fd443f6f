"""Wall motion: the pose of every body of every replica at time t, and frame changes.

The motion form is that of `geometry.Motion`: x_world = p + R(a, phi(t)) (x_body - p) + d(t).
The pose is evaluated once per step per (replica, body); particles then use its rotation
matrix, so no trigonometry is done per particle.
"""

import math

import numpy as np
import taichi as ti
from taichi.lang.util import to_numpy_type

from . import layout
from .transfer import write_fields


@ti.data_oriented
class Motions:
    """Prescribed rigid motions of `n_body` bodies in `n_rep` replicas and their current pose."""

    def __init__(self, spec, n_rep: int):
        r, b = n_rep, max(len(spec.bodies), 1)
        self.n_rep, self.n_body = n_rep, len(spec.bodies)
        self.pivot = layout.vector(3, float, (r, b))
        self.axis = layout.vector(3, float, (r, b))
        self.trans = layout.vector(3, float, (r, b))
        self.omega = layout.scalar(float, (r, b))
        self.amp = layout.scalar(float, (r, b))
        self.freq = layout.scalar(float, (r, b))
        self.phase = layout.scalar(float, (r, b))
        self.start = layout.scalar(float, (r, b))
        # current pose: rotation matrix, displacement d and its rate, angular velocity
        self.rot = layout.matrix(3, 3, float, (r, b))
        self.d = layout.vector(3, float, (r, b))
        self.vd = layout.vector(3, float, (r, b))
        self.w = layout.vector(3, float, (r, b))
        rows = {k: np.zeros((r, b) + s) for k, s in
                (("pivot", (3,)), ("axis", (3,)), ("trans", (3,)), ("omega", ()), ("amp", ()), ("freq", ()),
                 ("phase", ()), ("start", ()))}
        rows["axis"][..., 2] = 1.0
        for k, body in enumerate(spec.bodies):
            for rep in range(r):
                m = body.motion(rep)
                rows["pivot"][rep, k], rows["axis"][rep, k] = m.pivot_m, unit(m.axis)
                rows["trans"][rep, k] = m.translation_amplitude_m
                rows["omega"][rep, k], rows["amp"][rep, k] = m.angular_velocity_rad_per_s, m.angle_amplitude_rad
                rows["freq"][rep, k], rows["phase"][rep, k] = m.frequency_hz, m.phase_rad
                rows["start"][rep, k] = m.start_time_s
        write_fields([(getattr(self, name), values) for name, values in rows.items()])
        self.axis_np = rows["axis"].astype(to_numpy_type(self.axis.dtype))  # (replicas, bodies, 3) world axes (constant)

    @ti.func
    def pose(self, r, b, t_abs):
        """Set the pose of body b of replica r at time t_abs (s)."""
        t = ti.max(t_abs - self.start[r, b], 0.0)
        moving = 1.0 if t_abs > self.start[r, b] else 0.0
        om = 2.0 * math.pi * self.freq[r, b]
        arg = om * t + self.phase[r, b]
        osc = ti.sin(arg) - ti.sin(self.phase[r, b])
        angle = self.omega[r, b] * t + self.amp[r, b] * osc
        a = self.axis[r, b]
        c, s = ti.cos(angle), ti.sin(angle)
        cross = ti.Matrix([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
        self.rot[r, b] = c * ti.Matrix.identity(float, 3) + s * cross + (1.0 - c) * a.outer_product(a)
        self.w[r, b] = moving * (self.omega[r, b] + self.amp[r, b] * om * ti.cos(arg)) * a
        self.d[r, b] = self.trans[r, b] * osc
        self.vd[r, b] = moving * self.trans[r, b] * om * ti.cos(arg)

    @ti.func
    def to_body(self, r, b, x):
        """World point -> body frame."""
        piv = self.pivot[r, b]
        return piv + self.rot[r, b].transpose() @ (x - self.d[r, b] - piv)

    @ti.func
    def point_to_world(self, r, b, xb):
        piv = self.pivot[r, b]
        return piv + self.d[r, b] + self.rot[r, b] @ (xb - piv)

    @ti.func
    def vector_to_world(self, r, b, vb):
        return self.rot[r, b] @ vb

    @ti.func
    def velocity_at(self, r, b, c):
        """Velocity (m/s) of the body's material point at world point c."""
        return self.vd[r, b] + self.w[r, b].cross(c - self.pivot[r, b] - self.d[r, b])

    @ti.func
    def lever(self, r, b, c):
        """Arm from the body's moving pivot to world point c (for torque about the axis)."""
        return c - self.pivot[r, b] - self.d[r, b]


def unit(v) -> tuple[float, float, float]:
    a = np.asarray(v, float)
    return tuple(a / np.linalg.norm(a))
