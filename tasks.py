"""Two commands for a fresh machine with python3 and pip: `python3 tasks.py reproduce|test`.

Each creates .venv (once), installs the package with what it needs, then runs.
"""

import json
import os
import queue
import subprocess
import sys
import venv
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")


def sh(*cmd: str) -> None:
    """Run cmd in the project root."""
    print(f"+ {' '.join(cmd)}", flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)


def install(extras: str) -> None:
    """The package, editable, with the given extras ("" or e.g. "[dev]"), into .venv."""
    if not (BIN / "python").exists():
        venv.create(VENV, with_pip=True)
    sh(str(BIN / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check", "-e", f".{extras}")


# A stream's process: `ballmill ARGS` for each JSON list of ARGS on its input, then DONE and the exit status.
DONE = "\x00ballmill exited "
RUNNER = f"""
import json, sys, traceback
from ballmill.cli import main
for line in sys.stdin:
    try:
        main(json.loads(line))
        status = 0
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except Exception:
        traceback.print_exc()
        status = 1
    print({DONE!r} + str(status), flush=True)
"""


class Runner:
    """One process that runs the ballmill commands it is given one after another, each line of
    their output printed behind its unit's tag: ballmill, BioSTEAM and Taichi are imported once
    per stream instead of once per command (2-9 s each)."""

    def __init__(self, env: dict):
        self.proc = subprocess.Popen([str(BIN / "python"), "-u", "-c", RUNNER], cwd=ROOT, env=env, text=True,
                                     bufsize=1, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)

    def __call__(self, tag: str, *args: str) -> None:
        print(f"[{tag}] + ballmill {' '.join(args)}", flush=True)
        self.proc.stdin.write(json.dumps(args) + "\n")
        self.proc.stdin.flush()
        status = None
        for line in self.proc.stdout:
            head, done, tail = line.partition(DONE)
            if head.strip():
                print(f"[{tag}] {head.rstrip()}", flush=True)
            if done:
                status = int(tail)
                break
        if status != 0:  # None: the process died
            raise subprocess.CalledProcessError(-1 if status is None else status, ["ballmill", *args])

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


Unit = tuple[str, Callable[[Callable[..., None]], None]]  # a name, and a function of a `ballmill(*args)` runner


def in_two_streams(units: list[Unit], last: Unit | None = None, start: Callable[[dict], Runner] = Runner) -> None:
    """Run the units two at a time, in list order, each on one core, then `last` in one of the
    two streams: each stream one ballmill process (`start(env)`, Runner) running its units'
    commands one after another, each sweep's jobs one after another (Hydra's basic launcher;
    every sweep file sets sim.threads=1), with
    BALLMILL_LOCAL_JOBS=2 so that a command left to pick its threads (render, calibrate) takes one.
    Two one-core streams keep both cores busy where one two-job sweep at a time would leave one
    idle while its last job runs and while the next sweep starts.  After a failure no further unit
    starts."""
    env = {**os.environ, "BALLMILL_LOCAL_JOBS": "2"}
    failed: list[str] = []
    idle, started = queue.SimpleQueue(), []

    def run(name, unit):
        if failed:
            return
        try:
            runner = idle.get_nowait()
        except queue.Empty:
            runner = start(env)
            started.append(runner)
        try:
            unit(lambda *args: runner(name, *args))
        except subprocess.CalledProcessError as exc:
            failed.append(f"{name}: {' '.join(map(str, exc.cmd))} exited with {exc.returncode}")
        finally:
            idle.put(runner)

    pool = ThreadPoolExecutor(max_workers=2)
    try:
        for future in [pool.submit(run, name, unit) for name, unit in units]:
            future.result()
        if last is not None:
            run(*last)
    except KeyboardInterrupt:
        failed.append("interrupted")
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        for runner in started:
            runner.close()
    if failed:
        sys.exit("reproduce stopped (finished results are kept; run it again to resume): " + "; ".join(failed))


def reproduce() -> None:
    """The paper's results into outputs/report: Figures 3b and 4 at full stiffness, the whole
    plant around them (MSP against BPR and per state), the shape-rule and stiffness studies,
    and the lab chain (film -> track -> calibrate -> Figure 3a)."""
    sim = os.environ.get("BALLMILL_SIM", "paper")

    def sweep(name: str, *overrides: str):
        return name, lambda ballmill: ballmill("run", f"+sweep={name}", "hydra/launcher=basic", *overrides)

    def lab_chain(ballmill) -> None:
        # No real videos ship with the project: film a simulation whose ball-wall pair the
        # calibration is not told, as the proof of the method, then validate at the calibrated pair
        # (the MM400 geometry study needs none of it: a unit of its own).
        videos, cal = "outputs/lab/videos", "outputs/lab/calibration"
        ballmill("render", f"out={videos}", "wall_restitution=0.6", "wall_friction=0.3", "lab.duration_s=1.5",
                 "sim.seed=7")
        ballmill("calibrate", f"videos={videos}", f"out={cal}", "lab.duration_s=1.5")
        best = json.loads((ROOT / cal / "best.json").read_text())
        ballmill("run", "+sweep=lab_validation", "hydra/launcher=basic",
                 f"interactions.steel-pmma.restitution={best['wall_restitution']}",
                 f"interactions.steel-pmma.static_friction={best['wall_friction']}",
                 f"study.observations={cal}/observations.csv")

    names = ("fig3b", "fig4", "shape_rule", "plant", "plant_states", "regional", "stiffness", "lab_validation",
             "mm400_geometry")
    report = "report", lambda ballmill: ballmill("report", f"sweeps=[{','.join(f'outputs/sweeps/{n}' for n in names)}]")
    # Largest first (one-core seconds in a reproduce run, each command's start included: plant per
    # state ~400 with its options' fronts, Figure 4 ~230, BPR plant ~190, lab chain ~145, shape rule
    # ~130, Figure 3b ~50, stiffness ~30, MM400 geometry ~25, regional plant ~15), so that the two streams
    # end together.  The paper's mills at steel stiffness (sim=paper); the plants' recycle mills at the
    # default preset, whose power is within 2 % of steel's: it moves their MSP by under 0.01 %.
    in_two_streams([sweep("plant_states"), sweep("fig4", f"sim={sim}"), sweep("plant"),
                    ("lab", lab_chain), sweep("shape_rule", f"sim={sim}"), sweep("fig3b", f"sim={sim}"),
                    sweep("stiffness"), sweep("mm400_geometry"), sweep("regional")], last=report)


def test() -> None:
    """The suite, one worker per core (pytest-xdist), each test file whole on one worker so that
    its module fixtures are built once, the files handed out in collection order (the longest
    first: tests/conftest.py)."""
    sh(str(BIN / "python"), "-m", "pytest", "-q", "-ra", "--durations=15", "-n", "auto", "--dist", "loadfile",
       "--no-loadscope-reorder", *sys.argv[2:])


if __name__ == "__main__":
    # each task and the extras it installs (reproduce needs neither the test tools nor the
    # cluster launchers: half the install time on a fresh machine, 32 s instead of 62 s here)
    tasks = {"reproduce": (reproduce, ""), "test": (test, "[dev]")}
    if len(sys.argv) < 2 or sys.argv[1] not in tasks:
        sys.exit(f"usage: python3 tasks.py {{{'|'.join(tasks)}}}")
    task, extras = tasks[sys.argv[1]]
    install(extras)
    task()
