"""Particle state (struct of arrays, SI) and the velocity Verlet integrator.

A step is LIGGGHTS' initial/final integrate: kick_drift (half kick, drift), forces at the
new positions, kick (second half kick).
"""

import math

import numpy as np
import taichi as ti

from . import layout
from .transfer import write_fields


def capacity(n: int) -> int:
    """Slots allocated for n items (particles, grid cells): the next power of two up to 8,192
    (at least 64), above that the next multiple of an eighth of the power of two below (at most
    12.5 % spare).  Taichi compiles a kernel for the shapes of the fields it touches: systems of
    one capacity share compiled kernels (a sweep's mills, once per capacity instead of per mill)."""
    if n <= 8192:
        return max(64, 1 << max(n - 1, 0).bit_length())
    step = 1 << (n.bit_length() - 4)
    return -(-n // step) * step


def padded(values, cap: int) -> np.ndarray:
    """values (first axis n) with zero rows appended up to cap."""
    values = np.asarray(values)
    return np.concatenate([values, np.zeros((cap - len(values), *values.shape[1:]), values.dtype)])


@ti.data_oriented
class Particles:
    """Positions, velocities, spins, forces and constants of n spheres, sorted by replica, in
    fields of `cap` = capacity(n) slots; kernels loop over the first `live[None]` = n."""

    STATE = ("x", "v", "w", "f", "tq")  # what a saved run keeps (the rest is the spec's)

    def __init__(self, spec):
        n, reps = spec.n_particles, spec.n_replicas
        counts = np.bincount(spec.replica, minlength=reps)
        self.n, self.n_rep, self.counts = n, reps, counts
        self.cap = cap = capacity(n)
        self.live = layout.scalar(ti.i32, ())
        # what a contact reads of a partner, in one record; then what the integrator adds
        self.x, self.v, self.w = layout.vector(3, float), layout.vector(3, float), layout.vector(3, float)
        self.rad, self.mass, self.mat = layout.scalar(float), layout.scalar(float), layout.scalar(ti.i32)
        layout.records(cap, self.x, self.v, self.w, self.rad, self.mass, self.mat)
        self.f, self.tq, self.inertia = layout.vector(3, float), layout.vector(3, float), layout.scalar(float)
        layout.records(cap, self.f, self.tq, self.inertia)
        self.rep = layout.scalar(ti.i32, cap)
        self.rep_start = layout.scalar(ti.i32, reps)
        self.rep_end = layout.scalar(ti.i32, reps)
        self.gravity = layout.vector(3, float, ())
        self.dt = layout.scalar(float, ())
        self.domain_lo = layout.vector(3, float, ())
        self.domain_hi = layout.vector(3, float, ())
        density = np.array([spec.materials[m].density_kg_per_m3 for m in spec.material_names])[spec.material]
        self.mass_np = density * 4.0 / 3.0 * math.pi * spec.radius_m**3
        ends = np.cumsum(counts)
        write_fields([*((field, padded(values, cap)) for field, values in (
            (self.x, spec.position_m), (self.v, spec.velocity_m_per_s), (self.w, spec.angular_velocity_rad_per_s),
            (self.rad, spec.radius_m), (self.mass, self.mass_np), (self.inertia, 0.4 * self.mass_np * spec.radius_m**2),
            (self.mat, spec.material.astype(np.int32)), (self.rep, spec.replica.astype(np.int32)))),
            (self.rep_start, (ends - counts).astype(np.int32)), (self.rep_end, ends.astype(np.int32))])
        self.live[None] = self.n
        self.gravity[None] = spec.gravity_m_per_s2
        self.domain_lo[None], self.domain_hi[None] = spec.domain_lo_m, spec.domain_hi_m

    @ti.func
    def export_kinematics(self, out: ti.template()):
        """Positions, velocities and spins into out[0], out[1], out[2] ((3, n, 3); inside a kernel)."""
        for i in range(self.live[None]):
            for c in ti.static(range(3)):
                out[0, i, c], out[1, i, c], out[2, i, c] = self.x[i][c], self.v[i][c], self.w[i][c]

    # Each update below is a plain load and store, never `field[i] += ...`: only i's own thread
    # writes i, but Taichi makes `+=` on a field an atomic add (a compare-and-swap loop per
    # component) unless i is the parallel loop's own index, and the serial and team launches
    # compute i inside their loop: 15 such loops a particle-step took ~30 % of a step's time.
    @ti.func
    def kick(self, i):
        """Half a velocity step with the current force and torque."""
        dt = self.dt[None]
        self.v[i] = self.v[i] + 0.5 * dt * self.f[i] / self.mass[i]
        self.w[i] = self.w[i] + 0.5 * dt * self.tq[i] / self.inertia[i]

    @ti.func
    def kick_drift(self, i, monitor):
        self.kick(i)
        self.x[i] = self.x[i] + self.dt[None] * self.v[i]
        if not all(self.domain_lo[None] <= self.x[i] <= self.domain_hi[None]):
            ti.atomic_max(monitor.escaped[None], i + 1)

    @ti.func
    def next_position(self, i):
        """Where the next kick_drift will put particle i (m), for the neighbour-list trigger."""
        dt = self.dt[None]
        return self.x[i] + dt * (self.v[i] + 0.5 * dt * self.f[i] / self.mass[i])
