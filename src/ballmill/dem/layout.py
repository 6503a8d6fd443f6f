"""The engine's fields: how they are laid out in memory, and how a kept engine takes them again.

A field made with a shape is a separate array (structure of arrays), so reading a partner's
position, velocity, spin, radius and mass touches five cache lines.  `records` places
fields made without a shape in one array of records instead: what a contact reads of one
item comes in one or two lines.  Only the layout changes, not the arithmetic: results are
the same bits.

Every field of an engine is made here (`scalar`, `vector`, `matrix`, `records`).  While an
`Allocation` records, the fields made are kept in order; while it replays, the same calls
get those fields back, each checked to be of the same kind, type and shape
(`LayoutMismatch` otherwise), and nothing is allocated; `zero` sets them all to zero.  A
kept engine built again for another system of the same shapes so keeps its fields, and with
them the kernels Taichi compiled for them (engine.py: `Engine.reload`).
"""

from contextlib import contextmanager

import taichi as ti
from taichi.lang.field import Field

from .transfer import UNROLL


class LayoutMismatch(Exception):
    """A replayed allocation asked for a field unlike the one made at that place."""


class Allocation:
    """The fields an engine made, in the order it made them (see the module's docstring)."""

    def __init__(self):
        self.made: list[tuple[tuple, Field | None]] = []  # (what was asked, the field or None for a placement)
        self._next: int | None = None  # replaying: the index of the next field to hand back
        self._zeros: _Zeros | None = None

    def take(self, ask: tuple, make):
        """The field (or placement) `ask` describes: made by `make()` while recording, the one
        made at this place while replaying."""
        if self._next is None:
            made = make()
            self.made.append((ask, made))
            return made
        if self._next >= len(self.made) or self.made[self._next][0] != ask:
            raise LayoutMismatch(f"allocation {self._next}: {ask} asked, {self.made[self._next:self._next + 1]} made")
        self._next += 1
        return self.made[self._next - 1][1]

    @contextmanager
    def replaying(self):
        """Hand back the recorded fields to the same calls in the same order."""
        self._next = 0
        try:
            yield
            if self._next != len(self.made):
                raise LayoutMismatch(f"{self._next} of {len(self.made)} allocations replayed")
        finally:
            self._next = None

    def zero(self) -> None:
        """Every field made set to zero, as Taichi makes a new one (a kernel compiled on first use)."""
        if self._zeros is None:
            self._zeros = _Zeros([field for _, field in self.made if field is not None])
        self._zeros.run()


@ti.data_oriented
class _Zeros:
    """Fields set to zero, UNROLL at a time (Taichi's unrolling limit)."""

    def __init__(self, fields: list[Field]):
        self.chunks = [fields[i:i + UNROLL] for i in range(0, len(fields), UNROLL)]

    @ti.kernel
    def run(self):
        for chunk in ti.static(self.chunks):
            for field in ti.static(chunk):
                for index in ti.grouped(field):
                    if ti.static(not hasattr(field, "n")):
                        field[index] = ti.cast(0, field.dtype)
                    elif ti.static(field.ndim == 1):
                        field[index] = ti.Vector.zero(field.dtype, field.n)
                    else:
                        field[index] = ti.Matrix.zero(field.dtype, field.n, field.m)


_current: Allocation | None = None  # the allocation the engine being built records or replays


@contextmanager
def allocating(allocation: Allocation):
    """Make (or replay) every field of the block through `allocation`."""
    global _current
    outer, _current = _current, allocation
    try:
        yield allocation
    finally:
        _current = outer


def _take(ask: tuple, make):
    return make() if _current is None else _current.take(ask, make)


def scalar(dtype, shape=None) -> Field:
    return _take(("scalar", dtype, shape), lambda: ti.field(dtype, shape))


def vector(n: int, dtype, shape=None) -> Field:
    return _take(("vector", n, dtype, shape), lambda: ti.Vector.field(n, dtype, shape))


def matrix(n: int, m: int, dtype, shape=None) -> Field:
    return _take(("matrix", n, m, dtype, shape), lambda: ti.Matrix.field(n, m, dtype, shape))


def records(shape, *fields, slot_major: bool = False) -> None:
    """Allocate `fields` (made without a shape) as one array of records of the given shape;
    slot_major (2-D shapes): stored by column, item [i, s] beside [i + 1, s]."""
    shape = (shape,) if isinstance(shape, int) else tuple(shape)

    def place():
        if slot_major:
            ti.root.dense(ti.j, shape[1]).dense(ti.i, shape[0]).place(*fields)
        else:
            ti.root.dense(ti.axes(*range(len(shape))), shape).place(*fields)

    _take(("records", shape, len(fields), slot_major), place)
