"""The shape of a tumbling charge from ball positions, and the empirical power models that use it.

Angles follow Morrell (1996; Napier-Munn et al. 1996, "Mineral Comminution Circuits", JKMRC):
degrees measured anticlockwise from the horizontal through the axis at 3 o'clock, seen with the
mill turning anticlockwise (270 at the bottom).  Our drum turns about +y, clockwise in the (x, z)
plane with z up, so x is mirrored.  The charge rides the shell from the toe (about 220-250 deg,
where the cascade lands) through the bottom to the shoulder (about 30-60 deg, where it leaves).

Definitions, following the en-masse region of Powell & McBride (2004, Minerals Engineering
17:1099) as an operational rule: the shell layer holds the balls whose centres lie within one
largest ball diameter of the shell (of the lifters' tops on a lined shell); its occupancy is
binned by angle; the charge's arc on the shell is the longest run of bins holding at least half
of the 90th-percentile bin, the toe its start and the shoulder its end.  A ball is airborne when
no ball and not the shell lie within a quarter of its radius of its surface.  Regime:
centrifuging when the arc covers 340 deg or more, cataracting when 5 % or more of the balls are
airborne, else cascading (these two thresholds are ours, not the literature's).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

BIN_DEG = 5.0
LAYER_DIAMETERS = 1.0
AIR_GAP = 0.25  # of the ball's radius
CATARACT_AIRBORNE = 0.05
CENTRIFUGE_ARC_DEG = 340.0
G = 9.81


def morrell_angle_deg(x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
    """Morrell's angle (deg, 0-360) of points of our drum's cross-section."""
    return np.degrees(np.arctan2(z_m, -x_m)) % 360.0


def longest_arc(occupied: np.ndarray) -> tuple[int, int]:
    """(first bin, bin count) of the longest circular run of True bins."""
    n = len(occupied)
    if occupied.all():
        return 0, n
    start = int(np.argmin(occupied))  # a gap: runs do not wrap past it
    best, run_from, run = (0, 0), 0, 0
    for k in range(1, n + 1):
        b = (start + k) % n
        if occupied[b]:
            run_from, run = (b, 1) if run == 0 else (run_from, run + 1)
            best = max(best, (run_from, run), key=lambda r: r[1])
        else:
            run = 0
    return best


def airborne(positions: np.ndarray, radii: np.ndarray, shell_gap_m: np.ndarray) -> np.ndarray:
    """Balls with no ball and no shell within AIR_GAP of their radius of their surface."""
    tree = cKDTree(positions)
    pairs = tree.query_pairs(2 * radii.max() * (1 + AIR_GAP), output_type="ndarray")
    near = np.zeros(len(positions), bool)
    if len(pairs):
        i, j = pairs.T
        gap = np.linalg.norm(positions[i] - positions[j], axis=1) - radii[i] - radii[j]
        near[i[gap < AIR_GAP * radii[i]]] = True
        near[j[gap < AIR_GAP * radii[j]]] = True
    return ~near & (shell_gap_m > AIR_GAP * radii)


def charge_shape(snapshots: list[np.ndarray], radii: np.ndarray, shell_radius_m: float,
                 liner_height_m: float = 0.0) -> dict:
    """Toe and shoulder angles (deg), the charge's arc on the shell, the airborne share and the
    regime from ball centres (each snapshot (n, 3), m, world frame) of a drum turning about +y."""
    r_max = float(radii.max())
    layer_from = shell_radius_m - liner_height_m - LAYER_DIAMETERS * 2 * r_max
    counts = np.zeros(int(360 / BIN_DEG))
    flying = []
    for x in snapshots:
        rho = np.hypot(x[:, 0], x[:, 2])
        shell = rho > layer_from
        bins = (morrell_angle_deg(x[shell, 0], x[shell, 2]) // BIN_DEG).astype(int) % len(counts)
        counts += np.bincount(bins, minlength=len(counts))
        flying.append(airborne(x, radii, shell_radius_m - rho - radii).mean())
    occupied = counts >= 0.5 * np.percentile(counts, 90)
    first, length = longest_arc(occupied)
    arc = length * BIN_DEG
    toe, shoulder = first * BIN_DEG, ((first + length) * BIN_DEG) % 360.0
    share = float(np.mean(flying))
    regime = ("centrifuging" if arc >= CENTRIFUGE_ARC_DEG else
              "cataracting" if share >= CATARACT_AIRBORNE else "cascading")
    return {"toe_deg": toe, "shoulder_deg": shoulder, "shell_arc_deg": arc, "airborne_fraction": share,
            "regime": regime}


def torque_arm_power_w(snapshots: list[np.ndarray], masses_kg: np.ndarray, omega_rad_per_s: float) -> float:
    """Hogg & Fuerstenau's (1972) power: the torque that holds the charge's centre of mass off the
    vertical through the axis, P = omega g |sum m x| (W), averaged over the snapshots."""
    return float(np.mean([omega_rad_per_s * G * abs((masses_kg * x[:, 0]).sum()) for x in snapshots]))


def morrell_toe_shoulder_deg(fill: float, fraction_of_critical: float) -> tuple[float, float]:
    """Morrell's (1996) empirical toe and shoulder angles (deg), fitted to photographs of a
    laboratory mill with a glass end: J the charge's volume fraction, phi the fraction of critical."""
    j, phi = fill, fraction_of_critical
    phi_c = max(phi, 0.35 * (3.364 - j))
    toe = 2.5307 * (1.2796 - j) * (1 - math.exp(-19.42 * (phi_c - phi))) + math.pi / 2
    shoulder = math.pi / 2 - (toe - math.pi / 2) * ((0.3386 + 0.1041 * phi) + (1.54 - 2.5673 * phi) * j)
    return math.degrees(toe), math.degrees(shoulder) % 360.0


def morrell_net_power_w(diameter_m: float, length_m: float, speed_rpm: float, fill: float, bed_density_kg_per_m3: float,
                        toe_deg: float, shoulder_deg: float) -> float:
    """Morrell's C-model net power of a dry, flat-ended cylinder (W) for a given toe and shoulder
    (no slurry pool): the lift of the charge plus its kinetic energy (Morrell 1996, Part 2)."""
    r_m, n_m = diameter_m / 2, speed_rpm / 60.0
    t_t, t_s = math.radians(toe_deg), math.radians(shoulder_deg)
    if t_s > math.pi:
        t_s -= 2 * math.pi
    r_mean = r_m / 2 * (1 + math.sqrt(max(0.0, 1 - 2 * math.pi * fill / (2 * math.pi + t_s - t_t))))
    t_c = (2 * math.pi - t_t + t_s) / (2 * math.pi * n_m / 2)
    t_f = math.sqrt(max(0.0, 2 * r_mean * (math.sin(t_s) - math.sin(t_t)) / G))
    beta = t_c / (t_f + t_c)
    r_i = r_m * math.sqrt(max(0.0, 1 - 2 * math.pi * beta * fill / (2 * math.pi + t_s - t_t)))
    z = (1 - fill) ** 0.4532
    rho = bed_density_kg_per_m3
    lift = (math.pi * G * length_m * n_m * r_m / (3 * (r_m - z * r_i))
            * (2 * r_m**3 - 3 * z * r_m**2 * r_i + r_i**3 * (3 * z - 2)) * rho * (math.sin(t_s) - math.sin(t_t)))
    kinetic = length_m * rho * (n_m * r_m * math.pi / (r_m - z * r_i)) ** 3 * ((r_m - z * r_i) ** 4
                                                                              - r_i**4 * (z - 1) ** 4)
    return lift + kinetic
