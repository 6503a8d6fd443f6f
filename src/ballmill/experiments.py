"""The kinetics experiments table: one row per measured yield, with the lab mill and its
conditions, the yield and its error, and where the number comes from.

A data/ table (data/yield_experiments.csv ships the published evidence) or a user's CSV of
the same columns (COLUMNS).  `read_experiments` checks every row before anything runs and
refuses a bad one in one line naming it; `conditions` groups the rows by experimental condition
(everything but the milling time) and by lab DEM condition (what the DEM sees: jar, balls,
frequency; the powder masses only scale the dose per kg of PET).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .config import ConfigError
from .data import DATA_DIR

# column -> (kind, lower bound, lower bound open, meaning); kind: number, count or text
COLUMNS = {
    "experiment": ("text", None, False, "a name for the row"),
    "mill": ("text", None, False, "the lab mill: Retsch MM400 (the one the lab DEM models)"),
    "jar_inner_diameter_mm": ("number", 0.0, True, "the jar's bore"),
    "jar_inner_length_mm": ("number", 0.0, True, "the jar's inner length, end to end (hemispherical ends)"),
    "jar_material": ("text", None, False, "a name of materials.* (steel, pmma, ...)"),
    "frequency_hz": ("number", 0.0, True, "shaking frequency"),
    "ball_diameter_mm": ("number", 0.0, True, "ball diameter"),
    "ball_count": ("count", 1, False, "balls in the jar (1 or 2)"),
    "ball_material": ("text", None, False, "a name of materials.*"),
    "pet_mass_g": ("number", 0.0, True, "PET in the jar"),
    "naoh_mass_g": ("number", 0.0, False, "NaOH in the jar"),
    "time_min": ("number", 0.0, True, "milling time"),
    "yield_percent": ("number", 0.0, False, "TPA (Na2TPA) yield, at most 100"),
    "yield_error_percent": ("number", 0.0, True, "the yield's standard error (percentage points): its weight"),
    "evidence": ("text", None, False, "measured, figure (read from a figure) or derived (computed from a fit)"),
    "assumed": ("text", None, False, "what had to be assumed (empty: nothing)"),
    "source": ("text", None, False, "where the number comes from"),
    "location": ("text", None, False, "where in the source (table, figure, text)"),
    "year": ("text", None, False, "the source's year"),
    "url": ("text", None, False, "the source's address"),
}
EVIDENCE = ("measured", "figure", "derived")
MILLS = ("Retsch MM400",)
MAX_BALLS = 2  # the lab DEM's jar holds one or two balls
# what the lab DEM sees, and what makes an experimental condition (the milling time aside)
DEM_CONDITION = ("mill", "jar_inner_diameter_mm", "jar_inner_length_mm", "jar_material", "frequency_hz",
                 "ball_diameter_mm", "ball_count", "ball_material")
CONDITION = (*DEM_CONDITION, "pet_mass_g", "naoh_mass_g")


@dataclass(frozen=True)
class Experiments:
    """A checked table: its rows (with `condition` and `dem_condition` numbers) and the hash of its
    content (what names a fit of it)."""

    path: Path
    rows: pd.DataFrame
    digest: str


def table_path(name: str) -> Path:
    """A data/ table by name, else a path."""
    path = DATA_DIR / name if (DATA_DIR / name).is_file() else Path(name).expanduser()
    if not path.is_file():
        raise ConfigError(f"yield_model.experiments={name}: no such data/ table or file")
    return path


def read_experiments(name: str, materials) -> Experiments:
    """The experiments table, every row checked; one line naming the first bad row otherwise."""
    path = table_path(name)
    where = f"yield_model.experiments={name}"
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ConfigError(f"{where}: not a readable CSV ({' '.join(str(exc).split())})") from exc
    missing = [c for c in COLUMNS if c not in raw]
    if missing:
        raise ConfigError(f"{where}: missing columns {missing} (the columns: docs/how-to/yield-rules.md)")
    if raw.empty:
        raise ConfigError(f"{where}: holds no experiments")
    rows = pd.DataFrame({c: [cell(raw, i, c, where, materials) for i in range(len(raw))] for c in COLUMNS})
    for i, r in rows.iterrows():
        check_row(r, f"{where}: row {i + 1} ({r.experiment})")
    rows["condition"] = rows.groupby(list(CONDITION), sort=False).ngroup()
    rows["dem_condition"] = rows.groupby(list(DEM_CONDITION), sort=False).ngroup()
    rows["bpr"] = ball_mass_g(rows, materials) / (rows.pet_mass_g + rows.naoh_mass_g)
    if rows.condition.nunique() < 2:
        raise ConfigError(f"{where}: rows 1-{len(rows)} are all one condition (they differ in the milling time "
                          "alone): leave-one-condition-out cross-validation needs experiments at two conditions or "
                          "more")
    digest = hashlib.sha256(rows[list(COLUMNS)].to_csv(index=False).encode()).hexdigest()[:16]
    return Experiments(path, rows, digest)


def cell(raw: pd.DataFrame, i: int, column: str, where: str, materials):
    """One cell as its kind, checked against the column's range (the row named when not)."""
    kind, lo, lo_open, _ = COLUMNS[column]
    text = raw[column].iloc[i].strip()
    row = f"{where}: row {i + 1} ({raw.experiment.iloc[i]})"
    if kind == "text":
        if column.endswith("material") and text not in materials:
            raise ConfigError(f"{row}: {column}={text!r} is not a name of materials.*; known: {sorted(materials)}")
        return text
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"{row}: {column}={text!r} is not a number") from None
    if not math.isfinite(value) or (value < lo or (lo_open and value == lo)):
        raise ConfigError(f"{row}: {column}={text} is outside the allowed range {'(' if lo_open else '['}{lo}, inf)")
    if kind == "count":
        if value != int(value):
            raise ConfigError(f"{row}: {column}={text} is not a whole number")
        return int(value)
    return value


def check_row(r: pd.Series, row: str) -> None:
    """What a row's cells must satisfy together: a known mill and evidence, a yield of at most
    100 %, balls that fit the jar."""
    if r.mill not in MILLS:
        raise ConfigError(f"{row}: mill={r.mill!r}: the lab DEM models {list(MILLS)}")
    if r.evidence not in EVIDENCE:
        raise ConfigError(f"{row}: evidence={r.evidence!r} is not one of {list(EVIDENCE)}")
    if r.yield_percent > 100.0:
        raise ConfigError(f"{row}: yield_percent={r.yield_percent} is outside the allowed range [0.0, 100.0]")
    if r.ball_count > MAX_BALLS:
        raise ConfigError(f"{row}: ball_count={r.ball_count} is outside the allowed range [1, {MAX_BALLS}]")
    if r.jar_inner_length_mm < r.jar_inner_diameter_mm:
        raise ConfigError(f"{row}: jar_inner_length_mm={r.jar_inner_length_mm} is shorter than the bore "
                          f"jar_inner_diameter_mm={r.jar_inner_diameter_mm}: give the length end to end")
    if r.ball_diameter_mm >= r.jar_inner_diameter_mm:
        raise ConfigError(f"{row}: ball_diameter_mm={r.ball_diameter_mm} does not fit the bore "
                          f"jar_inner_diameter_mm={r.jar_inner_diameter_mm}")
    if r.ball_count == MAX_BALLS and MAX_BALLS * r.ball_diameter_mm > r.jar_inner_length_mm:
        raise ConfigError(f"{row}: two {r.ball_diameter_mm} mm balls do not fit side by side in a jar "
                          f"{r.jar_inner_length_mm} mm long")


def ball_mass_g(rows: pd.DataFrame, materials) -> pd.Series:
    """The balls' mass in each row's jar (g)."""
    density = rows.ball_material.map(lambda m: materials[m].density_kg_per_m3)
    return rows.ball_count * density * math.pi / 6 * (rows.ball_diameter_mm / 1e3) ** 3 * 1e3
