"""The inner profile of a mill's shell (smooth, lifter bars or a wave liner) and its mesh.

The profile is a closed polygon in the drum's cross-section (body frame: x, z; the axis is y),
counter-clockwise, the direction the drum turns.  A lined shell becomes a triangle mesh: the
profile swept along the axis, open at the ends (the end walls stay analytic planes).  A mesh
rather than analytic boxes because the engine bins a mesh's triangles in cells, so a ball
meets the few facets near it whatever the number of lifters, where every analytic wall is
tested by every ball every step; and one mesh also covers wave liners and goes unchanged to
LIGGGHTS, which turns walls only as meshes.
"""

from __future__ import annotations

import math

import numpy as np

from .config import ConfigError, DrumConfig, LinerConfig
from .dem import Mesh


def liner_size(liner: LinerConfig, diameter_m: float) -> tuple[float, float]:
    """(height, top width) of the bars or waves in metres (top width 0 for waves; both 0 for a
    smooth shell)."""
    if liner.kind == "smooth":
        return 0.0, 0.0
    height = liner.height_m if liner.height_m is not None else liner.height_to_diameter * diameter_m
    if liner.kind != "bars":
        return height, 0.0
    width = liner.top_width_m if liner.top_width_m is not None else liner.top_width_to_height * height
    return height, width


def arc(radius: float, a0: float, a1: float, step: float) -> np.ndarray:
    """Points on a circle from angle a0 to a1 (rad, a1 > a0), at most `step` apart in angle, a1 left out."""
    n = max(1, math.ceil((a1 - a0) / step))
    a = a0 + (a1 - a0) * np.arange(n) / n
    return radius * np.column_stack([np.cos(a), np.sin(a)])


def bar_corners(radius: float, angle: float, height: float, width: float, face_angle: float) -> np.ndarray:
    """The four corners of a lifter bar centred at `angle` (rad): trailing base, trailing top,
    leading top, leading base (counter-clockwise order, x-z plane, m)."""
    e_r = np.array([math.cos(angle), math.sin(angle)])  # outward
    e_t = np.array([-math.sin(angle), math.cos(angle)])  # direction of rotation
    corners = []
    for side in (-1.0, 1.0):
        top = (radius - height) * e_r + side * width / 2 * e_t
        d = math.cos(face_angle) * e_r + side * math.sin(face_angle) * e_t  # down the face, to the shell
        b = top @ d
        s = -b + math.sqrt(b * b - (top @ top - radius**2))  # |top + s d| = radius
        corners.append((top + s * d, top))
    (base_lo, top_lo), (base_hi, top_hi) = corners
    return np.array([base_lo, top_lo, top_hi, base_hi])


def liner_profile(drum: DrumConfig) -> np.ndarray:
    """(P, 2) vertices (x, z in m, counter-clockwise) of the shell's inner profile; the circle
    is cut into stl_segments arcs a revolution."""
    liner, radius = drum.liner, drum.inner_diameter_m / 2
    step = 2 * math.pi / drum.stl_segments
    if liner.kind == "smooth":
        return arc(radius, 0.0, 2 * math.pi, step)
    height, width = liner_size(liner, drum.inner_diameter_m)
    if height >= radius / 2:
        raise ConfigError(f"mill.liner: lifters of height {height:.3g} m reach beyond half the shell's radius "
                          f"({radius:.3g} m): lower the height")
    first, pitch = math.radians(liner.first_angle_deg), 2 * math.pi / liner.count
    if liner.kind == "wave":
        n = max(drum.stl_segments, 16 * liner.count)
        a = first + 2 * math.pi * np.arange(n) / n
        r = radius - height * (1 + np.cos(liner.count * (a - first))) / 2  # crests at first + k pitch
        return r[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    points = []
    for k in range(liner.count):
        bar = bar_corners(radius, first + k * pitch, height, width, math.radians(liner.face_angle_deg))
        span = math.atan2(*bar[3][::-1]) - math.atan2(*bar[0][::-1])
        span = (span + math.pi) % (2 * math.pi) - math.pi
        if span >= pitch or span <= 0:
            raise ConfigError(f"mill.liner: {liner.count} bars {width:.3g} m wide at the top and {height:.3g} m high "
                              f"with {liner.face_angle_deg:g} deg faces overlap on a shell of radius {radius:.3g} m: "
                              "fewer, narrower or lower bars")
        gap_from = math.atan2(*bar[3][::-1])
        points += [*bar, *arc(radius, gap_from, gap_from + pitch - span, step)[1:]]
    return np.array(points)


def liner_mesh(drum: DrumConfig, closed: bool = False) -> Mesh:
    """The profile swept along the axis (y from -L/2 to L/2): two triangles per profile edge;
    `closed` adds the end walls as fans from the axis (the profile is star-shaped about it), for
    programs that take the whole drum as one mesh."""
    profile = liner_profile(drum)
    n, half = len(profile), drum.inner_length_m / 2
    ring = np.column_stack([profile[:, 0], np.zeros(n), profile[:, 1]])
    vertices = np.vstack([ring + [0.0, -half, 0.0], ring + [0.0, half, 0.0]])
    i = np.arange(n)
    j = (i + 1) % n
    faces = [np.column_stack([i, j, j + n]), np.column_stack([i, j + n, i + n])]
    if closed:
        vertices = np.vstack([vertices, [[0.0, -half, 0.0], [0.0, half, 0.0]]])
        faces += [np.column_stack([np.full(n, 2 * n), j, i]), np.column_stack([np.full(n, 2 * n + 1), i + n, j + n])]
    return Mesh(vertices, np.vstack(faces))
