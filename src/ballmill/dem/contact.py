"""The contact law and contact geometry, as Taichi functions.

One law, `hertz_mindlin`, serves sphere-sphere and sphere-wall contacts (a wall is a body
of infinite mass and radius).  Conventions: `n` is the unit normal from particle a towards
its partner, `delta` the overlap (m) and `v_rel` the velocity of a's contact point relative
to the partner's (m/s).
"""

import numpy as np
import taichi as ti

from . import layout
from .materials import damping_ratio_for_restitution, effective_shear_modulus, effective_youngs_modulus
from .transfer import write_fields

SQRT_5_6 = 0.9128709291752769  # sqrt(5/6), EDEM damping prefactor


@ti.data_oriented
class PairTables:
    """Contact parameters per material pair (E*, G*) and per replica (damping, friction)."""

    def __init__(self, spec):
        m, r = len(spec.material_names), spec.n_replicas
        mats = [spec.materials[k] for k in spec.material_names]
        self.e_star = layout.scalar(float, (m, m))
        self.g_star = layout.scalar(float, (m, m))
        self.zeta = layout.scalar(float, (r, m, m))
        self.mu_s = layout.scalar(float, (r, m, m))
        self.mu_r = layout.scalar(float, (r, m, m))
        zeta, mu_s, mu_r = (np.zeros((r, m, m)) for _ in range(3))
        particle_mats = set(np.unique(spec.material).tolist())
        for rep in range(r):
            for a in range(m):
                for b in range(m):
                    if a not in particle_mats and b not in particle_mats:
                        continue  # wall-wall: never in contact
                    pair = spec.interaction(rep, spec.material_names[a], spec.material_names[b])
                    zeta[rep, a, b] = damping_ratio_for_restitution(pair.restitution)
                    mu_s[rep, a, b] = pair.static_friction
                    mu_r[rep, a, b] = pair.rolling_friction
        write_fields([(self.e_star, np.array([[effective_youngs_modulus(a, b) for b in mats] for a in mats])),
                      (self.g_star, np.array([[effective_shear_modulus(a, b) for b in mats] for a in mats])),
                      (self.zeta, zeta), (self.mu_s, mu_s), (self.mu_r, mu_r)])

    @ti.func
    def law(self, r, ma, mb, delta, n, v_rel, xi, m_eff, r_eff, dt):
        """hertz_mindlin with the parameters of materials ma, mb in replica r."""
        return hertz_mindlin(delta, n, v_rel, xi, m_eff, r_eff, self.e_star[ma, mb], self.g_star[ma, mb],
                             self.zeta[r, ma, mb], self.mu_s[r, ma, mb], dt)


@ti.func
def hertz_mindlin(delta, n, v_rel, xi, m_eff, r_eff, e_star, g_star, zeta, mu_s, dt):
    """Hertz-Mindlin (no slip) with Tsuji/EDEM damping and a Coulomb cap.

    Normal: F_n = 4/3 E* sqrt(R*) d^1.5 + 2 sqrt(5/6) z sqrt(S_n m*) v_n, clipped at zero
    (no pull); S_n = 2 E* sqrt(R* d).  Tangential: spring S_t = 8 G* sqrt(R* d) on the
    accumulated tangential displacement `xi` (rotated into the current tangent plane with its
    length kept), damped like the normal; when |S_t xi| > mu_s F_n the contact slides: the
    spring force is scaled to the cap, xi reset to match and damping dropped (LIGGGHTS
    tangential_model history).  Returns F_n >= 0, the tangential force on a, the new xi and
    the energy stored now: Hertz 2/5 F_el delta and spring 1/2 S_t |xi|^2 (J).
    """
    sqrt_rd = ti.sqrt(r_eff * delta)
    s_n = 2.0 * e_star * sqrt_rd
    s_t = 8.0 * g_star * sqrt_rd
    v_n = v_rel.dot(n)
    f_elastic = 4.0 / 3.0 * e_star * sqrt_rd * delta
    fn = ti.max(f_elastic + 2.0 * SQRT_5_6 * zeta * ti.sqrt(s_n * m_eff) * v_n, 0.0)
    v_t = v_rel - v_n * n
    xi_len = xi.norm()
    xi_rot = xi - xi.dot(n) * n
    rot_len = xi_rot.norm()
    if rot_len > 0.0:
        xi_rot *= xi_len / rot_len
    xi_new = xi_rot + v_t * dt
    f_spring = -s_t * xi_new
    f_cap = mu_s * fn
    gamma_t = 2.0 * SQRT_5_6 * zeta * ti.sqrt(s_t * m_eff)
    f_t = f_spring - gamma_t * v_t
    f_spring_len = f_spring.norm()
    if f_spring_len > f_cap:
        f_t = f_spring * (f_cap / f_spring_len)
        xi_new = -f_t / s_t
    stored = ti.Vector([0.4 * f_elastic * delta, 0.5 * s_t * xi_new.dot(xi_new)])
    return fn, f_t, xi_new, stored


@ti.func
def absorbed_power(f_then, f_now, n, v_rel):
    """Power the relative motion puts into a contact over the step just taken, normal and
    tangential (W): -F . v_rel with F the mean of the force on a at the last step and now.

    Velocity Verlet applies each step's force over two half kicks, around the half-step
    velocity v_rel; the mean force at that velocity is what changes the kinetic energy, so a
    collision's absorbed energy summed this way is its kinetic-energy loss but for half a step
    at the last, near-zero force (booking F_now . v_rel instead overstates the loss by a share
    ~ zeta omega dt: 2 % at 20 % of the Rayleigh step, 5 % at 40 %).
    """
    f = 0.5 * (f_then + f_now)
    v_n = v_rel.dot(n)
    p_n = -f.dot(n) * v_n
    return ti.Vector([p_n, -f.dot(v_rel) - p_n])


@ti.func
def rolling_torque(fn, mu_r, radius, w_rel):
    """EDEM type-A rolling friction torque on a: -mu_r F_n R w_rel/|w_rel| (N m)."""
    tq = ti.Vector([0.0, 0.0, 0.0])
    w_len = w_rel.norm()
    if w_len > 1e-12:
        tq = -mu_r * fn * radius / w_len * w_rel
    return tq


@ti.func
def rotate(v, axis, angle):
    """Rodrigues rotation of vector v about unit `axis` by `angle` (rad)."""
    c = ti.cos(angle)
    s = ti.sin(angle)
    return v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)


@ti.func
def wall_geometry(kind, point, axis, radius, half_length, x, r):
    """Overlap (m), unit normal towards the wall and contact point of a sphere at x (body frame).

    kind 0: plane through `point` with normal `axis` (into the particles' side);
    1: inside of a cylinder; 2: inside of a capsule.  Overlap <= 0 means no contact.
    """
    delta = -1.0
    n = ti.Vector([0.0, 0.0, 0.0])
    c = ti.Vector([0.0, 0.0, 0.0])
    rel = x - point
    z = rel.dot(axis)
    if kind == 0:
        delta = r - z
        n = -axis
        c = x - z * axis
    else:
        zc = z
        if kind == 2:
            zc = ti.min(ti.max(z, -half_length), half_length)
        if kind == 2 or ti.abs(z) <= half_length:
            q = point + zc * axis
            d = x - q
            dist = d.norm()
            if dist > 0.0:
                n = d / dist
                delta = r - (radius - dist)
                c = q + radius * n
    return delta, n, c


@ti.func
def closest_point_on_triangle(p, a, b, c):
    """Closest point to p on triangle abc and whether it lies inside the face (Ericson 5.1.5)."""
    ab = b - a
    ac = c - a
    ap = p - a
    d1 = ab.dot(ap)
    d2 = ac.dot(ap)
    q = a
    face = 0
    bp = p - b
    d3 = ab.dot(bp)
    d4 = ac.dot(bp)
    cp = p - c
    d5 = ab.dot(cp)
    d6 = ac.dot(cp)
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    if d1 <= 0.0 and d2 <= 0.0:
        q = a
    elif d3 >= 0.0 and d4 <= d3:
        q = b
    elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        q = a + d1 / (d1 - d3) * ab
    elif d6 >= 0.0 and d5 <= d6:
        q = c
    elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        q = a + d2 / (d2 - d6) * ac
    elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        q = b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)
    else:
        denom = 1.0 / (va + vb + vc)
        q = a + ab * (vb * denom) + ac * (vc * denom)
        face = 1
    return q, face
