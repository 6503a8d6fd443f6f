"""Literature tables shipped in data/, each row with its source, year and URL."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pandas as pd

DATA_DIR = Path(__file__).resolve().parents[2] / "data"


@cache
def table(name: str) -> pd.DataFrame:
    """A data/ table; raises with the folder's listing when it is missing."""
    path = DATA_DIR / name
    if not path.exists():
        known = sorted(p.name for p in DATA_DIR.glob("*.csv"))
        raise FileNotFoundError(f"data table {name!r} not found in {DATA_DIR}; available: {known}")
    return pd.read_csv(path)


def lookup(name: str, key_column: str, key, value_column: str) -> float:
    df = table(name)
    rows = df[df[key_column] == key]
    if rows.empty:
        raise KeyError(f"{name}: no row with {key_column}={key!r}; have {df[key_column].tolist()}")
    return float(rows.iloc[0][value_column])
