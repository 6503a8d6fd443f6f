"""Two commands for a fresh machine with python3 and pip: `python3 tasks.py reproduce|test`.

Each creates .venv (once), installs the package with what it needs, then runs.
"""

import json
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")


def sh(*cmd: str) -> None:
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)


def install() -> None:
    if not (BIN / "python").exists():
        venv.create(VENV, with_pip=True)
    sh(str(BIN / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check", "-e", ".[dev]")


def reproduce() -> None:
    """The paper's results into outputs/report: Figures 3b and 4 at full stiffness, the whole
    plant around them (MSP against BPR and per state), the shape-rule and stiffness studies,
    and the lab chain (film -> track -> calibrate -> Figure 3a)."""
    ballmill = str(BIN / "ballmill")
    sim = os.environ.get("BALLMILL_SIM", "paper")
    for sweep in ("fig3b", "fig4", "shape_rule", "plant", "plant_states"):
        sh(ballmill, "run", f"+sweep={sweep}", f"sim={sim}")
    sh(ballmill, "run", "+sweep=stiffness")
    # No real videos ship with the project: film a simulation whose ball-wall pair the
    # calibration is not told, as the proof of the method, then validate at the calibrated pair.
    videos, cal = "outputs/lab/videos", "outputs/lab/calibration"
    sh(ballmill, "render", f"out={videos}", "wall_restitution=0.6", "wall_friction=0.3", "lab.duration_s=1.5",
       "sim.seed=7")
    sh(ballmill, "calibrate", f"videos={videos}", f"out={cal}", "lab.duration_s=1.5")
    best = json.loads((ROOT / cal / "best.json").read_text())
    sh(ballmill, "run", "+sweep=lab_validation", f"interactions.steel-pmma.restitution={best['wall_restitution']}",
       f"interactions.steel-pmma.static_friction={best['wall_friction']}", f"study.observations={cal}/observations.csv")
    sh(ballmill, "run", "+sweep=mm400_geometry")
    names = ("fig3b", "fig4", "shape_rule", "plant", "plant_states", "stiffness", "lab_validation", "mm400_geometry")
    sh(ballmill, "report", f"sweeps=[{','.join(f'outputs/sweeps/{name}' for name in names)}]")


def test() -> None:
    sh(str(BIN / "python"), "-m", "pytest", "-q", "-ra", "--durations=15", *sys.argv[2:])


if __name__ == "__main__":
    tasks = {"reproduce": reproduce, "test": test}
    if len(sys.argv) < 2 or sys.argv[1] not in tasks:
        sys.exit(f"usage: python3 tasks.py {{{'|'.join(tasks)}}}")
    install()
    tasks[sys.argv[1]]()
