"""The configuration schema: structured configs registered with Hydra.

Every field has a unit in its name (or is dimensionless) and, where a range applies, the
allowed range in its metadata.  `validate` checks a composed config against them before any
simulation starts and names the field, the value and the range when one is off.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Optional

from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf


def rng(default, lo=None, hi=None, *, lo_open=False, hi_open=False, doc=""):
    """A field with an allowed range [lo, hi] (ends open where asked) and a docstring."""
    return field(default=default, metadata={"range": (lo, hi, lo_open, hi_open), "doc": doc})


class ConfigError(ValueError):
    """A config value outside its allowed range, or an unknown name."""


@dataclass
class MaterialConfig:
    density_kg_per_m3: float = rng(7900.0, 0.0, None, lo_open=True)
    shear_modulus_pa: float = rng(77e9, 0.0, None, lo_open=True)
    poisson_ratio: float = rng(0.3, 0.0, 0.5, hi_open=True)
    source: str = ""


@dataclass
class InteractionConfig:
    restitution: float = rng(0.5, 0.0, 1.0, lo_open=True)
    static_friction: float = rng(0.5, 0.0, None)
    rolling_friction: float = rng(0.01, 0.0, None)
    source: str = ""


@dataclass
class SimConfig:
    arch: str = field(default="cpu", metadata={"choices": ("cpu", "cuda")})
    precision: str = field(default="f64", metadata={"choices": ("f64", "f32")})
    threads: int = rng(0, 0, None, doc="CPU threads for Taichi; 0 = all cores")
    seed: int = rng(0, 0, None)
    dt_fraction: float = rng(0.2, 0.0, 1.0, lo_open=True, doc="time step as a fraction of Rayleigh's")
    dt_s: Optional[float] = rng(None, 0.0, None, lo_open=True, doc="explicit time step (s), overrides dt_fraction")
    shear_modulus_scale: float = rng(1.0, 0.0, 1.0, lo_open=True, doc="stiffness reduction for speed (1 = physical)")
    settle_s: float = rng(0.5, 0.0, None, doc="time the charge settles before the vessel moves (s)")
    duration_s: float = rng(1.0, 0.0, None, lo_open=True, doc="time simulated after settling (s)")
    sample_every_s: float = rng(0.01, 0.0, None, lo_open=True)
    steady_after_s: float = rng(0.5, 0.0, None, doc="power is averaged over samples later than this after start (s)")
    trajectory_every: int = rng(0, 0, None, doc="record particle states every n samples (0: never)")
    max_contacts_per_particle: int = rng(16, 1, None)
    event_capacity: int = rng(200_000, 1, None)
    max_overlap_fraction: float = rng(0.05, 0.0, 1.0, lo_open=True)


@dataclass
class DrumConfig:
    """A horizontal rotating drum (axis along y), flat ends, smooth walls."""

    inner_diameter_m: float = rng(0.4, 0.0, None, lo_open=True)
    inner_length_m: float = rng(0.2, 0.0, None, lo_open=True)
    ball_radius_m: float = rng(0.005, 0.0, None, lo_open=True)
    fill_fraction: float = rng(0.3, 0.0, 1.0, lo_open=True, hi_open=True, doc="ball bed volume / mill volume")
    bed_porosity: float = rng(0.4, 0.0, 1.0, hi_open=True)
    ball_count: Optional[int] = rng(None, 1, None, doc="overrides fill_fraction and bed_porosity")
    speed_rpm: Optional[float] = rng(None, 0.0, None, doc="explicit speed; else fraction_of_critical")
    fraction_of_critical: float = rng(0.7, 0.0, 1.5, lo_open=True)
    geometry: str = field(default="analytic", metadata={"choices": ("analytic", "stl")})
    stl_path: Optional[str] = None
    stl_segments: int = rng(128, 8, None, doc="facets around a generated STL drum")
    ball_material: str = "steel"
    wall_material: str = "steel"


def register() -> None:
    """Schemas for the config groups, so Hydra type-checks them when composing."""
    cs = ConfigStore.instance()
    cs.store(group="sim", name="base_sim", node=SimConfig)
    cs.store(group="mill", name="base_drum", node=DrumConfig)


def _check_field(path: str, value, meta) -> None:
    if "choices" in meta and value not in meta["choices"]:
        raise ConfigError(f"{path}={value!r} is not one of {list(meta['choices'])}")
    if "range" not in meta or value is None:
        return
    lo, hi, lo_open, hi_open = meta["range"]
    bad = (lo is not None and (value < lo or (lo_open and value == lo))) or (
        hi is not None and (value > hi or (hi_open and value == hi))
    )
    if bad:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        span = f"{left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"
        raise ConfigError(f"{path}={value} is outside the allowed range {span}")


def check(obj, path: str) -> None:
    """Range-check a dataclass instance (recursing into dataclasses and dicts of them)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            check(v, f"{path}.{k}")
        return
    if not dataclasses.is_dataclass(obj):
        return
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        _check_field(f"{path}.{f.name}", value, f.metadata)
        check(value, f"{path}.{f.name}")


def to_object(cfg: DictConfig, schema: type, path: str):
    """Turn a config node into the dataclass `schema`, refusing unknown keys, then range-check."""
    base = OmegaConf.structured(schema)
    try:
        merged = OmegaConf.merge(base, cfg)
    except Exception as exc:  # omegaconf's message names the key and the expected type
        raise ConfigError(f"{path}: {exc}") from exc
    obj = OmegaConf.to_object(merged)
    check(obj, path)
    return obj
