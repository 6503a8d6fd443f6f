"""Lifter bars and wave liners (the profile's geometry, a ball carried by a lifter) and graded charges."""

import math

import numpy as np
import pytest
from helpers import MATERIALS, PAIRS, run

from ballmill.config import BallSizeConfig, ConfigError, DrumConfig, LinerConfig, SimConfig, check_charge
from ballmill.dem import Body, Interaction, Material, Motion, SystemSpec
from ballmill.drum import AXIS, ball_radii, bed_ball_volume_m3, drum_spec, drum_speed_rpm, drum_walls
from ballmill.liner import liner_mesh, liner_profile, liner_size

SOFT_STEEL = Material("steel", 7900.0, 77e7, 0.3)  # shear modulus 100x lower: fewer steps
G = 9.81


def bars(count=1, height=0.03, width=0.02, face=0.0, first=0.0, d=0.4, length=0.08):
    liner = LinerConfig(kind="bars", count=count, height_m=height, top_width_m=width, face_angle_deg=face,
                        first_angle_deg=first)
    return DrumConfig(inner_diameter_m=d, inner_length_m=length, ball_radius_m=0.01, ball_count=1,
                      fraction_of_critical=0.1, liner=liner, stl_segments=720)  # facets 2 um from the circle


def test_bar_profile_has_the_requested_height_top_width_and_face_angle():
    drum = bars(count=6, height=0.03, width=0.02, face=30.0, first=90.0)
    p = liner_profile(drum)
    r = np.hypot(p[:, 0], p[:, 1])
    assert r.max() == pytest.approx(0.2, abs=1e-12)
    top = p[np.isclose(p[:, 1], 0.17)]  # the bar at 90 deg: its top at z = R - h
    assert len(top) == 2 and np.ptp(top[:, 0]) == pytest.approx(0.02, abs=1e-12)
    face = p[0] - p[1]  # the first bar's corners come first: its trailing face, top to base
    assert math.degrees(math.atan2(abs(face[0]), face[1])) == pytest.approx(30.0, abs=1e-9)  # tilt from the radius
    assert (r < 0.2 - 1e-9).sum() == 6 * 2  # two top corners per bar inside the shell
    mesh = liner_mesh(drum)
    assert len(mesh.faces) == 2 * len(p)


def test_wave_profile_has_crests_of_the_requested_height():
    drum = DrumConfig(inner_diameter_m=0.4, liner=LinerConfig(kind="wave", count=8, height_m=0.02))
    r = np.hypot(*liner_profile(drum).T)
    assert r.min() == pytest.approx(0.18, abs=1e-9) and r.max() == pytest.approx(0.2, abs=1e-9)


def test_overlapping_or_too_high_bars_are_refused():
    with pytest.raises(ConfigError, match="overlap"):
        liner_profile(bars(count=60, width=0.03))
    with pytest.raises(ConfigError, match="half the shell's radius"):
        liner_profile(bars(height=0.12))


def one_ball_at_the_bottom(drum):
    """The drum turning from t = 0 with one ball resting at its bottom (no rolling friction): (spec, omega)."""
    big_r, r = drum.inner_diameter_m / 2, drum.ball_radius_m
    omega = drum_speed_rpm(drum) * 2 * math.pi / 60
    spec = SystemSpec(
        materials={"steel": SOFT_STEEL}, interactions=[{("steel", "steel"): Interaction(0.5, 0.5, 0.0)}],
        position_m=np.array([[0.0, 0.0, -(big_r - r - 1e-4)]]), radius_m=np.array([r]), material=np.zeros(1),
        bodies=[Body("drum", "steel", drum_walls(drum), (Motion(axis=AXIS, angular_velocity_rad_per_s=omega),))],
        domain_lo_m=(-0.3, -0.1, -0.3), domain_hi_m=(0.3, 0.1, 0.3), gravity_m_per_s2=(0, 0, -G),
    )
    return spec, omega


def rotate(xz, angle):
    """Body-frame (x, z) vectors to world after the drum turned `angle` about +y (clockwise seen with z up)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([xz[..., 0] * c + xz[..., 1] * s, -xz[..., 0] * s + xz[..., 1] * c], axis=-1)


@pytest.mark.parametrize("face_angle", [0.0, 30.0])
def test_a_ball_on_a_lifter_is_carried_until_the_face_levels_in_the_effective_gravity(face_angle):
    """A ball in the corner of the shell and a lifter's leading face (no rolling friction) stays
    there while gravity plus the centrifugal force presses it along the face toward the shell;
    it leaves the shell when that component vanishes: face angle 0 near 90 deg past the bottom,
    30 deg about 30 deg earlier."""
    lifter_at = -70.0  # deg in the (x, z) plane; the ball starts at the bottom, -90 deg, ahead of it
    drum = bars(face=face_angle, first=lifter_at)
    big_r, r = drum.inner_diameter_m / 2, drum.ball_radius_m
    spec, omega = one_ball_at_the_bottom(drum)
    _, results = run(spec, 2e-5, 2.9, sample_every=0.002, trajectory_every=1)
    tr = results.trajectories.sort_values("t_s")
    phi = omega * tr.t_s.to_numpy()
    body = rotate(tr[["x_m", "z_m"]].to_numpy(), -phi)  # the ball in the body frame
    gap = (big_r - r) - np.hypot(*body.T)
    off = np.flatnonzero((phi > math.radians(50)) & (gap > 1e-5))
    assert len(off), "the ball never left the shell"
    assert gap[off[0] - 100:off[0]].max() < 1e-5, "the ball was not carried in the corner before it left"
    released = phi[off[0]]
    corner = body[off[0] - 20]  # the ball in the corner, 2.4 deg before it left
    # the leading face (toward lower angles, where the drum turns), from its top to the shell
    a, alpha = math.radians(lifter_at), math.radians(face_angle)
    e_r, e_t = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    down_face = math.cos(alpha) * e_r - math.sin(alpha) * e_t
    angles = np.linspace(0.2, 3.0, 28001)
    g_eff = np.array([0.0, -G]) + omega**2 * rotate(corner, angles)
    pressing = (g_eff * rotate(down_face, angles)).sum(axis=1)
    predicted = angles[np.argmax(pressing < 0)]
    assert math.degrees(released) == pytest.approx(math.degrees(predicted), abs=2.0)
    assert math.degrees(predicted) == pytest.approx(110.0 - face_angle, abs=3.0)  # the face horizontal


def test_a_graded_charge_is_packed_with_the_requested_sizes():
    by_count = DrumConfig(inner_diameter_m=0.305, inner_length_m=0.305, speed_rpm=70.0,
                          charge=[BallSizeConfig(0.0368, 43), BallSizeConfig(0.0297, 67), BallSizeConfig(0.0254, 10),
                                  BallSizeConfig(0.0191, 71), BallSizeConfig(0.0155, 94)])
    spec = drum_spec(by_count, MATERIALS, PAIRS, SimConfig())
    sizes, counts = np.unique(spec.radius_m * 2, return_counts=True)
    assert dict(zip(sizes.round(4), counts)) == {0.0155: 94, 0.0191: 71, 0.0254: 10, 0.0297: 67, 0.0368: 43}
    gaps = np.linalg.norm(spec.position_m[:, None] - spec.position_m[None], axis=2) - spec.radius_m[:, None] - \
        spec.radius_m[None]
    assert gaps[~np.eye(len(gaps), dtype=bool)].min() > 0  # no ball starts in contact
    assert len(set(spec.radius_m[:43])) > 1  # sizes shuffled over the lattice, not layered

    fractions = [0.5, 0.3, 0.2]
    by_mass = DrumConfig(inner_diameter_m=0.4, inner_length_m=0.2, fill_fraction=0.3,
                         charge=[BallSizeConfig(d, mass_fraction=f) for d, f in zip((0.03, 0.02, 0.015), fractions)])
    r = ball_radii(by_mass)
    mass = np.array([(r[np.isclose(r, d / 2)] ** 3).sum() for d in (0.03, 0.02, 0.015)])
    assert mass / mass.sum() == pytest.approx(fractions, abs=0.01)  # a ball's rounding
    assert (r**3).sum() * 4 / 3 * math.pi == pytest.approx(bed_ball_volume_m3(by_mass), rel=0.01)


def test_a_charge_by_count_and_mass_fraction_at_once_is_refused():
    with pytest.raises(ConfigError, match="every size a count, or every size a mass_fraction"):
        check_charge("mill.charge", [BallSizeConfig(0.02, 10), BallSizeConfig(0.01, mass_fraction=0.5)])
    with pytest.raises(ConfigError, match="sum to 0.9"):
        check_charge("mill.charge", [BallSizeConfig(0.02, mass_fraction=0.4), BallSizeConfig(0.01, mass_fraction=0.5)])


def test_lifters_sized_as_a_fraction_of_the_diameter_grow_with_the_mill():
    liner = LinerConfig(kind="bars", count=12, height_to_diameter=0.04, top_width_to_height=1.5)
    for d in (1.0, 3.0):
        height, width = liner_size(liner, d)
        assert (height, width) == pytest.approx((0.04 * d, 0.06 * d))
        drum = DrumConfig(inner_diameter_m=d, inner_length_m=d, ball_radius_m=0.04, liner=liner)
        assert np.hypot(*liner_profile(drum).T).min() == pytest.approx(math.hypot(0.46 * d, 0.03 * d))


def test_a_lifter_lower_than_the_ball_carries_it_by_its_edge():
    """A 6 mm lifter meets a 10 mm ball at its convex top edge while the ball touches a shell facet:
    both contacts act, so the ball is carried up, not sunk into the edge."""
    drum = bars(height=0.006, width=0.01, first=-75.0)
    spec, _ = one_ball_at_the_bottom(drum)
    _, results = run(spec, 2e-5, 1.5, sample_every=0.01, trajectory_every=1, max_overlap_fraction=0.02)
    end = results.trajectories.sort_values("t_s").iloc[-1]
    assert math.degrees(math.atan2(end.x_m, -end.z_m)) < -25.0  # carried up the rising side (x < 0)
