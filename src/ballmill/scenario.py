"""From command-line overrides to one validated scenario, and what every command derives from it.

`compose` reads the packaged conf/ (and any directory a user adds to Hydra's search path with
`hydra.searchpath=[file:///my/conf]`); `load` turns the run's config into a `Scenario`, every
group range-checked; `engine_materials`, `time_step_s` and `engine_options` are the one place
where config becomes engine settings, for the drum, the MM400, calibration and the benchmark
(they import the engine, and so Taichi, only when called).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from omegaconf import DictConfig

from .config import (
    CONF_DIR,
    ConfigError,
    DemConfig,
    DrumConfig,
    EconomicsConfig,
    InteractionConfig,
    MaterialConfig,
    MM400Config,
    OptimiserConfig,
    PlantConfig,
    ScaleupConfig,
    SimConfig,
    StudyConfig,
    YieldModelConfig,
    material_tables,
    one_line,
    register,
    to_object,
)

if TYPE_CHECKING:
    from .dem import EngineOptions, SystemSpec


def compose(config_name: str, overrides: list[str], hydra: bool = False) -> DictConfig:
    """conf/<config_name>.yaml with Hydra overrides; Hydra's own messages become ConfigErrors."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    register()
    try:
        with initialize_config_dir(str(CONF_DIR), version_base="1.3"):
            return hydra_compose(config_name, list(overrides), return_hydra_config=hydra)
    except (HydraException, OmegaConfBaseException) as exc:  # unknown key, group option or bad syntax
        raise ConfigError(hydra_message(exc)) from exc


def hydra_message(exc: Exception) -> str:
    """Hydra's first line, the cause's (which names the expected type), and the options of a group."""
    message = one_line(exc).removeprefix("In 'config': ").rstrip(".")
    if exc.__cause__ is not None and one_line(exc.__cause__) not in message:
        message += f": {one_line(exc.__cause__)}"
    options = re.search(r"Available options in '[^']*':\n((?:\t.*\n?)+)", str(exc))
    if options:
        names = [o.strip() for o in options.group(1).split("\n") if o.strip() and not o.strip().startswith("base_")]
        message += "; available: " + ", ".join(names)
    return message


@dataclass
class Scenario:
    """The run's config, typed and range-checked (the root schema)."""

    study: StudyConfig
    sim: SimConfig
    mill: DrumConfig
    scaleup: ScaleupConfig
    economics: EconomicsConfig
    lab: MM400Config
    yield_model: YieldModelConfig
    plant: PlantConfig
    dem: DemConfig
    optimiser: OptimiserConfig
    materials: dict[str, MaterialConfig]
    interactions: dict[str, InteractionConfig]
    cache_dir: Path


def load(cfg: DictConfig) -> Scenario:
    materials, interactions = material_tables(cfg)
    return Scenario(
        study=to_object(cfg.study, StudyConfig, "study"), sim=to_object(cfg.sim, SimConfig, "sim"),
        mill=to_object(cfg.mill, DrumConfig, "mill"), scaleup=to_object(cfg.scaleup, ScaleupConfig, "scaleup"),
        economics=to_object(cfg.economics, EconomicsConfig, "economics"),
        lab=to_object(cfg.lab, MM400Config, "lab"),
        yield_model=to_object(cfg.yield_model, YieldModelConfig, "yield_model"),
        plant=to_object(cfg.plant, PlantConfig, "plant"), dem=to_object(cfg.dem, DemConfig, "dem"),
        optimiser=to_object(cfg.optimiser, OptimiserConfig, "optimiser"), materials=materials, interactions=interactions,
        cache_dir=Path(cfg.cache_dir),
    )


def engine_materials(materials: dict[str, MaterialConfig], interactions: dict[str, InteractionConfig],
                     shear_modulus_scale: float = 1.0, ball: str | None = None, wall: str | None = None):
    """Engine materials (stiffness scaled) and the pair table from config entries 'a-b'; the
    ball and wall materials must exist, with entries ball-ball and ball-wall."""
    from .dem import Interaction, Material

    used = [m for m in (ball, wall) if m is not None]
    for name in used:
        if name not in materials:
            raise ConfigError(f"unknown material {name!r}; known: {sorted(materials)}")
    mats = {
        k: Material(k, m.density_kg_per_m3, m.shear_modulus_pa * shear_modulus_scale, m.poisson_ratio)
        for k, m in materials.items()
    }
    pairs = {}
    for key, p in interactions.items():
        a, _, b = key.partition("-")
        if a not in mats or b not in mats:
            raise ConfigError(f"interactions.{key}: names materials not in {sorted(mats)} (write 'a-b')")
        pairs[tuple(sorted((a, b)))] = Interaction(p.restitution, p.static_friction, p.rolling_friction)
    for a, b in ((ball, ball), (ball, wall)):
        if a and b and tuple(sorted((a, b))) not in pairs:
            raise ConfigError(f"interactions: no entry '{a}-{b}' (restitution, static_friction, rolling_friction)")
    return mats, pairs


def time_step_s(spec: SystemSpec, sim: SimConfig) -> float:
    """sim.dt_s, else sim.dt_fraction of the Rayleigh step of the system's smallest, softest ball."""
    return sim.dt_s if sim.dt_s is not None else sim.dt_fraction * spec.rayleigh_timestep_s()


def engine_options(sim: SimConfig, dt_s: float) -> EngineOptions:
    """The engine's numerical settings from the sim group."""
    from .dem import EngineOptions

    return EngineOptions(
        dt_s=dt_s, max_contacts_per_particle=sim.max_contacts_per_particle, event_capacity=sim.event_capacity,
        max_overlap_fraction=sim.max_overlap_fraction, skin_fraction=sim.neighbour_skin,
        grid={"auto": None, "grid": True, "all_pairs": False}[sim.neighbour_search],
        launch=None if sim.launch == "auto" else sim.launch,
        collision_log=sim.collision_log, progress_every_s=sim.progress_every_s,
    )
