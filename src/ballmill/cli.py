"""The `ballmill` command: `ballmill COMMAND [key=value ...]`.

Every command takes Hydra overrides and nothing else: its own options (conf/<command>.yaml,
schema in config.py) by bare name, and for run, render and calibrate any field of the run's
config groups (sim.*, mill.*, lab.*, materials.*, interactions.*, ...).  `ballmill COMMAND
--help` lists the fields with their defaults, allowed ranges and units.

A user error (a value out of range, an unknown key, a missing or unreadable input) prints one
line, `error: ...`, and exits with status 2 before anything runs; `--debug` (or
BALLMILL_DEBUG=1) prints the traceback too.  A run or sweep with failed jobs exits with 1.
A new command is a function here, its entry in COMMANDS, a schema and a conf/<command>.yaml.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from . import __version__
from .config import COMMANDS as SCHEMAS
from .config import (
    CONF_DIR,
    ConfigError,
    DemConfig,
    DrumConfig,
    EconomicsConfig,
    MM400Config,
    OptimiserConfig,
    PlantConfig,
    ScaleupConfig,
    SimConfig,
    StudyConfig,
    YieldModelConfig,
    allowed,
    to_object,
    walk,
)

log = logging.getLogger("ballmill")
USER_ERRORS = (ConfigError, FileNotFoundError, IsADirectoryError, NotADirectoryError)
HYDRA_VALUE_FLAGS = {"--config-dir", "-cd", "--config-path", "-cp", "--config-name", "-cn", "--cfg", "-c",
                     "--package", "-p", "--info", "-i", "--experimental-rerun"}


class JobsFailed(Exception):
    """A run or sweep finished with failed jobs (their folders hold FAILED.json)."""


def options(cfg: DictConfig, command: str):
    """The command's own options (its schema's fields at the config's root), range-checked."""
    schema = SCHEMAS[command]
    own = OmegaConf.masked_copy(cfg, [f.name for f in dataclasses.fields(schema)])
    return to_object(own, schema, "")


def scenario_of(cfg: DictConfig):
    from .scenario import load

    return load(cfg)


def track_cmd(cfg: DictConfig) -> None:
    from .vision.track import track_to_files

    opts = options(cfg, "track")
    table, out = track_to_files(opts)
    lost = table.groupby("particle").lost.sum().to_dict()
    print(f"{out}: {table.frame.nunique()} frames, frames with a ball lost {lost}, "
          f"mean speed {table.frame_speed_m_per_s.mean():.3f} m/s ({table.attrs['polarity']} balls)")


def render_cmd(cfg: DictConfig) -> None:
    from .lab import conditions, simulate_mm400
    from .vision.render import Camera, render_lab_videos

    opts, s = options(cfg, "render"), scenario_of(cfg)
    conds = conditions(s.lab, [opts.wall_restitution], [opts.wall_friction])
    traj, _ = simulate_mm400(s.lab, conds, s.materials, s.interactions, s.sim)
    cam = Camera(mm_per_px=opts.mm_per_px, backlit=opts.backlit, noise_grey=opts.noise_grey, seed=s.sim.seed)
    manifest = render_lab_videos(opts.out, s.lab, conds, traj, cam)
    print(f"{opts.out}: {len(manifest)} videos, manifest videos.csv")


def calibrate_cmd(cfg: DictConfig) -> None:
    from .calibrate import calibrate_to_files

    best = calibrate_to_files(options(cfg, "calibrate"), scenario_of(cfg))
    print(json.dumps(best, indent=2))


def report_cmd(cfg: DictConfig) -> None:
    from .report import finished, headline, index, report

    opts = options(cfg, "report")
    if not opts.sweeps:
        raise ConfigError("sweeps=[] is empty: give sweeps=[outputs/sweeps/NAME,...]")
    out = Path(opts.out)
    names = [report(Path(d), out).stem for d in opts.sweeps]
    for name in names:  # the answer last, where the console ends
        print("\n".join([f"{out / name}.md", *headline(finished(out, name))[2:]]))
    print(f"Every table and figure: {index(out)}")


def bench_cmd(cfg: DictConfig) -> None:
    from .bench import main

    main(options(cfg, "bench"))


def surrogate_cmd(cfg: DictConfig) -> None:
    from .plots import plot_surrogate_parity, save_figure
    from .surrogate.model import describe, error_table
    from .surrogate.space import OUTPUTS
    from .surrogate.training import train_table, write_table

    opts, s = options(cfg, "surrogate"), scenario_of(cfg)
    table = train_table(s, opts)
    path = write_table(table, s, opts, Path(opts.out))
    runs, summary = error_table(table, opts.folds, opts.seed)
    runs.to_csv(path.parent / "surrogate_errors_per_run.csv", index=False)
    summary.to_csv(path.parent / "surrogate_errors.csv", index=False)
    save_figure(plot_surrogate_parity(runs, OUTPUTS), path.parent / "surrogate_parity")
    print(f"{path}: {len(table)} runs, {int((table.status != 'ok').sum())} failed; errors (surrogate_errors.csv):")
    print(describe(summary))


def compare_cmd(cfg: DictConfig) -> None:
    import pandas as pd

    from .surrogate.check import compare_sweep
    from .surrogate.model import load

    opts = options(cfg, "compare")
    if not opts.sweeps:
        raise ConfigError("sweeps=[] is empty: give sweeps=[outputs/sweeps/NAME,...]")
    model = load(opts.table)
    table = pd.concat([compare_sweep(Path(d), model).assign(sweep=d) for d in opts.sweeps], ignore_index=True)
    if table.empty:
        raise ConfigError(f"sweeps={opts.sweeps}: no finished job took its power from the DEM (dem=full) to compare "
                          "with: run the sweep without dem=surrogate first")
    Path(opts.out).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(opts.out, index=False)
    shown = table[["sweep", "job", "inside_hull", "dem_power_w", "surrogate_power_w", "power_error",
                   "collision_power_error"]]
    print(shown.to_markdown(index=False, floatfmt=".4g"))
    inside = table[table.inside_hull]
    print(f"{opts.out}: {len(table)} jobs, {len(inside)} inside the training hull; |power error| median "
          f"{100 * inside.power_error.abs().median():.1f} %, 90th percentile {100 * inside.power_error.abs().quantile(0.9):.1f} % "
          "inside the hull")


@dataclass(frozen=True)
class Command:
    summary: str
    main: Callable[[DictConfig], None] | None  # None: `run`, handed to Hydra's launcher
    groups: tuple[tuple[str, type], ...] = ()  # config groups it reads, listed by --help


RUN_GROUPS = (("sim", SimConfig), ("mill", DrumConfig), ("scaleup", ScaleupConfig), ("economics", EconomicsConfig),
              ("lab", MM400Config), ("study", StudyConfig), ("yield_model", YieldModelConfig),
              ("plant", PlantConfig), ("dem", DemConfig), ("optimiser", OptimiserConfig))
LAB_GROUPS = (("sim", SimConfig), ("lab", MM400Config))
COMMANDS = {
    "run": Command("one scenario, or a sweep (-m, or +sweep=NAME from conf/sweep/)", None, RUN_GROUPS),
    "report": Command("tables, figures and a Markdown report from sweep folders", report_cmd),
    "track": Command("ball positions and speeds from a video file or image folder", track_cmd),
    "render": Command("simulate the MM400 conditions and film them: videos + videos.csv", render_cmd, LAB_GROUPS),
    "calibrate": Command("fit the ball-wall restitution and friction to tracked videos", calibrate_cmd, LAB_GROUPS),
    "bench": Command("DEM throughput (particle-steps/s) on the reference drum", bench_cmd),
    "surrogate": Command("train the DEM surrogate on a space-filling design; its error table", surrogate_cmd,
                         RUN_GROUPS),
    "compare": Command("the surrogate against the DEM on finished sweeps (power, collision power)", compare_cmd),
}


def as_run(name: str) -> DictConfig:
    """The command's config as it runs with no override: each group at its default preset."""
    from .scenario import compose

    return compose("config" if name == "run" else name, [])


def value_in(cfg: DictConfig, path: str, default):
    """A field's value in a composed config as plain data (the schema's default for a list's items)."""
    value = OmegaConf.select(cfg, path.split("[]")[0], default=default, throw_on_missing=False)
    if "[]" in path or (value is None and default == "???"):
        return default
    return OmegaConf.to_container(value) if OmegaConf.is_config(value) else value


def describe(schema, prefix: str, cfg: DictConfig) -> list[str]:
    """One line per field: name = its value as the command runs, allowed range or choices, and its note."""
    lines = []
    for path, f, default in walk(schema, prefix):
        value = value_in(cfg, path, default)
        shown = "(required)" if value == "???" else json.dumps(value)
        lines.append(f"  {path} = {shown}  {allowed(f.metadata)}  {f.metadata.get('doc', '')}".rstrip())
    return lines


def usage() -> str:
    width = max(map(len, COMMANDS))
    head = "usage: ballmill COMMAND [key=value ...] [--debug]   (COMMAND --help: its fields; ballmill --version)"
    return "\n".join([head, "", *(f"  {name:<{width}}  {c.summary}" for name, c in COMMANDS.items())])


def help_text(name: str) -> str:
    command = COMMANDS[name]
    cfg = as_run(name)
    lines = [f"usage: ballmill {name} [key=value ...]: {command.summary}", "",
             "Each field = its value as the command runs with no override (each group at its default preset)."]
    if name in SCHEMAS:
        lines += [f"{SCHEMAS[name].__doc__.strip()}", "", "Options:", *describe(SCHEMAS[name], "", cfg), ""]
    for group, schema in command.groups:
        lines += [f"{group}.*: {schema.__doc__.strip().splitlines()[0]}",
                  *describe(schema, f"{group}.", cfg), ""]
    if command.groups:
        lines += ["materials.NAME.* and interactions.A-B.* as in conf/material/ and conf/interactions/.", ""]
    if name == "run":
        sweeps = sorted(p.stem for p in (CONF_DIR / "sweep").glob("*.yaml"))
        lines += [f"Sweeps (+sweep=NAME): {', '.join(sweeps)}",
                  ("Hydra's flags (-m, --cfg job, --hydra-help, ...) pass through; add your own config folder "
                  "with hydra.searchpath=[file:///path/to/conf].")]
    return "\n".join(lines)


def compose_command(name: str, overrides: list[str]) -> DictConfig:
    from .scenario import compose

    for arg in overrides:
        if "=" not in arg:
            example = {"report": "sweeps=[{}]", "track": "video={}", "calibrate": "videos={}"}.get(name, "key={}")
            raise ConfigError(f"{arg!r} is not key=value: options are Hydra overrides, e.g. {example.format(arg)}")
    return compose(name, [one_value(arg) for arg in overrides])


def one_value(override: str) -> str:
    """key=a,b as the one string 'a,b': a command other than `run` sweeps nothing, so Hydra's
    reading of the comma (a sweep over a and b) cannot be meant; lists are written [a,b]."""
    key, value = override.split("=", 1)
    if "," in value and value[0] not in "[{'\"" and "${" not in value:
        quoted = value.replace("'", "\\'")
        return f"{key}='{quoted}'"
    return override


def run_command(args: list[str]) -> None:
    """Check every job of the run or sweep (no simulation), then hand the lot to Hydra's launcher."""
    from . import run as run_module
    from .config import register
    from .jobs import check_jobs, records_since

    register()  # the schemas Hydra composes with, also when no check runs (--cfg, --info)
    overrides, flags, i = [], [], 0
    while i < len(args):
        if args[i] in HYDRA_VALUE_FLAGS and i + 1 < len(args):
            flags += args[i:i + 2]
            i += 2
            continue
        (flags if args[i].startswith("-") else overrides).append(args[i])
        i += 1
    inspecting = any(f in flags for f in ("--cfg", "-c", "--info", "-i", "--hydra-help", "--resolve"))
    sweep_dir = None if inspecting else check_jobs(overrides, multirun="-m" in flags or "--multirun" in flags)
    started, first = time.time(), len(run_module.JOBS)
    saved, sys.argv = sys.argv, ["ballmill run", *args]
    try:
        run_module.main()
    finally:
        sys.argv = saved
    jobs = records_since(sweep_dir, started) if sweep_dir else run_module.JOBS[first:]
    if not sweep_dir:
        for folder, record in jobs:
            if record["status"] == "ok" and ("dem_power_w" in record or "fit_candidate" in record):
                print(result_line(folder, record))
    unsteady = [folder for folder, record in jobs if record.get("dem_steady") is False]
    if len(unsteady) == 1:
        print(f"warning: {unsteady[0]}: the power is not the steady one: "
              f"{dict(jobs)[unsteady[0]]['dem_unsteady_reason']} (sim=steady, the default, averages a revolution after "
              "one)", file=sys.stderr)
    elif unsteady:
        print(f"warning: {len(unsteady)} jobs' power is not the steady one (dem_unsteady_reason in their records): "
              f"{', '.join(map(str, unsteady))}", file=sys.stderr)
    failed = [folder for folder, record in jobs if record["status"] != "ok"]
    if failed:
        raise JobsFailed(f"{len(failed)} job(s) failed (see their FAILED.json): {', '.join(map(str, failed))}")


def result_line(folder: Path, record: dict) -> str:
    """A finished run's headline numbers in one line: the mill's power (and where it comes from)
    or the kinetics fit's choice, and what the study made of it."""
    source = {"full": "DEM", "surrogate": "surrogate"}.get(record.get("dem_source"), "DEM")
    parts = [f"power {record['dem_power_w'] / 1e3:.4g} +- {record['dem_power_se_w'] / 1e3:.2g} kW ({source})"
             ] if "dem_power_w" in record else []
    for key, text in (("fit_candidate", "fit {}"), ("fit_a_percent", "intercept {:.4g} %"),
                      ("fit_cv_rmse_percent", "cross-validated error {:.2g} %"),
                      ("residence_time_min", "residence time {:.3g} min"), ("yield_percent", "yield {:.3g} %"),
                      ("electricity_usd_per_t_pet", "electricity {:.3g} $/t PET"),
                      ("purchase_cost_usd", "purchase cost {:,.0f} $"), ("msp_usd_per_kg", "MSP {:.3g} $/kg rTPA"),
                      ("gwp_total_kg_per_kg", "footprint {:.3g} kg CO2e/kg rTPA")):
        if isinstance(record.get(key), (int, float, str)):
            parts.append(text.format(record[key]))
    return f"{folder}: {', '.join(parts)}"


def main(argv: list[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv or os.environ.get("BALLMILL_DEBUG", "") not in ("", "0")
    argv = [a for a in argv if a != "--debug"]
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(usage())
        return
    if argv[0] in ("-V", "--version"):
        print(f"ballmill {__version__}")
        return
    name, args = argv[0], argv[1:]
    if name not in COMMANDS:
        fail(f"unknown command {name!r}; one of {', '.join(COMMANDS)}", 2)
    if any(a in ("-h", "--help") for a in args):
        print(help_text(name))
        return
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")  # libraries: warnings
    log.setLevel(logging.INFO)
    try:
        if name == "run":
            run_command(args)
        else:
            COMMANDS[name].main(compose_command(name, args))
    except USER_ERRORS as exc:
        if debug:
            traceback.print_exc()
        fail(str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__, 2)
    except JobsFailed as exc:
        fail(str(exc), 1)


def fail(message: str, status: int) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(status)
