"""A horizontal rotating drum as a DEM system, and its simulation to torque and power."""

from __future__ import annotations

import hashlib
import json
import logging
import math
import tempfile
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from .charge_shape import charge_shape, morrell_net_power_w, morrell_toe_shoulder_deg, torque_arm_power_w
from .config import ConfigError, DrumConfig, SimConfig
from .dem import (
    Body,
    Checkpoint,
    Cylinder,
    Material,
    Mesh,
    Motion,
    ParquetSink,
    Plane,
    Recorder,
    Results,
    SettledBed,
    SimulationError,
    SystemSpec,
    available_memory_bytes,
    memory_estimate_bytes,
    new_engine,
)
from .dem.results import batch_mean, batch_trend
from .dem.vtk import VtkWriter
from .dem.walls import wall_slots
from .files import exclusive, read_json, write_json
from .impacts import impact_statistics
from .liner import liner_mesh, liner_size
from .scaleup import critical_speed_rpm
from .scenario import engine_materials, engine_options, time_step_s

log = logging.getLogger(__name__)
AXIS = (0.0, 1.0, 0.0)  # drum axis; gravity is -z
TYPICAL_RATE = 1e7  # particle-steps/s of a drum on one or two cores (docs/benchmarks/index.md): for the run's ETA line
# particle states recorded at instants of the averaging window (charge shape, bed picture): at
# least 4, and enough for about 20,000 ball positions, at most 40
SNAPSHOT_BALLS, MIN_SNAPSHOTS, MAX_SNAPSHOTS = 20_000, 4, 40
MORRELL_K = 1.26  # C-model: measured net power / the model's (Morrell 1996; wiki.metdynamics.com.au)
# The starting lattice: sites 2.04 r apart (2 % gaps, so no ball starts in contact) at least
# 1.05 r from the walls (5 % clearance): a loose bed that settles in a fraction of a second.
LATTICE_SPACING = 2.04
WALL_CLEARANCE = 1.05
FCC_BASIS = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]])
# A steady averaging window (window_check): the power reaches its plateau 0.25-0.31 revolutions
# after the drum starts (docs/explanation/case-studies.md); the trend's two-sided 1 % point of
# Student's t with the 8 degrees of freedom of a line through 10 batch means, and a drift that
# matters beside it.
MIN_STARTUP_REVOLUTIONS, TREND_T, MIN_DRIFT = 0.25, 3.355, 0.02
CONFIGURED = "the configured window (sim.window_revolutions or sim.duration_s)"


class PowerWindow:
    """Ends a drum run once the mean power's standard error (10 batch means) is below `target`
    of the mean, after at least `min_window_s` of averaging; `reason` says why the run ended."""

    CHECK_EVERY = 10  # samples between two looks at the power

    def __init__(self, recorder: Recorder, body: str, after_s: float, min_window_s: float, target: float):
        self.recorder, self.body, self.after, self.min_window, self.target = (recorder, body, after_s, min_window_s,
                                                                              target)
        self.reason = CONFIGURED
        self.calls = 0

    def __call__(self) -> bool:
        self.calls += 1
        if self.calls % self.CHECK_EVERY:
            return False
        t, p = self.recorder.power_so_far(self.body)
        window = p[t > self.after]
        if not len(window) or t[-1] - self.after < self.min_window:
            return False
        mean, se = batch_mean(window)
        if se < self.target * abs(mean):
            self.reason = (f"standard error {se / abs(mean):.2%} of the mean power below sim.power_se_target "
                           f"{self.target:.2%} after {t[-1] - self.after:.3g} s of averaging")
            return True
        return False


@dataclass
class DrumRun:
    """A finished drum DEM: its summary (torque, power, impacts) and time series."""

    summary: dict
    results: Results


def ball_radii(drum: DrumConfig) -> np.ndarray:
    """Radius of every ball (m): one size, or a graded charge's sizes, largest first.  A charge
    by mass fraction holds the ball volume of `fill_fraction` of the drum at `bed_porosity`,
    split by mass (one density), each size's count rounded."""
    if not drum.charge:
        return np.full(ball_count(drum), drum.ball_radius_m)
    sizes = sorted(drum.charge, key=lambda c: -c.diameter_m)
    return np.repeat([c.diameter_m / 2 for c in sizes], size_counts(drum, sizes))


def size_counts(drum: DrumConfig, sizes) -> list[int]:
    """Balls of each size of a graded charge: as given, or from the mass fractions."""
    if sizes[0].count is not None:
        return [c.count for c in sizes]
    return [round(c.mass_fraction * bed_ball_volume_m3(drum) / (math.pi / 6 * c.diameter_m**3)) for c in sizes]


def ball_radii_as_run(drum: DrumConfig, seed: int) -> np.ndarray:
    """Radius of each particle of the DEM (m): a graded charge's sizes shuffled over the lattice."""
    radii = ball_radii(drum)
    return np.random.default_rng(seed + 1).permutation(radii) if drum.charge else radii


def bed_ball_volume_m3(drum: DrumConfig) -> float:
    """Volume of the balls of a bed filling `fill_fraction` of the drum at `bed_porosity` (m3)."""
    return drum.fill_fraction * math.pi / 4 * drum.inner_diameter_m**2 * drum.inner_length_m * (1 - drum.bed_porosity)


def ball_count(drum: DrumConfig) -> int:
    """Balls in the drum: a graded charge's, the given count, or those of one size filling the bed
    (counted, not listed: the memory check comes before any array)."""
    if drum.charge:
        return sum(size_counts(drum, drum.charge))
    if drum.ball_count is not None:
        return drum.ball_count
    return max(1, round(bed_ball_volume_m3(drum) / (4 / 3 * math.pi * drum.ball_radius_m**3)))


def charge_mass_kg(drum: DrumConfig, density_kg_per_m3: float) -> float:
    return float(density_kg_per_m3 * 4 / 3 * math.pi * (ball_radii(drum) ** 3).sum())


def largest_radius_m(drum: DrumConfig) -> float:
    return max(c.diameter_m for c in drum.charge) / 2 if drum.charge else drum.ball_radius_m


def mean_ball_diameter_m(drum: DrumConfig) -> float:
    """Mass-weighted mean ball diameter (m): the d of the critical speed for a graded charge."""
    if not drum.charge:
        return 2 * drum.ball_radius_m
    r = ball_radii(drum)
    return float(2 * (r**4).sum() / (r**3).sum())


def critical_speed_of(drum: DrumConfig) -> float:
    return critical_speed_rpm(drum.inner_diameter_m, mean_ball_diameter_m(drum))


def drum_speed_rpm(drum: DrumConfig) -> float:
    if drum.speed_rpm is not None:
        return drum.speed_rpm
    return drum.fraction_of_critical * critical_speed_of(drum)


def sim_in_seconds(sim: SimConfig, speed_rpm: float) -> SimConfig:
    """sim with its start-up and averaging window in seconds (steady_after_s, duration_s) for a
    vessel turning at speed_rpm: sim.startup_revolutions and sim.window_revolutions of its turn
    where given (then set null), else as given."""
    if sim.startup_revolutions is None:
        return sim
    turn = 60.0 / speed_rpm
    return replace(sim, steady_after_s=sim.startup_revolutions * turn,
                   duration_s=(sim.startup_revolutions + sim.window_revolutions) * turn,
                   startup_revolutions=None, window_revolutions=None)


def window_check(loads, summary: dict, settle_s: float, sample_every_s: float) -> dict:
    """Whether a finished run's averaging window gives the steady power: it starts after
    MIN_STARTUP_REVOLUTIONS of turning, spans at least one revolution, and the power has no trend
    over it (the slope of its 10 batch means against time, significant at 1 % and moving the
    power by more than MIN_DRIFT over the window).  The window's length in revolutions, the
    trend's t statistic and drift, `steady`, and `unsteady_reason` ("" when steady)."""
    turn = 60.0 / summary["speed_rpm"]
    after, end = summary["averaging_from_s"], summary["simulated_s"]
    startup = (after - settle_s) / turn
    window = loads[(loads.body == "drum") & (loads.t_s > after)]
    t_stat, drift = batch_trend(window.t_s.to_numpy(), window.power_w.to_numpy())
    reasons = []
    if startup < MIN_STARTUP_REVOLUTIONS - 1e-6:
        reasons.append(f"the averaging starts {startup:.2g} revolutions after the drum starts, within its start-up "
                       f"(at least {MIN_STARTUP_REVOLUTIONS:g})")
    if end - after < turn - sample_every_s:  # the run ends on a whole sample
        reasons.append(f"the averaging window is {(end - after) / turn:.2g} of a revolution, less than one")
    if abs(t_stat) > TREND_T and abs(drift) > MIN_DRIFT:
        reasons.append(f"the power still moves {drift:+.0%} over the window (trend t = {t_stat:.1f})")
    return {"startup_revolutions": startup, "window_revolutions": (end - after) / turn, "power_trend_t": t_stat,
            "power_drift_fraction": drift, "steady": not reasons, "unsteady_reason": "; ".join(reasons)}


def lattice_sites(drum: DrumConfig, cell_m: float, basis: np.ndarray) -> np.ndarray:
    """Sites of a lattice (cubic cells of cell_m, `basis` points per cell in cell units) inside the
    drum with the wall clearance of its largest ball (and of the lifters' height)."""
    r, half = largest_radius_m(drum), drum.inner_length_m / 2
    big_r = drum.inner_diameter_m / 2 - liner_size(drum.liner, drum.inner_diameter_m)[0]
    gap = WALL_CLEARANCE * r
    xs = np.arange(-big_r + gap, big_r - r, cell_m)
    ys = np.arange(-half + gap, half - r, cell_m)
    corners = np.array(np.meshgrid(xs, ys, xs, indexing="ij")).reshape(3, -1).T
    grid = (corners[:, None, :] + cell_m * basis[None, :, :]).reshape(-1, 3)
    inside = (np.hypot(grid[:, 0], grid[:, 2]) <= big_r - gap) & (np.abs(grid[:, 1]) < half - r)
    return grid[inside]


def lattice_packing(drum: DrumConfig, n: int, seed: int) -> np.ndarray:
    """n ball centres on a loose cubic lattice (a face-centred one, 1.4x denser, when the cubic
    one has too few sites: small drums at high fill), lowest sites first, slightly jittered (m);
    the lattice is that of the largest ball, within the lifters' tops."""
    r = largest_radius_m(drum)
    sites = lattice_sites(drum, LATTICE_SPACING * r, np.zeros((1, 3)))
    if len(sites) < n:
        sites = lattice_sites(drum, LATTICE_SPACING * r * math.sqrt(2), FCC_BASIS)
    if len(sites) < n:
        raise ConfigError(
            f"mill: {n} balls of radius {r} m do not fit loosely in the drum ({len(sites)} sites); "
            "lower mill.fill_fraction or enlarge the drum"
        )
    sites = sites[np.lexsort((sites[:, 0], sites[:, 1], sites[:, 2]))][:n]
    jitter = np.random.default_rng(seed).uniform(-0.01 * r, 0.01 * r, sites.shape)
    return sites + jitter


def drum_mesh(drum: DrumConfig, max_aspect: float | None = None) -> Mesh:
    """A closed faceted drum (trimesh) whose flat facets touch the analytic cylinder; with
    max_aspect, the shell is cut along the axis so that no facet is longer than max_aspect
    times its width (else each facet runs the drum's whole length)."""
    import trimesh

    n = drum.stl_segments
    radius = drum.inner_diameter_m / 2 / math.cos(math.pi / n)
    half, width = drum.inner_length_m / 2, 2 * radius * math.sin(math.pi / n)
    cuts = 1 if max_aspect is None else max(1, math.ceil(drum.inner_length_m / (max_aspect * width)))
    profile = [[0.0, -half], *([radius, y] for y in np.linspace(-half, half, cuts + 1)), [0.0, half]]
    mesh = trimesh.creation.revolve(profile, sections=n)  # a cylinder (trimesh's own, when cuts = 1)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
    with tempfile.TemporaryDirectory() as tmp:  # round trip through STL, as CAD input would come
        path = Path(tmp) / "drum.stl"
        mesh.export(path)
        return Mesh.from_stl(path)


def drum_walls(drum: DrumConfig) -> tuple:
    """The drum's walls in its body frame: a user's STL, a faceted closed drum (geometry=stl), or
    the shell (an analytic cylinder when smooth, the liner's mesh when lined) and two end planes."""
    big_r, half = drum.inner_diameter_m / 2, drum.inner_length_m / 2
    if drum.geometry == "stl":
        return (Mesh.from_stl(drum.stl_path) if drum.stl_path else drum_mesh(drum),)
    shell = Cylinder((0, 0, 0), AXIS, big_r, half) if drum.liner.kind == "smooth" else liner_mesh(drum)
    return shell, Plane((0, -half, 0), (0, 1, 0)), Plane((0, half, 0), (0, -1, 0))


def drum_system(drum: DrumConfig, materials: dict[str, Material], interactions, sim: SimConfig,
                 walls: tuple) -> SystemSpec:
    """The drum (its `drum_walls`), its charge at rest (sizes shuffled over the lattice by the
    seed), turning from t = sim.settle_s at drum_speed_rpm."""
    radii = ball_radii_as_run(drum, sim.seed)
    n = len(radii)
    big_r, half, r = drum.inner_diameter_m / 2, drum.inner_length_m / 2, largest_radius_m(drum)
    omega = drum_speed_rpm(drum) * 2 * math.pi / 60
    motion = Motion(axis=AXIS, angular_velocity_rad_per_s=omega, start_time_s=sim.settle_s)
    margin = 4 * r
    names = sorted(materials)
    return SystemSpec(
        materials=materials, interactions=[interactions], material_names=names,
        position_m=lattice_packing(drum, n, sim.seed), radius_m=radii,
        material=np.full(n, names.index(drum.ball_material)),
        bodies=[Body("drum", drum.wall_material, walls, (motion,))],
        domain_lo_m=(-big_r - margin, -half - margin, -big_r - margin),
        domain_hi_m=(big_r + margin, half + margin, big_r + margin),
    )


UNKEYED_SIM_FIELDS = ("threads", "neighbour_skin", "launch", "checkpoint_every_wall_s", "progress_every_s")
# left out of a key when null: an unset target, and the revolutions, which sim_in_seconds has made seconds
UNSET_SIM_FIELDS = ("power_se_target", "startup_revolutions", "window_revolutions")


def check_stl(path: str) -> None:
    """A readable, closed (watertight) triangle mesh, or a ConfigError naming mill.stl_path."""
    import trimesh

    if not Path(path).is_file():
        raise ConfigError(f"mill.stl_path={path}: no such file")
    try:
        mesh = trimesh.load_mesh(path, file_type="stl", force="mesh")
    except Exception as exc:  # trimesh raises many kinds on a file that is not an STL
        raise ConfigError(f"mill.stl_path={path}: not a readable STL file ({type(exc).__name__})") from exc
    if len(mesh.faces) == 0:
        raise ConfigError(f"mill.stl_path={path}: holds no triangles")
    if not mesh.is_watertight:
        raise ConfigError(f"mill.stl_path={path}: the mesh is not closed ({len(mesh.faces)} triangles with open "
                          "edges); balls would leak out: close it in the CAD tool")


def drum_spec(drum: DrumConfig, materials, interactions, sim: SimConfig) -> SystemSpec:
    """The engine's system for a drum config (checks materials, the STL and that the balls fit)."""
    d_ball = 2 * largest_radius_m(drum)
    if d_ball >= min(drum.inner_diameter_m, drum.inner_length_m) / 2:
        field_name = "charge" if drum.charge else f"ball_radius_m={drum.ball_radius_m}"
        raise ConfigError(f"mill.{field_name}: balls of {d_ball:g} m do not fit a drum of "
                          f"D {drum.inner_diameter_m:g} m x L {drum.inner_length_m:g} m "
                          "(at most a quarter of the smaller side)")
    if drum.liner.kind != "smooth" and drum.geometry == "stl":
        raise ConfigError(f"mill.liner.kind={drum.liner.kind} builds the shell's mesh itself: use geometry=analytic "
                          "(the end walls stay planes), or draw the lifters into your STL")
    if drum.geometry == "stl" and drum.stl_path:
        check_stl(drum.stl_path)
    walls = drum_walls(drum)
    check_memory(drum, sim, walls)
    mats, pairs = engine_materials(materials, interactions, sim.shear_modulus_scale, drum.ball_material,
                                   drum.wall_material)
    return drum_system(drum, mats, pairs, sim, walls)


def charge_fill(drum: DrumConfig) -> float:
    """The charge's volume fraction J of the drum (balls / (1 - porosity) / drum volume)."""
    return float((ball_radii(drum) ** 3).sum() * 4 / 3 * math.pi / (1 - drum.bed_porosity)
                 / (math.pi / 4 * drum.inner_diameter_m**2 * drum.inner_length_m))


def drum_charge_shape(drum: DrumConfig, trajectories, after_s: float, radii: np.ndarray, masses: np.ndarray,
                      density_kg_per_m3: float) -> dict:
    """Toe, shoulder, regime and torque-arm power of the charge over the averaging window (from
    at most MAX_SNAPSHOTS of the recorded ball states), beside Morrell's empirical angles and
    C-model power."""
    times = np.unique(trajectories.t_s[trajectories.t_s > after_s])
    if not len(times):
        return {}
    times = times[np.linspace(0, len(times) - 1, min(len(times), MAX_SNAPSHOTS)).round().astype(int)]
    window = trajectories[trajectories.t_s.isin(times)]
    snapshots = [g.sort_values("particle")[["x_m", "y_m", "z_m"]].to_numpy() for _, g in window.groupby("t_s")]
    speed = drum_speed_rpm(drum)
    shape = charge_shape(snapshots, radii, drum.inner_diameter_m / 2, liner_size(drum.liner, drum.inner_diameter_m)[0])
    fill = charge_fill(drum)
    toe, shoulder = morrell_toe_shoulder_deg(fill, speed / critical_speed_of(drum))
    return {**{f"charge_{k}": v for k, v in shape.items()},
            "torque_arm_power_w": torque_arm_power_w(snapshots, masses, speed * math.pi / 30),
            "morrell_toe_deg": toe, "morrell_shoulder_deg": shoulder,
            "morrell_net_power_w": MORRELL_K * morrell_net_power_w(
                drum.inner_diameter_m, drum.inner_length_m, speed, fill,
                density_kg_per_m3 * (1 - drum.bed_porosity), toe, shoulder)}


def check_memory(drum: DrumConfig, sim: SimConfig, walls: tuple) -> None:
    """Refuse a drum (with its `drum_walls`) whose engine would not fit in the memory this
    machine has now."""
    n_balls, k = ball_count(drum), sim.max_contacts_per_particle
    meshes = sum(isinstance(w, Mesh) for w in walls)
    slots = wall_slots(len(walls) - meshes, meshes > 0, k)
    need = memory_estimate_bytes(n_balls, k, sim.event_capacity, slots)
    have = available_memory_bytes()
    if need > have:
        raise ConfigError(f"mill: {n_balls:.4g} balls need about {need / 2**30:.3g} GiB for the DEM "
                          f"({need / n_balls / 1e3:.2g} kB per ball), more than the {have / 2**30:.3g} GiB available "
                          "here: lower the feed or the residence time, or use larger balls")


def dem_key(drum: DrumConfig, materials, interactions, sim: SimConfig) -> str:
    """Hash of everything that determines a drum DEM result (prices and feeds do not, nor the
    thread count, the neighbour skin, the launch mode, checkpoints or progress: results are
    identical bits whatever they are; the run's length in seconds, so that revolutions and the
    seconds they make share a key; an unset power_se_target, a smooth liner and an empty charge
    are left out, so runs keep the keys they had before those existed)."""
    numerics = {k: v for k, v in asdict(sim_in_seconds(sim, drum_speed_rpm(drum))).items()
                if k not in UNKEYED_SIM_FIELDS and not (k in UNSET_SIM_FIELDS and v is None)}
    mill = asdict(drum)
    if drum.liner.kind == "smooth":
        del mill["liner"]
    if not drum.charge:
        del mill["charge"]
    payload = {
        "drum": mill, "materials": {k: asdict(v) for k, v in materials.items()},
        "interactions": {k: asdict(v) for k, v in interactions.items()}, "sim": numerics,
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def settle_key(drum: DrumConfig, materials, interactions, sim: SimConfig) -> str:
    """Hash of what determines the charge at rest before the drum turns: dem_key's inputs but
    the drum's speed and the run's length and averaging, and the neighbour skin (which sizes
    the saved cell grid)."""
    still = dem_key(replace(drum, speed_rpm=None, fraction_of_critical=1.0), materials, interactions,
                    replace(sim, duration_s=1.0, steady_after_s=0.0, startup_revolutions=None, window_revolutions=None,
                            power_se_target=None))
    return hashlib.sha256(f"{still} skin {sim.neighbour_skin!r}".encode()).hexdigest()[:16]


def settled_bed(drum: DrumConfig, materials, interactions, sim: SimConfig, dt: float,
                beds_dir: Path | None) -> SettledBed | None:
    """Where the charge at rest is kept for other runs of the same drum and charge: two steps
    before the drum starts (however t = k dt rounds); none without a folder, a settling time or
    with VTK output (its files of the settling would be missing from a run that skips it)."""
    step = math.ceil(sim.settle_s / dt) - 2
    if beds_dir is None or step < 1 or sim.vtk_every:
        return None
    key = settle_key(drum, materials, interactions, sim)
    return SettledBed(Path(beds_dir) / f"{key}.npz", key, step)


def simulate_drum(drum: DrumConfig, materials, interactions, sim: SimConfig, out_dir: Path,
                  beds_dir: Path | None = None) -> DrumRun:
    """Run the drum DEM (or reuse the finished run in out_dir, a cache entry) and summarise
    torque and power; the tables go to out_dir as Parquet (and VTK files when asked).  Two jobs
    asking for the same entry at once: the second waits for the first and reuses its result.
    With beds_dir, the settled charge is shared with every run of the same drum and charge
    (other speeds, durations, windows): the first saves it there, the others start from it.
    The summary says whether the averaging window gave the steady power (window_check)."""
    out_dir = Path(out_dir)
    summary_path = out_dir / "dem_summary.json"
    sim = sim_in_seconds(sim, drum_speed_rpm(drum))
    key = dem_key(drum, materials, interactions, sim)
    with exclusive(out_dir / ".lock"):
        cached = read_json(summary_path)
        if cached is not None and cached.get("key") == key:
            log.info("reusing the DEM result in %s", out_dir)
            run = DrumRun(cached, Results.read(out_dir))
        else:
            if summary_path.exists():
                log.warning("%s: unreadable or of another run: running it again", summary_path)
            run = run_drum_dem(drum, materials, interactions, sim, out_dir, key, beds_dir)
    return DrumRun(run.summary | window_check(run.results.loads, run.summary, sim.settle_s, sim.sample_every_s), run.results)


def run_drum_dem(drum: DrumConfig, materials, interactions, sim: SimConfig, out_dir: Path, key: str,
                 beds_dir: Path | None) -> DrumRun:
    """The drum DEM itself, written into the cache entry out_dir (see simulate_drum)."""
    summary_path = out_dir / "dem_summary.json"
    spec = drum_spec(drum, materials, interactions, sim)
    dt = time_step_s(spec, sim)
    engine = new_engine(spec, engine_options(sim, dt), sim.arch, sim.precision, sim.threads, sim.seed)
    steps = (sim.settle_s + sim.duration_s) / dt
    log.info("drum DEM: %d balls, dt = %.3g s (%.0f %% of Rayleigh), %s neighbour search, %s steps; %.3g "
             "particle-steps to go (about %.2g min at %.0e particle-steps/s)", spec.n_particles, dt,
             100 * dt / spec.rayleigh_timestep_s(), "grid" if engine.use_grid else "all-pairs",
             engine.launch, steps * spec.n_particles,
             steps * spec.n_particles / TYPICAL_RATE / 60, TYPICAL_RATE)
    # the skin sizes the saved cell grid: a checkpoint of another skin is not this run's
    checkpoint = (Checkpoint(out_dir / "checkpoint.npz", sim.checkpoint_every_wall_s,
                             f"{key} skin {sim.neighbour_skin!r}") if sim.checkpoint_every_wall_s else None)
    after = sim.settle_s + sim.steady_after_s
    end = sim.settle_s + sim.duration_s
    sinks = (ParquetSink(out_dir), *((VtkWriter(out_dir, sim.vtk_every),) if sim.vtk_every else ()))
    snapshots = int(np.clip(math.ceil(SNAPSHOT_BALLS / spec.n_particles), MIN_SNAPSHOTS, MAX_SNAPSHOTS))
    recorder = Recorder(engine, sim.trajectory_every, np.linspace(after, end, snapshots + 1)[1:], sinks)
    turn = 60.0 / drum_speed_rpm(drum)
    window = PowerWindow(recorder, "drum", after, turn, sim.power_se_target) if sim.power_se_target else None
    results = engine.run(end, sim.sample_every_s, recorder, label="drum", checkpoint=checkpoint,
                         phases=((0.0, "settle"), (sim.settle_s, "rotate"), (after, "average")), stop=window,
                         bed=settled_bed(drum, materials, interactions, sim, dt, beds_dir))
    shape = drum_charge_shape(drum, results.trajectories, after, spec.radius_m, engine.p.mass_np,
                              float(spec.materials[drum.ball_material].density_kg_per_m3))
    power, power_se = results.mean_power_w("drum", after)
    power_roll, _ = results.mean_power_w("drum", after, rolling=True)
    loads = results.loads[results.loads.t_s > after]
    if not math.isfinite(power):
        raise SimulationError(f"drum DEM: the mean power is {power} ({len(loads)} samples after {after:g} s, "
                              f"dt {dt:.3g} s = {dt / spec.rayleigh_timestep_s():.0%} of Rayleigh); "
                              "lengthen sim.duration_s beyond sim.steady_after_s or shorten the time step")
    summary = {
        "key": key,
        "balls": spec.n_particles, "speed_rpm": drum_speed_rpm(drum),
        "critical_speed_rpm": critical_speed_of(drum),
        "dt_s": dt, "rayleigh_dt_s": spec.rayleigh_timestep_s(),
        "torque_axis_nm": float(loads.torque_axis_nm.mean()),
        "torque_axis_with_rolling_nm": float((loads.torque_axis_nm + loads.torque_rolling_axis_nm).mean()),
        "power_w": power, "power_se_w": power_se, "power_with_rolling_w": power_roll,
        "simulated_s": engine.time_s, "averaging_from_s": after,
        "averaging_ended_by": window.reason if window else CONFIGURED,
        **impact_statistics(results.collisions, after, engine.time_s, float(engine.p.mass_np.sum())),
        **shape,
    }
    write_json(summary_path, summary)  # last: its presence marks a finished cache entry
    if checkpoint:
        checkpoint.remove()
    return DrumRun(summary, results)
