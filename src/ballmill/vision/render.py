"""Synthetic high-speed video of the MM400 jar from simulated trajectories (known truth).

Side view along y: image x is world x (the jar's axis), image up is world z.  Balls are
shaded discs with a specular highlight, the jar's outline moves with the mill (its centre
follows the prescribed motion; the few degrees of swing foreshorten it by < 0.3 %, not drawn),
the exposure blurs motion (several sub-frame renders averaged) and the sensor adds Gaussian
noise.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from ..columns import world_to_image
from ..config import MM400Config
from ..dem import Capsule, Motion
from ..dem.runtime import cpu_threads
from ..lab import Condition, jar_capsule, jar_motion
from .frames import write_frames

SHIFT = 4  # OpenCV fixed-point bits: sub-pixel drawing


@dataclass(frozen=True)
class Camera:
    fps: float = 2134.0
    mm_per_px: float = 0.2
    width_px: int = 360
    height_px: int = 220
    exposure_fraction: float = 0.5  # shutter open for this share of the frame interval
    blur_samples: int = 4
    noise_grey: float = 2.0  # sensor noise, standard deviation in grey levels
    backlit: bool = True  # bright jar, dark balls; False: dark background, bright balls
    seed: int = 0

    def to_px(self, x_m, z_m):
        """World (x, z) in m to image (column, row) in px; the world origin at the image centre."""
        return world_to_image(x_m, z_m, self.width_px, self.height_px, self.mm_per_px)


def _fixed(v: float) -> int:
    return round(v * (1 << SHIFT))


def _draw(canvas, cam: Camera, balls, jar_centre_m, jar: Capsule) -> None:
    bg, ball, spec, line = (200, 45, 235, 90) if cam.backlit else (30, 190, 250, 110)
    canvas[:] = bg
    (cx, cy), s = cam.to_px(jar_centre_m[0], jar_centre_m[2]), 1e3 / cam.mm_per_px
    r_px, h_px = jar.radius_m * s, jar.half_length_m * s
    for sign in (-1, 1):
        cv2.line(canvas, (_fixed(cx - h_px), _fixed(cy + sign * r_px)), (_fixed(cx + h_px), _fixed(cy + sign * r_px)),
                 line, 2, cv2.LINE_AA, SHIFT)
        cv2.ellipse(canvas, (_fixed(cx + sign * h_px), _fixed(cy)), (_fixed(r_px), _fixed(r_px)), 0,
                    -90 if sign > 0 else 90, 90 if sign > 0 else 270, line, 2, cv2.LINE_AA, SHIFT)
    for x, z, r in balls:
        u, v = cam.to_px(x, z)
        rp = r * s
        cv2.circle(canvas, (_fixed(u), _fixed(v)), _fixed(rp), ball, -1, cv2.LINE_AA, SHIFT)
        cv2.circle(canvas, (_fixed(u - 0.3 * rp), _fixed(v - 0.3 * rp)), _fixed(0.15 * rp), spec, -1, cv2.LINE_AA, SHIFT)


def render(track: pd.DataFrame, radius_m: dict[int, float], jar: Capsule, motion: Motion,
           cam: Camera) -> tuple[Iterator[np.ndarray], pd.DataFrame]:
    """Frames of one jar (axis along x) from a trajectory sampled at the camera rate.

    `track` has columns t_s, particle, x_m, y_m, z_m; the camera looks along +y (nearer balls,
    smaller y, hide farther ones); `motion` moves the jar.  Returns the frames (a generator) and
    the truth: each ball's centre (px) averaged over the exposure, as the image shows it.
    """
    times = np.sort(track.t_s.unique())
    offsets = -cam.exposure_fraction / cam.fps * (1 - (np.arange(cam.blur_samples) + 0.5) / cam.blur_samples)
    when = times[:, None] + offsets[None, :]  # (frames, sub-frame renders)
    wide = {c: track.pivot(index="t_s", columns="particle", values=c).loc[times] for c in ("x_m", "y_m", "z_m")}
    ids = list(wide["x_m"].columns)
    # every ball's centre at every sub-frame time: {coordinate: (balls, frames, renders)}
    at = {c: np.stack([np.interp(when, times, w[p].to_numpy()) for p in ids]) for c, w in wide.items()}
    u, v = cam.to_px(at["x_m"], at["z_m"])
    truth = pd.DataFrame({"t_s": np.repeat(times, len(ids)), "particle": np.tile(ids, len(times)),
                          "u_px": u.mean(axis=2).T.ravel(), "v_px": v.mean(axis=2).T.ravel()})

    def frames():
        cv2.setRNGSeed(cam.seed)  # the sensor noise: OpenCV's generator (this thread's; 4x NumPy's speed)
        canvas = np.zeros((cam.height_px, cam.width_px), np.uint8)
        noise = np.empty(canvas.shape, np.float32)
        for k, t in enumerate(times):
            acc = np.zeros(canvas.shape, np.float64)
            for b, tt in enumerate(t + offsets):
                far_first = np.argsort(-at["y_m"][:, k, b], kind="stable")
                balls = [(at["x_m"][q, k, b], at["z_m"][q, k, b], radius_m[ids[q]]) for q in far_first]
                _draw(canvas, cam, balls, motion.place(tt, jar.center_m), jar)
                acc += canvas
            cv2.randn(noise, 0.0, cam.noise_grey)
            acc = acc / len(offsets) + noise
            yield np.clip(np.rint(acc), 0, 255).astype(np.uint8)

    return frames(), truth


def _film(path: Path, traj: pd.DataFrame, radius_m: float, motion: Motion, jar: Capsule, cam: Camera) -> None:
    """Render one condition's trajectory into the video at path, its truth beside it."""
    frames, truth = render(traj, dict.fromkeys(traj.particle.unique(), radius_m), jar, motion, cam)
    write_frames(frames, path, cam.fps, cam.mm_per_px)
    truth.to_csv(path.with_name(f"{path.name}.truth.csv"), index=False)


def render_lab_videos(folder: str | Path, lab: MM400Config, conds: list[Condition], trajectories: pd.DataFrame,
                      cam: Camera) -> pd.DataFrame:
    """One video per simulated condition (after lab.settle_s), its truth table and a videos.csv manifest
    (the videos rendered side by side, one per core).

    The camera is sized to the jar's reach and runs at the lab's camera rate.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    jar = jar_capsule(lab)
    reach_m = jar.half_length_m + jar.radius_m + 2 * lab.amplitude_m
    cam = replace(cam, fps=lab.camera_fps, width_px=int(2.3 * reach_m * 1e3 / cam.mm_per_px),
                  height_px=int(3.0 * jar.radius_m * 1e3 / cam.mm_per_px))
    jobs = [(folder / f"mm400_{k:03d}.avi", trajectories[(trajectories.replica == k) & (trajectories.t_s > lab.settle_s)],
             c.ball_diameter_m / 2, jar_motion(lab, c.frequency_hz)) for k, c in enumerate(conds)]
    Parallel(n_jobs=min(cpu_threads(0), len(jobs)))(delayed(_film)(*job, jar, cam) for job in jobs)
    rows = [{"file": path.name, "frequency_hz": c.frequency_hz, "ball_diameter_mm": c.ball_diameter_m * 1e3,
             "balls": lab.balls_per_jar, "wall_restitution": c.wall_restitution, "wall_friction": c.wall_friction}
            for (path, *_), c in zip(jobs, conds)]
    manifest = pd.DataFrame(rows)
    manifest.to_csv(folder / "videos.csv", index=False)
    return manifest
