"""Sphere-wall contacts: analytic walls and triangle meshes, their history and the wall loads.

At each neighbour-list build a particle marks the analytic walls within its reach (radius +
skin): the walls whose motion keeps their distances (a drum's shell and ends turning about
its axis, a wall at rest) and that lie farther are left out until the next build, as the
list leaves out far particles; the others are tested at every step.  Contacts are found in
the body frame of each wall (one frame change per particle and body), then resolved with the
same contact law as sphere-sphere contacts (a wall is a body of infinite mass and radius).
Each particle keeps its wall contacts in slots double buffered by step parity (old: the
previous step, new: this one), keyed by partner: cap + w for analytic wall w,
cap + n_wall + t for triangle t (cap: the particle capacity).  A sphere touches each analytic
wall at most once, so without meshes a particle gets one slot per wall (a drum: 3); a mesh
can give more contacts, and then it gets the configured capacity.  The reaction on each body
is accumulated per (particle, body) and summed in particle order when drained.
"""

import math

import numpy as np
import taichi as ti

from . import layout
from .contact import absorbed_power, closest_point_on_triangle, rolling_torque, wall_geometry
from .geometry import CAPSULE, CYLINDER, PLANE, Capsule, Cylinder, Mesh, Plane
from .monitor import WALL_CONTACTS
from .motion import unit
from .transfer import write_fields

MESH_CELLS_PER_SIDE = 64  # a mesh's bounding box is binned into at most this many cells per side
EDGE_SLOTS = 4  # edge/vertex contacts of one ball with one mesh, in distinct directions
EDGE_SAME = math.cos(math.radians(20.0))  # normals closer than 20 deg: the same contact direction
LOAD_COLUMNS = 11  # force (3), torque (3), rolling torque (3), power, rolling power
MAX_WALLS = 32  # analytic walls: one bit each in a particle's mask of walls within reach


def wall_slots(analytic_walls: int, meshes: bool, capacity: int) -> int:
    """Wall-contact slots per particle: one per analytic wall when there is no mesh, else `capacity`."""
    return capacity if meshes else max(analytic_walls, 1)


@ti.data_oriented
class Walls:
    # what a saved run keeps: the wall contacts and the loads not yet drained (the rest: geometry)
    STATE = ("c_n", "c_key", "c_xi", "c_start", "c_vn", "c_ed", "c_f", "acc_f", "acc_tq", "acc_tq_roll", "acc_pw",
             "acc_pw_roll")
    def __init__(self, spec, particles, tables, motions, monitor, book, capacity: int, collision_log: bool):
        self.p, self.tables, self.mo, self.monitor, self.book = particles, tables, motions, monitor, book
        # partner keys: particles are < cap, walls from the particle capacity on (fixed at compile time)
        self.cap, self.collision_log = particles.cap, collision_log
        self.n_body = len(spec.bodies)
        self._build_primitives(spec)
        self.k_max = wall_slots(self.n_wall, self.n_mesh > 0, capacity)
        cap, k, b = self.cap, self.k_max, max(self.n_body, 1)
        # bit w: analytic wall w is within reach of the particle (set at each list build)
        self.reach = layout.scalar(ti.u32, cap)
        self.c_n = layout.scalar(ti.i32, (2, cap))
        # one record per (parity, particle, slot); c_f: the force on the particle at that step
        self.c_key, self.c_start, self.c_vn, self.c_ed = layout.scalar(ti.i32), layout.scalar(ti.i32), layout.scalar(float), layout.scalar(float)
        self.c_xi, self.c_f = layout.vector(3, float), layout.vector(3, float)
        layout.records((2, cap, k), self.c_key, self.c_start, self.c_vn, self.c_ed, self.c_xi, self.c_f)
        # one record per (particle, body)
        self.acc_f, self.acc_tq, self.acc_tq_roll = (layout.vector(3, float) for _ in range(3))
        self.acc_pw, self.acc_pw_roll = layout.scalar(float), layout.scalar(float)
        layout.records((cap, b), self.acc_f, self.acc_tq, self.acc_tq_roll, self.acc_pw, self.acc_pw_roll)

    # ---------------------------------------------------------------- set-up
    def _build_primitives(self, spec) -> None:
        kinds = {Plane: PLANE, Cylinder: CYLINDER, Capsule: CAPSULE}
        rows, tris, tri_body, tri_mat, meshes = [], [], [], [], []
        for b, body in enumerate(spec.bodies):
            mat = spec.material_names.index(body.material)
            for wall in body.walls:
                if isinstance(wall, Mesh):
                    meshes.append((b, len(tris), wall))
                    tris.extend(wall.triangles)
                    tri_body += [b] * len(wall.faces)
                    tri_mat += [mat] * len(wall.faces)
                elif isinstance(wall, Plane):
                    rows.append((PLANE, b, mat, wall.point_m, unit(wall.normal), 0.0, 0.0))
                else:
                    rows.append((kinds[type(wall)], b, mat, wall.center_m, unit(wall.axis), wall.radius_m,
                                 wall.half_length_m))
        rows.sort(key=lambda row: row[1])  # grouped by body: one frame change per body
        self.n_wall, self.n_tri, self.n_mesh = len(rows), len(tris), len(meshes)
        if self.n_wall > MAX_WALLS:
            raise ValueError(f"{self.n_wall} analytic walls: at most {MAX_WALLS} (use a mesh for more)")
        # the body of each analytic wall and of each mesh (what the collision log names)
        self.wall_body = np.array([row[1] for row in rows], int)
        self.mesh_body = np.array([b for b, _, _ in meshes], int)
        nw = max(self.n_wall, 1)
        self.w_kind = layout.scalar(ti.i32, nw)
        self.w_body = layout.scalar(ti.i32, nw)
        self.w_mat = layout.scalar(ti.i32, nw)
        self.w_point = layout.vector(3, float, nw)
        self.w_axis = layout.vector(3, float, nw)
        self.w_radius = layout.scalar(float, nw)
        self.w_half = layout.scalar(float, nw)
        for k, (kind, b, mat, point, axis, radius, half) in enumerate(rows):
            self.w_kind[k], self.w_body[k], self.w_mat[k] = kind, b, mat
            self.w_point[k], self.w_axis[k] = point, axis
            self.w_radius[k], self.w_half[k] = radius, half
        # 1: the wall's motion in that replica keeps every point's distance to it (see still_under)
        self.w_still = layout.scalar(ti.i32, (spec.n_replicas, nw))
        for r in range(spec.n_replicas):
            for k, (kind, b, _, point, axis, _, _) in enumerate(rows):
                self.w_still[r, k] = still_under(spec.bodies[b].motion(r), kind, point, axis)
        self._build_meshes(spec, np.array(tris).reshape(-1, 3, 3), tri_body, tri_mat, meshes)

    def _build_meshes(self, spec, tris, tri_body, tri_mat, meshes) -> None:
        """Triangles in body frame, binned per mesh in a uniform grid (CSR) of cell >= 2 r_max."""
        nt, nm = max(self.n_tri, 1), max(self.n_mesh, 1)
        self.t_corner = layout.vector(3, float, (nt, 3))
        self.t_body = layout.scalar(ti.i32, nt)
        self.t_mat = layout.scalar(ti.i32, nt)
        self.m_body = layout.scalar(ti.i32, nm)
        self.m_tri0 = layout.scalar(ti.i32, nm)
        self.m_tri1 = layout.scalar(ti.i32, nm)
        self.m_lo = layout.vector(3, float, nm)
        self.m_dims = layout.vector(3, ti.i32, nm)
        self.m_cell0 = layout.scalar(ti.i32, nm)
        self.m_h = layout.scalar(float, nm)
        starts, ids, cell0 = [0], [], 0
        reach = 2.0 * float(spec.radius_m.max())
        for k, (b, t0, mesh) in enumerate(meshes):
            corners = mesh.triangles
            lo = corners.min(axis=(0, 1)) - reach
            hi = corners.max(axis=(0, 1)) + reach
            h = max(reach, float((hi - lo).max()) / MESH_CELLS_PER_SIDE)
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
        self.mc_start = layout.scalar(ti.i32, len(starts))
        self.mc_tris = layout.scalar(ti.i32, max(len(ids), 1))
        write_fields([(self.mc_start, np.array(starts, dtype=np.int32)),
                      *([(self.mc_tris, np.array(ids, dtype=np.int32))] if ids else []),
                      *([(self.t_corner, tris), (self.t_body, np.array(tri_body, dtype=np.int32)),
                         (self.t_mat, np.array(tri_mat, dtype=np.int32))] if self.n_tri else [])])

    # ---------------------------------------------------------------- history slots
    @ti.func
    def find_slot(self, i, old, key):
        slot = -1
        for s in range(self.c_n[old, i]):
            if self.c_key[old, i, s] == key:
                slot = s
        return slot

    @ti.func
    def store(self, i, new, cnt, key, xi, start, vn, ed, f):
        if cnt < self.k_max:
            self.c_key[new, i, cnt] = key
            self.c_xi[new, i, cnt] = xi
            self.c_start[new, i, cnt] = start
            self.c_vn[new, i, cnt] = vn
            self.c_ed[new, i, cnt] = ed
            self.c_f[new, i, cnt] = f
        else:
            self.monitor.overflow[None] = WALL_CONTACTS
        return cnt + 1

    @ti.func
    def partner_class(self, key):
        """Key of the partner for collision bookkeeping: triangles collapse to their mesh."""
        out = key
        if ti.static(self.n_mesh > 0) and key >= self.cap + self.n_wall:
            t = key - self.cap - self.n_wall
            for m in range(self.n_mesh):
                if self.m_tri0[m] <= t < self.m_tri1[m]:
                    out = self.cap + self.n_wall + self.n_tri + m
        return out

    # ---------------------------------------------------------------- walls within reach
    @ti.func
    def mark_within_reach(self, i, skin):
        """At a list build: mark the analytic walls particle i may touch before the next build.
        The list holds while no particle moves more than skin / 2, so a wall whose motion keeps
        every distance to it (`still_under`) and that lies farther than radius + skin is out of
        reach until then.  Such a wall is where it lies at rest, where the body frame is the
        world's, whatever the pose; every other wall is marked."""
        p = self.p
        r = p.rep[i]
        marks = ti.u32(0)
        for w in range(self.n_wall):
            near = True
            if self.w_still[r, w]:
                point, axis, half = self.w_point[w], self.w_axis[w], self.w_half[w]
                delta, _, _ = wall_geometry(self.w_kind[w], point, axis, self.w_radius[w], half, p.x[i], p.rad[i] + skin)
                near = delta > 0.0
                if self.w_kind[w] == CYLINDER:  # past its open ends a sphere may come back into range
                    near = near or ti.abs((p.x[i] - point).dot(axis)) > half - skin
            if near:
                marks |= ti.u32(1) << ti.cast(w, ti.u32)
        self.reach[i] = marks

    # ---------------------------------------------------------------- contacts of one particle
    @ti.func
    def contact(self, i, key, b, mat, delta, nb, cb, old, new, cnt, k, slot):
        """Contact of particle i with a wall of body b found in body frame: (force, torque, count)."""
        p, mo = self.p, self.mo
        r = p.rep[i]
        n = mo.vector_to_world(r, b, nb)
        c = mo.point_to_world(r, b, cb)
        w_wall = mo.w[r, b]
        v_wall = mo.velocity_at(r, b, c)
        arm = c - p.x[i]
        v_rel = p.v[i] + p.w[i].cross(arm) - v_wall
        xi, f_then = ti.Vector([0.0, 0.0, 0.0]), ti.Vector([0.0, 0.0, 0.0])
        start, vn0, ed = k, v_rel.dot(n), 0.0
        if slot >= 0:
            xi, f_then = self.c_xi[old, i, slot], self.c_f[old, i, slot]
            start, vn0, ed = self.c_start[old, i, slot], self.c_vn[old, i, slot], self.c_ed[old, i, slot]
        mi = p.mat[i]
        fn, ft, xi, stored = self.tables.law(r, mi, mat, delta, n, v_rel, xi, p.mass[i], p.rad[i], p.dt[None])
        roll = rolling_torque(fn, self.tables.mu_r[r, mi, mat], p.rad[i], p.w[i] - w_wall)
        f_i = -fn * n + ft
        power, power_roll = f_i.dot(v_wall), roll.dot(w_wall)
        e = absorbed_power(f_then, f_i, n, v_rel)
        # accumulators of i, written by i's thread only: plain stores, not atomics
        self.acc_f[i, b] = self.acc_f[i, b] - f_i
        self.acc_tq[i, b] = self.acc_tq[i, b] + mo.lever(r, b, c).cross(-f_i)
        self.acc_tq_roll[i, b] = self.acc_tq_roll[i, b] - roll
        self.acc_pw[i, b] = self.acc_pw[i, b] + power
        self.acc_pw_roll[i, b] = self.acc_pw_roll[i, b] + power_roll
        loss_r = -roll.dot(p.w[i] - w_wall)
        self.book.add(i, 0.5 * (f_then + f_i).dot(v_wall) + power_roll, e[0], e[1], loss_r)
        self.monitor.overlap(delta / p.rad[i])
        cnt = self.store(i, new, cnt, key, xi, start, vn0, ed + (e[0] + e[1] + loss_r) * p.dt[None], f_i)
        return f_i, arm.cross(ft) + roll, stored, cnt

    @ti.func
    def mesh_slot(self, i, old, key, m, xb):
        """History slot for a triangle contact: the triangle's own, else one inherited from a
        triangle of the same mesh the particle has left (a ball rolling across facets)."""
        slot = self.find_slot(i, old, key)
        if slot < 0:
            base = self.cap + self.n_wall
            for s in range(self.c_n[old, i]):
                t = self.c_key[old, i, s] - base
                if slot < 0 and self.m_tri0[m] <= t < self.m_tri1[m]:
                    q, _ = closest_point_on_triangle(xb, self.t_corner[t, 0], self.t_corner[t, 1], self.t_corner[t, 2])
                    if (q - xb).norm() >= self.p.rad[i]:
                        slot = s
        return slot

    @ti.func
    def mesh_contacts(self, i, m, old, new, cnt, k):
        """Face contacts with every triangle touched, then the edge/vertex contacts that are not a
        face contact seen again: one per direction (the deepest of those within EDGE_SAME of
        each other, as the two triangles of one edge give), none within EDGE_SAME of a face
        contact's normal (a smooth mesh's facet edges), so a ball in the corner of a shell facet and
        a lifter's convex edge feels both.  The candidate edges are resolved by EDGE_SLOTS more
        iterations of the triangle loop, so the contact code is compiled once.
        """
        f_i = ti.Vector([0.0, 0.0, 0.0])
        t_i = ti.Vector([0.0, 0.0, 0.0])
        elastic = ti.Vector([0.0, 0.0])  # Hertz, spring (J)
        b = self.m_body[m]
        xb = self.mo.to_body(self.p.rep[i], b, self.p.x[i])
        rad = self.p.rad[i]
        cell = ti.floor((xb - self.m_lo[m]) / self.m_h[m], ti.i32)
        dims = self.m_dims[m]
        if 0 <= cell[0] < dims[0] and 0 <= cell[1] < dims[1] and 0 <= cell[2] < dims[2]:
            c = self.m_cell0[m] + (cell[0] * dims[1] + cell[1]) * dims[2] + cell[2]
            faces = 0
            face_n = ti.Matrix([[0.0] * 3 for _ in range(EDGE_SLOTS)])  # normals of the first face contacts
            edge_t = ti.Vector([-1] * EDGE_SLOTS)  # candidate edge/vertex contacts: triangle, depth, normal
            edge_d = ti.Vector([0.0] * EDGE_SLOTS)
            edge_n = ti.Matrix([[0.0] * 3 for _ in range(EDGE_SLOTS)])
            q_end = self.mc_start[c + 1]
            for q in range(self.mc_start[c], q_end + EDGE_SLOTS):
                t = -1
                if q < q_end:
                    t = self.mc_tris[q]
                else:
                    t = edge_t[q - q_end]
                if t >= 0:
                    p, face = closest_point_on_triangle(xb, self.t_corner[t, 0], self.t_corner[t, 1], self.t_corner[t, 2])
                    d = p - xb
                    dist = d.norm()
                    delta = rad - dist
                    touch = False
                    if delta > 0.0 and dist > 0.0:
                        nrm = d / dist
                        if q < q_end and face == 1:
                            touch = True
                            if faces < EDGE_SLOTS:
                                for a in ti.static(range(3)):
                                    face_n[faces, a] = nrm[a]
                            faces += 1
                        elif q < q_end:
                            slot_e = -1  # the candidate of this direction, else a free one
                            for e in range(EDGE_SLOTS):
                                same = nrm.dot(ti.Vector([edge_n[e, 0], edge_n[e, 1], edge_n[e, 2]])) > EDGE_SAME
                                if slot_e < 0 and (edge_t[e] < 0 or same):
                                    slot_e = e
                            if slot_e >= 0 and (edge_t[slot_e] < 0 or delta > edge_d[slot_e]):
                                edge_t[slot_e], edge_d[slot_e] = t, delta
                                for a in ti.static(range(3)):
                                    edge_n[slot_e, a] = nrm[a]
                        else:
                            touch = True
                            for f in range(ti.min(faces, EDGE_SLOTS)):
                                if nrm.dot(ti.Vector([face_n[f, 0], face_n[f, 1], face_n[f, 2]])) > EDGE_SAME:
                                    touch = False
                    if touch:
                        key = self.cap + self.n_wall + t
                        slot = self.mesh_slot(i, old, key, m, xb)
                        df, dt_, de, cnt = self.contact(i, key, b, self.t_mat[t], delta, d / dist, p, old, new, cnt, k,
                                                        slot)
                        f_i += df
                        t_i += dt_
                        elastic += de
        return f_i, t_i, elastic, cnt

    @ti.func
    def forces(self, i, k):
        """All wall contacts of particle i at step k: (force, torque); logs finished collisions."""
        old, new = (k + 1) % 2, k % 2
        p = self.p
        r = p.rep[i]
        f = ti.Vector([0.0, 0.0, 0.0])
        t = ti.Vector([0.0, 0.0, 0.0])
        cnt, elastic = 0, ti.Vector([0.0, 0.0])  # Hertz, spring (J)
        last_b, xb, reach = -1, p.x[i], self.reach[i]
        for w in range(self.n_wall if ti.static(self.n_wall > 0) else 0):
            delta, nb, cb, b = -1.0, ti.Vector([0.0, 0.0, 0.0]), ti.Vector([0.0, 0.0, 0.0]), self.w_body[w]
            if reach & (ti.u32(1) << ti.cast(w, ti.u32)):
                if b != last_b:  # walls are grouped by body
                    xb, last_b = self.mo.to_body(r, b, p.x[i]), b
                delta, nb, cb = wall_geometry(
                    self.w_kind[w], self.w_point[w], self.w_axis[w], self.w_radius[w], self.w_half[w], xb, p.rad[i]
                )
            if delta > 0.0:
                slot = self.find_slot(i, old, self.cap + w)
                df, dt_, de, cnt = self.contact(i, self.cap + w, b, self.w_mat[w], delta, nb, cb, old, new, cnt, k, slot)
                f += df
                t += dt_
                elastic += de
        if ti.static(self.n_mesh > 0):
            for m in range(self.n_mesh):
                df, dt_, de, cnt = self.mesh_contacts(i, m, old, new, cnt, k)
                f += df
                t += dt_
                elastic += de
        # no wall contact now nor at the last step: nothing to book, bit for bit, so i's energy
        # record (a cache line) is not read; most particles of a bed touch no wall
        if cnt > 0 or self.c_n[old, i] > 0:
            self.book.hold(i, elastic[0], elastic[1], self.book.elastic_walls, self.book.spring_walls)
        self.c_n[new, i] = ti.min(cnt, self.k_max)
        if ti.static(self.collision_log):
            self.finish_collisions(i, old, new, k)
        return f, t

    @ti.func
    def finish_collisions(self, i, old, new, k):
        """Log the wall contacts of i that ended at step k."""
        for s in range(self.c_n[old, i]):
            key = self.c_key[old, i, s]
            cls = self.partner_class(key)
            start = self.c_start[old, i, s]
            alive = False
            for s2 in range(self.c_n[new, i]):
                if self.c_start[new, i, s2] == start and self.partner_class(self.c_key[new, i, s2]) == cls:
                    alive = True
            if not alive:
                self.monitor.collision(i, cls, start, k, self.c_vn[old, i, s], self.c_ed[old, i, s])

    # ---------------------------------------------------------------- loads
    @ti.func
    def export_loads(self, out: ti.template()):
        """Sum the per-particle wall-load accumulators per (replica, body), in particle order,
        into out[r, b, :LOAD_COLUMNS], and zero them (inside a sample's kernel)."""
        for r, b in ti.ndrange(self.p.n_rep, self.n_body):
            acc = ti.Vector([0.0] * LOAD_COLUMNS)
            for i in range(self.p.rep_start[r], self.p.rep_end[r]):
                f, tq, tr = self.acc_f[i, b], self.acc_tq[i, b], self.acc_tq_roll[i, b]
                acc += ti.Vector([f[0], f[1], f[2], tq[0], tq[1], tq[2], tr[0], tr[1], tr[2],
                                  self.acc_pw[i, b], self.acc_pw_roll[i, b]])
                self.acc_f[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_tq[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_tq_roll[i, b] = ti.Vector([0.0, 0.0, 0.0])
                self.acc_pw[i, b] = 0.0
                self.acc_pw_roll[i, b] = 0.0
            for c in ti.static(range(LOAD_COLUMNS)):
                out[r, b, c] = acc[c]


def still_under(motion, kind: int, point, axis) -> bool:
    """Whether `motion` keeps the distance of every point to the wall (kind, point, axis in body
    frame): a body at rest, or one turning about its pivot's axis with no translation, where the
    wall is a plane across that axis or a cylinder or capsule around it (a drum's shell and ends)."""
    if any(motion.translation_amplitude_m):
        return False
    if motion.angular_velocity_rad_per_s == 0.0 and motion.angle_amplitude_rad == 0.0:
        return True
    a = np.asarray(unit(motion.axis))
    across = np.linalg.norm(np.cross(axis, a)) < 1e-12
    if kind == PLANE:
        return bool(across)
    off_axis = np.linalg.norm(np.cross(np.asarray(point, float) - np.asarray(motion.pivot_m, float), a))
    return bool(across and off_axis < 1e-12 * max(1.0, float(np.linalg.norm(point))))


def mean_loads(out: np.ndarray, steps: int) -> dict[str, np.ndarray]:
    """Mean wall loads per (replica, body) over `steps` steps (N, N m, W) from what
    `Walls.export_loads` summed."""
    out = out / max(steps, 1)
    return {"force": out[..., 0:3], "torque": out[..., 3:6], "torque_rolling": out[..., 6:9],
            "power": out[..., 9], "power_rolling": out[..., 10]}
