"""Literature tables shipped with the package (data/), each row with its source, year and URL."""

from __future__ import annotations

import math
from functools import cache
from importlib.resources import files
from pathlib import Path

import pandas as pd

from .config import ConfigError

DATA_DIR = Path(str(files("ballmill") / "data"))


@cache
def table(name: str) -> pd.DataFrame:
    """A data/ table; a ConfigError names the folder's tables when it is missing."""
    path = DATA_DIR / name
    if not path.is_file():
        known = sorted(p.name for p in DATA_DIR.glob("*.csv"))
        raise ConfigError(f"data table {name!r} not found in {DATA_DIR}; available: {known}")
    return pd.read_csv(path)


@cache
def lookup(name: str, key_column: str, key, value_column: str) -> float:
    df = table(name)
    rows = df[df[key_column] == key]
    if rows.empty:
        raise ConfigError(f"{name}: no row with {key_column}={key!r}; have {df[key_column].tolist()}")
    try:
        value = float(rows.iloc[0][value_column])
    except (KeyError, ValueError, TypeError) as exc:
        raise ConfigError(f"{DATA_DIR / name}: {value_column} of the row {key_column}={key!r} is not a number "
                          f"({exc})") from exc
    if not math.isfinite(value):
        raise ConfigError(f"{DATA_DIR / name}: {value_column} of the row {key_column}={key!r} is {value}")
    return value
