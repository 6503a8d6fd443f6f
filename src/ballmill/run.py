"""One scenario (a composed Hydra config) -> one record, written into the run's folder.

The Hydra task function of `ballmill run`: it checks the scenario (studies.plan), executes the
plan and writes record.json / record.parquet beside the resolved config.  A failure during the
run is recorded (status, message, FAILED.json) so a sweep carries on; an interrupted job (Ctrl-C)
writes nothing, even when a library caught the interrupt and failed otherwise; a job whose
folder already holds a finished record of the same resolved config is skipped, so a sweep can
be resumed (and one rerun with, say, another sim reruns every job).  Records are written whole
or not at all.
"""

from __future__ import annotations

import logging
import os
import platform
import signal
import subprocess
import threading
import time
from pathlib import Path

import hydra
import pandas as pd
import pyarrow.parquet as pq
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from . import __version__
from .config import CONF_DIR
from .files import read_json, write_atomic, write_json, write_text
from .scenario import load
from .studies import plan

log = logging.getLogger(__name__)
RECORD, FAILED, RESOLVED = "record.json", "FAILED.json", "config_resolved.yaml"
JOBS: list[tuple[Path, dict]] = []  # folder and record of each job this process ran (read by the command line)


def provenance(sim) -> dict:
    """Package versions, git commit and machine, so a record can be trusted later."""
    import numpy
    import taichi

    try:
        commit = subprocess.run(["git", "-C", str(CONF_DIR), "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=10, check=False).stdout.strip()
    except OSError:
        commit = ""
    return {
        "ballmill_version": __version__, "git_commit": commit, "taichi_version": ".".join(map(str, taichi.__version__)),
        "numpy_version": numpy.__version__, "python": platform.python_version(), "machine": platform.machine(),
        "cpu_count": os.cpu_count(), "arch": sim.arch, "threads": sim.threads, "precision": sim.precision,
    }


def run(cfg: DictConfig, out_dir: Path) -> dict:
    """Check everything first (ConfigError), then simulate; returns the record (no status fields)."""
    scenario = load(cfg)
    p = plan(scenario)
    return p.record | p.execute(out_dir)


def write_record(record: dict, out_dir: Path) -> None:
    """record.parquet first, record.json (the mark of a finished job) last, each written whole."""
    write_atomic(out_dir / "record.parquet", lambda tmp: pd.DataFrame([record]).to_parquet(tmp, index=False))
    write_json(out_dir / RECORD, record)


def finished(out_dir: Path, resolved: str) -> bool:
    """True when out_dir holds a finished record of this very config (a changed or unreadable one reruns)."""
    record = read_json(out_dir / RECORD)
    if record is None:
        if (out_dir / RECORD).exists():
            log.warning("%s is unreadable (interrupted or corrupted): rerunning", out_dir / RECORD)
        return False
    if record.get("status") != "ok":
        return False
    try:
        pq.read_metadata(out_dir / "record.parquet")
    except (OSError, ValueError):
        log.warning("%s is unreadable: rerunning", out_dir / "record.parquet")
        return False
    config = out_dir / RESOLVED
    if not config.exists() or config.read_text() != resolved:
        log.warning("%s holds a record of another config: rerunning", out_dir)
        return False
    return True


class InterruptWatch:
    """Notes a Ctrl-C (SIGINT) inside the block, then handles it as before (Python's handler
    raises KeyboardInterrupt).  Installed only where a Python handler is in place, in the main
    thread; elsewhere `seen` stays False."""

    def __enter__(self):
        self.seen, self.previous = False, None
        if threading.current_thread() is threading.main_thread() and callable(signal.getsignal(signal.SIGINT)):
            self.previous = signal.signal(signal.SIGINT, self._note)
        return self

    def _note(self, signum, frame) -> None:
        self.seen = True
        self.previous(signum, frame)

    def __exit__(self, *exc) -> None:
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)


def attempt(cfg: DictConfig, out_dir: Path) -> dict:
    """The job's record: its results and status "ok", or its failure (status "failed").  An
    interrupt propagates and is not a failure, also when a library caught it and raised another
    error instead (matplotlib, cut mid-figure: "'Axes' object has no attribute ..."), so that a
    resumed sweep reruns the job."""
    with InterruptWatch() as interrupt:
        try:
            return {**run(cfg, out_dir), "status": "ok", "error": ""}
        except Exception as exc:  # recorded, so the sweep and its report carry on
            if interrupt.seen:
                raise KeyboardInterrupt from exc
            log.exception("run failed")
            return {"study": cfg.study.name, "status": "failed", "error": f"{type(exc).__name__}: {exc}"}


@hydra.main(version_base="1.3", config_path=str(CONF_DIR), config_name="config")
def main(cfg: DictConfig) -> str:
    """One job: returns its status ("ok", "skipped" or "failed")."""
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    resolved = OmegaConf.to_yaml(cfg, resolve=True)
    if finished(out_dir, resolved):
        log.info("%s already holds a finished record: skipped", out_dir)
        log_sweep_progress()
        return "skipped"
    (out_dir / FAILED).unlink(missing_ok=True)
    write_text(out_dir / RESOLVED, resolved)
    started = time.time()
    record = attempt(cfg, out_dir)
    record.update(provenance(cfg.sim), wall_time_s=time.time() - started,
                  overrides=" ".join(HydraConfig.get().overrides.task))
    write_record(record, out_dir)
    if record["status"] != "ok":
        write_json(out_dir / FAILED, record)
    if record.get("dem_steady") is False:
        log.warning("the power is not the steady one: %s", record["dem_unsteady_reason"])
    JOBS.append((out_dir, record))
    log_sweep_progress()
    return record["status"]


def log_sweep_progress() -> None:
    """In a multirun: how many of the sweep's jobs hold a record (finished or failed) so far.
    The total counts the sweep file's parameters; sweeps given only on the command line are
    not visible to a job, so then the count alone is logged."""
    hc = HydraConfig.get()
    if hc.mode != RunMode.MULTIRUN:
        return
    done = len(list(Path(hc.sweep.dir).glob(f"*/{RECORD}")))
    params = hc.sweeper.get("params") or {}
    total = 1
    for override in OverridesParser.create().parse_overrides([f"{k}={v}" for k, v in params.items()]):
        if override.is_sweep_override():
            total *= len(list(override.sweep_string_iterator()))
    log.info("sweep: %d of %s jobs done", done, total if params else "?")
