"""A sweep gives the same records whichever Hydra launcher runs its jobs: joblib (the default of
the sweep files), submitit's local executor (what `hydra/launcher=slurm` runs on a cluster) and
Ray (a local instance started by the launcher, as `hydra/launcher=ray_jobs` would join a cluster)."""

import json
import os
import subprocess
import sys

import pytest

SWEEP = ["-m", "scaleup.bpr=19,20", "sim=test", "sim.threads=1", "sim.settle_s=0.05", "sim.duration_s=0.15",
         "sim.steady_after_s=0.05"]
SAME = ["pet_feed_kg_per_h", "diameter_m", "ball_count", "dem_power_w", "dem_collisions_per_s",
        "electricity_usd_per_t_pet", "purchase_cost_usd"]


def sweep(tmp_path, name, *launcher):
    # Ray starts its workers at nice 15: beside the suite's other worker its two jobs starved
    # (138 s instead of 21 s alone); at 0 they share the cores as joblib's do
    proc = subprocess.run([sys.executable, "-m", "ballmill", "run", *SWEEP, *launcher,
                           f"hydra.sweep.dir={tmp_path / name}", f"cache_dir={tmp_path / name / 'cache'}"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600, check=False,
                          env={**os.environ, "RAY_worker_niceness": "0"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    records = {}
    for path in sorted((tmp_path / name).glob("*/record.json")):
        rec = json.loads(path.read_text())
        assert rec["status"] == "ok"
        records[rec["bpr"]] = {k: rec[k] for k in SAME}
    assert sorted(records) == [19.0, 20.0]
    return records


@pytest.fixture(scope="module")
def by_joblib(tmp_path_factory):
    return sweep(tmp_path_factory.mktemp("joblib"), "joblib", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2")


@pytest.mark.parametrize("launcher", [["hydra/launcher=slurm_local"],
                                      ["hydra/launcher=ray_jobs", "hydra.launcher.ray.init.num_cpus=2",
                                       "+hydra.launcher.ray.init.include_dashboard=false"]],
                         ids=["submitit_local", "ray_local"])
def test_a_launcher_gives_the_records_of_joblib(by_joblib, tmp_path, launcher):
    assert sweep(tmp_path, launcher[0].split("=")[1], *launcher) == by_joblib  # identical bits


def test_a_slurm_sweep_of_gpu_jobs_is_checked_here_but_not_against_this_machine():
    """The submitting machine (a login node) has no GPU: a CUDA job for SLURM is still accepted,
    the job size comes from sim.threads, and a job of 'all cores' cannot be sized."""
    from ballmill.config import ConfigError
    from ballmill.jobs import check_jobs
    from ballmill.scenario import compose

    gpu = ["+sweep=fig4", "sim=paper", "sim.arch=cuda", "sim.threads=1", "hydra/launcher=slurm",
           "hydra.launcher.gpus_per_task=1", "hydra.launcher.partition=gpu"]
    assert check_jobs(gpu, multirun=True).name == "fig4"
    launcher = compose("config", gpu, hydra=True).hydra.launcher
    assert launcher.cpus_per_task == 1 and launcher.gpus_per_task == 1 and "Slurm" in launcher._target_
    with pytest.raises(ConfigError, match="sim.threads=0 .* cannot size a submitit job"):
        check_jobs([*gpu, "sim.threads=0"], multirun=True)
