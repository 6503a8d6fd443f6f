"""Calibrate the MM400 model's ball-wall restitution and friction against tracked videos.

A folder of videos carries a manifest, `videos.csv` (file, frequency_hz, ball_diameter_mm,
balls; optional fps and mm_per_px where a video has no capture sidecar).  Each video is
tracked once (one per core at a time; the table is kept beside it as `<file>.track.csv`) and
reduced to an observation: mean frame-to-frame ball speed and video collisions per second,
counted exactly as lab.summarise counts them on simulated trajectories.

Grid search: every (restitution, friction) pair of the grid runs every observed condition,
all as replicas of one Taichi launch per ball count; the score of a pair is the mean over
conditions of (relative speed error)^2, plus collision_weight * (relative error of the
collision rate pooled over the conditions)^2.  With `repeats` > 1 each condition and pair is
simulated from that many starts and the statistics averaged before scoring.

Bayesian search (method=optuna): Optuna's TPE sampler, seeded, over continuous ranges with
the same score.  Optuna is called directly (ask and tell) rather than through Hydra's Optuna
sweeper: a sweeper runs one job, so one Taichi start-up and compilation, per trial, while here
the `batch` pairs Optuna proposes at a time run as replicas of one launch, as the grid does.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from .columns import add_frame_velocities
from .config import CalibrationConfig, ConfigError, InteractionConfig, MM400Config, SimConfig, one_line
from .dem.runtime import cpu_threads
from .lab import Condition, simulate_mm400, summarise, video_collisions
from .vision.track import TrackerSettings, track

log = logging.getLogger(__name__)
MANIFEST = "videos.csv"
KEYS = ["balls", "frequency_hz", "ball_diameter_m"]
PAIR = ["wall_restitution", "wall_friction"]
TRACK_COLUMNS = {"t_s", "frame", "particle", "x_m", "z_m", "lost"}


def read_manifest(folder: str | Path) -> pd.DataFrame:
    """The manifest, checked: its columns, numbers where numbers belong, and every video present."""
    folder = Path(folder)
    path = folder / MANIFEST
    if not path.is_file():
        raise FileNotFoundError(f"videos={folder}: no {MANIFEST} (columns file, frequency_hz, ball_diameter_mm, balls)")
    try:
        df = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not a readable CSV ({one_line(exc)})") from exc
    missing = {"file", "frequency_hz", "ball_diameter_mm", "balls"} - set(df.columns)
    if missing:
        raise ConfigError(f"{path}: missing columns {sorted(missing)}")
    if df.empty:
        raise ConfigError(f"{path}: lists no videos")
    for col in ("frequency_hz", "ball_diameter_mm", "balls", "fps", "mm_per_px"):
        if col in df:
            values = pd.to_numeric(df[col], errors="coerce")
            bad = df[col][~(values > 0) & (df[col].notna() if col in ("fps", "mm_per_px") else True)]
            if len(bad):
                raise ConfigError(f"{path}: column {col} holds {bad.iloc[0]!r}; give positive numbers")
    if not set(df.balls.astype(int)) <= {1, 2}:
        raise ConfigError(f"{path}: column balls must be 1 or 2")
    absent = [f for f in df.file if not (folder / str(f)).exists()]
    if absent:
        raise FileNotFoundError(f"{path}: names videos that are not in {folder}: {absent}")
    return df


def observe(tracked: pd.DataFrame, fps: float, jump_m_per_s: float) -> dict:
    """Mean frame-to-frame speed (m/s) and video collisions per s from a tracker table, measured
    as lab.summarise measures them on simulated trajectories."""
    fs = add_frame_velocities(tracked, fps)
    span = tracked.t_s.max() - tracked.t_s.min()
    return {"mean_speed_m_per_s": float(fs.frame_speed_m_per_s.mean()),
            "video_collisions_per_s": video_collisions(fs, jump_m_per_s) / span,
            "frames": int(tracked.frame.nunique()), "lost_ball_frames": int(tracked.lost.sum())}


def tracked(video: Path, balls: int, ball_diameter_mm: float, fps: float | None,
            mm_per_px: float | None) -> pd.DataFrame:
    """The video's tracker table: tracked once, then kept beside it as `<file>.track.csv`."""
    cached = video.with_name(video.name + ".track.csv")
    table = pd.read_csv(cached) if cached.exists() else None
    if table is None or not TRACK_COLUMNS <= set(table.columns):  # none yet, or of an older tracker
        log.info("tracking %s", video)
        table = track(video, TrackerSettings(balls=balls, ball_diameter_mm=ball_diameter_mm), fps=fps,
                      mm_per_px=mm_per_px)
        table.to_csv(cached, index=False)
    return table


def observations(folder: str | Path, lab: MM400Config) -> pd.DataFrame:
    """One row per video of the manifest: its condition and what tracking measured (the videos
    tracked side by side, one per core)."""
    folder = Path(folder)
    manifest = read_manifest(folder)
    given = [tuple(None if pd.isna(x) else float(x) for x in (getattr(v, "fps", None), getattr(v, "mm_per_px", None)))
             for v in manifest.itertuples()]
    tables = Parallel(n_jobs=min(cpu_threads(0), len(manifest)))(
        delayed(tracked)(folder / v.file, int(v.balls), float(v.ball_diameter_mm), fps, mm_per_px)
        for v, (fps, mm_per_px) in zip(manifest.itertuples(), given))
    rows = []
    for v, table, (fps, _) in zip(manifest.itertuples(), tables, given):
        fps = fps or 1.0 / np.median(np.diff(np.sort(table.t_s.unique())))
        rows.append({"file": v.file, "balls": int(v.balls), "frequency_hz": float(v.frequency_hz),
                     "ball_diameter_m": float(v.ball_diameter_mm) / 1e3,
                     **observe(table, fps, lab.collision_speed_jump_m_per_s)})
    return pd.DataFrame(rows)


def simulate_grid(obs: pd.DataFrame, lab: MM400Config, pairs: list[tuple[float, float]], materials,
                  interactions: dict[str, InteractionConfig], sim: SimConfig, repeats: int = 1) -> pd.DataFrame:
    """Simulated statistics of every observed condition at every (restitution, friction) pair,
    averaged over `repeats` starts."""
    out = []
    for balls, group in obs.groupby("balls"):
        conds = [Condition(r.frequency_hz, r.ball_diameter_m, e, mu, k) for r in group.itertuples() for e, mu in pairs
                 for k in range(repeats)]
        cfg = replace(lab, balls_per_jar=int(balls))
        traj, collisions = simulate_mm400(cfg, conds, materials, interactions, sim)
        out.append(summarise(traj, collisions, cfg, conds).assign(balls=int(balls)))
    table = pd.concat(out, ignore_index=True).drop(columns=["replica", "replicate"])
    return table.groupby([*KEYS, *PAIR], as_index=False, sort=False).mean().assign(repeats=repeats)


def score(sim: pd.DataFrame, obs: pd.DataFrame, collision_weight: float) -> pd.DataFrame:
    """Per (restitution, friction): speed and collision-rate errors and the score (lower is better).

    Speed: RMS over conditions of the relative error.  Collisions: relative error of the rate
    pooled over all conditions, since a video of a second or two holds only tens of them
    (Poisson noise ~25 % per video, ~9 % pooled over eight).
    """
    m = sim.merge(obs, on=KEYS, suffixes=("_sim", "_obs"))
    m["speed_error2"] = (m.mean_speed_m_per_s_sim / m.mean_speed_m_per_s_obs - 1) ** 2
    g = m.groupby(PAIR)
    out = pd.DataFrame({
        "speed_rms_error": np.sqrt(g.speed_error2.mean()),
        "collision_error": g.video_collisions_per_s_sim.mean() / np.maximum(g.video_collisions_per_s_obs.mean(),
                                                                             1e-9) - 1,
    })
    out["score"] = out.speed_rms_error**2 + collision_weight * out.collision_error**2
    return out.reset_index()


def calibrate(obs: pd.DataFrame, lab: MM400Config, grid: CalibrationConfig, materials,
              interactions: dict[str, InteractionConfig], sim: SimConfig) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Score surface, the simulated table behind it, and the best pair with its sensitivity."""
    pairs = [(e, mu) for e in grid.restitutions for mu in grid.frictions]
    log.info("calibration: %d pairs x %d conditions", len(pairs), len(obs))
    simulated = simulate_grid(obs, lab, pairs, materials, interactions, sim, grid.repeats)
    surface = score(simulated, obs, grid.collision_weight)
    best = surface.loc[surface.score.idxmin()]
    result = {"wall_restitution": float(best.wall_restitution), "wall_friction": float(best.wall_friction),
              "score": float(best.score), "speed_rms_error": float(best.speed_rms_error),
              "collision_error": float(best.collision_error), **sensitivity(simulated, best)}
    return surface, simulated, result


def search(obs: pd.DataFrame, lab: MM400Config, opts: CalibrationConfig, materials,
           interactions: dict[str, InteractionConfig], sim: SimConfig) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Optuna (TPE, seeded) over the restitution and friction ranges: the trials in order (with
    the best score so far), the simulated table behind them, and the best pair."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=opts.seed, n_startup_trials=opts.startup_trials, multivariate=True,
                                         constant_liar=True)
    study = optuna.create_study(sampler=sampler)
    space = {"wall_restitution": optuna.distributions.FloatDistribution(*opts.restitution_range),
             "wall_friction": optuna.distributions.FloatDistribution(*opts.friction_range)}
    rows, tables = [], []
    while len(rows) < opts.trials:
        asked = [study.ask(space) for _ in range(min(opts.batch, opts.trials - len(rows)))]
        pairs = [(t.params["wall_restitution"], t.params["wall_friction"]) for t in asked]
        log.info("calibration search: trials %d-%d of %d", len(rows) + 1, len(rows) + len(asked), opts.trials)
        simulated = simulate_grid(obs, lab, pairs, materials, interactions, sim, opts.repeats)
        scored = {(r.wall_restitution, r.wall_friction): r for r in
                  score(simulated, obs, opts.collision_weight).itertuples()}
        for trial, pair in zip(asked, pairs):
            r = scored[pair]
            study.tell(trial, float(r.score))
            rows.append({"trial": trial.number + 1, "wall_restitution": pair[0], "wall_friction": pair[1],
                         "score": r.score, "speed_rms_error": r.speed_rms_error, "collision_error": r.collision_error})
        tables.append(simulated)
    trials = pd.DataFrame(rows).assign(best_score=lambda t: t.score.cummin())
    best = trials.loc[trials.score.idxmin()]
    return trials, pd.concat(tables, ignore_index=True), {
        **{k: float(best[k]) for k in (*PAIR, "score", "speed_rms_error", "collision_error")},
        "trial": int(best.trial), "trials": len(trials)}


def trials_to_reach(trials: pd.DataFrame, target: float) -> int | None:
    """The first trial whose best score so far is at or below target (None: never)."""
    hit = trials[trials.best_score <= target]
    return int(hit.trial.iloc[0]) if len(hit) else None


def sensitivity(simulated: pd.DataFrame, best) -> dict:
    """Relative change of mean speed and collision rate per unit restitution and friction near the best pair
    (least-squares slopes over the grid lines through it)."""
    out = {}
    for var, fixed in (("wall_restitution", "wall_friction"), ("wall_friction", "wall_restitution")):
        line = simulated[np.isclose(simulated[fixed], best[fixed])].groupby(var)[
            ["mean_speed_m_per_s", "video_collisions_per_s"]].mean()
        for col, name in (("mean_speed_m_per_s", "speed"), ("video_collisions_per_s", "collisions")):
            slope = np.polyfit(line.index, line[col], 1)[0] if len(line) > 1 else float("nan")
            out[f"d_{name}_d_{var.removeprefix('wall_')}_relative"] = float(slope / max(line[col].mean(), 1e-12))
    return out


def calibrate_to_files(opts: CalibrationConfig, s) -> dict:
    """`ballmill calibrate`: observations, then per method its tables and figures in opts.out
    (grid: score_surface, simulated, validation at the best pair; optuna: trials and the score
    history), and best.json: the best pair of each method and, with both, how many trials the
    search needed to reach the grid's best score."""
    from .files import write_json
    from .plots import plot_lab_validation, plot_score_history, plot_score_surface, save_figure

    obs = observations(opts.videos, s.lab)  # checks the videos before anything is written
    out = Path(opts.out)
    out.mkdir(parents=True, exist_ok=True)
    obs.to_csv(out / "observations.csv", index=False)
    result, grid_best = {"method": opts.method, "repeats": opts.repeats}, None
    if opts.method in ("grid", "both"):
        surface, simulated, best = calibrate(obs, s.lab, opts, s.materials, s.interactions, s.sim)
        surface.to_csv(out / "score_surface.csv", index=False)
        simulated.to_csv(out / "simulated.csv", index=False)
        save_figure(plot_score_surface(surface, best), out / "score_surface")
        at_best = simulated[(simulated.wall_restitution == best["wall_restitution"])
                            & (simulated.wall_friction == best["wall_friction"])]
        save_figure(plot_lab_validation(at_best, obs), out / "validation")
        result |= {**best, "grid_points": len(surface)}
        grid_best = best["score"]
    if opts.method in ("optuna", "both"):
        trials, simulated, best = search(obs, s.lab, opts, s.materials, s.interactions, s.sim)
        trials.to_csv(out / "trials.csv", index=False)
        simulated.to_csv(out / "search_simulated.csv", index=False)
        save_figure(plot_score_history(trials, grid_best), out / "score_history")
        found = {f"search_{k}": v for k, v in best.items()}
        result = result | found if opts.method == "both" else result | best
        if grid_best is not None:
            result["search_trials_to_reach_grid_best"] = trials_to_reach(trials, grid_best)
    write_json(out / "best.json", result)
    return result
