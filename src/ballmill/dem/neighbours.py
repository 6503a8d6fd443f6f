"""Verlet neighbour list with a skin, found through a cell grid or all pairs of a replica.

Half list: particle i holds the partners j > i whose centres were closer than
r_i + r_j + skin when the list was built, in slots; the pair loop (`pairs.py`) sums i's
contacts with them in slot order and the gather (`gather`) adds, per particle, what its
lower partners left for it.  Partners are kept in id order, so the sums depend neither on
thread scheduling nor on the skin or when the list was rebuilt: identical bits.  A bit mask
per particle marks the slots whose contact is open, so the pair loop and the gather read
records only for open contacts.

An open contact has two records of 48 B: its history (collision start step, tangential
spring, impact speed, energy dissipated), which only the pair loop reads, and the force on
i and torque on j that the pair loop leaves for the gather, so the gather reads one of them,
not both (100,000 balls +16 %, against one record of 96 B).  The records belong to the
contact, not to the slot: a contact that opens takes the lowest record free in i's row and
keeps it until it ends, and each slot names its contact's record (`rec`).  So a ball's
records in use are its first few, whatever slots its contacts hold, and are stored record
by record (record r of i beside record r of i + 1, layout.py): a step's reads of them lie
close together.  A rebuild renumbers slots, not records.  Each particle also lists the
slots (j, s) of the lower partners that hold it, the reverse list.

The list stays valid while no particle has moved more than skin / 2 from where it was at
the build: at the end of every step each particle checks where its next drift will take
it and, if that is past skin / 2, marks its replica for a rebuild before the next step.
A rebuild carries each pair's history over by partner id, and marks the analytic walls
within the same reach of each particle (walls.py).  A larger skin means fewer rebuilds but
more candidate pairs to test every step.
"""

import math

import numpy as np
import taichi as ti

from . import layout
from .monitor import CELL, NEIGHBOURS
from .particles import capacity

MAX_SLOTS = 64  # list slots per particle: one bit each in the open-contact mask


@ti.func
def bit(s):
    """The open-contact mask's bit of slot s."""
    return ti.u64(1) << ti.cast(s, ti.u64)


@ti.data_oriented
class NeighbourList:
    """Candidate pairs in slots (capacity per particle) and the records of their open contacts."""

    # what a saved run keeps: the list, its open contacts and their records (a rebuild carries them
    # over) and the rebuild count; the rest is rebuilt (a restore marks the list due) or recomputed
    # by the next step's pair loop
    STATE = ("nb_n", "nb_j", "open", "used", "rec", "start", "xi", "vn0", "ed", "f", "builds")

    def __init__(self, spec, particles, monitor, walls, capacity: int, skin_m: float, use_grid: bool,
                 parallel_binning: bool | None = None):
        cap, reps = particles.cap, spec.n_replicas
        self.p, self.monitor, self.walls = particles, monitor, walls
        if not 1 <= capacity <= MAX_SLOTS:
            raise ValueError(f"max_contacts_per_particle={capacity} must lie in [1, {MAX_SLOTS}]")
        self.n_rep, self.k_max, self.skin, self.use_grid = reps, capacity, skin_m, use_grid
        # on a CPU one thread bins faster than launching threads; a GPU bins in parallel, then sorts
        on_cpu = ti.lang.impl.current_cfg().arch == ti.cpu
        self.serial_binning = on_cpu if parallel_binning is None else not parallel_binning
        k = capacity
        self.nb_n = layout.scalar(ti.i32, cap)
        self.rv_n = layout.scalar(ti.i32, cap)
        self.rv_slot = layout.scalar(ti.i32, (cap, k))  # j * capacity + s of the lower partner's slot
        self.nb_j = layout.scalar(ti.i32, (cap, k))
        # bit s of open: slot s is an open contact, whose records are rec[i, s]; bit r of used:
        # record r is an open contact's (a pair loop or gather reads no other record)
        self.open, self.used = layout.scalar(ti.u64), layout.scalar(ti.u64)
        layout.records(cap, self.open, self.used)
        self.rec = layout.scalar(ti.u8, (cap, k))
        # two records per open contact: its history, and the force on i (kept to the next step,
        # history too) and the torque on j (the gather's)
        self.start, self.vn0, self.ed = layout.scalar(ti.i32), layout.scalar(float), layout.scalar(float)
        self.f, self.t_j, self.xi = layout.vector(3, float), layout.vector(3, float), layout.vector(3, float)
        layout.records((cap, k), self.start, self.xi, self.vn0, self.ed, slot_major=True)
        layout.records((cap, k), self.f, self.t_j, slot_major=True)
        # scratch for a rebuild: the new partners of i before they replace the old ones
        self.new_j = layout.scalar(ti.i32, (cap, k))
        self.x_ref = layout.vector(3, float, cap)
        self.due = layout.scalar(ti.i32, reps)  # 1: rebuild the replica's list before its next step
        self.any_due = layout.scalar(ti.i32, ())
        self.builds = layout.scalar(ti.i32, ())
        self.due.fill(1)
        self._build_grid(spec)

    def _build_grid(self, spec) -> None:
        """Cells of side 2 r_max + skin, so partners within the cut-off lie in the 27 cells around;
        the grid's dimensions are read at run time and its storage has capacity(cells) rows, so
        that vessels of other sizes share the compiled kernels."""
        self.h = 2.0 * float(spec.radius_m.max()) + self.skin
        lo, hi = np.asarray(spec.domain_lo_m, float), np.asarray(spec.domain_hi_m, float)
        dims = np.maximum(np.ceil((hi - lo) / self.h).astype(int), 1) if self.use_grid else np.ones(3, int)
        cells = int(np.prod(dims)) * self.n_rep
        self.dims = layout.vector(3, ti.i32, ())
        self.dims[None] = dims.astype(np.int32)
        r_min = float(spec.radius_m.min())
        # centres at least 2 r_min (1 - 5 % overlap) apart: one size, at most (h / 1.9 r_min + 1)^3 in a
        # cell; several sizes (h up to 2 r_max + skin), at most what the densest packing (0.7405) of
        # those spheres puts in the cell widened by their radius
        self.cell_cap = (math.floor(self.h / (1.9 * r_min)) + 1) ** 3
        if r_min < float(spec.radius_m.max()):
            ball = 4 / 3 * math.pi * (0.95 * r_min) ** 3
            self.cell_cap = max(self.cell_cap, math.floor(0.7405 * (self.h + 1.9 * r_min) ** 3 / ball))
        self.cell_count = layout.scalar(ti.i32, capacity(cells))
        self.cell_list = layout.scalar(ti.i32, (capacity(cells), self.cell_cap))

    # ------------------------------------------------------------------ cell grid
    @ti.func
    def cells_per_replica(self):
        """Cells of the grid in use for one replica."""
        dims = self.dims[None]
        return dims[0] * dims[1] * dims[2]

    @ti.func
    def cells(self):
        """Cells of the grid in use (every replica)."""
        return self.cells_per_replica() * self.n_rep

    @ti.func
    def cell_of(self, i):
        rel = (self.p.x[i] - self.p.domain_lo[None]) / self.h
        dims = self.dims[None]
        c = ti.Vector([0, 0, 0])
        for a in ti.static(range(3)):
            c[a] = ti.min(ti.max(int(ti.floor(rel[a])), 0), dims[a] - 1)
        return c

    @ti.func
    def cell_id(self, r, c):
        dims = self.dims[None]
        return ((r * dims[0] + c[0]) * dims[1] + c[1]) * dims[2] + c[2]

    @ti.func
    def bin(self, i):
        cid = self.cell_id(self.p.rep[i], self.cell_of(i))
        s = ti.atomic_add(self.cell_count[cid], 1)
        if s < self.cell_cap:
            self.cell_list[cid, s] = i
        else:
            self.monitor.overflow[None] = CELL

    @ti.func
    def sort_row(self, a: ti.template(), row, m):
        """Insertion sort of a[row, :m] (short rows: a cell's ids, a particle's partners)."""
        for q in range(1, m):
            key = a[row, q]
            b = q - 1
            while b >= 0 and a[row, b] > key:
                a[row, b + 1] = a[row, b]
                b -= 1
            a[row, b + 1] = key

    # ------------------------------------------------------------------ list build
    @ti.func
    def consider(self, i, j, cnt, low):
        """Add j to i's list (j > i) or to its lower partners (j < i) if within the cut-off."""
        if j != i:
            cut = self.p.rad[i] + self.p.rad[j] + self.skin
            d = self.p.x[j] - self.p.x[i]
            if d.dot(d) < cut * cut:
                if j > i:
                    if cnt < self.k_max:
                        self.new_j[i, cnt] = j
                    cnt += 1
                else:
                    if low < self.k_max:
                        self.rv_slot[i, low] = j
                    low += 1
        return cnt, low

    @ti.func
    def old_slot(self, i, s, step, n_old, j):
        """From slot s of i's old list, moving by `step` (+1 or -1), the first slot whose partner
        is not past j (below it moving up, above it moving down), and whether it holds j."""
        while 0 <= s < n_old:  # Taichi evaluates both sides of `and`: no read out of the row
            if (self.nb_j[i, s] - j) * step >= 0:
                break
            s += step
        found = False
        if 0 <= s < n_old:
            found = self.nb_j[i, s] == j
        return s, found

    @ti.func
    def build_particle(self, i):
        """New list of i (partners in id order), open contacts carried over by partner id."""
        cnt, low = 0, 0
        r = self.p.rep[i]
        if ti.static(self.use_grid):
            c0, dims = self.cell_of(i), self.dims[None]
            for o in range(27):  # a dynamic loop: the scan is compiled once, not 27 times
                c = c0 + ti.Vector([o // 9 - 1, (o // 3) % 3 - 1, o % 3 - 1])
                if 0 <= c[0] < dims[0] and 0 <= c[1] < dims[1] and 0 <= c[2] < dims[2]:
                    cid = self.cell_id(r, c)
                    for q in range(ti.min(self.cell_count[cid], self.cell_cap)):
                        cnt, low = self.consider(i, self.cell_list[cid, q], cnt, low)
        else:
            for j in range(self.p.rep_start[r], self.p.rep_end[r]):
                cnt, low = self.consider(i, j, cnt, low)
        if cnt > self.k_max or low > self.k_max:
            self.monitor.overflow[None] = NEIGHBOURS
        cnt, low = ti.min(cnt, self.k_max), ti.min(low, self.k_max)
        # partners in id order: forces are summed in the same order whatever the skin
        self.sort_row(self.new_j, i, cnt)
        self.sort_row(self.rv_slot, i, low)
        # each open contact (within the cut-off, so in the new list) moves in place from its old slot
        # to its new one, with the name of its records, which stay where they are.  Both lists are
        # in partner order, so kept pairs keep their order: those moving down are moved lowest
        # first, then those moving up highest first, and no name is overwritten before it is read
        n_old, was_open = self.nb_n[i], self.open[i]
        s, open_ = 0, ti.u64(0)
        for c in range(cnt):
            s, found = self.old_slot(i, s, 1, n_old, self.new_j[i, c])
            # Taichi evaluates both sides of `and`: bit(s) only once s is a slot of the row
            if found:  # noqa: SIM102
                if was_open & bit(s):
                    open_ |= bit(c)
                    if s > c:
                        self.rec[i, c] = self.rec[i, s]
        s = n_old - 1
        for m in range(cnt):
            c = cnt - 1 - m
            s, found = self.old_slot(i, s, -1, n_old, self.new_j[i, c])
            if found and s < c:  # noqa: SIM102 (as above)
                if was_open & bit(s):
                    self.rec[i, c] = self.rec[i, s]
        for c in range(cnt):
            self.nb_j[i, c] = self.new_j[i, c]
        self.nb_n[i], self.rv_n[i], self.open[i] = cnt, low, open_
        self.x_ref[i] = self.p.x[i]
        self.walls.mark_within_reach(i, self.skin)

    @ti.func
    def link_reverse(self, i):
        """Replace each lower partner j of i by the slot (j, s) that holds i in j's list."""
        for q in range(self.rv_n[i]):
            j = self.rv_slot[i, q]
            slot = -1
            for s in range(self.nb_n[j]):
                if self.nb_j[j, s] == i:
                    slot = j * self.k_max + s
            self.rv_slot[i, q] = slot

    @ti.func
    def build_replica(self, r):
        """Serial rebuild of replica r (one thread; used inside multi-step kernels)."""
        i0, i1 = self.p.rep_start[r], self.p.rep_end[r]
        if ti.static(self.use_grid):
            per_rep = self.cells_per_replica()
            for c in range(r * per_rep, (r + 1) * per_rep):
                self.cell_count[c] = 0
            for i in range(i0, i1):  # in id order, so each cell is already sorted
                self.bin(i)
        for i in range(i0, i1):
            self.build_particle(i)
        for i in range(i0, i1):
            self.link_reverse(i)
        self.due[r] = 0
        self.builds[None] += 1

    @ti.func
    def gather_due(self):
        """any_due from the replicas' flags (per-replica rebuilds clear theirs, not any_due)."""
        due = 0
        for r in range(self.n_rep):
            due |= self.due[r]
        self.any_due[None] = due

    @ti.func
    def bin_all(self):
        """Every particle into its cell, serially in id order, so each cell is already sorted."""
        if ti.static(self.use_grid):
            for c in range(self.cells()):
                self.cell_count[c] = 0
            for i in range(self.p.live[None]):
                self.bin(i)

    @ti.func
    def built(self):
        """After a rebuild of every replica: nothing due, one more build."""
        for r in range(self.n_rep):
            self.due[r] = 0
        self.any_due[None] = 0
        self.builds[None] += 1

    @ti.kernel
    def build_all(self):
        """Parallel rebuild of every replica."""
        if ti.static(self.use_grid and not self.serial_binning):
            for c in range(self.cells()):
                self.cell_count[c] = 0
            for i in range(self.p.live[None]):
                self.bin(i)
            for c in range(self.cells()):
                self.sort_row(self.cell_list, c, ti.min(self.cell_count[c], self.cell_cap))
        else:
            ti.loop_config(serialize=True)
            for _ in range(1):
                self.bin_all()
        for i in range(self.p.live[None]):
            self.build_particle(i)
        for i in range(self.p.live[None]):
            self.link_reverse(i)
        ti.loop_config(serialize=True)
        for _ in range(1):
            self.built()

    # ------------------------------------------------------------------ per step
    @ti.func
    def gather(self, i):
        """Forces and torques of i's open contacts: its own list's sum (which the pair loop left in
        i's force and torque), then the lower partners' slots in id order (N, N m)."""
        f, t = self.p.f[i], self.p.tq[i]
        for q in range(self.rv_n[i]):
            slot = self.rv_slot[i, q]
            if slot >= 0:  # always, unless j's list overflowed (then the run stops)
                j, s = slot // self.k_max, slot % self.k_max
                if self.open[j] & bit(s):
                    r = self.record(j, s)
                    f -= self.f[j, r]
                    t += self.t_j[j, r]
        return f, t

    @ti.func
    def record(self, i, s):
        """Where the records of the open contact in slot s of i's list are: (i, record)."""
        return ti.cast(self.rec[i, s], ti.i32)

    @ti.func
    def take_record(self, i, s, used):
        """A contact opens in slot s of i: the lowest record not in `used` is its; returns the record
        and the new `used` (a free record exists: i has fewer open contacts than slots)."""
        free = ~used
        r = ti.cast(ti.math.popcnt((free & (~free + ti.u64(1))) - ti.u64(1)), ti.i32)
        self.rec[i, s] = ti.cast(r, ti.u8)
        return r, used | bit(r)

    @ti.func
    def watch(self, i):
        """Mark i's replica for a rebuild if its next drift leaves the skin (end of a step)."""
        x_next = self.p.next_position(i)
        half = 0.5 * self.skin
        if (x_next - self.x_ref[i]).norm_sqr() > half * half:
            self.due[self.p.rep[i]] = 1
            self.any_due[None] = 1
            if (x_next - self.p.x[i]).norm_sqr() > half * half:
                ti.atomic_max(self.monitor.fast[None], i + 1)

    def open_slots(self) -> np.ndarray:
        """(n, capacity) mask of the list slots whose pair is in contact now."""
        n = self.p.n
        bits = np.uint64(1) << np.arange(self.k_max, dtype=np.uint64)
        return (self.open.to_numpy()[:n, None] & bits[None, :]) != 0

    def contact_pairs(self) -> int:
        """Pairs in contact now."""
        return int(self.open_slots().sum())
