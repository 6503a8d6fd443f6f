"""A team of CPU threads that runs many whole steps in one kernel launch.

On a CPU each parallel loop costs a thread-pool dispatch (tens of microseconds on a virtual
machine: ~70 us measured here, against ~3 ms for a whole step of 8,640 balls), and a step has
three of them.  A team launches once for many steps: one loop iteration per thread and a spin
barrier between the phases of a step.  The particles are cut into chunks and each member owns a
run of consecutive chunks; in every phase it does its own chunks first, in order, and then
takes chunks from the far end of the runs of members still busy (a claim per chunk, so each is
done once).  Owning keeps a particle's data in one core's cache from phase to phase; handing
out chunks first-come (a shared ticket) let a particle move between cores at every phase, and
that swung a run between 1.0x and 1.85x of one thread (8,640-ball drum, 2 threads).  Every
particle is still processed by exactly one thread with the same functions in the same order,
so results do not depend on the team or its size.

Every member must run at once (a barrier waits for all), so a team is only as large as the
thread pool: `size` = Taichi's CPU threads.  Taichi's CPU runtime hands a range-for's
iterations to its threads in blocks (of 512 in Taichi 1.7, whatever block_dim asks: a loop of
two iterations runs both on one thread), so member t is iteration t * SPACING of a loop over
size * SPACING iterations (`members`), each in a block of its own, the others empty.
"""

import logging
import math

import taichi as ti

from . import layout
from .particles import capacity

log = logging.getLogger(__name__)

SPACING = 1024  # iterations per member: a multiple of the runtime's block of 512
# chunks: about 32 per member, so that the chunks taken from a busy member even out the load
# (on the 8,640-ball drum, 2 threads, the barrier waits fell ~3x against 8 per member), and
# no fewer than 64 particles, so that a chunk's neighbours are mostly in the chunk
PER_MEMBER, MIN_CHUNK, MAX_CHUNK = 32, 64, 4096


@ti.func
def block_lead(q):
    """Which block of SPACING iterations q is the first of (-1: not a block's first): the one
    iteration of its block that does the block's work (a team member, a run of replicas)."""
    return q // SPACING if q % SPACING == 0 else -1


@ti.data_oriented
class Team:
    """`size` threads sharing `n` particles in chunks, with a barrier."""

    def __init__(self, size: int, n: int):
        self.size = size
        chunk = min(MAX_CHUNK, max(MIN_CHUNK, n // (PER_MEMBER * size)))
        self.n_chunks = math.ceil(n / chunk)
        # read at run time, so that systems of other sizes share the compiled kernels
        self.chunk = layout.scalar(ti.i32, ())  # particles per chunk
        self.chunks = layout.scalar(ti.i32, ())  # = n_chunks
        self.chunk[None], self.chunks[None] = chunk, self.n_chunks
        # the last phase (of this launch) that took each chunk; sized by the team, not by n, so
        # that systems of one size class share the compiled kernels (n_chunks <= ~33 per member)
        self.claim = layout.scalar(ti.i32, capacity(max(2 * PER_MEMBER * size, math.ceil(n / MAX_CHUNK) + 1)))
        assert self.n_chunks <= self.claim.shape[0]
        self.arrived = layout.scalar(ti.i32, ())  # arrivals at barriers this launch

    @property
    def members(self) -> int:
        return self.size * SPACING

    @property
    def max_steps_per_launch(self) -> int:
        """Steps whose phase numbers and barrier arrivals fit an i32: at most 5 phases a step."""
        return max(1, (2**31 - 1) // (5 * self.size))

    @ti.kernel
    def reset(self):
        """Before each launch: no chunk taken, no barrier passed."""
        ti.loop_config(serialize=True)
        for c in range(self.claim.shape[0]):
            self.claim[c] = -1
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
    def own(self, u):
        """Member u's own chunks: [first, last)."""
        nc = self.chunks[None]
        return u * nc // self.size, (u + 1) * nc // self.size

    @ti.func
    def take(self, c, phase):
        """Whether this member takes chunk c in `phase` (no other member took it yet)."""
        return ti.atomic_max(self.claim[c], phase) < phase


class Pacer:
    """Runs a team engine's steps on the team or on one thread, whichever is faster now.

    A team's barriers wait for its slowest member, so a core taken by another process slows
    the whole team: the BPR 19 mill (523 balls, 2 threads) ran at 3.1-4.0e6 particle-steps/s
    with a busy loop on one core, against 7.0-8.7e6 on one thread.  Both launches give the same
    bits (engine.py), so the pacer may switch at any launch.  It times the team over windows of
    PROBE_AFTER_S of running time, and after a window in which the team was not MARGIN ahead of
    one thread's last rate (or before any), it times one thread on a short probe: a team
    clearly ahead is not probed again.  The first window is PROBE_FIRST_S, so that the first
    probe falls early in a run (its settling), not in the part that is timed or averaged (after
    2 s it fell in the bench's 0.05 s windows and took 37 % of their steps).  While one thread
    is ahead, it tries the team after a window of one thread's running time that doubles each
    time the team loses (RETRY_S).  The team's first launch compiles, and is not timed (the
    engine compiled the serial launch when it computed its first forces)."""

    PROBE_FIRST_S = 0.5  # the team's running time before the first probe (s)
    PROBE_AFTER_S = 2.0  # a window of the team's running time (s)
    PROBE_S = 0.25  # a probe's length (s), at the rate of what runs now
    MARGIN = 1.1  # the other launch takes over when it is this much faster
    RETRY_S = (2.0, 64.0)  # one thread's running time before the team is tried again: first, most

    def __init__(self, n_particles: int, threads: int):
        self.n, self.threads = n_particles, threads
        self.current, self.probing = "team", False
        self.rate = {"team": 0.0, "serial": 0.0}  # particle-steps per second, as last measured
        self.compiled = {"serial"}  # a team engine's first forces ran the serial launch
        self.window = [0, 0.0]  # steps and seconds of the current launch in this window
        self.retry_s = self.RETRY_S[0]
        self.steps = {"team": 0, "serial": 0}

    def plan(self, remaining: int) -> tuple[str, int]:
        """The launch for the next steps and how many of the `remaining` it runs."""
        steps, seconds = self.window
        if self.current == "serial":
            limit = self.retry_s
        else:
            limit = self.PROBE_AFTER_S if self.rate["serial"] else self.PROBE_FIRST_S
        if seconds >= limit:
            rate = self.rate[self.current] = self.n * steps / seconds
            self.window = [0, 0.0]
            self.probing = self.current == "serial" or rate < self.MARGIN * self.rate["serial"] or \
                not self.rate["serial"]
        if not self.probing:
            return self.current, remaining
        other = "serial" if self.current == "team" else "team"
        return other, max(1, min(remaining, round(self.PROBE_S * self.rate[self.current] / self.n)))

    def record(self, kind: str, steps: int, seconds: float) -> None:
        """What the last launch did: `steps` steps of `kind` in `seconds` of wall time."""
        self.steps[kind] += steps
        if kind not in self.compiled:
            self.compiled.add(kind)
        elif kind == self.current:
            self.window[0] += steps
            self.window[1] += seconds
        else:
            self.probing = False
            rate = self.rate[kind] = self.n * steps / max(seconds, 1e-9)
            if rate > self.MARGIN * self.rate[self.current]:
                log.info("%d balls: %s at %.3g particle-steps/s against %.3g: running %s", self.n, self._name(kind),
                         rate, self.rate[self.current], self._name(kind))
                self.current, self.retry_s = kind, self.RETRY_S[0]
            elif kind == "team":
                self.retry_s = min(2 * self.retry_s, self.RETRY_S[1])

    def _name(self, kind: str) -> str:
        return f"the team of {self.threads} threads" if kind == "team" else "one thread"
