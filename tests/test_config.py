"""Configs compose, sweeps compose, and bad values fail early with the field and the range."""

import os
from pathlib import Path

import pytest

from ballmill.config import CONF_DIR, ConfigError, DrumConfig, SimConfig, to_object
from ballmill.run import run
from ballmill.scenario import compose, load


def composed(overrides=()):
    return compose("config", list(overrides), hydra=True)


@pytest.mark.parametrize("sweep", sorted(p.stem for p in (CONF_DIR / "sweep").glob("*.yaml")))
def test_every_sweep_composes(sweep):
    cfg = composed([f"+sweep={sweep}"])
    assert cfg.hydra.mode.name == "MULTIRUN"
    assert cfg.hydra.sweeper.params
    assert cfg.study.name == sweep
    assert cfg.hydra.launcher.n_jobs == 2  # two joblib processes, one per core


@pytest.mark.parametrize(
    "override, message",
    [
        ("materials.steel.density_kg_per_m3=-1", r"materials.steel.density_kg_per_m3=-1.0 is outside .*\(0.0, inf\]"),
        ("interactions.steel-steel.restitution=1.5", r"interactions.steel-steel.restitution=1.5 is outside .*\(0.0, 1.0\]"),
        ("scaleup.fill_fraction=1.0", r"scaleup.fill_fraction=1.0 is outside .*\(0.0, 1.0\)"),
        ("sim.arch=gpu", r"sim.arch='gpu' is not one of \['cpu', 'cuda'\]"),
        ("mill.ball_material=unobtainium", r"unknown material 'unobtainium'"),
        ("scaleup.bpr=30", r"scaleup.bpr=30.0 is outside the yield fit's range"),
    ],
)
def test_bad_values_fail_before_any_simulation_naming_field_and_range(override, message, tmp_path):
    cfg = composed([override, f"cache_dir={tmp_path}"])
    with pytest.raises(ConfigError, match=message):
        run(cfg, tmp_path)
    assert not any(Path(tmp_path).glob("dem/*/loads.parquet"))


def test_unknown_keys_and_wrong_types_are_refused():
    with pytest.raises(ConfigError, match="sim"):
        to_object({"dt_fractoin": 0.1}, SimConfig, "sim")
    with pytest.raises(ConfigError, match="mill"):
        to_object({"inner_diameter_m": "wide"}, DrumConfig, "mill")


def test_all_cores_are_shared_among_the_jobs_a_sweep_runs_at_once_here(monkeypatch):
    from ballmill.dem.runtime import LOCAL_JOBS_ENV, cpu_threads

    cores = len(os.sched_getaffinity(0))
    assert cpu_threads(3) == 3
    monkeypatch.delenv(LOCAL_JOBS_ENV, raising=False)
    assert cpu_threads(0) == cores
    monkeypatch.setenv(LOCAL_JOBS_ENV, "2")
    assert cpu_threads(0) == max(1, cores // 2)


def test_a_kernel_that_does_not_compile_is_shown_at_its_line_with_the_fault_marked():
    """Taichi's excerpt of the faulty line, which the engine's start-up formats only for an error."""
    import taichi as ti

    from ballmill.dem.runtime import init_taichi

    init_taichi(threads=1)
    total = ti.field(float, ())

    @ti.kernel
    def broken():
        total[None] = undefined_name + 1.0  # noqa: F821

    with pytest.raises(ti.TaichiNameError) as raised:
        broken()
    line = next(k for k, text in enumerate(Path(__file__).read_text().splitlines(), 1) if "1.0  # noqa" in text)
    message = str(raised.value)
    assert f'File "{__file__}", line {line}, in broken:' in message, message
    assert "total[None] = undefined_name + 1.0" in message and "^^^^^^^^^^^^^^" in message, message


def test_a_sequential_sweep_gives_each_job_every_core_and_a_parallel_one_shares_them(monkeypatch):
    from ballmill.dem.runtime import LOCAL_JOBS_ENV
    from ballmill.jobs import check_jobs

    monkeypatch.delenv(LOCAL_JOBS_ENV, raising=False)
    sweep = ["study=drum", "mill.fraction_of_critical=0.3,0.5,0.7"]
    check_jobs(sweep, multirun=True)  # Hydra's basic launcher: one job after another
    assert os.environ[LOCAL_JOBS_ENV] == "1"
    check_jobs([*sweep, "hydra/launcher=processes"], multirun=True)  # two at a time
    assert os.environ[LOCAL_JOBS_ENV] == "2"


def test_a_jobs_value_overrides_applied_to_the_composed_base_give_the_composed_job():
    from ballmill.jobs import with_values

    base = compose("config", ["+sweep=fig4", "sim=paper"])
    job = ["scaleup.region=GA", "scaleup.bpr=22.9", "sim.power_se_target=null"]
    assert with_values(base, job) == compose("config", ["+sweep=fig4", "sim=paper", *job])
    # a group, an addition or a bad value: composed instead
    for other in (["mill=bond"], ["+mill.extra=1"], ["scaleup.bpr=abc"], ["scaleup.no_such_key=1"]):
        assert with_values(base, other) is None


def test_a_sweep_of_groups_and_values_composes_each_combination_of_groups_once_and_checks_every_job(monkeypatch):
    """+sweep=scaleup_rule: 5 yield models x 7 BPRs; each job's config the one Hydra composes for it."""
    from ballmill import jobs

    composed, loaded = [], []
    monkeypatch.setattr(jobs, "compose", lambda name, overrides, hydra=False: composed.append(overrides) or
                        compose(name, overrides, hydra=hydra))
    monkeypatch.setattr(jobs, "load", lambda cfg: loaded.append(cfg) or load(cfg))
    jobs.check_jobs(["+sweep=scaleup_rule", "sim.threads=1"], multirun=True)
    assert len(loaded) == 35 and len(composed) == 1 + 5  # the sweep's own, then one per yield model
    fixed = ["+sweep=scaleup_rule", "sim.threads=1"]
    for cfg, job in ((loaded[0], ["scaleup.bpr=10", "yield_model=bpr_line"]),
                     (loaded[-1], ["scaleup.bpr=22.9", "yield_model=impact_threshold_20mj"])):
        expected = compose("config", [*fixed, *job])
        assert {k: cfg[k] for k in expected} == {k: expected[k] for k in expected}
