"""Two commands for a fresh machine with python3 and pip: `python3 tasks.py reproduce|test`.

Each creates .venv (once), installs the package with what it needs, then runs.
"""

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
    """The paper's results: Figure 3b and Figure 4 sweeps at full fidelity, then the report."""
    sim = os.environ.get("BALLMILL_SIM", "paper")
    for sweep in ("fig3b", "fig4"):
        sh(str(BIN / "ballmill"), "run", f"+sweep={sweep}", f"sim={sim}")
    sh(str(BIN / "ballmill"), "report", "outputs/sweeps/fig3b", "outputs/sweeps/fig4")


def test() -> None:
    sh(str(BIN / "python"), "-m", "pytest", "-q", "-ra", "--durations=15", *sys.argv[2:])


if __name__ == "__main__":
    tasks = {"reproduce": reproduce, "test": test}
    if len(sys.argv) < 2 or sys.argv[1] not in tasks:
        sys.exit(f"usage: python3 tasks.py {{{'|'.join(tasks)}}}")
    install()
    tasks[sys.argv[1]]()
