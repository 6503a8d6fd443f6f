"""Small systems for the physics tests (BALLMILL_TEST_ARCH=cuda runs them on a GPU,
BALLMILL_TEST_PRECISION=f32 in single precision)."""

import os

import numpy as np

from ballmill.config import DrumConfig, InteractionConfig, MaterialConfig, SimConfig
from ballmill.dem import Body, EngineOptions, Interaction, Material, Plane, Recorder, SystemSpec, new_engine

RIGID = Material("rigid", 1.0, 1e25, 0.3)  # a wall that does not deform: E* = E_ball / (1 - v^2)
NO_GRAVITY = (0.0, 0.0, 0.0)


def floor_system(material, radius, velocities, restitutions=(1.0,), friction=0.0, rolling=0.0,
                 gap=1e-6, gravity=NO_GRAVITY, wall=RIGID, spins=None):
    """One sphere per replica just above a floor plane z=0, moving with velocities[r]."""
    velocities = np.atleast_2d(velocities)
    n = len(velocities)
    rest = np.broadcast_to(restitutions, (n,))
    pos = np.tile([0.0, 0.0, radius + gap], (n, 1))
    tables = [
        {tuple(sorted((material.name, wall.name))): Interaction(float(e), friction, rolling),
         (material.name, material.name): Interaction(float(e), friction, rolling)}
        for e in rest
    ]
    return SystemSpec(
        materials={material.name: material, wall.name: wall}, interactions=tables,
        position_m=pos, radius_m=np.full(n, radius), material=np.zeros(n), replica=np.arange(n),
        velocity_m_per_s=velocities, angular_velocity_rad_per_s=spins,
        bodies=[Body("floor", wall.name, (Plane((0, 0, 0), (0, 0, 1)),))],
        domain_lo_m=(-10, -10, -1), domain_hi_m=(10, 10, 10), gravity_m_per_s2=gravity,
    )


def run(spec, dt, duration, sample_every=None, trajectory_every=0, phases=(), **options):
    """The engine (the kept one where the system fits it, as a run takes it) and its results."""
    engine = new_engine(spec, EngineOptions(dt_s=dt, **options), os.environ.get("BALLMILL_TEST_ARCH", "cpu"),
                        os.environ.get("BALLMILL_TEST_PRECISION", "f64"))
    results = engine.run(duration, sample_every or duration, Recorder(engine, trajectory_every), phases=phases)
    return engine, results


MATERIALS = {"steel": MaterialConfig()}
PAIRS = {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}
DRUM_SIM = SimConfig(shear_modulus_scale=1e-2, settle_s=0.3, startup_revolutions=None, window_revolutions=None,
                     steady_after_s=0.2, duration_s=1.5, sample_every_s=0.01)


def small_drum(geometry="analytic"):
    """A 0.3 m drum with 304 balls of 20 mm turning at 70 % of critical, as an analytic or STL wall."""
    return DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, ball_radius_m=0.01, geometry=geometry,
                      stl_segments=64)
