"""Tracking against known truth: videos rendered from simulated MM400 trajectories, then tracked.

Requirements: centre error RMS < 0.5 px, mean speed within 2 %, no identity swaps and no
lost ball on a 2-ball video of 2000 frames; both lighting polarities; video file and image
folder input.
"""

import numpy as np
import pandas as pd
import pytest

from ballmill.lab import conditions, simulate_mm400
from ballmill.scenario import compose, load
from ballmill.vision.frames import read_frames, write_frames
from ballmill.vision.render import Camera, render_lab_videos
from ballmill.vision.track import TrackerSettings, track

FPS = 2134.0


def film(folder, balls: int, frames: int, backlit: bool = True, mm_per_px: float = 0.2, seed: int = 3):
    """Simulate one 25 Hz MM400 jar with 17.6 mm balls and render `frames` frames after settling."""
    s = load(compose("config", [
        "sim=lab", f"lab.balls_per_jar={balls}", "lab.frequencies_hz=[25.0]", "lab.ball_diameters_m=[0.0176]",
        f"lab.duration_s={0.2 + (frames + 1.5) / FPS}", f"sim.seed={seed}"]))
    conds = conditions(s.lab, [0.6], [0.3])
    traj, _ = simulate_mm400(s.lab, conds, s.materials, s.interactions, s.sim)
    render_lab_videos(folder, s.lab, conds, traj, Camera(mm_per_px=mm_per_px, backlit=backlit, seed=seed))
    return folder / "mm400_000.avi", pd.read_csv(folder / "mm400_000.avi.truth.csv")


def compare(tracked: pd.DataFrame, truth: pd.DataFrame, mm_per_px: float) -> dict:
    """Per ball: centre error RMS (px), speed ratio tracked/true, frames matched to the wrong ball."""
    times = np.sort(truth.t_s.unique())
    tracked = tracked.assign(t_s=times[tracked.frame])
    first = tracked[tracked.frame == 0]
    ids = {}
    for row in first.itertuples():  # identity: the truth particle nearest in the first frame
        t0 = truth[truth.t_s == times[0]]
        ids[row.particle] = int(t0.particle.iloc[np.argmin(np.hypot(t0.u_px - row.u_px, t0.v_px - row.v_px))])
    out = {}
    for ball, particle in ids.items():
        mine = tracked[tracked.particle == ball].merge(truth[truth.particle == particle], on="t_s", suffixes=("", "_true"))
        err = np.hypot(mine.u_px - mine.u_px_true, mine.v_px - mine.v_px_true)
        true_speed = np.hypot(np.diff(mine.u_px_true), np.diff(mine.v_px_true)) * FPS * mm_per_px / 1e3  # m/s
        others = truth[(truth.particle != particle)].merge(mine[["t_s", "u_px", "v_px"]], on="t_s", suffixes=("", "_t"))
        closer_to_other = np.hypot(others.u_px - others.u_px_t, others.v_px - others.v_px_t) < err.to_numpy()[:len(others)]
        out[ball] = {"rms_px": float(np.sqrt((err**2).mean())), "max_px": float(err.max()),
                     "speed_ratio": float(mine.frame_speed_m_per_s.mean() / true_speed.mean()),
                     "swapped_frames": int(closer_to_other.sum()), "lost": int(mine.lost.sum())}
    return out


@pytest.fixture(scope="module")
def two_ball_video(tmp_path_factory):
    return film(tmp_path_factory.mktemp("two_balls"), balls=2, frames=2000)


def test_two_ball_video_of_2000_frames_is_tracked_within_half_a_pixel_without_swaps(two_ball_video):
    video, truth = two_ball_video
    tracked = track(video, TrackerSettings(balls=2, ball_diameter_mm=17.6))
    assert tracked.frame.nunique() >= 2000
    assert tracked.attrs["polarity"] == "dark"
    for r in compare(tracked, truth, 0.2).values():
        assert r["lost"] == 0, r
        assert r["swapped_frames"] == 0, r
        assert r["rms_px"] < 0.5, r
        assert abs(r["speed_ratio"] - 1) < 0.02, r


def test_bright_balls_on_dark_background_from_an_image_folder(tmp_path):
    video, truth = film(tmp_path / "video", balls=1, frames=300, backlit=False, mm_per_px=0.25, seed=4)
    folder = write_frames(read_frames(video), tmp_path / "frames", FPS, 0.25)
    (folder / "capture.json").unlink()  # no metadata: the capture rate and scale must be given
    with pytest.raises(ValueError, match="fps=.*mm_per_px="):
        track(folder, TrackerSettings(balls=1))
    tracked = track(folder, TrackerSettings(balls=1, ball_diameter_mm=17.6), fps=FPS, mm_per_px=0.25)
    assert tracked.attrs["polarity"] == "bright"
    r = compare(tracked, truth, 0.25)[0]
    assert r["lost"] == 0 and r["rms_px"] < 0.5, r
    assert abs(r["speed_ratio"] - 1) < 0.02, r


@pytest.mark.parametrize("suffix", [".avi", ".mkv"])
def test_both_video_containers_give_back_the_frames_written(tmp_path, suffix):
    rng = np.random.default_rng(5)
    frames = [rng.integers(0, 256, (40, 64), dtype=np.uint8) for _ in range(5)]
    video = write_frames(frames, tmp_path / f"noise{suffix}", FPS, 0.25)
    back = list(read_frames(video))
    assert len(back) == 5 and all(np.array_equal(a, b) for a, b in zip(frames, back))


def test_tracker_settings_are_checked():
    with pytest.raises(ValueError, match="balls=3"):
        TrackerSettings(balls=3)
    with pytest.raises(ValueError, match="polarity"):
        TrackerSettings(polarity="grey")
