"""Proof of the calibration method: film a simulation whose ball-wall pair the calibration is
not told, track the videos, calibrate on a grid, and recover the hidden pair.

The filmed run starts as the calibration's run of the same pair does (the same seed, the pair's
replicas in the same places of the grid's batch): the model is then exact, and what stands
between the videos and the truth is the renderer and the tracker alone.  With another seed the
pair cannot be told at these lengths: the collision rate of a 1.2 s run carries ~20 % of start
noise, more than a friction step moves it (measured near the pair: -0.28 of the rate per unit
friction against +3.2 per unit restitution), and over five other seeds the grid's best was
(0.9, 0.5), (0.6, 0.1), (0.6, 0.1), (0.6, 0.5), (0.9, 0.5); an earlier test of that kind passed
on one CPU's floating-point path and failed on another's.
"""

import json
from dataclasses import replace

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
LAB = ["lab.balls_per_jar=1", "lab.frequencies_hz=[25.0,30.0]", "lab.ball_diameters_m=[0.0176]", "lab.duration_s=1.2",
       "sim.seed=11"]


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    """The grid's runs as the calibration makes them; the hidden pair's filmed."""
    folder = tmp_path_factory.mktemp("experiment")
    s = load(compose("config", ["sim=lab", *LAB]))
    conds = conditions(s.lab, GRID.restitutions, GRID.frictions)
    traj, _ = simulate_mm400(s.lab, conds, s.materials, s.interactions, s.sim)
    filmed = [k for k, c in enumerate(conds) if (c.wall_restitution, c.wall_friction) == HIDDEN]
    traj = traj[traj.replica.isin(filmed)].assign(replica=lambda t: t.replica.map(filmed.index))
    # 0.2 mm/px, the default camera: at 0.3 mm/px the tracker errs by up to ~1 px where a ball
    # touches the jar's outline, 0.6 m/s at 2134 fps, and the 1 m/s jumps it counts double
    render_lab_videos(folder, s.lab, [conds[k] for k in filmed], traj, Camera(mm_per_px=0.2, seed=11))
    pd.read_csv(folder / "videos.csv").drop(columns=["wall_restitution", "wall_friction"]).to_csv(
        folder / "videos.csv", index=False)  # the calibration is not told
    return folder


def test_calibration_recovers_the_hidden_pair(experiment):
    """On the mean speed alone (collision_weight=0): the hidden pair's run is the filmed one, off by
    the tracker's error (measured 0.07 % rms in mean speed), every other pair's by its own dynamics
    (1.7 % and more over six seeds).  The tracker counts fewer collisions than the frames of the same run
    show (the hidden pair's collision_error measured +0.21), a bias the size of a restitution step's
    effect: with the collision rate in the score the pair is not told apart (0.045 against 0.055)."""
    s = load(compose("config", ["sim=lab", *LAB]))
    obs = observations(experiment, s.lab)
    assert (obs.lost_ball_frames == 0).all()
    surface, simulated, best = calibrate(obs, s.lab, replace(GRID, collision_weight=0.0), s.materials,
                                         s.interactions, s.sim)
    assert len(surface) == 9 and len(simulated) == 18
    assert (best["wall_restitution"], best["wall_friction"]) == HIDDEN, surface
    error = surface.set_index(["wall_restitution", "wall_friction"]).speed_rms_error
    assert best["speed_rms_error"] < 0.005 and error.drop(HIDDEN).min() > 5 * best["speed_rms_error"], surface
    assert abs(best["collision_error"]) < 0.3, surface


def test_bad_grid_names_the_field():
    with pytest.raises(ConfigError, match=r"restitutions\[1\]=1.5 .*\(0.0, 1.0\]"):
        CalibrationConfig(restitutions=[0.5, 1.5])


def smooth_response(obs, lab, pairs, materials, interactions, sim, repeats=1):
    """A noise-free stand-in for the simulator: speed and collision rate smooth in (e, mu)."""
    return pd.DataFrame([{**{k: getattr(o, k) for k in ("balls", "frequency_hz", "ball_diameter_m")},
                          "wall_restitution": e, "wall_friction": mu,
                          "mean_speed_m_per_s": o.frequency_hz / 10 * (1 + 0.3 * e - 0.5 * mu),
                          "video_collisions_per_s": o.frequency_hz * (4 * e**2 + 0.5 * mu)}
                         for o in obs.itertuples() for e, mu in pairs])


@pytest.mark.parametrize("seed", range(3))
def test_bayesian_search_finds_the_minimum_of_a_smooth_response_in_nine_trials(monkeypatch, seed):
    """The search machinery against a known minimum (the synthetic videos are too noisy for a
    0.05 resolution: docs/explanation/lab.md), in as many trials as the test grid has points:
    restitution within 0.05; the friction, on which the statistics hardly depend, within 0.17
    of it (the range, 0.1-0.5, allows 0.2), the score below 0.02 (0 at the minimum); measured
    over the three seeds: restitution 0.037, 0.049, 0.030 off, friction 0.157, 0.074, 0.026,
    score 0.011, 0.016, 0.0075."""
    import ballmill.calibrate as cal

    monkeypatch.setattr(cal, "simulate_grid", smooth_response)
    conditions_ = pd.DataFrame({"balls": [1, 1], "frequency_hz": [25.0, 30.0], "ball_diameter_m": [0.0176] * 2})
    obs = smooth_response(conditions_, None, [HIDDEN], None, None, None).drop(columns=["wall_restitution",
                                                                                         "wall_friction"])
    opts = CalibrationConfig(videos="-", trials=len(GRID.restitutions) * len(GRID.frictions), batch=3, seed=seed)
    trials, _, best = cal.search(obs, None, opts, None, None, None)
    assert len(trials) == 9 and trials.best_score.is_monotonic_decreasing
    assert abs(best["wall_restitution"] - HIDDEN[0]) < 0.05, trials
    assert abs(best["wall_friction"] - HIDDEN[1]) < 0.17 and best["score"] < 0.02, trials
    again, _, _ = cal.search(obs, None, opts, None, None, None)
    pd.testing.assert_frame_equal(trials, again)  # seeded: the same trials every time


def test_calibrate_both_methods_writes_the_comparison(experiment, tmp_path):
    """The grid finds the filmed pair as alone (the speed alone scored) and draws its figures; the
    search's best is its lowest-scoring trial, and the trials it needed to reach the grid's best
    score are counted from its trials as written: the first whose best score so far is at or below
    the grid's, or none when no trial is."""
    main(["calibrate", f"videos={experiment}", f"out={tmp_path}", *LAB, "method=both", "restitutions=[0.3,0.6,0.9]",
          "frictions=[0.1,0.3,0.5]", "collision_weight=0", "trials=6", "batch=3"])
    best = json.loads((tmp_path / "best.json").read_text())
    assert best["method"] == "both" and best["grid_points"] == 9 and best["search_trials"] == 6
    assert (best["wall_restitution"], best["wall_friction"]) == HIDDEN
    surface, trials = pd.read_csv(tmp_path / "score_surface.csv"), pd.read_csv(tmp_path / "trials.csv")
    same = {"rel": 1e-12}  # the tables' CSV keeps 15 digits, best.json all 17
    assert best["score"] == pytest.approx(surface.score.min(), **same)
    lowest = trials.loc[trials.score.idxmin()]
    assert best["search_trial"] == lowest.trial
    assert [best[f"search_{k}"] for k in ("wall_restitution", "wall_friction", "score")] == pytest.approx(
        [lowest.wall_restitution, lowest.wall_friction, lowest.score], **same)
    grid = best["score"] * (1 + same["rel"])
    at_or_below = [t for t, score in zip(trials.trial, trials.score.cummin()) if score <= grid]
    assert best["search_trials_to_reach_grid_best"] == (at_or_below[0] if at_or_below else None)
    for name in ("score_history.png", "score_history.svg", "score_surface.png", "score_surface.svg", "validation.png",
                 "observations.csv", "trials.csv"):
        assert (tmp_path / name).stat().st_size > 0
