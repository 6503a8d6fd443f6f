"""The plant's options crossed around one mill (plant.options_front): each combination's MSP
($/kg rTPA) and footprint (kg CO2e/kg rTPA), and which lie on the Pareto front of the two (no
other combination at most as dear and as dirty, and less of one).  The mill is the same in all:
the options change only the plant around it."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pandas as pd

from ..config import PlantConfig
from .model import Plant, plant


def choices(group: str) -> tuple[str, ...]:
    """The options of a group: its kind's choices (config.PlantConfig), naoh_dosing's own."""
    fields = {f.name: f for f in dataclasses.fields(PlantConfig)}
    if group == "naoh_dosing":
        return fields[group].metadata["choices"]
    kind = next(f for f in dataclasses.fields(fields[group].default_factory()) if f.name == "kind")
    return kind.metadata["choices"]


def with_options(cfg: PlantConfig, options: dict[str, str]) -> PlantConfig:
    """cfg with each group's option replaced (an option group's other fields kept)."""
    kw = {g: o if g == "naoh_dosing" else dataclasses.replace(getattr(cfg, g), kind=o) for g, o in options.items()}
    return dataclasses.replace(cfg, **kw)


def pareto_front(cost: np.ndarray, footprint: np.ndarray) -> np.ndarray:
    """Which points no other point dominates (at most as high in both, lower in one)."""
    c, f = np.asarray(cost, float), np.asarray(footprint, float)
    dominated = ((c[None, :] <= c[:, None]) & (f[None, :] <= f[:, None])
                 & ((c[None, :] < c[:, None]) | (f[None, :] < f[:, None]))).any(axis=1)
    return ~dominated


def options_table(p: Plant, groups: list[str]) -> pd.DataFrame:
    """Every combination of the groups' options around p's mill (the other groups as p's config
    has them): the options, MSP, footprint, on_front, and whether each beats virgin TPA's price
    and virgin PTA's footprint."""
    rows = []
    for combo in itertools.product(*(choices(g) for g in groups)):
        options = dict(zip(groups, combo))
        built = plant(p.mill, with_options(p.cfg, options), p.econ, p.region, name="option")
        rows.append(options | built.evaluate())
    out = pd.DataFrame(rows)
    out["on_front"] = pareto_front(out.msp_usd_per_kg, out.gwp_kg_per_kg)
    out["below_virgin_price"] = out.msp_usd_per_kg < p.prices["tpa"]
    out["below_virgin_footprint"] = out.gwp_kg_per_kg < p.cf["virgin_tpa"]
    return out
