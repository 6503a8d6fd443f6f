"""Components, streams (kg/h of each component) and element balances.

Molar masses and formulas come from data/molar_masses.csv; reactions are written in moles, so
the element balances close to round-off whatever the molar masses' rounding.
"""

from __future__ import annotations

import re
from functools import cache

import pandas as pd

from ..data import table

# component -> its row in molar_masses.csv
COMPONENTS = {"pet": "pet_repeat_unit", "naoh": "naoh", "na2tpa": "na2tpa", "eg": "eg", "water": "water",
              "h2so4": "h2so4", "tpa": "tpa", "na2so4": "na2so4"}
ELEMENTS = ("C", "H", "O", "Na", "S")
Stream = dict[str, float]  # component -> kg/h


@cache
def molar_mass_kg_per_mol(component: str) -> float:
    row = table("molar_masses.csv").set_index("species").loc[COMPONENTS[component]]
    return float(row.molar_mass_g_per_mol) / 1000.0


@cache
def formula(component: str) -> dict[str, int]:
    """Element counts of a component's formula (e.g. C8H4Na2O4)."""
    text = table("molar_masses.csv").set_index("species").loc[COMPONENTS[component]].formula
    counts: dict[str, int] = {}
    for element, n in re.findall(r"([A-Z][a-z]?)(\d*)", text):
        counts[element] = counts.get(element, 0) + int(n or 1)
    return counts


def kg(component: str, mol_per_h: float) -> float:
    return mol_per_h * molar_mass_kg_per_mol(component)


def mol(stream: Stream, component: str) -> float:
    return stream.get(component, 0.0) / molar_mass_kg_per_mol(component)


def elements(stream: Stream) -> dict[str, float]:
    """mol/h of each element in a stream."""
    return {e: sum(mol(stream, c) * formula(c).get(e, 0) for c in stream) for e in ELEMENTS}


def stream_table(streams: dict[str, Stream]) -> pd.DataFrame:
    """kg/h of every component (rows) in every stream (columns), with each stream's total."""
    df = pd.DataFrame({name: {c: s.get(c, 0.0) for c in COMPONENTS} for name, s in streams.items()})
    df.loc["total"] = df.sum()
    return df.rename_axis("component_kg_per_h")
