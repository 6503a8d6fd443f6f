"""Memory layout: the values a kernel reads together, placed side by side.

A field made with a shape is a separate array (structure of arrays), so reading a partner's
position, velocity, spin, radius and mass touches five cache lines.  `records` places
fields made without a shape in one array of records instead: what a contact reads of one
item comes in one or two lines.  Only the layout changes, not the arithmetic: results are
the same bits.
"""

import taichi as ti


def records(shape, *fields, slot_major: bool = False) -> None:
    """Allocate `fields` (made without a shape) as one array of records of the given shape;
    slot_major (2-D shapes): stored by column, item [i, s] beside [i + 1, s]."""
    shape = (shape,) if isinstance(shape, int) else tuple(shape)
    if slot_major:
        ti.root.dense(ti.j, shape[1]).dense(ti.i, shape[0]).place(*fields)
    else:
        ti.root.dense(ti.axes(*range(len(shape))), shape).place(*fields)
