"""The package as a user installs it: a wheel (no source tree) holds every config and data file,
and in a fresh virtual environment composes and checks every sweep with every launcher, runs a
small design sweep and reports it from a folder outside the checkout."""

import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


# In the installed package: every sweep file, its jobs checked (composed, range-checked, planned) as
# `ballmill run +sweep=NAME` does before launching them, and every launcher composed with a sweep.
COMPOSE_EVERY_SWEEP_AND_LAUNCHER = """
from ballmill.config import CONF_DIR
from ballmill.jobs import check_jobs
from ballmill.scenario import compose
for path in sorted((CONF_DIR / "sweep").glob("*.yaml")):
    check_jobs([f"+sweep={path.stem}", "sim.threads=1"], multirun=True)
    print("checked", path.stem)
for path in sorted((CONF_DIR / "hydra" / "launcher").glob("*.yaml")):
    launcher = compose("config", ["+sweep=stiffness", f"hydra/launcher={path.stem}", "sim.threads=1"], hydra=True)
    assert launcher.hydra.launcher._target_, path
    print("checked", path.stem)
"""


def sh(*cmd, cwd):
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc.stdout


def test_a_wheel_installed_in_a_fresh_venv_runs_a_sweep_and_its_report(tmp_path):
    sh(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "dist"),
       str(ROOT), cwd=tmp_path)
    wheel = next((tmp_path / "dist").glob("ballmill-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    package = ROOT / "src" / "ballmill"
    tracked = sh("git", "ls-files", "conf", "data", cwd=package).split()
    assert len(tracked) > 60 and "conf/hydra/launcher/slurm.yaml" in tracked
    assert {f"ballmill/{name}" for name in tracked} | {"ballmill/py.typed"} <= names
    env = tmp_path / "env"
    venv.create(env, with_pip=True)
    python = env / "bin" / "python"
    sh(str(python), "-m", "pip", "install", "-q", "--no-deps", "--disable-pip-version-check", str(wheel), cwd=tmp_path)
    # the dependencies (not ballmill) from the test's own environment, after the new one's packages
    site = Path(sh(str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=tmp_path).strip())
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    where = sh(str(python), "-c", "import ballmill; print(ballmill.__file__)", cwd=tmp_path)
    assert where.startswith(str(env)), where
    out = sh(str(python), "-c", COMPOSE_EVERY_SWEEP_AND_LAUNCHER, cwd=tmp_path)
    checked = [line.split()[1] for line in out.splitlines() if line.startswith("checked ")]
    assert sorted(checked) == sorted(Path(n).stem for n in tracked
                                     if n.startswith(("conf/sweep/", "conf/hydra/launcher/")))
    sh(str(python), "-m", "ballmill", "run", "-m", "scaleup.bpr=19,20", "sim=test", "sim.settle_s=0.05",
       "sim.duration_s=0.1", "sim.steady_after_s=0.0", "hydra.sweep.dir=sweep", cwd=tmp_path)
    out = sh(str(python), "-m", "ballmill", "report", "sweeps=[sweep]", "out=report", cwd=tmp_path)
    assert "report/design.md" in out
    assert "2 finished, 0 failed" in (tmp_path / "report" / "design.md").read_text()
