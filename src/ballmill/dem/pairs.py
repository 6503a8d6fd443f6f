"""Sphere-sphere contacts: every candidate pair of the neighbour list evaluated once per step."""

import taichi as ti

from .contact import absorbed_power, rolling_torque
from .neighbours import bit


@ti.data_oriented
class PairContacts:
    """Sums the contacts of i with its partners j > i, in slot order, into i's force and torque
    (the step's end adds the rest: engine.finish); writes what j needs (force on i, torque on j)
    and the contact's history into the open contact's records (neighbours.py)."""

    def __init__(self, particles, tables, nlist, monitor, book, collision_log: bool):
        self.p, self.tables, self.nl, self.monitor, self.book = particles, tables, nlist, monitor, book
        self.collision_log = collision_log

    @ti.func
    def forces(self, i, k):
        """Contacts of i with its partners j > i at step k; a contact that ended is logged."""
        p, nl = self.p, self.nl
        zero = ti.Vector([0.0, 0.0, 0.0])
        dt = p.dt[None]
        f_i, t_i = zero, zero
        energy = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0])  # normal, tangential, rolling (W); Hertz, spring (J)
        open_, used = nl.open[i], nl.used[i]
        for s in range(nl.nb_n[i]):
            j = nl.nb_j[i, s]
            d = p.x[j] - p.x[i]
            sum_r = p.rad[i] + p.rad[j]
            dist2 = d.dot(d)
            if dist2 < sum_r * sum_r and dist2 > 0.0:
                dist = ti.sqrt(dist2)
                delta = sum_r - dist
                n = d / dist  # from i towards j
                ca, cb = p.rad[i] - 0.5 * delta, p.rad[j] - 0.5 * delta
                v_rel = p.v[i] + p.w[i].cross(ca * n) - p.v[j] + p.w[j].cross(cb * n)
                start, xi, vn0, ed, f_then = k, zero, v_rel.dot(n), 0.0, zero  # a new contact
                c = 0  # its records
                if open_ & bit(s):
                    c = nl.record(i, s)
                    start, xi, vn0, ed, f_then = nl.start[i, c], nl.xi[i, c], nl.vn0[i, c], nl.ed[i, c], nl.f[i, c]
                else:
                    c, used = nl.take_record(i, s, used)
                open_ |= bit(s)
                r, ma, mb = p.rep[i], p.mat[i], p.mat[j]
                m_eff = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j])
                r_eff = p.rad[i] * p.rad[j] / sum_r
                fn, ft, xi, stored = self.tables.law(r, ma, mb, delta, n, v_rel, xi, m_eff, r_eff, dt)
                mu_r = self.tables.mu_r[r, ma, mb]
                roll = rolling_torque(fn, mu_r, 1.0, p.w[i] - p.w[j])  # per metre of radius
                roll_a, roll_b = p.rad[i] * roll, -p.rad[j] * roll
                loss_r = -(roll_a.dot(p.w[i]) + roll_b.dot(p.w[j]))
                f_now = -fn * n + ft
                e = absorbed_power(f_then, f_now, n, v_rel)
                energy += ti.Vector([e[0], e[1], loss_r, stored[0], stored[1]])
                self.monitor.overlap(delta / ti.min(p.rad[i], p.rad[j]))
                nl.start[i, c], nl.xi[i, c], nl.vn0[i, c], nl.ed[i, c] = start, xi, vn0, ed + (e[0] + e[1] + loss_r) * dt
                nl.f[i, c] = f_now
                f_i += f_now
                t_i += (ca * n).cross(ft) + roll_a
                nl.t_j[i, c] = (cb * n).cross(ft) + roll_b
            elif open_ & bit(s):  # the contact ended at this step: its records are free
                c = nl.record(i, s)
                if ti.static(self.collision_log):
                    self.monitor.collision(i, j, nl.start[i, c], k, nl.vn0[i, c], nl.ed[i, c])
                open_ ^= bit(s)
                used ^= bit(c)
        # no open contact now nor at the last step: nothing to book, bit for bit (record untouched)
        if open_ != 0 or nl.open[i] != 0:
            self.book.add(i, 0.0, energy[0], energy[1], energy[2])
            self.book.hold(i, energy[3], energy[4], self.book.elastic_pairs, self.book.spring_pairs)
        nl.open[i], nl.used[i] = open_, used
        p.f[i], p.tq[i] = f_i, t_i  # the gather adds the rest: no separate record to stream
