"""Every command the README and the docs show (the tutorials are run as written by test_docs),
run on small inputs, so that a field added in one place cannot break a command elsewhere
unseen.  The pages fall in two groups, run side by side, each in a folder of its own with its
pages' commands in order (a command shown twice runs once: its outputs are there for the
commands after it).  "Small" is the test preset (sim=test) with a shorter window, short
lab runs, small drums, a few Monte Carlo draws, and a sweep cut to one or two of its jobs; a
user's own file (a price table, an STL, a video) is stood in for by one made here.  A command
that needs what this machine lacks (a cluster, a GPU, the peer programs) or hours is not run
but still checked as `ballmill` checks it before running anything (composed, range-checked,
every job planned).  The cookbook's figures are checked against what its commands print."""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
import yaml

from ballmill.cli import compose_command, options
from ballmill.dem.runtime import LOCAL_JOBS_ENV
from ballmill.jobs import check_jobs
from ballmill.studies import mechanics
from ballmill.vision.frames import write_frames

ROOT = Path(__file__).resolve().parents[1]
# the tutorials run in test_docs as written
DOCS = [ROOT / "README.md", *sorted(p for p in (ROOT / "docs").rglob("*.md") if p.parent.name != "tutorials")]

# Shown, not run here, and why (checked as ballmill checks them before running).
NOT_RUN = {
    "python3 tasks.py reproduce": "the paper's whole results (10 min): each of its sweeps is a command below",
    "python3 tasks.py test": "this suite",
    "ballmill bench peer=both rounds=3": "LIGGGHTS and LAMMPS (test_peer_torque runs LIGGGHTS where installed)",
    "ballmill run +sweep=fig4 sim=paper sim.arch=cuda sim.threads=1 hydra/launcher=slurm": "a SLURM cluster with GPUs",
    "ballmill report sweeps=[/shared/ballmill/fig4]": "the cluster sweep's folder",
    "ballmill run +sweep=fig3b sim=paper sim.threads=2 hydra/launcher=slurm": "a SLURM cluster",
    "ballmill run sim.arch=cuda": "a GPU",
}
# The cookbook's figures are full-size runs' (docs/numbers.yaml, `printed`): its designs and plants
# run small with the DEM's surrogate, which agrees with the DEM within its measured error, so that
# the small run prints the figure the full one did.
SURROGATE_PAGES = ("cookbook.md",)

# What makes a command small: overrides put in place of the command's own for the same key (the
# window in seconds, not revolutions; a plant's break-even searched for one lever; the lab
# calibration of the energy rules keeps its length: its dose line sets their mills' size).
LAB = ["lab.duration_s=0.3", "lab.settle_s=0.1", "lab.frequencies_hz=[25.0]", "lab.ball_diameters_m=[0.0176]"]
RUN = ["sim=test", "sim.threads=1", "sim.shear_modulus_scale=0.01", "sim.settle_s=0.1", "sim.steady_after_s=0.1",
       "sim.duration_s=0.3", "sim.startup_revolutions=null", "sim.window_revolutions=null", "plant.monte_carlo_draws=10",
       "plant.what_it_takes=[price.naoh]", "optimiser.trials=30", "yield_model.lab.frequencies_hz=[30.0]",
       "yield_model.lab.ball_diameters_m=[0.0206]", "yield_model.lab.jar_inner_diameters_m=[0.028]",
       "yield_model.lab.jar_inner_lengths_m=[0.05]", "yield_model.lab.starts=2", *LAB]
SWEEP_JOBS = {"fig3b": ["scaleup.bpr=19,22.9"], "fig4": ["scaleup.region=DC,DE"], "plant": ["scaleup.bpr=19"],
              "plant_states": ["scaleup.region=DC"], "cheapest_mill_states": ["scaleup.region=DC", "optimiser.confirm=false"],
              "scaleup_rule": ["scaleup.bpr=19", "yield_model=bpr_line,specific_energy"],
              "bond_mill": ["interactions.liner-steel.restitution=0.5", "interactions.liner-steel.static_friction=0.5"],
              "lab_validation": ["sim.threads=1", *LAB], "cheapest_mill": ["optimiser.confirm=false"],
              "yield_fit": ["yield_model.rtd.kind=tanks_in_series"]}
OTHERS = {"render": LAB, "calibrate": [*LAB, "restitutions=[0.6]", "frictions=[0.3]"],
          "surrogate": ["points=8", "holdout=0", "folds=8", "jobs=1", "sim.settle_s=0.1", "bounds.diameter_to_ball=[5.0,6.0]",
                        "bounds.fraction_of_critical=[0.8,0.9]", "bounds.fill_fraction=[0.2,0.25]",
                        "bounds.length_to_diameter=[0.75,1.0]"]}


def shown(page: Path) -> list[str]:
    """The command lines of the page's code blocks that run ballmill or tasks.py, comments dropped."""
    blocks = re.findall(r"^```[a-z]*\n(.*?)^```", page.read_text(), re.MULTILINE | re.DOTALL)
    lines = [line for block in blocks for line in block.replace("\\\n", " ").splitlines()]
    return [" ".join(shlex.split(line, comments=True)).replace(".venv/bin/ballmill", "ballmill")
            for line in lines if re.search(r"\bballmill |tasks\.py ", line)]


def key(override: str) -> str:
    return override.lstrip("+").split("=", 1)[0]


def small(args: list[str], cache: Path, stand_ins: dict[str, str], surrogate: bool = False) -> list[str]:
    """The command's arguments on small inputs, with this test's stand-ins for a user's files (a
    design's or a plant's power from the surrogate where `surrogate`)."""
    args = [re.sub("|".join(map(re.escape, stand_ins)), lambda m: stand_ins[m[0]], a) if stand_ins else a
            for a in args]
    command, rest = args[0], args[1:]
    if command == "run":
        sweep = next((a.split("=", 1)[1] for a in rest if a.startswith("+sweep=")), None)
        extra = SWEEP_JOBS[sweep] if sweep == "lab_validation" else [*RUN, *SWEEP_JOBS.get(sweep, [])]
        if surrogate and single_design_or_plant(rest) and not any(key(a) == "dem" for a in rest):
            extra = [*extra, "dem=surrogate"]
        if "study=drum" in rest:  # the reference drum's 8,640 balls of 10 mm: 40 of 60 mm
            extra = [*extra, "mill.ball_radius_m=0.03"]
        if sweep is not None:  # its jobs one after another in this process, as the reproduce runs them: no
            extra = [*extra, "hydra/launcher=basic"]  # worker to start and import (test_launchers runs the others)
        # jobs' folders by number: these overrides would name them past the file system's limit
        extra = [*extra, f"cache_dir={cache}", "hydra.sweep.subdir=${hydra.job.num}"]
    elif command in ("surrogate", "render", "calibrate"):
        extra = [*OTHERS[command], *([f"cache_dir={cache}"] if command == "surrogate" else [])]
    else:
        extra = []
    replaced = {key(e) for e in extra}
    return [command, *[a for a in rest if key(a) not in replaced], *extra]


@pytest.fixture(scope="module")
def stand_ins(tmp_path_factory) -> dict[str, str]:
    """A user's own files the docs name: a price table, kinetics experiments, a closed STL vessel, a
    video of two balls."""
    d = tmp_path_factory.mktemp("own_files")
    shutil.copy(ROOT / "src/ballmill/data/prices.csv", d / "prices_2025.csv")
    shutil.copy(ROOT / "src/ballmill/data/yield_experiments.csv", d / "my_experiments.csv")
    trimesh.creation.cylinder(radius=0.2, height=0.2, sections=64).apply_transform(
        trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])).export(d / "vessel.stl")
    frames = []
    for k in range(20):  # two dark 17.6 mm balls (176 px at 0.1 mm/px) crossing a bright frame
        frame = np.full((400, 900), 220, np.uint8)
        for x0 in (150, 600):
            cv2.circle(frame, (x0 + 3 * k, 200), 88, 40, -1, lineType=cv2.LINE_AA)
        frames.append(frame)
    write_frames(frames, d / "run1.avi", 2134.0, 0.1)
    return {"/home/me/prices_2025.csv": str(d / "prices_2025.csv"),
            "/home/me/my_experiments.csv": str(d / "my_experiments.csv"), "/path/vessel.stl": str(d / "vessel.stl"),
            "run1.avi": str(d / "run1.avi")}


PAGES = [page for page in DOCS if shown(page)]
GROUPS = {"the user's guide": ("README.md", "getting-started.md", "own-mill.md", "cluster.md", "cookbook.md"),
          "studies": ("own-data.md", "plant.md", "surrogate.md", "yield-rules.md")}


def test_the_pages_show_the_commands_listed_as_not_run_here():
    every = {line for page in PAGES for line in shown(page)}
    for line in NOT_RUN:
        assert any(shown_line.startswith(line) for shown_line in every), f"no page shows {line!r} any more"


def test_the_commands_not_run_here_are_checked_as_ballmill_checks_them(monkeypatch):
    """As on a machine with a GPU (this one may have none)."""
    monkeypatch.setattr(mechanics, "cuda_available", lambda: True)
    for line in {line for page in PAGES for line in shown(page) if line.startswith(tuple(NOT_RUN))}:
        args = shlex.split(line)
        if args[0] != "ballmill":
            continue
        if args[1] == "run":
            check_jobs([a for a in args[2:] if a != "-m"], multirun="-m" in args)
        else:
            options(compose_command(args[1], args[2:]), args[1])


# Runs the commands in order in one process, each as `ballmill ARGS` would: its exit status and time.
DRIVER = """
import json, sys, time, traceback
from ballmill.cli import main
for args in json.loads(sys.argv[1]):
    print("=== ballmill", " ".join(args), flush=True)
    started = time.perf_counter()
    try:
        main(args)
        status = 0
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except Exception:  # a traceback, as the command would end: the next command runs all the same
        traceback.print_exc()
        status = 1
    print(f"=== exit {status} after {time.perf_counter() - started:.1f} s", flush=True)
"""


# What each command prints as it ends (cli.py), looked for in its output: a design's or a plant's
# single run its power (a sweep prints no headline of its own: test_sweeps reads its records),
# a report the path of each page it wrote, whose title counts no failed run.
HEADLINES = {
    "--help": r"^  run +one scenario",
    "run": r"^\S+: power [0-9.e+]+ \+- [0-9.e+]+ kW \((DEM|surrogate)\)",  # 4 and 2 figures: 1.1e+02
    "report": r"^\S+\.md$",
    "track": r"^\S+: 20 frames, frames with a ball lost \{[^}]*\}, mean speed [0-9.]+ m/s",
    "render": r"^\S+: \d+ videos, manifest videos\.csv$",
    "calibrate": r'^  "wall_restitution": 0\.6,$',
    "surrogate": r"^\S+: 8 runs, 0 failed; errors",
    "compare": r"^\S+: \d+ jobs, \d+ inside the training hull; \|power error\| median [0-9.]+ %",
}


def single_design_or_plant(args: list[str]) -> bool:
    """Whether `ballmill run ARGS` is one design or one plant."""
    study = next((a.split("=", 1)[1] for a in args if a.startswith("study=")), "design")
    return "-m" not in args and not any(a.startswith("+sweep=") for a in args) and study in ("design", "plant")


def headline_missing(args: list[str], output: str, folder: Path) -> str | None:
    """What the command's output lacks of its headline, or None."""
    if args[0] == "run" and not single_design_or_plant(args[1:]):
        return None
    found = re.findall(HEADLINES[args[0]], output, re.MULTILINE)
    if not found:
        return f"no line matching {HEADLINES[args[0]]!r}"
    if args[0] == "report":
        pages = re.findall(r"^(\S+\.md)$", output, re.MULTILINE)
        bad = [page for page in pages if ", 0 failed runs" not in (folder / page).read_text().splitlines()[0]]
        return f"pages with failed runs: {bad}" if bad else None
    return None


def test_the_groups_hold_every_page_with_a_command():
    assert sorted(name for names in GROUPS.values() for name in names) == sorted(p.name for p in PAGES)


def figure(text: str) -> float:
    """The first number of a figure as written (1,234.5 +- 6: 1234.5)."""
    return float(re.search(r"-?[0-9][0-9,]*(\.[0-9]+)?(e[+-]?[0-9]+)?", text)[0].replace(",", ""))


def figures_off(printed: dict[str, str]) -> list[str]:
    """Each figure of docs/numbers.yaml that names the command printing it (`printed`: by, as,
    within) against what that command printed, where it is not within `within` of it."""
    off = []
    for name, entry in yaml.safe_load((ROOT / "docs/numbers.yaml").read_text()).items():
        if "printed" in entry:
            by, label, within = entry["printed"]["by"], entry["printed"]["as"], entry["printed"]["within"]
            found = re.search(rf"\b{re.escape(label)} (-?[0-9][0-9,.]*)", printed.get(by, ""))
            if not found or abs(figure(found[1]) / figure(str(entry["value"])) - 1) > figure(within) / 100:
                off.append(f"{name}: {by} printed {found[0] if found else 'no ' + label}; the full run "
                           f"{entry['value']} (within {within})")
    return off


def test_every_command_shown_runs_on_small_inputs(stand_ins, tmp_path):
    """Each group's commands in one process, the two groups side by side; the DEM cache shared; a
    command shown on several pages run once; each command's headline in what it printed
    (HEADLINES) and the cookbook's figures in it (figures_off)."""
    drivers, ran = {}, {}  # a line shown: its group and its small arguments
    pages = sorted(((group, name) for group, names in GROUPS.items() for name in names),
                   key=lambda page: page[1] in SURROGATE_PAGES)  # the cookbook's last: another page's runs as it is
    for group, name in pages:
        for line in (line for page in PAGES if page.name == name for line in shown(page)
                     if not line.startswith(tuple(NOT_RUN)) and line not in ran):
            ran[line] = group, small(shlex.split(line)[1:], tmp_path / "cache", stand_ins, name in SURROGATE_PAGES)
    env = {**os.environ, LOCAL_JOBS_ENV: str(len(GROUPS))}  # a command that picks its threads takes its group's share
    for group in GROUPS:
        commands = [args for g, args in ran.values() if g == group]
        folder = tmp_path / group.replace(" ", "_").replace("'", "")
        folder.mkdir()
        drivers[group] = (commands, folder, subprocess.Popen([sys.executable, "-c", DRIVER, json.dumps(commands)],
                                                             cwd=folder, stdout=subprocess.PIPE, env=env,
                                                             stderr=subprocess.STDOUT, text=True))
    failed, outputs = [], {}
    for group, (commands, folder, proc) in drivers.items():
        log = proc.communicate(timeout=1500)[0]
        statuses = re.findall(r"^=== exit (\d+) after ([0-9.]+) s", log, re.MULTILINE)
        parts = re.split(r"^=== ballmill ", log, flags=re.MULTILINE)[1:]
        print(group, [f"{' '.join(c[:3])} {t} s" for c, (_, t) in zip(commands, statuses)])
        outputs |= {tuple(c): part for c, part in zip(commands, parts)}
        failed += [f"{group}: ballmill {part[-2500:]}" for part, (status, _) in zip(parts, statuses) if status != "0"]
        failed += [f"{group}: ballmill {' '.join(c)}: {missing}\n{part[-1500:]}"
                   for c, part, (status, _) in zip(commands, parts, statuses)
                   if status == "0" and (missing := headline_missing(c, part, folder))]
        if len(statuses) != len(commands):
            failed.append(f"{group}: {len(statuses)} of {len(commands)} commands ended\n{log[-5000:]}")
    failed += figures_off({line: outputs[tuple(args)] for line, (_, args) in ran.items() if tuple(args) in outputs})
    assert not failed, "\n\n".join(failed)
