"""The documentation site's reference pages, generated from the code.

Commands and their options (cli.COMMANDS, the schemas of config.py), every config group and
field with its unit, default, allowed values and doc, the columns of every output table
(columns.TABLES) and every data table with its sources (data/*.csv and data/README.md).
`python -m ballmill.reference docs/reference` writes PAGES; they are committed, so that they read on
the repository host too, and the documentation's tests fail when one no longer matches the code.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import yaml
from omegaconf import DictConfig, OmegaConf

from .cli import COMMANDS, RUN_GROUPS, as_run, value_in
from .columns import RECORD, TABLES
from .config import COMMANDS as SCHEMAS
from .config import CONF_DIR, InteractionConfig, MaterialConfig, allowed, walk
from .data import DATA_DIR

# unit tokens of names (field_m, power_w_per_kg, ...) and the words that may follow a unit after "per"
UNITS = {"m": "m", "mm": "mm", "m2": "m²", "m3": "m³", "ml": "mL", "s": "s", "min": "min", "h": "h", "yr": "yr",
         "kg": "kg", "t": "t", "g": "g", "mol": "mol", "pa": "Pa", "n": "N", "nm": "N m", "w": "W", "kw": "kW",
         "kwh": "kWh", "j": "J", "kj": "kJ", "hz": "Hz", "rpm": "rpm", "deg": "deg", "rad": "rad", "percent": "%",
         "px": "px", "k": "K", "usd": "USD"}
OF = {"pet": "PET", "tpa": "TPA", "eg": "EG", "na2tpa": "Na2TPA", "balls": "balls", "water": "water"}
# whole-table rows shown up to this many cells; larger tables show their columns and sources
MAX_CELLS = 800
# a group's presets get a column each beside the default up to this many (study's eight: a list)
MAX_SIDE_BY_SIDE = 6


def unit(name: str) -> str:
    """The unit a name ends with (power_w_per_kg_pet -> W/kg PET), or '' (dimensionless, text)."""
    tokens = name.split(".")[-1].split("_")
    for start in range(len(tokens)):
        text = parse_unit(tokens[start:])
        if text:
            return text
    return ""


def parse_unit(tokens: list[str]) -> str:
    """'w per kg pet' -> 'W/kg PET': one unit, then groups of per + units (+ one word of what)."""
    out, i = "", 0
    if tokens[0] in UNITS:
        out, i = UNITS[tokens[0]], 1
    elif tokens[0] != "per":
        return ""
    while i < len(tokens):
        if tokens[i] != "per" or i + 1 == len(tokens) or tokens[i + 1] not in UNITS:
            return ""
        i += 1
        group = []
        while i < len(tokens) and tokens[i] in UNITS:
            group.append(UNITS[tokens[i]])
            i += 1
        if i < len(tokens) and tokens[i] in OF:
            group.append(OF[tokens[i]])
            i += 1
        out += "/" + " ".join(group)
    return out if not out.startswith("/") else "1" + out


def cell(value) -> str:
    """A value as a Markdown table cell."""
    text = "" if value is None or (isinstance(value, float) and pd.isna(value)) else str(value)
    return text.replace("|", "\\|").replace("\n", " ")


def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]) + "\n"


def shown(default) -> str:
    return "required" if default == "???" else f"`{json.dumps(default)}`"


def field_table(schema: type, prefix: str, cfg: DictConfig, presets: dict[str, DictConfig] | None = None,
                default_header: str = "default") -> str:
    """Each field with its value as the command runs (cfg), and beside it each other preset's value
    where it differs (presets: name -> the config composed with that preset)."""
    presets = presets or {}
    rows = []
    for path, f, default in walk(schema, prefix):
        value = value_in(cfg, path, default)
        others = [value_in(c, path, default) for c in presets.values()]
        rows.append([f"`{path}`", unit(f.name), shown(value), *(shown(o) if o != value else "" for o in others),
                     allowed(f.metadata), f.metadata.get("doc", "")])
    return table(["field", "unit", default_header, *(f"`{n}`" for n in presets), "allowed", "meaning"], rows)


def summary_of(schema: type) -> str:
    return " ".join((schema.__doc__ or "").split())


def yaml_header(path: Path) -> str:
    """A YAML file's leading comment, as one paragraph."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        if not line.startswith("# @package"):
            lines.append(line.lstrip("# "))
    return " ".join(" ".join(lines).split())


def config_groups() -> list[tuple[str, type]]:
    """Every group a run composes, as (override prefix, schema)."""
    return [(f"{g}.", s) for g, s in RUN_GROUPS] + [("materials.NAME.", MaterialConfig),
                                                    ("interactions.A-B.", InteractionConfig)]


def commands_page() -> str:
    out = ["# Commands", "",
           ("Generated from the code (`ballmill/cli.py`, the schemas of `ballmill/config.py`): "
           "`ballmill COMMAND --help` prints the same. Every command takes Hydra overrides, `key=value`, and "
           "nothing else: its own options by bare name, and for `run`, `render`, `calibrate` and `surrogate` any "
           "field of the [config groups](config.md). `ballmill --version` prints the version, `--debug` (or "
           "`BALLMILL_DEBUG=1`) adds a traceback to an error, and `python -m ballmill` is the same command."), "",
           ("A refused input prints one line, `error: <what>, <what is allowed>`, and exits with status 2 before "
           "anything runs; a run or sweep with failed jobs exits with 1."), ""]
    for name, command in COMMANDS.items():
        what = summary_of(SCHEMAS[name]) if name in SCHEMAS else f"`ballmill {name}`: {command.summary}."
        out += [f"## {name}", "", f"`ballmill {name} [key=value ...]`", "", what, ""]
        if name in SCHEMAS:
            out += ["`default`: its value as the command runs with no override.", "",
                    field_table(SCHEMAS[name], "", as_run(name))]
        if command.groups:
            links = ", ".join(f"[`{g}.*`](config.md#{g})" for g, _ in command.groups)
            out += [f"Config groups it reads: {links}, and `materials.*`, `interactions.*`.", ""]
        if name == "run":
            sweeps = sorted((CONF_DIR / "sweep").glob("*.yaml"))
            out += ["Sweeps (`ballmill run +sweep=NAME`, files in `conf/sweep/`):", "",
                    table(["sweep", "what it runs"], [[f"`{p.stem}`", yaml_header(p)] for p in sweeps]),
                    ("`-m key=a,b` sweeps from the command line; Hydra's flags (`--cfg job`, `--hydra-help`, ...) "
                    "pass through."), ""]
    return "\n".join(out)


def run_defaults() -> dict[str, str]:
    """The preset `ballmill run` takes for each group (conf/config.yaml's defaults list)."""
    entries = yaml.safe_load((CONF_DIR / "config.yaml").read_text())["defaults"]
    return {k: v for e in entries if isinstance(e, dict) for k, v in e.items()}


def config_page() -> str:
    from .scenario import compose

    run = as_run("run")
    out = ["# Configuration", "",
           ("Generated from the dataclass schemas of `ballmill/config.py`, which also check every value (a number "
           "outside its range, an unknown key or option is refused before anything runs), and from the presets "
           "in `conf/`. `default` is the value `ballmill run` uses with no override: the group's default preset's "
           "(`conf/config.yaml` names them; `ballmill run --cfg job` prints them all), which may differ from the "
           "schema's. The other presets' columns show their values where they differ from it. Units are in the "
           "names; `allowed` is an interval (round brackets: the end excluded) or a list of choices; `null` turns "
           "an optional field off. Override any field on the command line: `ballmill run sim.dt_fraction=0.3`."),
           ""]
    for prefix, schema in config_groups():
        group = prefix.split(".")[0]
        out += [f"## {group}", "", summary_of(schema), ""]
        folder = "material" if group == "materials" else group
        presets = sorted((CONF_DIR / folder).glob("*.yaml"))
        if presets:
            out += [f"Presets (`{group}=NAME`, files in `conf/{folder}/`):", "",
                    *(f"- `{p.stem}`: {yaml_header(p) or 'the defaults below'}" for p in presets), ""]
        side_by_side = {}
        if 1 < len(presets) <= MAX_SIDE_BY_SIDE:
            if group == "materials":  # each is composed under its own name: shown under NAME
                side_by_side = {p.stem: OmegaConf.create({"materials": {"NAME": run.materials[p.stem]}})
                                for p in presets}
            else:
                side_by_side = {p.stem: compose("config", [f"{group}={p.stem}"]) for p in presets
                                if p.stem != run_defaults().get(group)}
        name = run_defaults().get(group)
        out += [field_table(schema, prefix, run, side_by_side, f"default (`{name}`)" if name else "default")]
    return "\n".join(out)


def columns_page() -> str:
    out = ["# Output columns", "",
           ("Generated from `ballmill/columns.py`, the vocabulary the tests hold every written column to. Units are "
           "in the names; `<x>` stands for a part of a name."), "",
           "## record", "",
           ("`record.json` and `record.parquet` in each run's folder: one row per run, the columns of the parts "
           "its study runs. `ballmill report` gathers a sweep's records into its tables."), ""]
    for part, (origin, columns) in RECORD.items():
        out += [f"### {part}", "", origin[0].upper() + origin[1:] + ".", "",
                table(["column", "unit", "meaning"], [[f"`{n}`", unit(n), d] for n, d in columns.items()])]
    where = {"loads": "`loads.parquet` in the DEM's cache folder (and `loads.csv` in the run's): per sample and "
                      "wall body",
             "energy": "`energy.parquet`: per sample, cumulative from the start",
             "collisions": "`collisions.parquet`: one row per finished contact",
             "trajectories": "`trajectories.parquet` (the DEM's particle states), the tracker's `*.track.csv` and "
                             "the calibration's observations share these names",
             "lab_summary": "`lab_summary.csv` of `study=lab`: one row per condition"}
    for name, text in where.items():
        out += [f"## {name}", "", text + ".", "",
                table(["column", "unit", "meaning"], [[f"`{n}`", unit(n), d] for n, d in TABLES[name].items()])]
    return "\n".join(out)


def data_notes() -> tuple[dict[str, str], dict[str, str]]:
    """data/README.md's one-line description and longer note of each table."""
    text = (DATA_DIR / "README.md").read_text()
    lines = {m[1]: m[2] for m in re.finditer(r"^\| (\S+\.csv) \| (.*) \|$", text, re.MULTILINE)}
    notes = {m[1]: " ".join(m[2].split())
             for m in re.finditer(r"^## (\S+)\n(.*?)(?=^## |\Z)", text, re.MULTILINE | re.DOTALL)}
    return lines, notes


def data_page() -> str:
    lines, notes = data_notes()
    out = ["# Data tables", "",
           ("Generated from `src/ballmill/data/` (`data/` at the top of the checkout): every number taken from the "
           "literature, one table per source, each row with its source. The code holds no literature numbers of its "
           "own. A report's tables carry this provenance in their Parquet metadata and in a `.provenance.json` "
           "beside them."), ""]
    for path in sorted(DATA_DIR.glob("*.csv")):
        frame = pd.read_csv(path)
        out += [f"## {path.stem}", "", f"`data/{path.name}`: {lines.get(path.name, '')}", ""]
        if path.name in notes:
            out += [notes[path.name], ""]
        cite = [c for c in ("source", "year", "url") if c in frame]
        sources = frame[cite].drop_duplicates() if cite else frame.iloc[:0]
        if frame.size <= MAX_CELLS:
            out += [table(list(frame.columns), frame.values.tolist())]
        else:
            out += [f"{len(frame)} rows; columns: " + ", ".join(f"`{c}`" for c in frame.columns) + ".", "",
                    "Sources:", "", table(cite, sources.values.tolist())]
    return "\n".join(out)


PAGES: dict[str, Callable[[], str]] = {"commands": commands_page, "config": config_page, "columns": columns_page,
                                       "data": data_page}
HEADER = ("<!-- Generated by `python -m ballmill.reference docs/reference` from the code; "
          "tests/test_docs.py fails when it is stale. -->\n\n")


def write_pages(folder: Path) -> None:
    """Each page of PAGES as folder/NAME.md."""
    for name, page in PAGES.items():
        (folder / f"{name}.md").write_text(HEADER + page())


if __name__ == "__main__":
    import sys

    write_pages(Path(sys.argv[1]))
