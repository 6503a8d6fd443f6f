"""The collision log and the guard-rail flags that the kernels raise and `Engine.check` reads."""

import numpy as np
import taichi as ti

from . import layout

# overflow codes
NEIGHBOURS, WALL_CONTACTS, CELL = 1, 2, 3
# what `export_flags` writes, in this order
FLAGS = ("ev_count", "escaped", "overflow", "fast", "max_overlap")


@ti.data_oriented
class Monitor:
    """Finished collisions (buffered until drained) and what went wrong during the last steps."""

    STATE = ("ev_count", "ev_int", "ev_val", "max_overlap", "escaped", "overflow", "fast")

    def __init__(self, event_capacity: int):
        self.capacity = event_capacity
        self.ev_count = layout.scalar(ti.i32, ())
        self.ev_int = layout.vector(4, ti.i32, event_capacity)  # particle, partner key, start step, end step
        self.ev_val = layout.vector(2, float, event_capacity)  # impact normal speed, energy dissipated
        self.max_overlap = layout.scalar(float, ())  # largest overlap / smaller radius so far
        self.escaped = layout.scalar(ti.i32, ())  # 1 + id of a particle that left the domain
        self.overflow = layout.scalar(ti.i32, ())  # one of the overflow codes
        self.fast = layout.scalar(ti.i32, ())  # 1 + id of a particle that moved over half the skin in one step

    @ti.func
    def collision(self, i, key, start, end, vn, ed):
        e = ti.atomic_add(self.ev_count[None], 1)
        if e < self.capacity:
            self.ev_int[e] = ti.Vector([i, key, start, end])
            self.ev_val[e] = ti.Vector([vn, ed])

    @ti.func
    def overlap(self, fraction):
        if fraction > self.max_overlap[None]:  # a read first: the shared value is rarely raised
            ti.atomic_max(self.max_overlap[None], fraction)

    @ti.func
    def export_flags(self, out: ti.template()):
        """The flags into out[k] in the order of FLAGS (inside a sample's kernel)."""
        out[0], out[1], out[2] = self.ev_count[None], self.escaped[None], self.overflow[None]
        out[3], out[4] = self.fast[None], self.max_overlap[None]

    @ti.kernel
    def _export(self, m: ti.i32, ints: ti.types.ndarray(), vals: ti.types.ndarray()):
        for e in range(m):
            for c in ti.static(range(4)):
                ints[e, c] = self.ev_int[e][c]
            for c in ti.static(range(2)):
                vals[e, c] = self.ev_val[e][c]
        self.ev_count[None] = 0

    def drain(self) -> tuple[np.ndarray, np.ndarray]:
        """Collisions ended since the last call, sorted: ints (i, partner, start, end step), values."""
        m = min(self.ev_count[None], self.capacity)
        ints, vals = np.zeros((m, 4), np.int32), np.zeros((m, 2))
        if m:
            self._export(m, ints, vals)
        order = np.lexsort((ints[:, 1], ints[:, 0], ints[:, 3]))
        return ints[order], vals[order]
