"""Energy bookkeeping: per particle, what the walls put in and what the contacts dissipated.

Cumulative since the engine was built (J): work done by the walls (the step's mean contact
force at the wall's contact-point velocity plus rolling torque at the wall's spin), energy dissipated by
normal damping, tangentially and by rolling friction; and the elastic energy stored in the
particle's contacts now (Hertz plus tangential spring; a pair's is booked on its lower id).
Normal and tangential dissipation are what the relative motion puts into the contact
(contact.absorbed_power: the step's mean force at the half-step velocity, as the integrator
applies it) less the change of the Hertz and the springs' energy: damping, Coulomb sliding,
and the energy a Mindlin spring loses as its stiffness falls with the overlap or its contact
opens.  Booked so, the balance closes to < 0.1 % of the input even at 40 % of the Rayleigh
step (tests/test_system_physics); what is left is still first order in the step, a tenth of
it rolling friction (booked at the half-step spin), the rest not isolated (likely each
contact's unbooked last half step and the lever arms' change over a step).
Summed per replica in particle order, so the totals are as deterministic as the run.
"""

import numpy as np
import taichi as ti

from . import layout

CHANNELS = ("wall_work_j", "dissipated_normal_j", "dissipated_tangential_j", "dissipated_rolling_j")
N_OUT = len(CHANNELS) + 1  # the channels and the elastic energy now


@ti.data_oriented
class EnergyBook:
    STATE = ("cumulative", "elastic_pairs", "elastic_walls", "spring_pairs", "spring_walls")
    def __init__(self, particles):
        self.p = particles
        n = particles.cap
        self.cumulative = layout.vector(len(CHANNELS), float)
        self.elastic_pairs, self.elastic_walls, self.spring_pairs, self.spring_walls = (layout.scalar(float) for _ in range(4))
        layout.records(n, self.cumulative, self.elastic_pairs, self.elastic_walls, self.spring_pairs, self.spring_walls)

    @ti.func
    def add(self, i, work, normal, tangential, rolling):
        """Book powers (W) over one time step (only i's own thread writes i: no atomics needed)."""
        self.cumulative[i] = self.cumulative[i] + self.p.dt[None] * ti.Vector([work, normal, tangential, rolling])

    @ti.func
    def hold(self, i, hertz, spring, elastic: ti.template(), springs: ti.template()):
        """Energy now in i's contacts of one kind (J); its change is stored, not dissipated."""
        c = self.cumulative[i]
        c[1] -= hertz - (elastic[i] - springs[i])
        c[2] -= spring - springs[i]
        self.cumulative[i] = c
        springs[i] = spring
        elastic[i] = hertz + spring

    @ti.func
    def export(self, out: ti.template()):
        """Per replica r: the channels and the elastic energy now into out[r, :N_OUT] (J)."""
        for r in range(self.p.n_rep):
            acc = ti.Vector([0.0] * N_OUT)
            for i in range(self.p.rep_start[r], self.p.rep_end[r]):
                c = self.cumulative[i]
                acc += ti.Vector([c[0], c[1], c[2], c[3], self.elastic_pairs[i] + self.elastic_walls[i]])
            for k in ti.static(range(N_OUT)):
                out[r, k] = acc[k]

    @ti.kernel
    def _export(self, out: ti.types.ndarray()):
        self.export(out)

    def totals(self) -> dict[str, np.ndarray]:
        """Per replica: the cumulative channels and the elastic energy stored now (J)."""
        out = np.zeros((self.p.n_rep, N_OUT))
        self._export(out)
        return named_totals(out)


def named_totals(out: np.ndarray) -> dict[str, np.ndarray]:
    """What `EnergyBook.export` wrote, by name (J per replica)."""
    return {**{name: out[:, k] for k, name in enumerate(CHANNELS)}, "elastic_j": out[:, -1]}
