"""Observers: what a run records, as tidy tables with units in the column names."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..files import read_parquet, write_atomic

TABLES = ("loads", "energy", "collisions", "trajectories")


@dataclass
class Results:
    """Time series of one run.

    loads: per sample, replica and body, the interval-mean force (N), torque about the
    body's motion axis (N m) and power delivered by the body to the particles (W); the
    `_rolling` columns hold the rolling-friction part, which EDEM leaves out of geometry
    torque: `torque_axis_nm` and `power_w` exclude it, add the `_rolling` column to include it.
    energy: per replica, kinetic, rotational, potential and elastic energy, the cumulative
    work of the walls and energy dissipated (normal, tangential, rolling), and the residual of
    the balance (J), see `Engine.energies`.
    collisions: one row per finished contact.
    trajectories: particle states at each sample (when recorded).
    """

    loads: pd.DataFrame
    energy: pd.DataFrame
    collisions: pd.DataFrame
    trajectories: pd.DataFrame

    @classmethod
    def read(cls, folder: str | Path) -> Results:
        """The tables a ParquetSink wrote into folder."""
        return cls(**{name: read_parquet(Path(folder) / f"{name}.parquet") for name in TABLES})

    def mean_power_w(self, body: str, after_s: float = 0.0, rolling: bool = False, blocks: int = 10):
        """Mean power (W) delivered by `body` after `after_s`, with its standard error from
        `blocks` batch means (robust to the autocorrelation of the signal)."""
        df = self.loads[(self.loads.body == body) & (self.loads.t_s > after_s)]
        return batch_mean((df.power_w + (df.power_rolling_w if rolling else 0.0)).to_numpy(), blocks)


def batch_mean(values: np.ndarray, blocks: int = 10) -> tuple[float, float]:
    """The mean of a series and its standard error from `blocks` batch means (nan: too short)."""
    if len(values) < blocks:
        return float(np.mean(values)) if len(values) else float("nan"), float("nan")
    means = np.array([c.mean() for c in np.array_split(values, blocks)])
    return float(values.mean()), float(means.std(ddof=1) / np.sqrt(blocks))


def batch_trend(times: np.ndarray, values: np.ndarray, blocks: int = 10) -> tuple[float, float]:
    """The straight line through a series' `blocks` batch means against time: its slope's t
    statistic and the change it makes over the series as a fraction of the mean (nan, nan:
    too short)."""
    if len(values) < blocks:
        return float("nan"), float("nan")
    parts = np.array_split(np.arange(len(values)), blocks)
    t = np.array([times[c].mean() for c in parts])
    m = np.array([values[c].mean() for c in parts])
    x = t - t.mean()
    slope = float(x @ (m - m.mean()) / (x @ x))
    residual = m - m.mean() - slope * x
    se = float(np.sqrt(residual @ residual / (blocks - 2) / (x @ x)))
    mean = float(values.mean())
    t_stat = slope / se if se > 0 else (0.0 if slope == 0 else math.copysign(math.inf, slope))
    return t_stat, slope * (times[-1] - times[0]) / mean if mean else float("nan")


class ParquetSink:
    """Writes a run's tables as <table>.parquet into a folder when the run ends."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)

    def sample(self, engine) -> None:
        pass

    def close(self, results: Results) -> None:
        """Each table to a temporary name, then renamed: jobs on other machines sharing a cache
        folder, or an interrupted one, never leave a half-written table."""
        for name in TABLES:
            table = getattr(results, name)
            write_atomic(self.folder / f"{name}.parquet", lambda tmp, table=table: table.to_parquet(tmp, index=False))


class Recorder:
    """Collects samples from an Engine into Results (in memory); trajectories every
    `trajectory_every` samples (0: never) and at the samples nearest to `snapshot_times_s`.
    `sinks` (ParquetSink, dem.vtk.VtkWriter, ...) see every sample and the finished Results."""

    def __init__(self, engine, trajectory_every: int = 0, snapshot_times_s=(), sinks=()):
        self.every = trajectory_every
        self.snapshots = sorted(snapshot_times_s)
        self.sinks = sinks
        self.body_names = [b.name for b in engine.spec.bodies]
        self.n_samples = 0
        self.columns = {name: defaultdict(list) for name in TABLES}

    def _add(self, table: str, **cols) -> None:
        n = max(np.size(v) for v in cols.values())
        for k, v in cols.items():
            self.columns[table][k].append(np.broadcast_to(v, (n,)) if np.ndim(v) == 0 else np.asarray(v))

    def sample(self, engine, seen) -> None:
        """Record the engine's step, whose `Engine.observe()` is `seen`."""
        t = engine.time_s
        reps = engine.spec.replica
        loads = seen.loads
        axis = engine.wall_axis()
        for b, name in enumerate(self.body_names):
            ax = axis[:, b]
            self._add(
                "loads", t_s=t, replica=np.arange(engine.n_rep), body=np.full(engine.n_rep, name, object),
                torque_axis_nm=np.einsum("ij,ij->i", loads["torque"][:, b], ax),
                torque_rolling_axis_nm=np.einsum("ij,ij->i", loads["torque_rolling"][:, b], ax),
                power_w=loads["power"][:, b], power_rolling_w=loads["power_rolling"][:, b],
                force_x_n=loads["force"][:, b, 0], force_y_n=loads["force"][:, b, 1],
                force_z_n=loads["force"][:, b, 2],
            )
        self._add("energy", t_s=t, replica=np.arange(engine.n_rep), **engine.energies(seen))
        if 2 * seen.flags["ev_count"] > engine.monitor.capacity:  # else left for a later sample (or finish)
            self._collisions(engine)
        snapshot = bool(self.snapshots) and t >= self.snapshots[0] - 0.5 * engine.dt
        if snapshot:
            self.snapshots.pop(0)
        if snapshot or (self.every and self.n_samples % self.every == 0):
            x, v, w = seen.x, seen.v, seen.w
            self._add(
                "trajectories", t_s=t, replica=reps, particle=np.arange(engine.n),
                x_m=x[:, 0], y_m=x[:, 1], z_m=x[:, 2],
                vx_m_per_s=v[:, 0], vy_m_per_s=v[:, 1], vz_m_per_s=v[:, 2],
                wx_rad_per_s=w[:, 0], wy_rad_per_s=w[:, 1], wz_rad_per_s=w[:, 2],
            )
        for sink in self.sinks:
            sink.sample(engine)
        self.n_samples += 1

    def _collisions(self, engine) -> None:
        ints, vals = engine.drain_events()
        if not len(ints):
            return
        i, key = ints[:, 0], ints[:, 1]
        walls = engine.walls
        cap, nw, nt = walls.cap, walls.n_wall, walls.n_tri  # keys of walls start at walls.cap
        is_pair = key < cap
        body = np.full(len(key), -1)
        wall = (key >= cap) & (key < cap + nw)
        body[wall] = walls.wall_body[key[wall] - cap]
        mesh = key >= cap + nw + nt
        body[mesh] = walls.mesh_body[key[mesh] - cap - nw - nt]
        m = engine.p.mass_np
        m_j = m[np.where(is_pair, key, i)]
        m_eff = np.where(is_pair, m[i] * m_j / (m[i] + m_j), m[i])
        names = np.array(self.body_names + [""], dtype=object)
        self._add(
            "collisions", t_start_s=ints[:, 2] * engine.dt, t_end_s=ints[:, 3] * engine.dt,
            replica=engine.spec.replica[i], particle=i, partner=np.where(is_pair, key, -1),
            kind=np.where(is_pair, "ball-ball", "ball-wall").astype(object), body=names[body],
            impact_speed_m_per_s=vals[:, 0], impact_energy_j=0.5 * m_eff * vals[:, 0] ** 2,
            dissipated_j=vals[:, 1],
        )

    def power_so_far(self, body: str) -> tuple[np.ndarray, np.ndarray]:
        """Sample times (s) and power (W) of `body` recorded so far (all replicas)."""
        cols = self.columns["loads"]
        if not cols["t_s"]:
            return np.empty(0), np.empty(0)
        mine = np.concatenate(cols["body"]) == body
        return np.concatenate(cols["t_s"])[mine], np.concatenate(cols["power_w"])[mine]

    def samples(self) -> dict:
        """The samples so far (a settled bed keeps these; a checkpoint keeps the whole state)."""
        return {"n_samples": self.n_samples, "columns": {k: dict(v) for k, v in self.columns.items()}}

    def restore_samples(self, samples: dict) -> None:
        self.n_samples = samples["n_samples"]
        self.columns = {k: defaultdict(list, v) for k, v in samples["columns"].items()}

    def state(self) -> dict:
        return self.samples() | {"snapshots": list(self.snapshots), "sinks": [vars(w).copy() for w in self.sinks]}

    def restore(self, state: dict) -> None:
        self.restore_samples(state)
        self.snapshots = state["snapshots"]
        for sink, saved in zip(self.sinks, state["sinks"]):
            vars(sink).update(saved)

    def finish(self, engine) -> Results:
        """The run's tables (with the collisions the engine still holds), handed to every sink."""
        self._collisions(engine)
        results = Results(**{
            name: pd.DataFrame({k: np.concatenate(v) for k, v in cols.items()}) for name, cols in self.columns.items()
        })
        for sink in self.sinks:
            sink.close(results)
        return results
