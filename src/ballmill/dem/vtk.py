"""ParaView output: particles and walls as VTK unstructured grids (.vtu, written by meshio) with
a .pvd time series for each, which ParaView opens in one step.

meshio rather than pyevtk: it writes and reads .vtu (so the test reads back what was written
with the same library) and takes points and triangle meshes alike.  The .pvd index, a list
of file names and times, is a few lines of XML written here.
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.etree import ElementTree

import meshio
import numpy as np

from .geometry import Capsule, Mesh, Plane

SEGMENTS = 48  # facets around a cylinder or capsule


def tessellate(wall, half_extent_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame triangles of a wall: (points (P, 3) m, triangles (T, 3)); a plane is drawn as a
    square of half side `half_extent_m` around its point."""
    if isinstance(wall, Mesh):
        return np.asarray(wall.vertices_m, float), np.asarray(wall.faces, np.int64)
    axis = np.asarray(wall.normal if isinstance(wall, Plane) else wall.axis, float)
    axis = axis / np.linalg.norm(axis)
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    if isinstance(wall, Plane):
        p = np.asarray(wall.point_m, float)
        corners = [p + half_extent_m * (a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        return np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])
    # rings along the axis: the straight part, then (capsule) hemispheres closing each end
    h, r = wall.half_length_m, wall.radius_m
    rings = [(-h, r), (h, r)]
    if isinstance(wall, Capsule):
        caps = [math.pi / 2 * k / 8 for k in range(1, 9)]
        rings = [(-h - r * math.sin(a), r * math.cos(a)) for a in reversed(caps)] + rings
        rings += [(h + r * math.sin(a), r * math.cos(a)) for a in caps]
    phi = np.linspace(0.0, 2 * math.pi, SEGMENTS, endpoint=False)
    centre = np.asarray(wall.center_m, float)
    points = np.array([centre + z * axis + rad * (math.cos(f) * u + math.sin(f) * v) for z, rad in rings for f in phi])
    tris = []
    for k in range(len(rings) - 1):
        for s in range(SEGMENTS):
            a, b = k * SEGMENTS + s, k * SEGMENTS + (s + 1) % SEGMENTS
            tris += [[a, b, b + SEGMENTS], [a, b + SEGMENTS, a + SEGMENTS]]
    return points, np.array(tris)


class VtkWriter:
    """A sink of a Recorder: writes `vtk/particles_NNNNN.vtu` and `vtk/walls_NNNNN.vtu` every `every` samples of a run
    into `folder`, and keeps `particles.pvd` and `walls.pvd` up to date."""

    def __init__(self, folder: str | Path, every: int):
        self.folder, self.every = Path(folder) / "vtk", every
        self.frames: list[tuple[float, str, str]] = []
        self.calls = 0

    def sample(self, engine) -> None:
        due = self.every and self.calls % self.every == 0
        self.calls += 1
        if not due:
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        k = len(self.frames)
        names = (f"particles_{k:05d}.vtu", f"walls_{k:05d}.vtu")
        self._particles(engine, self.folder / names[0])
        self._walls(engine, self.folder / names[1])
        self.frames.append((engine.time_s, *names))
        for j, series in enumerate(("particles", "walls")):
            write_pvd(self.folder / f"{series}.pvd", [(t, files[j]) for t, *files in self.frames])

    def close(self, results) -> None:
        pass

    @staticmethod
    def _particles(engine, path: Path) -> None:
        x, v, w = engine.kinematics()
        n = len(x)
        meshio.write(path, meshio.Mesh(x, [("vertex", np.arange(n).reshape(-1, 1))], point_data={
            "id": np.arange(n, dtype=np.int32), "replica": engine.spec.replica.astype(np.int32),
            "material": engine.spec.material.astype(np.int32), "radius": engine.spec.radius_m,
            "velocity": v, "angular_velocity": w,
            "contacts": engine.contact_counts().astype(np.int32)}))

    @staticmethod
    def _walls(engine, path: Path) -> None:
        """Every wall of replica 0 in its pose at the engine's time; cell data: body index."""
        spec = engine.spec
        extent = 0.5 * float(np.linalg.norm(np.subtract(spec.domain_hi_m, spec.domain_lo_m)))
        points, tris, body_of = [], [], []
        offset = 0
        for b, body in enumerate(spec.bodies):
            for wall in body.walls:
                p, t = tessellate(wall, extent)
                points.append(body.motions[0].place(engine.time_s, p))
                tris.append(t + offset)
                body_of.append(np.full(len(t), b, np.int32))
                offset += len(p)
        if not points:
            points, tris, body_of = [np.zeros((3, 3))], [np.array([[0, 1, 2]])], [np.zeros(1, np.int32)]
        meshio.write(path, meshio.Mesh(np.vstack(points), [("triangle", np.vstack(tris))],
                                       cell_data={"body": [np.concatenate(body_of)]}))


def write_pvd(path: Path, frames: list[tuple[float, str]]) -> None:
    """A ParaView collection: one dataset per time step."""
    root = ElementTree.Element("VTKFile", type="Collection", version="0.1")
    coll = ElementTree.SubElement(root, "Collection")
    for t, name in frames:
        ElementTree.SubElement(coll, "DataSet", timestep=f"{t:.9g}", part="0", file=name)
    ElementTree.ElementTree(root).write(path, xml_declaration=True)
