"""The column vocabulary of particle tables, and the one place that converts between them.

Simulated trajectories, the tracker's output and calibration observations share these names:

    t_s, frame, replica, particle      time (s), camera frame, replica (one jar or mill), particle id
    x_m, y_m, z_m                      position (m), z up; the camera looks along +y and sees (x, z)
    vx_m_per_s, vy_m_per_s, vz_m_per_s instantaneous velocity (simulation only)
    u_px, v_px, radius_px              image column, image row (downwards) and radius (tracker)
    radius_m, lost                     fitted radius (m); True where the tracker did not find the ball
    frame_vx_m_per_s, frame_vz_m_per_s displacement between consecutive frames x capture rate, as
    frame_speed_m_per_s                the paper measured ball speed in its videos
    frame_jump_m_per_s                 change of that velocity to the next frame (collisions)

The camera's world origin is the image centre (where the renderer puts the jar's rest centre).
"""

from __future__ import annotations

import numpy as np
import pandas as pd


def world_to_image(x_m, z_m, width_px: int, height_px: int, mm_per_px: float):
    """World (x, z) in m to image (column, row) in px."""
    return (width_px / 2 + np.asarray(x_m) * 1e3 / mm_per_px, height_px / 2 - np.asarray(z_m) * 1e3 / mm_per_px)


def image_to_world(u_px, v_px, width_px: int, height_px: int, mm_per_px: float):
    """Image (column, row) in px to world (x, z) in m; the inverse of world_to_image."""
    return ((np.asarray(u_px) - width_px / 2) * mm_per_px / 1e3, (height_px / 2 - np.asarray(v_px)) * mm_per_px / 1e3)


def add_frame_velocities(table: pd.DataFrame, fps: float) -> pd.DataFrame:
    """The frame_* columns per particle (and replica, where there is one), from x_m, z_m at
    consecutive frames; NaN on a particle's first frame and next to a frame where it was lost."""
    keys = [k for k in ("replica", "particle") if k in table]
    table = table.sort_values([*keys, "t_s"]).reset_index(drop=True)
    g = table.groupby(keys, sort=False)
    vx, vz = g.x_m.diff() * fps, g.z_m.diff() * fps
    step = pd.DataFrame({"vx": vx, "vz": vz, **{k: table[k] for k in keys}}).groupby(keys, sort=False)
    jump = np.hypot(step.vx.shift(-1) - vx, step.vz.shift(-1) - vz)
    return table.assign(frame_vx_m_per_s=vx, frame_vz_m_per_s=vz, frame_speed_m_per_s=np.hypot(vx, vz),
                        frame_jump_m_per_s=jump)
