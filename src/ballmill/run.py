"""One scenario (a composed Hydra config) -> one record, written into the run's folder.

A design run: feed -> scale-up -> DEM of the rotating mill -> power -> economics.
A drum run: the configured drum -> torque and power over time.
A lab run: the MM400 at every configured frequency and ball size -> lab_summary.csv.
Failures are recorded (status, message) instead of raised, so a sweep carries on; a job
whose folder already holds a finished record of the same resolved config is skipped, so a
sweep can be resumed (and one rerun with, say, another sim reruns every job).
"""

from __future__ import annotations

import json
import logging
import os
import platform
import shutil
import subprocess
import time
from dataclasses import replace
from pathlib import Path

import hydra
import pandas as pd
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from . import __version__
from .config import (
    MM400_GEOMETRY,
    ConfigError,
    DrumConfig,
    EconomicsConfig,
    MM400Config,
    ScaleupConfig,
    SimConfig,
    material_tables,
    register,
    to_object,
)
from .drum import dem_key, simulate_drum
from .economics import bond_rowland_power_w, evaluate, yield_percent
from .lab import conditions, simulate_mm400, summarise, wall_interaction
from .plots import plot_bed, plot_drum_loads, save_figure
from .scaleup import design_mill

ROOT = Path(__file__).resolve().parents[2]
log = logging.getLogger(__name__)
register()


def provenance(sim) -> dict:
    """Package versions, git commit and machine, so a record can be trusted later."""
    import numpy
    import taichi

    try:
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=10, check=False).stdout.strip()
    except OSError:
        commit = ""
    return {
        "ballmill_version": __version__, "git_commit": commit, "taichi_version": ".".join(map(str, taichi.__version__)),
        "numpy_version": numpy.__version__, "python": platform.python_version(), "machine": platform.machine(),
        "cpu_count": os.cpu_count(), "arch": sim.arch, "threads": sim.threads, "precision": sim.precision,
    }


def run(cfg: DictConfig, out_dir: Path) -> dict:
    """Validate everything first, then simulate; returns the record (no status fields)."""
    sim = to_object(cfg.sim, SimConfig, "sim")
    materials, pairs = material_tables(cfg)
    drum = to_object(cfg.mill, DrumConfig, "mill")
    kind = cfg.study.kind
    if kind not in ("design", "drum", "lab"):
        raise ConfigError(f"study.kind={kind!r} is not one of ['design', 'drum', 'lab']")
    record: dict = {"study": cfg.study.name, "kind": kind}
    if kind == "lab":
        return record | run_lab(to_object(cfg.lab, MM400Config, "lab"), materials, pairs, sim, out_dir,
                                cfg.study.get("observations"))
    if kind == "design":
        scale = to_object(cfg.scaleup, ScaleupConfig, "scaleup")
        econ = to_object(cfg.economics, EconomicsConfig, "economics")
        yield_percent(scale.bpr, econ)  # refuse an out-of-range BPR before the DEM
        design = design_mill(scale)
        drum = replace(drum, inner_diameter_m=design.diameter_m, inner_length_m=design.length_m,
                       ball_radius_m=design.ball_radius_m, ball_count=design.ball_count, speed_rpm=design.speed_rpm)
        record.update(bpr=scale.bpr, region=scale.region, shape_rule=scale.shape_rule, **design.as_record())
    dem_dir = Path(cfg.cache_dir) / "dem" / dem_key(drum, materials, pairs, sim)
    dem = simulate_drum(drum, materials, pairs, sim, dem_dir)
    record.update({f"dem_{k}": v for k, v in dem.items()})
    record["dem_dir"] = str(dem_dir)
    loads = pd.read_parquet(dem_dir / "loads.parquet")
    loads.to_csv(out_dir / "loads.csv", index=False)
    save_figure(plot_drum_loads(loads, steady_after_s=sim.settle_s + sim.steady_after_s), out_dir / "drum_loads")
    bed = pd.read_parquet(dem_dir / "trajectories.parquet")
    if len(bed):
        save_figure(plot_bed(bed, drum.ball_radius_m, drum.inner_diameter_m / 2), out_dir / "bed")
    if kind == "design":
        record.update(evaluate(dem["power_w"], scale.bpr, design.pet_feed_kg_per_h, design.naoh_feed_kg_per_h, econ))
        record["bond_rowland_power_w"] = bond_rowland_power_w(
            design.diameter_m, design.ball_mass_kg, scale.fill_fraction, design.fraction_of_critical,
            2 * design.ball_radius_m)
    return record


def run_lab(lab: MM400Config, materials, pairs, sim: SimConfig, out_dir: Path, observations: str | None) -> dict:
    """MM400 at the configured ball-wall pair: one summary row per frequency x ball size."""
    pair = wall_interaction(pairs, lab)
    conds = conditions(lab, [pair.restitution], [pair.static_friction])
    traj, collisions = simulate_mm400(lab, conds, materials, pairs, sim)
    summary = summarise(traj, collisions, lab, conds).assign(
        balls=lab.balls_per_jar, **{k: getattr(lab, k) for k in MM400_GEOMETRY})
    summary.to_csv(out_dir / "lab_summary.csv", index=False)
    return {"balls": lab.balls_per_jar, "wall_restitution": pair.restitution,
            "wall_friction": pair.static_friction, "conditions": len(conds), "observations": observations}


def write_record(record: dict, out_dir: Path) -> None:
    (out_dir / "record.json").write_text(json.dumps(record, indent=2, default=str))
    pd.DataFrame([record]).to_parquet(out_dir / "record.parquet", index=False)


def finished(out_dir: Path, resolved: str) -> bool:
    """True when out_dir holds a finished record of this very config (a changed config reruns)."""
    path, config = out_dir / "record.json", out_dir / "config_resolved.yaml"
    if not (path.exists() and json.loads(path.read_text()).get("status") == "ok"):
        return False
    if not config.exists() or config.read_text() != resolved:
        log.warning("%s holds a record of another config: rerunning", out_dir)
        return False
    return True


@hydra.main(version_base="1.3", config_path=str(ROOT / "conf"), config_name="config")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    resolved = OmegaConf.to_yaml(cfg, resolve=True)
    if finished(out_dir, resolved):
        log.info("%s already holds a finished record: skipped", out_dir)
        return
    (out_dir / "config_resolved.yaml").write_text(resolved)
    started = time.time()
    try:
        record = {**run(cfg, out_dir), "status": "ok", "error": ""}
    except Exception as exc:  # recorded, so the sweep and its report carry on
        log.exception("run failed")
        record = {"study": cfg.study.name, "status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    record.update(provenance(cfg.sim), wall_time_s=time.time() - started,
                  overrides=" ".join(HydraConfig.get().overrides.task))
    write_record(record, out_dir)
    if record["status"] != "ok":
        shutil.copy(out_dir / "record.json", out_dir / "FAILED.json")
    log_sweep_progress()


def log_sweep_progress() -> None:
    """In a multirun: how many of the sweep's jobs hold a record (finished or failed) so far.
    The total counts the sweep file's parameters; sweeps given only on the command line are
    not visible to a job, so then the count alone is logged."""
    hc = HydraConfig.get()
    if hc.mode != RunMode.MULTIRUN:
        return
    done = len(list(Path(hc.sweep.dir).glob("*/record.json")))
    params = hc.sweeper.get("params") or {}
    total = 1
    for override in OverridesParser.create().parse_overrides([f"{k}={v}" for k, v in params.items()]):
        if override.is_sweep_override():
            total *= len(list(override.sweep_string_iterator()))
    log.info("sweep: %d of %s jobs done", done, total if params else "?")
