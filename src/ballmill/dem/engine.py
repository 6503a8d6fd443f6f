"""The DEM engine: Taichi fields, the per-step kernels and the run loop.

Two ways to find neighbours, chosen once per system (`Engine.use_grid`):
- grid: a cell list rebuilt every step, parallel over particles (one large system);
- replicas: all pairs inside each replica, parallel over replicas, many steps per launch
  (a batch of small independent systems such as a calibration grid of 1-2-ball jars).
Both call the same per-particle functions, so both are verified by the same tests.

Forces are gathered per particle in a fixed order (each pair is evaluated from both sides
in canonical order, so the two forces are exact negatives): results do not depend on
thread scheduling.  Integration is velocity Verlet (LIGGGHTS' initial/final integrate).
"""


import logging
import math
import time
from dataclasses import dataclass

import numpy as np
import taichi as ti

from .contact import closest_point_on_triangle, hertz_mindlin, rolling_torque, rotate, wall_geometry
from .geometry import CAPSULE, CYLINDER, PLANE, Capsule, Cylinder, Mesh, Plane
from .materials import damping_ratio_for_restitution, effective_shear_modulus, effective_youngs_modulus
from .results import Recorder, Results
from .system import SystemSpec

log = logging.getLogger(__name__)


class SimulationError(RuntimeError):
    """The run went unphysical; the message says what happened and what to change."""


@dataclass(frozen=True)
class EngineOptions:
    """Numerical settings (SI).  dt_s is the time step actually used."""

    dt_s: float
    max_contacts_per_particle: int = 16
    event_capacity: int = 200_000
    max_overlap_fraction: float = 0.05
    grid: bool | None = None  # None: cell list when some replica has more than 8 particles
    collision_log: bool = True  # False compiles the collision log out (dense beds make millions)
    progress_every_s: float = 30.0


@ti.data_oriented
class Engine:
    """A Taichi DEM system built from a SystemSpec; Taichi must already be initialised."""

    def __init__(self, spec: SystemSpec, options: EngineOptions):
        self.spec = spec
        self.opt = options
        self.dt = options.dt_s
        n, reps = spec.n_particles, spec.n_replicas
        counts = np.bincount(spec.replica, minlength=reps)
        self.use_grid = bool(counts.max() > 8) if options.grid is None else options.grid
        self.n, self.n_rep, self.n_body = n, reps, len(spec.bodies)
        self.n_mat = len(spec.material_names)
        self.k_max = options.max_contacts_per_particle
        self._build_particles(counts)
        self._build_pairs()
        self._build_walls()
        self._build_grid()
        self._build_contacts_and_observers()
        self.step_index = 0
        self._accumulated_steps = 0
        self._poses(0.0)
        self._grid_update()
        self._forces(0)
        self._accumulated_steps = 1

    # ---------------------------------------------------------------- set-up
    def _build_particles(self, counts: np.ndarray) -> None:
        s, n = self.spec, self.n
        self.x = ti.Vector.field(3, float, n)
        self.v = ti.Vector.field(3, float, n)
        self.w = ti.Vector.field(3, float, n)
        self.f = ti.Vector.field(3, float, n)
        self.tq = ti.Vector.field(3, float, n)
        self.rad = ti.field(float, n)
        self.mass = ti.field(float, n)
        self.inertia = ti.field(float, n)
        self.mat = ti.field(ti.i32, n)
        self.rep = ti.field(ti.i32, n)
        self.rep_start = ti.field(ti.i32, self.n_rep)
        self.rep_end = ti.field(ti.i32, self.n_rep)
        self.gravity = ti.Vector.field(3, float, ())
        density = np.array([s.materials[m].density_kg_per_m3 for m in s.material_names])[s.material]
        mass = density * 4.0 / 3.0 * math.pi * s.radius_m**3
        self.mass_np = mass
        self.x.from_numpy(s.position_m)
        self.v.from_numpy(s.velocity_m_per_s)
        self.w.from_numpy(s.angular_velocity_rad_per_s)
        self.rad.from_numpy(s.radius_m)
        self.mass.from_numpy(mass)
        self.inertia.from_numpy(0.4 * mass * s.radius_m**2)
        self.mat.from_numpy(s.material.astype(np.int32))
        self.rep.from_numpy(s.replica.astype(np.int32))
        ends = np.cumsum(counts)
        self.rep_start.from_numpy((ends - counts).astype(np.int32))
        self.rep_end.from_numpy(ends.astype(np.int32))
        self.gravity[None] = s.gravity_m_per_s2
        self.dt_field = ti.field(float, ())
        self.dt_field[None] = self.dt

    def _build_pairs(self) -> None:
        s, m, r = self.spec, self.n_mat, self.n_rep
        mats = [s.materials[k] for k in s.material_names]
        self.e_star = ti.field(float, (m, m))
        self.g_star = ti.field(float, (m, m))
        self.zeta = ti.field(float, (r, m, m))
        self.mu_s = ti.field(float, (r, m, m))
        self.mu_r = ti.field(float, (r, m, m))
        self.e_star.from_numpy(np.array([[effective_youngs_modulus(a, b) for b in mats] for a in mats]))
        self.g_star.from_numpy(np.array([[effective_shear_modulus(a, b) for b in mats] for a in mats]))
        zeta, mu_s, mu_r = (np.zeros((r, m, m)) for _ in range(3))
        particle_mats = set(np.unique(s.material).tolist())
        for rep in range(r):
            for a in range(m):
                for b in range(m):
                    if a not in particle_mats and b not in particle_mats:
                        continue  # wall-wall: never in contact
                    pair = s.interaction(rep, s.material_names[a], s.material_names[b])
                    zeta[rep, a, b] = damping_ratio_for_restitution(pair.restitution)
                    mu_s[rep, a, b] = pair.static_friction
                    mu_r[rep, a, b] = pair.rolling_friction
        self.zeta.from_numpy(zeta)
        self.mu_s.from_numpy(mu_s)
        self.mu_r.from_numpy(mu_r)

    def _build_walls(self) -> None:
        s = self.spec
        kinds = {Plane: PLANE, Cylinder: CYLINDER, Capsule: CAPSULE}
        rows, tris, tri_body, tri_mat, meshes = [], [], [], [], []
        for b, body in enumerate(s.bodies):
            mat = s.material_names.index(body.material)
            for wall in body.walls:
                if isinstance(wall, Mesh):
                    meshes.append((b, len(tris), wall))
                    tris.extend(wall.triangles)
                    tri_body += [b] * len(wall.faces)
                    tri_mat += [mat] * len(wall.faces)
                elif isinstance(wall, Plane):
                    rows.append((PLANE, b, mat, wall.point_m, _unit(wall.normal), 0.0, 0.0))
                else:
                    rows.append(
                        (kinds[type(wall)], b, mat, wall.center_m, _unit(wall.axis), wall.radius_m, wall.half_length_m)
                    )
        self.n_wall, self.n_tri, self.n_mesh = len(rows), len(tris), len(meshes)
        nw = max(self.n_wall, 1)
        self.w_kind = ti.field(ti.i32, nw)
        self.w_body = ti.field(ti.i32, nw)
        self.w_mat = ti.field(ti.i32, nw)
        self.w_point = ti.Vector.field(3, float, nw)
        self.w_axis = ti.Vector.field(3, float, nw)
        self.w_radius = ti.field(float, nw)
        self.w_half = ti.field(float, nw)
        for k, (kind, b, mat, point, axis, radius, half) in enumerate(rows):
            self.w_kind[k], self.w_body[k], self.w_mat[k] = kind, b, mat
            self.w_point[k], self.w_axis[k] = point, axis
            self.w_radius[k], self.w_half[k] = radius, half
        self._build_meshes(np.array(tris).reshape(-1, 3, 3), tri_body, tri_mat, meshes)
        self._build_motions()

    def _build_meshes(self, tris, tri_body, tri_mat, meshes) -> None:
        """Triangles in body frame, binned per mesh in a uniform grid (CSR) of cell >= 2 r_max."""
        nt, nm = max(self.n_tri, 1), max(self.n_mesh, 1)
        self.t_corner = ti.Vector.field(3, float, (nt, 3))
        self.t_body = ti.field(ti.i32, nt)
        self.t_mat = ti.field(ti.i32, nt)
        self.m_body = ti.field(ti.i32, nm)
        self.m_tri0 = ti.field(ti.i32, nm)
        self.m_tri1 = ti.field(ti.i32, nm)
        self.m_lo = ti.Vector.field(3, float, nm)
        self.m_dims = ti.Vector.field(3, ti.i32, nm)
        self.m_cell0 = ti.field(ti.i32, nm)
        self.m_h = ti.field(float, nm)
        starts, ids, cell0 = [0], [], 0
        reach = 2.0 * float(self.spec.radius_m.max())
        for k, (b, t0, mesh) in enumerate(meshes):
            corners = mesh.triangles
            lo = corners.min(axis=(0, 1)) - reach
            hi = corners.max(axis=(0, 1)) + reach
            h = max(reach, float((hi - lo).max()) / 64.0)
            dims = np.maximum(np.ceil((hi - lo) / h).astype(int), 1)
            tlo = np.floor((corners.min(axis=1) - reach / 2 - lo) / h).astype(int).clip(0, dims - 1)
            thi = np.floor((corners.max(axis=1) + reach / 2 - lo) / h).astype(int).clip(0, dims - 1)
            cells = [[] for _ in range(int(np.prod(dims)))]
            for t in range(len(corners)):
                for cx in range(tlo[t, 0], thi[t, 0] + 1):
                    for cy in range(tlo[t, 1], thi[t, 1] + 1):
                        for cz in range(tlo[t, 2], thi[t, 2] + 1):
                            cells[(cx * dims[1] + cy) * dims[2] + cz].append(t0 + t)
            for c in cells:
                ids.extend(c)
                starts.append(len(ids))
            self.m_body[k], self.m_tri0[k], self.m_tri1[k] = b, t0, t0 + len(corners)
            self.m_lo[k], self.m_dims[k], self.m_cell0[k], self.m_h[k] = lo, dims, cell0, h
            cell0 += len(cells)
        self.mc_start = ti.field(ti.i32, len(starts))
        self.mc_tris = ti.field(ti.i32, max(len(ids), 1))
        self.mc_start.from_numpy(np.array(starts, dtype=np.int32))
        if ids:
            self.mc_tris.from_numpy(np.array(ids, dtype=np.int32))
        if self.n_tri:
            self.t_corner.from_numpy(tris)
            self.t_body.from_numpy(np.array(tri_body, dtype=np.int32))
            self.t_mat.from_numpy(np.array(tri_mat, dtype=np.int32))

    def _build_motions(self) -> None:
        r, b = self.n_rep, max(self.n_body, 1)
        self.mo_pivot = ti.Vector.field(3, float, (r, b))
        self.mo_axis = ti.Vector.field(3, float, (r, b))
        self.mo_trans = ti.Vector.field(3, float, (r, b))
        self.mo_omega = ti.field(float, (r, b))
        self.mo_amp = ti.field(float, (r, b))
        self.mo_freq = ti.field(float, (r, b))
        self.mo_phase = ti.field(float, (r, b))
        self.mo_start = ti.field(float, (r, b))
        # pose: x_world = rot(x_body - pivot) + pivot + d; wall velocity = vd + W x (x - pivot - d)
        self.po_angle = ti.field(float, (r, b))
        self.po_d = ti.Vector.field(3, float, (r, b))
        self.po_vd = ti.Vector.field(3, float, (r, b))
        self.po_w = ti.Vector.field(3, float, (r, b))
        for k, body in enumerate(self.spec.bodies):
            for rep in range(r):
                m = body.motions[rep if len(body.motions) > 1 else 0]
                self.mo_pivot[rep, k], self.mo_axis[rep, k] = m.pivot_m, _unit(m.axis)
                self.mo_trans[rep, k] = m.translation_amplitude_m
                self.mo_omega[rep, k], self.mo_amp[rep, k] = m.angular_velocity_rad_per_s, m.angle_amplitude_rad
                self.mo_freq[rep, k], self.mo_phase[rep, k] = m.frequency_hz, m.phase_rad
                self.mo_start[rep, k] = m.start_time_s

    def _build_grid(self) -> None:
        s = self.spec
        self.h = 2.0 * float(s.radius_m.max())
        lo, hi = np.asarray(s.domain_lo_m, float), np.asarray(s.domain_hi_m, float)
        dims = np.maximum(np.ceil((hi - lo) / self.h).astype(int), 1) if self.use_grid else np.ones(3, int)
        self.dims = tuple(int(d) for d in dims)
        n_cells = int(np.prod(dims)) * self.n_rep
        r_min = float(s.radius_m.min())
        self.cell_cap = math.ceil(0.7405 * self.h**3 / (4.0 / 3.0 * math.pi * r_min**3)) + 4
        self.domain_lo = ti.Vector.field(3, float, ())
        self.domain_hi = ti.Vector.field(3, float, ())
        self.domain_lo[None], self.domain_hi[None] = lo, hi
        self.cell_count = ti.field(ti.i32, n_cells)
        self.cell_list = ti.field(ti.i32, (n_cells, self.cell_cap))

    def _build_contacts_and_observers(self) -> None:
        n, k, b = self.n, self.k_max, max(self.n_body, 1)
        self.c_n = ti.field(ti.i32, (2, n))
        self.c_key = ti.field(ti.i32, (2, n, k))
        self.c_xi = ti.Vector.field(3, float, (2, n, k))
        self.c_start = ti.field(ti.i32, (2, n, k))
        self.c_vn = ti.field(float, (2, n, k))
        self.c_ed = ti.field(float, (2, n, k))
        self.acc_f = ti.Vector.field(3, float, (n, b))
        self.acc_tq = ti.Vector.field(3, float, (n, b))
        self.acc_tq_roll = ti.Vector.field(3, float, (n, b))
        self.acc_pw = ti.field(float, (n, b))
        self.acc_pw_roll = ti.field(float, (n, b))
        cap = self.opt.event_capacity
        self.ev_count = ti.field(ti.i32, ())
        self.ev_int = ti.Vector.field(4, ti.i32, cap)  # particle, partner key, start step, end step
        self.ev_val = ti.Vector.field(2, float, cap)  # impact normal speed, energy dissipated
        self.max_overlap = ti.field(float, ())
        self.escaped = ti.field(ti.i32, ())
        self.overflow = ti.field(ti.i32, ())  # 1 contact slots, 2 grid cell

    # ---------------------------------------------------------------- wall motion
    @ti.func
    def pose(self, r, b, t_abs):
        """Set the pose of body b of replica r at time t_abs (s)."""
        t = ti.max(t_abs - self.mo_start[r, b], 0.0)
        moving = 1.0 if t_abs > self.mo_start[r, b] else 0.0
        arg = 2.0 * math.pi * self.mo_freq[r, b] * t + self.mo_phase[r, b]
        om = 2.0 * math.pi * self.mo_freq[r, b]
        self.po_angle[r, b] = self.mo_omega[r, b] * t + self.mo_amp[r, b] * (ti.sin(arg) - ti.sin(self.mo_phase[r, b]))
        self.po_w[r, b] = moving * (self.mo_omega[r, b] + self.mo_amp[r, b] * om * ti.cos(arg)) * self.mo_axis[r, b]
        self.po_d[r, b] = self.mo_trans[r, b] * (ti.sin(arg) - ti.sin(self.mo_phase[r, b]))
        self.po_vd[r, b] = moving * self.mo_trans[r, b] * om * ti.cos(arg)

    @ti.func
    def to_body(self, r, b, x):
        piv = self.mo_pivot[r, b]
        return piv + rotate(x - self.po_d[r, b] - piv, self.mo_axis[r, b], -self.po_angle[r, b])

    @ti.func
    def to_world(self, r, b, xb, is_point):
        piv = self.mo_pivot[r, b]
        out = rotate(xb - piv * is_point, self.mo_axis[r, b], self.po_angle[r, b])
        return out + (piv + self.po_d[r, b]) * is_point

    # ---------------------------------------------------------------- contact bookkeeping
    @ti.func
    def find_slot(self, i, old, key):
        slot = -1
        for s in range(self.c_n[old, i]):
            if self.c_key[old, i, s] == key:
                slot = s
        return slot

    @ti.func
    def store(self, i, new, cnt, key, xi, start, vn, ed):
        if cnt < self.k_max:
            self.c_key[new, i, cnt] = key
            self.c_xi[new, i, cnt] = xi
            self.c_start[new, i, cnt] = start
            self.c_vn[new, i, cnt] = vn
            self.c_ed[new, i, cnt] = ed
        else:
            self.overflow[None] = 1
        return cnt + 1

    @ti.func
    def partner_class(self, key):
        """Key of the partner for collision bookkeeping: triangles collapse to their mesh."""
        out = key
        if ti.static(self.n_mesh > 0) and key >= self.n + self.n_wall:
            t = key - self.n - self.n_wall
            for m in range(self.n_mesh):
                if self.m_tri0[m] <= t < self.m_tri1[m]:
                    out = self.n + self.n_wall + self.n_tri + m
        return out

    # ---------------------------------------------------------------- contacts of one particle
    @ti.func
    def pair(self, i, j, old, new, cnt, k):
        """Contact of particle i with particle j: (force on i, torque on i, slot count)."""
        f_i = ti.Vector([0.0, 0.0, 0.0])
        t_i = ti.Vector([0.0, 0.0, 0.0])
        a, b = ti.min(i, j), ti.max(i, j)
        d = self.x[b] - self.x[a]
        dist = d.norm()
        delta = self.rad[a] + self.rad[b] - dist
        if delta > 0.0 and dist > 0.0:
            n = d / dist
            ca, cb = self.rad[a] - 0.5 * delta, self.rad[b] - 0.5 * delta
            v_rel = self.v[a] + self.w[a].cross(ca * n) - self.v[b] - self.w[b].cross(-cb * n)
            sgn = 1.0 if i == a else -1.0
            slot = self.find_slot(i, old, j)
            xi = ti.Vector([0.0, 0.0, 0.0])
            start, vn0, ed = k, v_rel.dot(n), 0.0
            if slot >= 0:
                xi = sgn * self.c_xi[old, i, slot]
                start, vn0, ed = self.c_start[old, i, slot], self.c_vn[old, i, slot], self.c_ed[old, i, slot]
            r, ma, mb = self.rep[i], self.mat[a], self.mat[b]
            m_eff = self.mass[a] * self.mass[b] / (self.mass[a] + self.mass[b])
            r_eff = self.rad[a] * self.rad[b] / (self.rad[a] + self.rad[b])
            fn, ft, xi, loss = hertz_mindlin(
                delta, n, v_rel, xi, m_eff, r_eff, self.e_star[ma, mb], self.g_star[ma, mb],
                self.zeta[r, ma, mb], self.mu_s[r, ma, mb], self.dt_field[None],
            )
            mu_r = self.mu_r[r, ma, mb]
            roll_a = rolling_torque(fn, mu_r, self.rad[a], self.w[a] - self.w[b])
            roll_b = rolling_torque(fn, mu_r, self.rad[b], self.w[b] - self.w[a])
            f_a = -fn * n + ft
            loss -= roll_a.dot(self.w[a]) + roll_b.dot(self.w[b])
            f_i = sgn * f_a
            t_i = (ca * n).cross(ft) + roll_a
            if i == b:
                t_i = (cb * n).cross(ft) + roll_b
            ti.atomic_max(self.max_overlap[None], delta / ti.min(self.rad[a], self.rad[b]))
            cnt = self.store(i, new, cnt, j, sgn * xi, start, vn0, ed + loss * self.dt_field[None])
        return f_i, t_i, cnt

    @ti.func
    def wall_contact(self, i, key, b, mat, delta, nb, cb, old, new, cnt, k, slot):
        """Contact of particle i with a wall of body b found in body frame: (force, torque, count)."""
        r = self.rep[i]
        n = self.to_world(r, b, nb, 0.0)
        c = self.to_world(r, b, cb, 1.0)
        piv = self.mo_pivot[r, b] + self.po_d[r, b]
        w_wall = self.po_w[r, b]
        v_wall = self.po_vd[r, b] + w_wall.cross(c - piv)
        arm = c - self.x[i]
        v_rel = self.v[i] + self.w[i].cross(arm) - v_wall
        xi = ti.Vector([0.0, 0.0, 0.0])
        start, vn0, ed = k, v_rel.dot(n), 0.0
        if slot >= 0:
            xi = self.c_xi[old, i, slot]
            start, vn0, ed = self.c_start[old, i, slot], self.c_vn[old, i, slot], self.c_ed[old, i, slot]
        mi = self.mat[i]
        fn, ft, xi, loss = hertz_mindlin(
            delta, n, v_rel, xi, self.mass[i], self.rad[i], self.e_star[mi, mat], self.g_star[mi, mat],
            self.zeta[r, mi, mat], self.mu_s[r, mi, mat], self.dt_field[None],
        )
        roll = rolling_torque(fn, self.mu_r[r, mi, mat], self.rad[i], self.w[i] - w_wall)
        f_i = -fn * n + ft
        self.acc_f[i, b] += -f_i
        self.acc_tq[i, b] += (c - piv).cross(-f_i)
        self.acc_tq_roll[i, b] += -roll
        self.acc_pw[i, b] += f_i.dot(v_wall)
        self.acc_pw_roll[i, b] += roll.dot(w_wall)
        loss -= roll.dot(self.w[i] - w_wall)
        ti.atomic_max(self.max_overlap[None], delta / self.rad[i])
        cnt = self.store(i, new, cnt, key, xi, start, vn0, ed + loss * self.dt_field[None])
        return f_i, arm.cross(ft) + roll, cnt

    @ti.func
    def mesh_slot(self, i, old, key, m, xb):
        """History slot for a triangle contact: the triangle's own, else one inherited from a
        triangle of the same mesh the particle has left (a ball rolling across facets)."""
        slot = self.find_slot(i, old, key)
        if slot < 0:
            base = self.n + self.n_wall
            for s in range(self.c_n[old, i]):
                t = self.c_key[old, i, s] - base
                if slot < 0 and self.m_tri0[m] <= t < self.m_tri1[m]:
                    q, _ = closest_point_on_triangle(xb, self.t_corner[t, 0], self.t_corner[t, 1], self.t_corner[t, 2])
                    if (q - xb).norm() >= self.rad[i]:
                        slot = s
        return slot

    @ti.func
    def mesh_contacts(self, i, m, old, new, cnt, k):
        """Face contacts with every triangle touched; if none, the deepest edge/vertex contact.

        One pass over the triangles of the particle's cell plus one extra iteration that
        resolves the deepest edge/vertex contact, so the contact code is compiled once.
        """
        f_i = ti.Vector([0.0, 0.0, 0.0])
        t_i = ti.Vector([0.0, 0.0, 0.0])
        b = self.m_body[m]
        xb = self.to_body(self.rep[i], b, self.x[i])
        rad = self.rad[i]
        cell = ti.floor((xb - self.m_lo[m]) / self.m_h[m], ti.i32)
        dims = self.m_dims[m]
        if 0 <= cell[0] < dims[0] and 0 <= cell[1] < dims[1] and 0 <= cell[2] < dims[2]:
            c = self.m_cell0[m] + (cell[0] * dims[1] + cell[1]) * dims[2] + cell[2]
            faces, best_t, best_delta = 0, -1, 0.0
            q_end = self.mc_start[c + 1]
            for q in range(self.mc_start[c], q_end + 1):
                t = best_t
                if q < q_end:
                    t = self.mc_tris[q]
                if t >= 0 and (q < q_end or faces == 0):
                    p, face = closest_point_on_triangle(xb, self.t_corner[t, 0], self.t_corner[t, 1], self.t_corner[t, 2])
                    d = p - xb
                    dist = d.norm()
                    delta = rad - dist
                    touch = delta > 0.0 and dist > 0.0 and (face == 1 or q == q_end)
                    if delta > best_delta and face == 0 and q < q_end:
                        best_t, best_delta = t, delta
                    if touch:
                        faces += face
                        key = self.n + self.n_wall + t
                        slot = self.mesh_slot(i, old, key, m, xb)
                        df, dt_, cnt = self.wall_contact(i, key, b, self.t_mat[t], delta, d / dist, p, old, new, cnt, k, slot)
                        f_i += df
                        t_i += dt_
        return f_i, t_i, cnt

    @ti.func
    def cell_of(self, i):
        rel = (self.x[i] - self.domain_lo[None]) / self.h
        cx = ti.min(ti.max(int(ti.floor(rel[0])), 0), self.dims[0] - 1)
        cy = ti.min(ti.max(int(ti.floor(rel[1])), 0), self.dims[1] - 1)
        cz = ti.min(ti.max(int(ti.floor(rel[2])), 0), self.dims[2] - 1)
        return ti.Vector([cx, cy, cz])

    @ti.func
    def cell_id(self, r, c):
        return ((r * self.dims[0] + c[0]) * self.dims[1] + c[1]) * self.dims[2] + c[2]

    @ti.func
    def particle_forces(self, i, k):
        """All contacts of particle i at step k: force, torque, contact list, finished collisions."""
        old, new = (k + 1) % 2, k % 2
        r = self.rep[i]
        f = self.mass[i] * self.gravity[None]
        t = ti.Vector([0.0, 0.0, 0.0])
        cnt = 0
        if ti.static(self.use_grid):
            c0 = self.cell_of(i)
            for o in range(27):  # a dynamic loop: the contact code is compiled once, not 27 times
                c = c0 + ti.Vector([o // 9 - 1, (o // 3) % 3 - 1, o % 3 - 1])
                if 0 <= c[0] < self.dims[0] and 0 <= c[1] < self.dims[1] and 0 <= c[2] < self.dims[2]:
                    cid = self.cell_id(r, c)
                    for q in range(ti.min(self.cell_count[cid], self.cell_cap)):
                        j = self.cell_list[cid, q]
                        if j != i:
                            df, dt_, cnt = self.pair(i, j, old, new, cnt, k)
                            f += df
                            t += dt_
        else:
            for j in range(self.rep_start[r], self.rep_end[r]):
                if j != i:
                    df, dt_, cnt = self.pair(i, j, old, new, cnt, k)
                    f += df
                    t += dt_
        for w in range(self.n_wall if ti.static(self.n_wall > 0) else 0):
            b = self.w_body[w]
            xb = self.to_body(r, b, self.x[i])
            delta, nb, cb = wall_geometry(
                self.w_kind[w], self.w_point[w], self.w_axis[w], self.w_radius[w], self.w_half[w], xb, self.rad[i]
            )
            if delta > 0.0:
                slot = self.find_slot(i, old, self.n + w)
                df, dt_, cnt = self.wall_contact(i, self.n + w, b, self.w_mat[w], delta, nb, cb, old, new, cnt, k, slot)
                f += df
                t += dt_
        if ti.static(self.n_mesh > 0):
            for m in range(self.n_mesh):
                df, dt_, cnt = self.mesh_contacts(i, m, old, new, cnt, k)
                f += df
                t += dt_
        self.c_n[new, i] = ti.min(cnt, self.k_max)
        self.f[i] = f
        self.tq[i] = t
        if ti.static(self.opt.collision_log):
            self.finish_collisions(i, old, new, k)

    @ti.func
    def finish_collisions(self, i, old, new, k):
        """Log contacts of i that ended at step k (pairs once, from the lower index)."""
        for s in range(self.c_n[old, i]):
            key = self.c_key[old, i, s]
            cls = self.partner_class(key)
            start = self.c_start[old, i, s]
            alive = False
            for s2 in range(self.c_n[new, i]):
                if self.c_start[new, i, s2] == start and self.partner_class(self.c_key[new, i, s2]) == cls:
                    alive = True
            if not alive and (key >= self.n or key > i):
                e = ti.atomic_add(self.ev_count[None], 1)
                if e < self.opt.event_capacity:
                    self.ev_int[e] = ti.Vector([i, cls, start, k])
                    self.ev_val[e] = ti.Vector([self.c_vn[old, i, s], self.c_ed[old, i, s]])

    @ti.func
    def kick(self, i):
        dt = self.dt_field[None]
        self.v[i] += 0.5 * dt * self.f[i] / self.mass[i]
        self.w[i] += 0.5 * dt * self.tq[i] / self.inertia[i]

    @ti.func
    def kick_drift(self, i):
        self.kick(i)
        self.x[i] += self.dt_field[None] * self.v[i]
        lo, hi = self.domain_lo[None], self.domain_hi[None]
        if not all(lo <= self.x[i] <= hi):
            ti.atomic_max(self.escaped[None], i + 1)

    # ---------------------------------------------------------------- kernels
    @ti.kernel
    def _poses(self, t: float):
        for r, b in ti.ndrange(self.n_rep, self.n_body):
            self.pose(r, b, t)

    @ti.kernel
    def _grid_fill(self):
        for c in self.cell_count:
            self.cell_count[c] = 0
        for i in self.x:
            cid = self.cell_id(self.rep[i], self.cell_of(i))
            s = ti.atomic_add(self.cell_count[cid], 1)
            if s < self.cell_cap:
                self.cell_list[cid, s] = i
            else:
                self.overflow[None] = 2

    @ti.kernel
    def _grid_sort(self):
        """Sort each cell's ids so that force sums do not depend on thread scheduling."""
        for c in self.cell_count:
            m = ti.min(self.cell_count[c], self.cell_cap)
            for a in range(1, m):
                key = self.cell_list[c, a]
                b = a - 1
                while b >= 0 and self.cell_list[c, b] > key:
                    self.cell_list[c, b + 1] = self.cell_list[c, b]
                    b -= 1
                self.cell_list[c, b + 1] = key

    @ti.kernel
    def _forces(self, k: ti.i32):
        for i in self.x:
            self.particle_forces(i, k)

    @ti.kernel
    def _kick_drift(self):
        for i in self.x:
            self.kick_drift(i)

    @ti.kernel
    def _kick(self):
        for i in self.x:
            self.kick(i)

    @ti.kernel
    def _replica_steps(self, k0: ti.i32, nsteps: ti.i32):
        """nsteps whole steps of every replica; parallel over replicas."""
        for r in range(self.n_rep):
            for s in range(nsteps):
                k = k0 + s + 1
                for i in range(self.rep_start[r], self.rep_end[r]):
                    self.kick_drift(i)
                for b in range(self.n_body):
                    self.pose(r, b, k * self.dt_field[None])
                for i in range(self.rep_start[r], self.rep_end[r]):
                    self.particle_forces(i, k)
                for i in range(self.rep_start[r], self.rep_end[r]):
                    self.kick(i)

    def _grid_update(self) -> None:
        if self.use_grid:
            self._grid_fill()
            self._grid_sort()

    # ---------------------------------------------------------------- driving
    def advance(self, nsteps: int) -> None:
        """Advance nsteps time steps."""
        if not self.use_grid:
            self._replica_steps(self.step_index, nsteps)
            self.step_index += nsteps
        else:
            for _ in range(nsteps):
                self._kick_drift()
                self.step_index += 1
                self._poses(self.step_index * self.dt)
                self._grid_update()
                self._forces(self.step_index)
                self._kick()
        self._accumulated_steps += nsteps

    def profile(self, nsteps: int) -> dict[str, float]:
        """Seconds spent per phase over nsteps grid-mode steps (each phase synchronised)."""
        spent = {"integrate": 0.0, "wall motion": 0.0, "cell list": 0.0, "contacts": 0.0}

        def timed(phase, call):
            t0 = time.perf_counter()
            call()
            ti.sync()
            spent[phase] += time.perf_counter() - t0

        for _ in range(nsteps):
            self.step_index += 1
            timed("integrate", self._kick_drift)
            timed("wall motion", lambda: self._poses(self.step_index * self.dt))
            timed("cell list", self._grid_update)
            timed("contacts", lambda: self._forces(self.step_index))
            timed("integrate", self._kick)
        self._accumulated_steps += nsteps
        return spent

    def contacts_per_particle(self) -> float:
        return float(self.c_n.to_numpy()[self.step_index % 2].mean())

    def run(self, duration_s: float, sample_every_s: float, recorder: Recorder | None = None,
            label: str = "run") -> Results:
        """Advance by duration_s, sampling every sample_every_s (rounded to whole steps)."""
        recorder = recorder or Recorder(self)
        per_sample = max(1, round(sample_every_s / self.dt))
        n_samples = max(1, round(duration_s / (per_sample * self.dt)))
        t_wall, last_log = time.perf_counter(), time.perf_counter()
        for s in range(n_samples):
            self.advance(per_sample)
            self.check()
            recorder.sample(self)
            now = time.perf_counter()
            if now - last_log > self.opt.progress_every_s or s == n_samples - 1:
                rate = (s + 1) * per_sample * self.n / (now - t_wall)
                log.info("%s: t=%.4f s (%d/%d samples), %.3g particle-steps/s", label,
                         self.time_s, s + 1, n_samples, rate)
                last_log = now
        return recorder.results()

    @property
    def time_s(self) -> float:
        return self.step_index * self.dt

    def check(self) -> None:
        """Stop with a clear message when the run went unphysical."""
        x = self.x.to_numpy()
        if not np.isfinite(x).all():
            raise SimulationError(
                f"non-finite particle position at t={self.time_s:.6g} s: reduce sim.dt_fraction "
                "(time step as a fraction of Rayleigh) or check material stiffness"
            )
        if self.escaped[None]:
            i = self.escaped[None] - 1
            raise SimulationError(
                f"particle {i} left the vessel's domain at t={self.time_s:.6g} s (position "
                f"{x[i].round(5).tolist()} m): the time step is too large for the wall speed "
                "or stiffness, or the particles were placed outside the walls"
            )
        if self.overflow[None]:
            what = ("sim.max_contacts_per_particle" if self.overflow[None] == 1 else "the cell capacity")
            raise SimulationError(f"a particle had more contacts than {what} allows at t={self.time_s:.6g} s")
        if self.max_overlap[None] > self.opt.max_overlap_fraction:
            raise SimulationError(
                f"overlap reached {100 * self.max_overlap[None]:.2f} % of a radius at t={self.time_s:.6g} s "
                f"(limit {100 * self.opt.max_overlap_fraction:.1f} %): reduce sim.dt_fraction, or "
                "raise the shear modulus if it was reduced for speed"
            )
        if self.ev_count[None] > self.opt.event_capacity:
            raise SimulationError(
                f"{self.ev_count[None]} collisions ended within one sample, more than "
                f"sim.event_capacity={self.opt.event_capacity}: raise it or sample more often"
            )

    @ti.kernel
    def _export_events(self, m: ti.i32, ints: ti.types.ndarray(), vals: ti.types.ndarray()):
        for e in range(m):
            for c in ti.static(range(4)):
                ints[e, c] = self.ev_int[e][c]
            for c in ti.static(range(2)):
                vals[e, c] = self.ev_val[e][c]
        self.ev_count[None] = 0

    @ti.kernel
    def _export_loads(self, out: ti.types.ndarray()):
        """Sum the per-particle wall-load accumulators per (replica, body), in particle order."""
        for r, b in ti.ndrange(self.n_rep, self.n_body):
            acc = ti.Vector([0.0] * 11)
            for i in range(self.rep_start[r], self.rep_end[r]):
                f, tq, tr = self.acc_f[i, b], self.acc_tq[i, b], self.acc_tq_roll[i, b]
                acc += ti.Vector([f[0], f[1], f[2], tq[0], tq[1], tq[2], tr[0], tr[1], tr[2],
                                  self.acc_pw[i, b], self.acc_pw_roll[i, b]])
                self.acc_f[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_tq[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_tq_roll[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_pw[i, b] = 0.0
                self.acc_pw_roll[i, b] = 0.0
            for c in ti.static(range(11)):
                out[r, b, c] = acc[c]

    def drain_events(self) -> tuple[np.ndarray, np.ndarray]:
        """Collisions ended since the last call: ints (i, partner, start, end step), values."""
        m = min(self.ev_count[None], self.opt.event_capacity)
        ints, vals = np.zeros((m, 4), np.int32), np.zeros((m, 2))
        if m:
            self._export_events(m, ints, vals)
        order = np.lexsort((ints[:, 1], ints[:, 0], ints[:, 3]))
        return ints[order], vals[order]

    def drain_loads(self) -> dict[str, np.ndarray]:
        """Mean wall loads per (replica, body) since the last call (N, N m, W)."""
        out = np.zeros((self.n_rep, max(self.n_body, 1), 11))
        self._export_loads(out)
        out /= max(self._accumulated_steps, 1)
        self._accumulated_steps = 0
        return {"force": out[..., 0:3], "torque": out[..., 3:6], "torque_rolling": out[..., 6:9],
                "power": out[..., 9], "power_rolling": out[..., 10]}

    def wall_axis(self) -> np.ndarray:
        """(replicas, bodies, 3) motion axes (world)."""
        return self.mo_axis.to_numpy()


def _unit(v) -> tuple[float, float, float]:
    a = np.asarray(v, float)
    return tuple(a / np.linalg.norm(a))
