"""Find and follow 1-2 balls in a high-speed video with OpenCV.

Background, per frame: a morphological closing (dark balls on a backlit jar) or opening
(bright balls on a dark background) with a disc wider than a ball removes the balls and keeps
the background, whatever the lighting does over time and wherever the jar has moved; the
difference (black-hat or top-hat) holds the balls and, as thin lines, the jar's outline.
`polarity="auto"` tells the side from the grey levels of frames sampled through the video.
The closing runs on a 4x downsampled frame: the background is smooth, and that is 16x cheaper.

Per frame: a mask of the difference (halved in size) closed over specular highlights and opened
to drop the jar's outline, distance-transform peaks as ball candidates (touching balls give two peaks),
then a sub-pixel circle fit to the half-contrast crossings along rays from each candidate
(rays heading into the other ball are left out; edge points off the fit by over a pixel,
e.g. where a ball touches the jar's outline, are dropped and the circle refitted).
Identities follow the nearest previous position (Hungarian assignment, gated at one
radius): at 2134 fps a ball moves a few pixels per frame, far less than its radius.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from scipy.ndimage import map_coordinates
from scipy.optimize import linear_sum_assignment

from ..columns import add_frame_velocities, image_to_world
from ..config import ConfigError
from .frames import read_frames, read_meta, spread_frames

# Thresholds, each relative to the expected ball radius r (px) or to grey levels of the difference image:
DOWNSAMPLE = 4  # the background closing runs on a frame this many times smaller (the background is smooth)
CANDIDATE_SCALE = 2  # ball candidates are sought on a frame this many times smaller (the fit refines them)
BACKGROUND_DISC = 1.4  # closing disc diameter / ball diameter: wider than a ball, so the ball is removed
MASK_LEVEL = 0.5  # foreground mask: above this share of the frame's strongest difference ...
MASK_MIN_GREY = 10.0  # ... and above this many grey levels (noise is ~2)
PEAK_MIN = 0.6  # a ball candidate's distance-transform peak reaches at least 0.6 r (a full disc reaches r)
PEAK_EXCLUSION = 1.2  # a second candidate lies more than 1.2 r from the first (touching balls: 2 r)
MIN_EDGE_POINTS = 8  # fewer valid ray crossings than this: no circle (the ball counts as lost)
SIZE_TOLERANCE = 0.05  # the measured ball size may differ from the given one by 5 % (fits are good to ~1 %)


@dataclass(frozen=True)
class TrackerSettings:
    balls: int = 2
    ball_diameter_mm: float = 17.6
    polarity: str = "auto"  # "dark" balls on a bright background, "bright" on a dark one, or "auto"
    polarity_frames: int = 20  # frames sampled through the video to tell the polarity
    rays: int = 90
    outlier_px: float = 1.0  # edge points farther than this from the fitted circle are dropped

    def __post_init__(self):
        if self.balls not in (1, 2):
            raise ConfigError(f"balls={self.balls}: the tracker follows 1 or 2 balls")
        if self.polarity not in ("auto", "dark", "bright"):
            raise ConfigError(f"polarity={self.polarity!r} is not one of ['auto', 'dark', 'bright']")
        if self.ball_diameter_mm <= 0:
            raise ConfigError(f"ball_diameter_mm={self.ball_diameter_mm} must be > 0")


def foreground(frame: np.ndarray, r_px: float, polarity: str) -> np.ndarray:
    """Black-hat (dark balls) or top-hat (bright balls) of a uint8 frame with a disc wider than a
    ball, computed in grey levels (the background within a level of the float result), as float32."""
    small = cv2.resize(frame, (max(1, frame.shape[1] // DOWNSAMPLE), max(1, frame.shape[0] // DOWNSAMPLE)),
                       interpolation=cv2.INTER_AREA)
    k = int(2 * BACKGROUND_DISC * r_px / DOWNSAMPLE) | 1
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    bg = cv2.morphologyEx(small, cv2.MORPH_CLOSE if polarity == "dark" else cv2.MORPH_OPEN, disc)
    bg = cv2.resize(bg, (frame.shape[1], frame.shape[0]), interpolation=cv2.INTER_LINEAR)
    return (cv2.subtract(bg, frame) if polarity == "dark" else cv2.subtract(frame, bg)).astype(np.float32)


def detect_polarity(sample: list[np.ndarray]) -> str:
    """"dark" or "bright" balls: the background fills most of a frame, so the median grey is its
    level, and the balls lie on the side of it where the frames reach farther (1st/99th percentile)."""
    lo, med, hi = np.percentile(np.stack(sample), [1, 50, 99])
    return "dark" if med - lo > hi - med else "bright"


def candidates(diff: np.ndarray, r_px: float, n: int) -> list[np.ndarray]:
    """Up to n ball centres (x, y px) from distance-transform peaks of the foreground mask, found
    on a frame CANDIDATE_SCALE times smaller (a peak only seeds `fit_circle`)."""
    s = CANDIDATE_SCALE
    small = cv2.resize(diff, (max(1, diff.shape[1] // s), max(1, diff.shape[0] // s)), interpolation=cv2.INTER_AREA)
    r_px = r_px / s
    blur = cv2.GaussianBlur(small, (0, 0), 1.5 / s)
    mask = (blur > max(float(blur.max()) * MASK_LEVEL, MASK_MIN_GREY)).astype(np.uint8)
    k = max(3, int(r_px / 2) | 1)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    x, y, w, h = cv2.boundingRect(mask)  # the closing and opening reach k px: run them around the blobs only
    roi = (slice(max(y - 2 * k, 0), y + h + 2 * k), slice(max(x - 2 * k, 0), x + w + 2 * k))
    mask[roi] = cv2.morphologyEx(cv2.morphologyEx(mask[roi], cv2.MORPH_CLOSE, disc), cv2.MORPH_OPEN, disc)
    dist = cv2.distanceTransform(mask, cv2.DIST_L2, 5)
    found = []
    for _ in range(n):
        _, peak, _, (x, y) = cv2.minMaxLoc(dist)
        if peak < PEAK_MIN * r_px:
            break
        found.append(s * np.array([x, y], float) + (s - 1) / 2)  # the small pixel's centre, in frame px
        cv2.circle(dist, (x, y), int(PEAK_EXCLUSION * r_px), 0, -1)
    return found


def _circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle (Kasa) through points (n, 2): centre, radius."""
    a = np.column_stack([2 * points, np.ones(len(points))])
    sol, *_ = np.linalg.lstsq(a, (points**2).sum(1), rcond=None)
    return sol[:2], float(np.sqrt(sol[2] + sol[:2] @ sol[:2]))


def fit_circle(diff: np.ndarray, centre: np.ndarray, r_px: float, others: list[np.ndarray], settings: TrackerSettings):
    """Sub-pixel centre and radius (px) from half-contrast crossings along rays; NaN radius if too few."""
    ang = np.linspace(0, 2 * np.pi, settings.rays, endpoint=False)
    d = np.column_stack([np.cos(ang), np.sin(ang)])
    ok = np.ones(len(ang), bool)
    for o in others:  # rays that would run into the neighbouring ball
        rel = o - centre
        along = d @ rel
        ok &= ~((along > 0) & (np.abs(d[:, 0] * rel[1] - d[:, 1] * rel[0]) < 1.1 * r_px)
                & (np.linalg.norm(rel) < 2.6 * r_px))
    d = d[ok]
    radii = np.linspace(0.55 * r_px, 1.5 * r_px, 120)
    xy = centre[None, :, None] + d[:, :, None] * radii[None, None, :]  # (rays, 2, samples)
    prof = map_coordinates(diff, [xy[:, 1].ravel(), xy[:, 0].ravel()], order=1, mode="nearest").reshape(len(d), -1)
    inside = np.percentile(prof[:, :20], 75, axis=1)
    half = 0.5 * inside[:, None]
    j = np.argmax(prof < half, axis=1)  # first sample below half contrast
    rows = np.arange(len(d))
    p0, p1 = prof[rows, j - 1], prof[rows, j]
    valid = (j > 0) & (p1 < half[:, 0]) & (p0 >= half[:, 0]) & (inside > MASK_MIN_GREY)
    if valid.sum() < MIN_EDGE_POINTS:
        return centre, float("nan")
    d, j, p0, p1, half = d[valid], j[valid], p0[valid], p1[valid], half[valid, 0]
    rr = radii[j - 1] + (p0 - half) / (p0 - p1) * (radii[1] - radii[0])
    pts = centre + rr[:, None] * d
    c, r = _circle(pts)
    for _ in range(3):
        keep = np.abs(np.linalg.norm(pts - c, axis=1) - r) < settings.outlier_px
        if keep.sum() < MIN_EDGE_POINTS or keep.all():
            break
        pts = pts[keep]
        c, r = _circle(pts)
    return c, r


def _assign(fitted: list, last: list, gate_px: float) -> dict[int, int]:
    """Ball id -> index into fitted: nearest to each ball's last position within the gate."""
    if all(p is None for p in last):  # first sight: left to right
        order = sorted(range(len(fitted)), key=lambda i: fitted[i][0][0])
        return dict(enumerate(order[:len(last)]))
    known = [b for b, p in enumerate(last) if p is not None]
    cost = np.array([[np.linalg.norm(f[0] - last[b]) for f in fitted] for b in known]).reshape(len(known), len(fitted))
    rows, cols = linear_sum_assignment(cost) if cost.size else ((), ())
    out = {known[r]: c for r, c in zip(rows, cols) if cost[r, c] < gate_px}
    spare = [i for i in range(len(fitted)) if i not in out.values()]
    for b in range(len(last)):  # a ball not yet seen, or lost a while, takes a detection left over
        if b not in out and spare:
            out[b] = spare.pop(0)
    return out


def track(path: str | Path, settings: TrackerSettings, fps: float | None = None,
          mm_per_px: float | None = None) -> pd.DataFrame:
    """Per frame and ball: frame, t_s, particle, u_px, v_px, radius_px, lost, x_m, z_m, radius_m and
    the frame_* velocities (columns.py).  The velocity of frame k is the displacement from frame
    k-1 times the capture rate, as the paper measured it; frames where a ball was not found have
    lost=True and NaN positions."""
    if not Path(path).exists():
        raise FileNotFoundError(f"video={path} does not exist")
    meta = read_meta(path)
    fps = fps or meta.get("capture_fps")
    mm_per_px = mm_per_px or meta.get("mm_per_px")
    if not fps or not mm_per_px:
        raise ConfigError(f"video={path}: give fps=... and mm_per_px=... (no capture metadata beside it)")
    r_px = settings.ball_diameter_mm / 2 / mm_per_px
    polarity = settings.polarity
    if polarity == "auto":
        polarity = detect_polarity(spread_frames(path, settings.polarity_frames))
    last: list[np.ndarray | None] = [None] * settings.balls
    rows = []
    for k, frame in enumerate(read_frames(path)):
        diff = foreground(frame, r_px, polarity)
        found = candidates(diff, r_px, settings.balls)
        fitted = [fit_circle(diff, c, r_px, found[:i] + found[i + 1:], settings) for i, c in enumerate(found)]
        fitted = [f for f in fitted if np.isfinite(f[1])]
        assign = _assign(fitted, last, r_px)
        for b in range(settings.balls):
            if b in assign:
                (u, v), radius = fitted[assign[b]]
                last[b] = np.array([u, v])
                rows.append((k, b, u, v, radius, False))
            else:
                rows.append((k, b, np.nan, np.nan, np.nan, True))
    if not rows:
        raise ConfigError(f"video={path}: holds no frames")
    df = pd.DataFrame(rows, columns=["frame", "particle", "u_px", "v_px", "radius_px", "lost"])
    check_size(df, path, settings, mm_per_px)
    df.insert(1, "t_s", df.frame / fps)
    height, width = frame.shape[:2]
    df["x_m"], df["z_m"] = image_to_world(df.u_px, df.v_px, width, height, mm_per_px)
    df["radius_m"] = df.radius_px * mm_per_px / 1e3
    df = add_frame_velocities(df, fps)
    df.attrs.update(capture_fps=fps, mm_per_px=mm_per_px, polarity=polarity)
    return df.sort_values(["frame", "particle"]).reset_index(drop=True)


def check_size(df: pd.DataFrame, path, settings: TrackerSettings, mm_per_px: float) -> None:
    """Stop when no ball was found, or when the balls found measure another size than the one given
    (a wrong size or scale puts the fits on the wrong edges: positions and speeds would be wrong)."""
    given = settings.ball_diameter_mm
    if df.lost.all():
        raise ConfigError(f"video={path}: no ball found in any of its {df.frame.nunique()} frames; check "
                          f"ball_diameter_mm={given}, mm_per_px={mm_per_px} and polarity={settings.polarity}")
    measured = 2 * float(df.radius_px.median()) * mm_per_px
    if abs(measured / given - 1) > SIZE_TOLERANCE:
        raise ConfigError(f"video={path}: the balls measure {measured:.2f} mm across, not ball_diameter_mm={given} "
                          f"(at mm_per_px={mm_per_px}); give ball_diameter_mm={measured:.2f}, or "
                          f"mm_per_px={mm_per_px * given / measured:.4g} if the size is right")


def track_to_files(opts) -> tuple[pd.DataFrame, Path]:
    """`ballmill track`: track opts.video (a config.TrackConfig) into <out>.csv and <out>.parquet."""
    table = track(opts.video, TrackerSettings(opts.balls, opts.ball_diameter_mm, opts.polarity), opts.fps,
                  opts.mm_per_px)
    out = Path(opts.out or f"{str(opts.video).rstrip('/')}.track.csv")
    table.to_csv(out, index=False)
    table.to_parquet(out.with_suffix(".parquet"), index=False)
    return table, out
