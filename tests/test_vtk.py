"""ParaView output read back with meshio and compared with the engine's state; the bed picture."""

import math
from dataclasses import replace
from xml.etree import ElementTree

import meshio
import numpy as np
from helpers import DRUM_SIM, MATERIALS, PAIRS, small_drum

from ballmill.drum import drum_mesh, simulate_drum
from ballmill.files import read_parquet
from ballmill.liner import liner_profile
from ballmill.plots import plot_bed, save_figure


def test_vtk_series_holds_the_particles_and_the_turned_drum(tmp_path):
    sim = replace(DRUM_SIM, settle_s=0.05, duration_s=0.1, vtk_every=5, steady_after_s=0.0)
    simulate_drum(small_drum("stl"), MATERIALS, PAIRS, sim, tmp_path)
    frames = ElementTree.parse(tmp_path / "vtk" / "particles.pvd").getroot().find("Collection")
    times = [float(d.get("timestep")) for d in frames]
    assert len(times) == 3 and times == sorted(times)  # samples 0, 5, 10 of 15
    last = meshio.read(tmp_path / "vtk" / frames[-1].get("file"))
    assert len(last.points) == 304
    assert set(last.point_data) >= {"id", "velocity", "angular_velocity", "radius", "material", "contacts"}
    assert last.point_data["contacts"].sum() > 304  # a bed at rest on the drum: most balls touch others
    # the walls turned with the drum: a mesh vertex lies where Motion.place puts it
    walls = meshio.read(tmp_path / "vtk" / "walls_00002.vtu")
    omega = 0.7 * 42.3 / math.sqrt(0.3 - 0.02) * 2 * math.pi / 60  # 70 % of critical (rad/s), about +y
    angle = omega * (times[-1] - sim.settle_s)
    rot = np.array([[math.cos(angle), 0, math.sin(angle)], [0, 1, 0], [-math.sin(angle), 0, math.cos(angle)]])
    assert np.allclose(walls.points[0], rot @ drum_mesh(small_drum("stl")).vertices_m[0], atol=1e-12)
    assert not np.allclose(walls.points[0], drum_mesh(small_drum("stl")).vertices_m[0])  # it did turn


def test_bed_picture_is_drawn_from_the_recorded_instants(analytic_drum_run, tmp_path):
    summary, folder = analytic_drum_run
    traj = read_parquet(folder / "trajectories.parquet")
    assert traj.t_s.nunique() == 40  # the snapshots of the averaging window (304 balls: the most)
    drum = small_drum("analytic")
    fig = plot_bed(traj, np.full(summary["balls"], 0.01), liner_profile(drum), summary["speed_rpm"] * math.pi / 30,
                   0.3, summary)
    assert len(fig.axes) == 5  # four instants and the colour bar
    save_figure(fig, tmp_path / "bed")
    assert (tmp_path / "bed.png").stat().st_size > 10_000
