"""The jobs of a run or sweep, expanded from the overrides and the sweep file and each checked
(composed, range-checked, planned: nothing simulated) before Hydra launches any of them."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import OverrideType
from hydra.errors import HydraException
from hydra.types import RunMode
from omegaconf import Container, DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from .config import ConfigError, one_line
from .dem.runtime import LOCAL_JOBS_ENV
from .files import read_json
from .run import RECORD
from .scenario import compose, load
from .studies import check_machine, plan

MISSING_NODE = object()  # OmegaConf.select's answer for a key the config lacks


def parse(overrides: list[str]):
    try:
        return OverridesParser.create().parse_overrides(overrides)
    except HydraException as exc:
        raise ConfigError(one_line(exc)) from exc


def expand(overrides: list[str], multirun: bool) -> tuple[list[list[str]], list[str], DictConfig, Path | None]:
    """Every job's overrides (the command line's sweeps and the sweep file's parameters, as
    Hydra's basic sweeper combines them), the overrides every job starts with, the config those
    compose (Hydra's node included) and the sweep folder (None for a single run)."""
    parsed = parse(overrides)
    fixed = [o.input_line for o in parsed if not o.is_sweep_override()]
    swept = {o.key_or_group: [f"{o.get_key_element()}={v}" for v in o.sweep_string_iterator()]
             for o in parsed if o.is_sweep_override()}
    cfg = compose("config", fixed, hydra=True)
    multirun = multirun or cfg.hydra.mode == RunMode.MULTIRUN
    if swept and not multirun:
        raise ConfigError(f"{', '.join(swept)}: several values need a sweep: add -m")
    if not multirun:
        return [fixed], fixed, cfg, None
    for o in parse([f"{k}={v}" for k, v in (cfg.hydra.sweeper.get("params") or {}).items()]):
        if o.key_or_group not in swept:
            values = o.sweep_string_iterator() if o.is_sweep_override() else [o.value()]
            swept[o.key_or_group] = [f"{o.get_key_element()}={v}" for v in values]
    return [fixed + list(combo) for combo in itertools.product(*swept.values())], fixed, cfg, \
        Path(cfg.hydra.sweep.dir)


def changes_a_value(cfg: DictConfig, o) -> bool:
    """Whether the parsed override `o` only changes the value of a leaf that cfg has (not a config
    group, an addition or a deletion)."""
    node = OmegaConf.select(cfg, o.key_or_group, default=MISSING_NODE)
    return (o.type == OverrideType.CHANGE and o.package is None and not o.is_sweep_override()
            and node is not MISSING_NODE and not isinstance(node, Container))


def with_values(base: DictConfig, overrides: list[str]) -> DictConfig | None:
    """base with `overrides` applied, if each only changes the value of an existing leaf (as
    Hydra applies such an override after composing: composing again per job cost ~0.15 s);
    None if any does more (a config group, an addition, a deletion), or fails: then compose."""
    cfg = base.copy()
    for o in parse(overrides):
        if not changes_a_value(cfg, o):
            return None
        try:
            OmegaConf.update(cfg, o.key_or_group, o.value(), merge=True)
        except OmegaConfBaseException:
            return None
    return cfg


def runs_here(launcher) -> bool:
    """Whether the launcher runs the jobs on this machine (not SLURM, not a remote Ray cluster)."""
    target = launcher.get("_target_", "")
    return not ("SlurmLauncher" in target or ("RayLauncher" in target and launcher.ray.init.get("address")))


def check_jobs(overrides: list[str], multirun: bool) -> Path | None:
    """Refuse the whole run (ConfigError naming the job) if any job's config is bad; the sweep folder.
    What depends on the machine (threads, CUDA) is checked here only when the jobs run here, and
    then the number of jobs run at once is put in LOCAL_JOBS_ENV (inherited by the job processes)."""
    jobs, fixed, base, sweep_dir = expand(overrides, multirun)
    # composed once (~0.5 s a composition): a job's own overrides change the launcher only if they name hydra's
    own_hydra = any(o.lstrip("+~").startswith("hydra") for o in jobs[0][len(fixed):])
    launcher = (compose("config", jobs[0], hydra=True) if own_hydra else base).hydra.launcher
    if runs_here(launcher) and len(jobs) > 1:  # sim.threads=0 then shares the cores among the jobs at once
        at_once = 1 if "BasicLauncher" in launcher.get("_target_", "") else launcher.get("n_jobs") or os.cpu_count()
        os.environ[LOCAL_JOBS_ENV] = str(min(len(jobs), int(at_once or 1)))
    bases = {(): base}  # the jobs' config groups composed once per combination (a sweep of groups x values)
    for job in jobs:
        try:
            own = job[len(fixed):]
            groups = tuple(o.input_line for o in parse(own) if not changes_a_value(base, o))
            if groups not in bases:
                bases[groups] = compose("config", [*fixed, *groups])
            cfg = with_values(bases[groups], [o for o in own if o not in groups])
            scenario = load(cfg if cfg is not None else compose("config", job))
            plan(scenario)
            if runs_here(launcher):
                check_machine(scenario.sim)
            if "submitit" in launcher.get("_target_", "") and scenario.sim.threads == 0:
                raise ConfigError("sim.threads=0 (all cores) cannot size a submitit job: give sim.threads >= 1, "
                                  "the CPUs each job gets")
        except ConfigError as exc:
            own = [o for o in job if o not in overrides]
            raise ConfigError(f"{exc}{f' (job {chr(32).join(own)})' if own else ''}") from exc
    return sweep_dir


def records_since(sweep_dir: Path, started_s: float) -> list[tuple[Path, dict]]:
    """(folder, record) of each job of the sweep whose record was written after started_s (time.time())."""
    found = ((p.parent, read_json(p)) for p in sorted(sweep_dir.glob(f"*/{RECORD}")) if p.stat().st_mtime >= started_s - 1)
    return [(folder, record) for folder, record in found if record is not None]
