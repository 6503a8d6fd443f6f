"""Find and follow 1-2 balls in a high-speed video with OpenCV.

Per frame: difference from a temporal-median background (any polarity: dark balls on a
backlit jar or bright balls on a dark one; a thin moving jar outline does not survive the
next step), a mask closed over specular highlights, distance-transform peaks as ball
candidates (touching balls give two peaks), then a sub-pixel circle fit to edge points found
along rays from each candidate (rays heading into the other ball are left out).  Identities
follow the nearest previous position (Hungarian assignment, gated at one radius): a ball
moves a few pixels per frame at 2134 fps, far less than its radius.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import pandas as pd
from scipy.ndimage import map_coordinates
from scipy.optimize import linear_sum_assignment

from .frames import read_frames, read_meta


@dataclass(frozen=True)
class TrackerSettings:
    balls: int = 2
    ball_diameter_mm: float = 17.6
    background_frames: int = 50  # frames spread over the video for the median background
    rays: int = 72


def background(frames: list[np.ndarray], n: int) -> np.ndarray:
    """Per-pixel median of n frames spread over the sequence."""
    pick = np.linspace(0, len(frames) - 1, min(n, len(frames))).astype(int)
    return np.median(np.stack([frames[k] for k in pick]).astype(np.float32), axis=0)


def candidates(diff: np.ndarray, r_px: float, n: int) -> list[np.ndarray]:
    """Up to n ball centres (x, y px) from distance-transform peaks of the foreground mask."""
    blur = cv2.GaussianBlur(diff, (0, 0), 1.5)
    level = max(float(blur.max()) * 0.5, 10.0)
    mask = (blur > level).astype(np.uint8)
    k = max(3, int(r_px / 2) | 1)
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    dist = cv2.distanceTransform(mask, cv2.DIST_L2, 5)
    found = []
    for _ in range(n):
        _, peak, _, (x, y) = cv2.minMaxLoc(dist)
        if peak < 0.6 * r_px:
            break
        found.append(np.array([x, y], float))
        cv2.circle(dist, (x, y), int(1.2 * r_px), 0, -1)
    return found


def fit_circle(diff: np.ndarray, centre: np.ndarray, r_px: float, others: list[np.ndarray], rays: int):
    """Sub-pixel centre and radius from edge points (half-contrast crossings) along rays."""
    angles = np.linspace(0, 2 * np.pi, rays, endpoint=False)
    radii = np.linspace(0.55 * r_px, 1.5 * r_px, 96)
    pts = []
    for a in angles:
        d = np.array([np.cos(a), np.sin(a)])
        if any(np.dot(o - centre, d) > 0 and np.linalg.norm(o - centre - np.dot(o - centre, d) * d) < r_px
               and np.linalg.norm(o - centre) < 2.6 * r_px for o in others):
            continue  # this ray runs into the neighbouring ball
        xy = centre[:, None] + d[:, None] * radii
        prof = map_coordinates(diff, [xy[1], xy[0]], order=1, mode="nearest")
        inside = np.percentile(prof[:20], 75)
        half = 0.5 * inside
        below = np.nonzero(prof < half)[0]
        below = below[below > 0]
        if not len(below) or inside < 10:
            continue
        j = below[0]
        f = (prof[j - 1] - half) / (prof[j - 1] - prof[j])
        rr = radii[j - 1] + f * (radii[j] - radii[j - 1])
        pts.append(centre + rr * d)
    if len(pts) < 8:
        return centre, float("nan")
    p = np.array(pts)
    a = np.column_stack([2 * p, np.ones(len(p))])
    sol, *_ = np.linalg.lstsq(a, (p**2).sum(1), rcond=None)
    return sol[:2], float(np.sqrt(sol[2] + sol[:2] @ sol[:2]))


def track(path, settings: TrackerSettings, fps: float | None = None, mm_per_px: float | None = None) -> pd.DataFrame:
    """Table of frame, time_s, ball, x_mm, y_mm (y up), radius_mm, speed_mm_per_s, lost."""
    meta = read_meta(path)
    fps = fps or meta.get("capture_fps")
    mm_per_px = mm_per_px or meta.get("mm_per_px")
    if not fps or not mm_per_px:
        raise ValueError("give fps=... and mm_per_px=... (no capture metadata beside the video)")
    r_px = settings.ball_diameter_mm / 2 / mm_per_px
    frames = list(read_frames(path))
    bg = background(frames, settings.background_frames)
    last: list[np.ndarray | None] = [None] * settings.balls
    rows = []
    for k, frame in enumerate(frames):
        diff = np.abs(frame.astype(np.float32) - bg)
        found = candidates(diff, r_px, settings.balls)
        fitted = []
        for i, c in enumerate(found):
            centre, radius = fit_circle(diff, c, r_px, [o for j, o in enumerate(found) if j != i], settings.rays)
            fitted.append((centre, radius))
        if k == 0 or any(p is None for p in last):
            order = sorted(range(len(fitted)), key=lambda i: fitted[i][0][0])  # first sight: left to right
            assign = {b: order[b] for b in range(min(len(order), settings.balls))}
        else:
            cost = np.array([[np.linalg.norm(f[0] - p) for f in fitted] for p in last]) if fitted else np.zeros((0, 0))
            assign = {}
            if cost.size:
                for b, i in zip(*linear_sum_assignment(cost)):
                    if cost[b, i] < r_px:
                        assign[b] = i
        for b in range(settings.balls):
            if b in assign:
                centre, radius = fitted[assign[b]]
                last[b] = centre
                rows.append((k, b, centre[0], centre[1], radius, False))
            else:
                rows.append((k, b, np.nan, np.nan, np.nan, True))
    df = pd.DataFrame(rows, columns=["frame", "ball", "u_px", "v_px", "radius_px", "lost"])
    h = frame.shape[0]
    df["time_s"] = df.frame / fps
    df["x_mm"] = df.u_px * mm_per_px
    df["y_mm"] = (h - df.v_px) * mm_per_px
    df["radius_mm"] = df.radius_px * mm_per_px
    df = df.sort_values(["ball", "frame"])
    step = df.groupby("ball")[["x_mm", "y_mm"]].diff()
    df["speed_mm_per_s"] = np.hypot(step.x_mm, step.y_mm) * fps
    return df.sort_values(["frame", "ball"]).reset_index(drop=True)
