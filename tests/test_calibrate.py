"""Proof of the calibration method: film a simulation whose ball-wall pair the calibration is
not told, track the videos, calibrate on a grid, and recover the hidden pair.

Mean ball speed hardly depends on the pair; the video collision rate carries the restitution
(tens of collisions per second more per +0.3), the friction only weakly: the test asks for the
restitution exactly and the friction within one grid step.
"""

import json

import pandas as pd
import pytest

from ballmill.calibrate import calibrate, observations
from ballmill.cli import main
from ballmill.config import CalibrationConfig, ConfigError
from ballmill.lab import conditions, simulate_mm400
from ballmill.scenario import compose, load
from ballmill.vision.render import Camera, render_lab_videos

HIDDEN = (0.6, 0.3)
GRID = CalibrationConfig(restitutions=[0.3, 0.6, 0.9], frictions=[0.1, 0.3, 0.5])
LAB = ["lab.balls_per_jar=1", "lab.frequencies_hz=[25.0,30.0]", "lab.ball_diameters_m=[0.0176]", "lab.duration_s=1.2"]


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    folder = tmp_path_factory.mktemp("experiment")
    s = load(compose("config", ["sim=lab", *LAB, "sim.seed=11"]))
    conds = conditions(s.lab, [HIDDEN[0]], [HIDDEN[1]])
    traj, _ = simulate_mm400(s.lab, conds, s.materials, s.interactions, s.sim)
    render_lab_videos(folder, s.lab, conds, traj, Camera(mm_per_px=0.3, seed=11))
    pd.read_csv(folder / "videos.csv").drop(columns=["wall_restitution", "wall_friction"]).to_csv(
        folder / "videos.csv", index=False)  # the calibration is not told
    return folder


def test_calibration_recovers_the_hidden_pair(experiment):
    s = load(compose("config", ["sim=lab", *LAB]))  # another seed than the experiment's
    obs = observations(experiment, s.lab)
    assert (obs.lost_ball_frames == 0).all()
    surface, simulated, best = calibrate(obs, s.lab, GRID, s.materials, s.interactions, s.sim)
    assert len(surface) == 9 and len(simulated) == 18
    assert best["wall_restitution"] == HIDDEN[0], surface
    assert abs(best["wall_friction"] - HIDDEN[1]) <= 0.2 + 1e-9, surface
    assert best["speed_rms_error"] < 0.25  # 1.2 s runs: the seed alone moves mean speed ~15 %


def test_calibrate_command_writes_surface_figures_and_best_pair(experiment, tmp_path):
    main(["calibrate", f"videos={experiment}", f"out={tmp_path}", *LAB, "lab.frequencies_hz=[25.0]",
          "restitutions=[0.3,0.6]", "frictions=[0.3]"])
    best = json.loads((tmp_path / "best.json").read_text())
    assert best["wall_restitution"] == HIDDEN[0]  # the pair the experiment was filmed at
    for name in ("score_surface.png", "score_surface.svg", "validation.png", "observations.csv"):
        assert (tmp_path / name).exists()


def test_bad_grid_names_the_field():
    with pytest.raises(ConfigError, match=r"restitutions\[1\]=1.5 .*\(0.0, 1.0\]"):
        CalibrationConfig(restitutions=[0.5, 1.5])
