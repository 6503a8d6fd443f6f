"""A team of CPU threads that runs many whole steps in one kernel launch.

On a CPU each parallel loop costs a thread-pool dispatch (tens of microseconds on a virtual
machine: ~70 us measured here, against ~3 ms for a whole step of 8,640 balls), and a step has
three of them.  A team launches once for many steps: one loop iteration per thread, the
particles handed out in chunks as threads free up (the cursor), and a spin barrier between
the phases of a step.  Every particle is still processed by exactly one thread with the same
functions in the same order, so results do not depend on the team or its size.

Every member must run at once (a barrier waits for all), so a team is only as large as the
thread pool: `size` = Taichi's CPU threads.  Taichi's CPU runtime hands a range-for's
iterations to its threads in blocks (of 512 in Taichi 1.7, whatever block_dim asks: a loop of
two iterations runs both on one thread), so member t is iteration t * SPACING of a loop over
size * SPACING iterations (`members`), each in a block of its own, the others empty.
"""

import math

import taichi as ti

SPACING = 1024  # iterations per member: a multiple of the runtime's block of 512
# chunk sizes: on the 8,640-ball drum, 2 threads, chunks of 256-4,320 particles ran ~1.4x
# faster than chunks of 16-64 (one process, 12 interleaved repeats)
MIN_CHUNK, MAX_CHUNK = 64, 4096


@ti.data_oriented
class Team:
    """`size` threads sharing `n` particles in chunks, with a barrier."""

    def __init__(self, size: int, n: int):
        # chunks of consecutive particles (neighbours in space, from the lattice the bed starts
        # on): large enough that a member mostly meets its own chunks' data, small enough that
        # each member gets about 8 and the last ones even out the load
        self.size = size
        chunk = min(MAX_CHUNK, max(MIN_CHUNK, n // (8 * size)))
        self.n_chunks = math.ceil(n / chunk)
        # read at run time, so that systems of other sizes share the compiled kernels
        self.chunk = ti.field(ti.i32, ())  # particles per chunk
        self.chunks = ti.field(ti.i32, ())  # = n_chunks
        self.chunk[None], self.chunks[None] = chunk, self.n_chunks
        self.cursor = ti.field(ti.i32, ())  # tickets handed out this launch
        self.arrived = ti.field(ti.i32, ())  # arrivals at barriers this launch

    @ti.func
    def member(self, q):
        """Which member iteration q of a loop over `members` iterations is (-1: an empty one)."""
        return q // SPACING if q % SPACING == 0 else -1

    @property
    def members(self) -> int:
        return self.size * SPACING

    @property
    def max_steps_per_launch(self) -> int:
        """Steps whose tickets and barrier arrivals fit an i32: at most 5 phases a step."""
        return max(1, (2**31 - 1) // (5 * (self.n_chunks + self.size)))

    @ti.kernel
    def reset(self):
        """Before each launch: no tickets handed out, no barrier passed."""
        self.cursor[None] = 0
        self.arrived[None] = 0

    @ti.func
    def barrier(self, passed):
        """Wait until every member has arrived; `passed` counts this member's earlier barriers."""
        ti.atomic_add(self.arrived[None], 1)
        target = (passed + 1) * self.size
        while ti.atomic_add(self.arrived[None], 0) < target:
            pass
        return passed + 1

    @ti.func
    def ticket(self, base):
        """The next chunk of the phase whose first ticket was `base` (>= n_chunks: none left)."""
        return ti.atomic_add(self.cursor[None], 1) - base

    @ti.func
    def next_base(self, base):
        """First ticket of the next phase: each member took one ticket past the last chunk."""
        return base + self.chunks[None] + self.size
