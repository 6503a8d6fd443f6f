"""The contact law against analytic results (Hertz, restitution, oblique impact, rolling)."""

import math

import numpy as np
import pytest
from helpers import NO_GRAVITY, RIGID, floor_system, run

from ballmill.dem import Interaction, Material, SystemSpec
from ballmill.dem.materials import effective_youngs_modulus, hertz_contact_time, hertz_max_overlap, rayleigh_timestep

ALUMINIUM = Material("aluminium", 2699.0, 70e9 / 2.6, 0.30)  # Chung & Ooi (2011) test 2
GLASS = Material("glass", 2800.0, 48e9 / 2.4, 0.20)  # test 1
ALUMINA = Material("alumina", 4000.0, 380e9 / 2.46, 0.23)  # tests 3 and 4
STEEL = Material("steel", 7900.0, 77e9, 0.30)  # the paper's balls


def hertz_peak_force(m_eff, r_eff, e_star, v):
    return 4.0 / 3.0 * e_star * math.sqrt(r_eff) * hertz_max_overlap(m_eff, r_eff, e_star, v) ** 1.5



@pytest.mark.parametrize(
    "material, radius, speed",
    [(ALUMINIUM, 0.10, 0.2), (STEEL, 0.0088, 1.0)],
    ids=["chung-ooi-2-aluminium", "steel-17.6mm"],
)
def test_elastic_impact_on_rigid_wall_matches_hertz(material, radius, speed):
    m = material.density_kg_per_m3 * 4 / 3 * math.pi * radius**3
    e_star = effective_youngs_modulus(material, RIGID)
    t_c = hertz_contact_time(m, radius, e_star, speed)  # Chung & Ooi test 2: 7.32e-4 s
    d_max = hertz_max_overlap(m, radius, e_star, speed)  # 4.972e-5 m
    f_max = hertz_peak_force(m, radius, e_star, speed)  # 11.37 kN
    dt = t_c / 2000
    engine, res = run(floor_system(material, radius, [[0.0, 0.0, -speed]], gap=0.0), dt, 1.3 * t_c, sample_every=dt)
    hit = res.collisions.iloc[0]
    assert hit.t_end_s - hit.t_start_s == pytest.approx(t_c, rel=0.01)
    assert engine.max_overlap[None] * radius == pytest.approx(d_max, rel=0.01)
    assert -res.loads.force_z_n.min() == pytest.approx(f_max, rel=0.01)
    assert engine.kinematics()[1][0, 2] == pytest.approx(speed, rel=1e-3)


def test_chung_ooi_reference_values_are_reproduced_by_the_formulas():
    m = ALUMINIUM.density_kg_per_m3 * 4 / 3 * math.pi * 0.1**3
    e_star = effective_youngs_modulus(ALUMINIUM, RIGID)
    assert hertz_max_overlap(m, 0.1, e_star, 0.2) == pytest.approx(4.972e-5, rel=2e-3)
    assert hertz_peak_force(m, 0.1, e_star, 0.2) == pytest.approx(11.37e3, rel=2e-3)
    assert hertz_contact_time(m, 0.1, e_star, 0.2) == pytest.approx(7.32e-4, rel=2e-3)


def two_spheres(material, radius, speed, restitution=1.0):
    return SystemSpec(
        materials={material.name: material, RIGID.name: RIGID},
        interactions=[{(material.name, material.name): Interaction(restitution, 0.0, 0.0),
                       tuple(sorted((material.name, RIGID.name))): Interaction(1.0, 0.0, 0.0)}],
        position_m=[[-radius, 0, 0], [radius, 0, 0]], radius_m=[radius, radius], material=[0, 0],
        velocity_m_per_s=[[speed, 0, 0], [-speed, 0, 0]], bodies=[],
        domain_lo_m=(-1, -1, -1), domain_hi_m=(1, 1, 1), gravity_m_per_s2=NO_GRAVITY,
    )


def test_elastic_sphere_sphere_impact_matches_chung_ooi_test_1():
    radius, speed = 0.01, 10.0
    m = GLASS.density_kg_per_m3 * 4 / 3 * math.pi * radius**3
    m_eff, r_eff = m / 2, radius / 2
    e_star = effective_youngs_modulus(GLASS, GLASS)
    t_c = hertz_contact_time(m_eff, r_eff, e_star, 2 * speed)
    assert t_c == pytest.approx(4.03e-5, rel=5e-3)  # published benchmark values
    assert hertz_max_overlap(m_eff, r_eff, e_star, 2 * speed) == pytest.approx(2.741e-4, rel=5e-3)
    assert hertz_peak_force(m_eff, r_eff, e_star, 2 * speed) == pytest.approx(10.70e3, rel=5e-3)
    dt = t_c / 2000
    engine, res = run(two_spheres(GLASS, radius, speed), dt, 1.2 * t_c, sample_every=dt, trajectory_every=1)
    hit = res.collisions.iloc[0]
    assert hit.kind == "ball-ball" and hit.particle == 0 and hit.partner == 1
    assert hit.t_end_s - hit.t_start_s == pytest.approx(t_c, rel=0.01)
    assert engine.max_overlap[None] * radius == pytest.approx(2.741e-4, rel=0.01)
    assert engine.kinematics()[1][:, 0] == pytest.approx([-speed, speed], rel=1e-3)
    assert hit.impact_speed_m_per_s == pytest.approx(2 * speed, rel=1e-3)


@pytest.mark.parametrize("restitution", [0.2, 0.5, 0.8, 0.95])
def test_requested_restitution_is_achieved_at_any_impact_speed_without_pulling(restitution):
    speeds = np.array([0.1, 1.0, 5.0])
    radius = 0.0088
    m = STEEL.density_kg_per_m3 * 4 / 3 * math.pi * radius**3
    t_c = hertz_contact_time(m, radius, effective_youngs_modulus(STEEL, RIGID), speeds.min())
    vel = np.column_stack([np.zeros(3), np.zeros(3), -speeds])
    spec = floor_system(STEEL, radius, vel, restitutions=restitution, gap=0.0)
    engine, res = run(spec, t_c / 1000, 1.5 * t_c, sample_every=t_c / 200)
    rebound = engine.kinematics()[1][:, 2] / speeds
    assert rebound == pytest.approx(np.full(3, restitution), rel=0.01)
    assert res.loads.force_z_n.max() <= 0.0  # the floor is only ever pushed, never pulled
    assert (res.collisions.dissipated_j / res.collisions.impact_energy_j).to_numpy() == pytest.approx(
        np.full(3, 1 - restitution**2), rel=0.03
    )


def test_booked_dissipation_is_the_kinetic_energy_lost_at_a_coarse_step():
    """At 40 % of the Rayleigh step (~15 steps per contact) the restitution drifts up a little;
    the dissipation booked per collision must still be the kinetic energy the ball lost."""
    radius, speeds = 0.08, np.array([0.2, 1.0, 3.0])
    vel = np.column_stack([np.zeros(3), np.zeros(3), -speeds])
    spec = floor_system(STEEL, radius, vel, restitutions=0.5, gap=0.0, wall=STEEL)
    engine, res = run(spec, 0.4 * rayleigh_timestep(radius, STEEL), 6e-3)
    rebound = engine.kinematics()[1][:, 2] / speeds
    assert rebound == pytest.approx(np.full(3, 0.5), abs=0.01)
    lost = (res.collisions.dissipated_j / res.collisions.impact_energy_j).to_numpy()
    assert lost == pytest.approx(1 - rebound**2, rel=0.01)


def test_sphere_sphere_restitution_is_achieved():
    engine, _ = run(two_spheres(STEEL, 0.0103, 1.0, restitution=0.5), 2e-8, 1e-4)
    assert engine.kinematics()[1][1, 0] == pytest.approx(0.5, rel=0.01)


ANGLES_DEG = np.array([5.0, 15.0, 25.0, 45.0, 60.0, 80.0])


def test_oblique_impact_follows_rigid_body_impulse_solution():
    """Chung & Ooi test 4: alumina sphere, 3.9 m/s, e 0.98, mu 0.092, on an alumina plane.

    Gross sliding for tan(theta) > 3.5 mu (1 + e) (theta > 32.5 deg): rebound spin
    2.5 mu (1 + e) v_n / R and tangential speed v_t - mu (1 + e) v_n.  Below it the contact
    sticks.  There a rigid-body "stick" model predicts spin 5 v_t / (7 R), but a Mindlin
    contact is tangentially compliant and its contact point recoils (Maw, Barber & Fawcett
    1976), so the spin is not that value; what must hold is Coulomb's bound: no more spin
    than gross sliding would give.
    """
    radius, speed, e, mu = 2.5e-3, 3.9, 0.98, 0.092
    theta = np.radians(ANGLES_DEG)
    v_t, v_n = speed * np.sin(theta), speed * np.cos(theta)
    vel = np.column_stack([v_t, np.zeros_like(v_t), -v_n])
    spec = floor_system(ALUMINA, radius, vel, restitutions=e, friction=mu, gap=0.0, wall=ALUMINA)
    engine, _ = run(spec, 5e-9, 1.2e-5)
    _, v, w = engine.kinematics()
    spin = w[:, 1]  # rolling about +y for motion along +x
    sliding = np.tan(theta) > 3.5 * mu * (1 + e)
    assert v[:, 2] == pytest.approx(e * v_n, rel=0.01)
    assert spin[sliding] == pytest.approx(2.5 * mu * (1 + e) * v_n[sliding] / radius, rel=0.03)
    assert v[sliding, 0] == pytest.approx(v_t[sliding] - mu * (1 + e) * v_n[sliding], rel=0.03)
    assert np.all(spin[~sliding] <= 1.01 * 2.5 * mu * (1 + e) * v_n[~sliding] / radius)
    assert np.all(spin[~sliding] > 0)


def test_rolling_friction_decelerates_a_rolling_ball_at_five_sevenths_mu_r_g():
    radius, mu_r, g, v0 = 0.01, 0.01, 9.81, 0.5
    m = STEEL.density_kg_per_m3 * 4 / 3 * math.pi * radius**3
    e_star = effective_youngs_modulus(STEEL, RIGID)
    settle = (m * g / (4 / 3 * e_star * math.sqrt(radius))) ** (2 / 3)  # static Hertz overlap
    spec = floor_system(STEEL, radius, [[v0, 0, 0]], restitutions=0.5, friction=0.5, rolling=mu_r,
                        gap=-settle, gravity=(0, 0, -g), spins=[[0, v0 / radius, 0]])
    _, res = run(spec, 2e-6, 0.3, sample_every=0.01, trajectory_every=1)
    tr = res.trajectories[res.trajectories.t_s > 0.05]
    slope = np.polyfit(tr.t_s, tr.vx_m_per_s, 1)[0]
    assert -slope == pytest.approx(5 / 7 * mu_r * g, rel=0.02)
