"""The documentation: the site builds with no broken link or reference, its reference covers
every config field with a doc and is the code's, every figure quoted on more than one page is
written once (docs/numbers.yaml) and no page quotes one an earlier run gave, the version is
written once, and the tutorials' commands run as written (at the tiny sizes they use), so a
tutorial cannot rot."""

import dataclasses
import importlib.metadata
import importlib.util
import inspect
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import typing
from pathlib import Path

import pandas as pd
import pytest
import tomllib

import ballmill
from ballmill import config
from ballmill.cli import compose_command, options, scenario_of
from ballmill.columns import undescribed
from ballmill.config import walk
from ballmill.files import read_parquet
from ballmill.jobs import check_jobs
from ballmill.reference import HEADER, PAGES, config_groups, unit
from ballmill.scenario import compose

ROOT = Path(__file__).resolve().parents[1]
QUIET = {"NO_MKDOCS_2_WARNING": "1", "DISABLE_MKDOCS_2_WARNING": "true"}  # the tools' banners
# the pages a reader reads (history keeps earlier runs' figures: that is its job)
READ = [ROOT / "README.md", *(p for p in sorted((ROOT / "docs").rglob("*.md")) if p.name != "history.md")]


def schemas() -> list[tuple[str, type]]:
    return config_groups() + [(f"{name}: ", schema) for name, schema in config.COMMANDS.items()]


def test_every_config_field_has_a_doc():
    missing = [path for prefix, schema in schemas() for path, f, _ in walk(schema, prefix)
               if not f.metadata.get("doc", "").strip()]
    assert not missing, f"fields without a doc (metadata 'doc'): {missing}"


def nested(schema: type) -> set[type]:
    """The schema and every dataclass its fields hold (as a value or a list's items)."""
    out = {schema}
    for hint in typing.get_type_hints(schema).values():
        for kind in (hint, *typing.get_args(hint)):
            if dataclasses.is_dataclass(kind):
                out |= nested(kind)
    return out


def test_the_reference_reaches_every_schema_of_config_py():
    reached = set().union(*(nested(schema) for _, schema in schemas()))
    defined = {obj for obj in vars(config).values()
               if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and obj.__module__ == config.__name__}
    assert defined - reached == set()


def test_units_are_read_from_names():
    assert unit("dem_specific_dissipated_power_w_per_kg") == "W/kg"
    assert unit("collision_power_w_per_kg_pet") == "W/kg PET"
    assert unit("evaporator_u_w_per_m2_k") == "W/m² K"
    assert unit("t_s") == "s" and unit("dem_torque_axis_nm") == "N m"
    assert unit("balls_per_jar") == "" and unit("fraction_of_critical") == ""


def test_the_site_builds_strictly_with_the_generated_reference(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, env=os.environ | QUIET, timeout=600, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert set(PAGES) <= {p.name for p in (tmp_path / "reference").iterdir()}
    page = {name: (tmp_path / "reference" / name / "index.html").read_text() for name in PAGES}
    assert "sim.dt_fraction" in page["config"] and "time step as a fraction of the Rayleigh step" in page["config"]
    assert "dem_specific_dissipated_power_w_per_kg" in page["columns"]
    assert all(f"data/{p.name}" in page["data"] for p in (ROOT / "src/ballmill/data").glob("*.csv"))
    assert all(f'id="{name}"' in page["commands"] for name in ("run", "report", "bench", "calibrate"))


def test_the_committed_reference_pages_are_what_the_code_generates():
    stale = [name for name, page in PAGES.items()
             if (ROOT / "docs" / "reference" / f"{name}.md").read_text() != HEADER + page()]
    assert not stale, f"stale reference pages {stale}: run `python -m ballmill.reference docs/reference`"


def test_the_reference_shows_the_default_presets_values_and_the_others_beside_them():
    page = (ROOT / "docs/reference/config.md").read_text()
    header = "| field | unit | default (`steady`) | `lab` | `paper` | `surrogate` | `test` | allowed | meaning |"
    assert header in page
    # the schema's 0.2, sim=steady's 0.4; paper as steady (blank), the others 0.2
    assert "| `sim.dt_fraction` |  | `0.4` | `0.2` |  | `0.2` | `0.2` |" in page


def hooks():
    spec = importlib.util.spec_from_file_location("hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_quoted_figure_a_page_names_is_in_numbers_yaml_with_its_source():
    docs = hooks()
    numbers = docs.numbers()
    for page in READ:
        docs.fill(page.read_text(), numbers, page.name)  # raises on a name not there
    named = {name for page in READ for name in docs.PLACEHOLDER.findall(page.read_text())}
    readme = (ROOT / "README.md").read_text()
    for name, entry in numbers.items():
        assert {"value", "what", "source"} <= entry.keys(), name
        assert name in named or str(entry["value"]) in readme, f"{name} is quoted by no page"


def test_no_page_quotes_a_figure_an_earlier_run_gave():
    texts = {p.relative_to(ROOT): p.read_text() for p in [*READ, *sorted((ROOT / "src/ballmill/conf").rglob("*.yaml"))]}
    old = [(name, quote, str(path)) for name, entry in hooks().numbers().items()
           for quote in entry.get("superseded", []) for path, text in texts.items() if quote in text]
    assert not old, f"(entry, the earlier figure, where): {old}; quote the entry instead"


def test_a_figure_that_is_a_config_value_matches_the_config():
    shown = {"times_softer": lambda x: f"{1 / x:g}x", "percent": lambda x: f"{100 * x:g} %"}
    for name, entry in hooks().numbers().items():
        if "config" in entry:
            c = entry["config"]
            value = compose("config", [c["preset"]])
            for part in c["key"].split("."):
                value = value[part]
            assert str(entry["value"]) == shown[c["as"]](value), f"{name}: {c['preset']} {c['key']} = {value}"


def prose_spans(page: Path) -> list[str]:
    """The page's inline code outside its code blocks (the blocks' commands: test_commands)."""
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.MULTILINE | re.DOTALL)
    return re.findall(r"`([^`\n]+)`", text)


def accepted(args: list[str]) -> bool:
    """Whether `ballmill ARGS` passes what ballmill checks before running anything: composed, every
    value in range, a sweep's jobs planned (a command named alone: composed, its required options not)."""
    try:
        if args[0] == "run" and "-m" in args:
            check_jobs([a for a in args[1:] if a != "-m"], multirun=True)
        elif args[0] == "run":
            scenario_of(compose("config", args[1:]))
        elif len(args) == 1:
            compose_command(args[0], [])
        else:
            options(compose_command(args[0], args[1:]), args[0])
    except config.ConfigError:
        return False
    return True


SHOWN_REFUSED = {"ballmill run scaleup.bpr=-1"}  # the pages show these as what ballmill refuses


def test_every_command_and_preset_named_in_the_prose_is_accepted_as_written():
    groups = {p.name for p in (ROOT / "src/ballmill/conf").iterdir() if p.is_dir()}
    spans = {s for page in READ for s in prose_spans(page)}
    # placeholders (NAME, ...), Hydra's flags and a user's own folders aside
    commands = {s for s in spans if s.startswith("ballmill ") and not re.search(r"[A-Z]{3}|\.\.\.|--|/home/", s)}
    presets = {s for s in spans if re.fullmatch(r"[a-z_]+=[a-z0-9_]+", s) and s.split("=")[0] in groups}
    assert len(commands) > 20 and len(presets) > 10
    refused = [line for line in sorted(commands | presets)
               if not accepted(shlex.split(line)[1:] if line.startswith("ballmill ") else ["run", line])]
    assert sorted(refused) == sorted(SHOWN_REFUSED)


def test_every_figure_a_command_prints_is_quoted_beside_that_command():
    """An entry with `printed` (checked against what its command prints by tests/test_commands.py)
    is quoted on a page that shows the command."""
    for name, entry in hooks().numbers().items():
        if "printed" in entry:
            line = re.compile(rf"^(\.venv/bin/)?{re.escape(entry['printed']['by'])}( |$)", re.MULTILINE)
            assert any(line.search(p.read_text()) and f"{{{{ {name} }}}}" in p.read_text() for p in READ), name


def test_the_pages_scale_up_figures_are_the_golden_tables():
    """Figure 4's rows (case-studies.md) and the seed's BPR 19 mill (yield.md, numbers.yaml) are
    the feeds, sizes, balls and purchase costs of the golden tables (tests/golden/; the DEM's
    columns are a run's)."""
    fig4 = pd.read_csv(ROOT / "tests/golden/fig4.csv").set_index("region")
    rows = dict(re.findall(r"^\| ([A-Z]{2}) \|(.*)$", (ROOT / "docs/explanation/case-studies.md").read_text(),
                           re.MULTILINE))
    assert sorted(rows) == sorted(fig4.index)
    for region, r in fig4.iterrows():
        cells = [c.strip() for c in rows[region].split("|")]
        assert [cells[i] for i in (0, 1, 2, 3, 7, 8)] == [
            f"{r.pet_feed_kg_per_h:,.0f}", f"{r.naoh_feed_kg_per_h:,.0f}", f"{r.diameter_m:.2f} x {r.length_m:.2f}",
            f"{int(r.ball_count):,}", f"{r.purchase_cost_usd:,.0f}", f"{r.purchase_cost_usd_per_kg_per_h:.0f}"], region
    seed = pd.read_csv(ROOT / "tests/golden/fig3b.csv").set_index("bpr").loc[19.0]
    assert (f"| bpr_line (the seed) | 20 | {seed.diameter_m:.2f} x {seed.length_m:.2f} | {int(seed.ball_count)} |"
            in (ROOT / "docs/explanation/yield.md").read_text())
    assert hooks().numbers()["bpr19_purchase_cost"]["value"] == f"{seed.purchase_cost_usd:,.0f}"


def test_the_own_data_pages_edits_of_a_table_change_exactly_the_row_they_name(tmp_path):
    """The page's `sed` lines, run on copies of the tables: each changes one row (a price or a
    factor that moved in the table would leave the copy unchanged, silently)."""
    lines = [line for block in re.findall(r"^```\n(.*?)^```", (ROOT / "docs/how-to/own-data.md").read_text(),
                                          re.MULTILINE | re.DOTALL) for line in block.splitlines() if line.startswith("sed ")]
    (tmp_path / "data").mkdir()
    tables = {"prices.csv": tmp_path / "prices_2025.csv"}
    for name in tables:
        shutil.copy(ROOT / "src/ballmill/data" / name, tmp_path / "data" / name)
    for line in lines:
        subprocess.run(["bash", "-c", line.replace("/home/me/", f"{tmp_path}/")], cwd=tmp_path, check=True)
    for name, written in tables.items():
        before, after = (pd.read_csv(p, dtype=str, keep_default_na=False) for p in (ROOT / "src/ballmill/data" / name,
                                                                                      written))
        assert (before != after).any(axis=1).sum() == 1, name


def test_the_version_is_written_once_and_printed():
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert ballmill.__version__ == version == importlib.metadata.version("ballmill")
    out = subprocess.run([sys.executable, "-m", "ballmill", "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"ballmill {version}"
    assert f"## [{version}]" in (ROOT / "CHANGELOG.md").read_text()


def commands(page: Path) -> list[list[str]]:
    """Each line of the page's ```bash blocks, as the arguments of `ballmill`."""
    blocks = re.findall(r"^```bash\n(.*?)^```", page.read_text(), re.MULTILINE | re.DOTALL)
    lines = [line for block in blocks for line in block.replace("\\\n", " ").splitlines() if line.strip()]
    assert lines and all(line.startswith("ballmill ") for line in lines), lines
    return [shlex.split(line)[1:] for line in lines]


def run_tutorial(name: str, folder: Path) -> list[subprocess.CompletedProcess]:
    """Each command of the tutorial in order, as it ran (what it printed in stdout, its log in stderr)."""
    done = []
    for args in commands(ROOT / "docs" / "tutorials" / f"{name}.md"):
        proc = subprocess.run([sys.executable, "-m", "ballmill", *args], cwd=folder, capture_output=True, text=True,
                              timeout=900, check=False)
        assert proc.returncode == 0, f"ballmill {' '.join(args)}\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}"
        done.append(proc)
    return done


def test_the_first_design_tutorial_runs_and_its_record_is_described(tmp_path):
    """The run's last line is its record's power and yield (4 and 3 figures printed), and the
    power is the tutorial's (bpr19_steady_power) within two of its standard errors (the DEM's path
    is this machine's)."""
    printed = [proc.stdout for proc in run_tutorial("first-design", tmp_path)]
    record = json.loads((tmp_path / "outputs/runs/design/first/record.json").read_text())
    assert record["status"] == "ok" and record["ballmill_version"] == ballmill.__version__
    assert undescribed("record", record) == []
    for table in ("loads", "energy", "collisions", "trajectories"):
        assert undescribed(table, read_parquet(tmp_path / record["dem_dir"] / f"{table}.parquet").columns) == []
    line = re.search(r"^\S*outputs/runs/design/first: power ([0-9.]+) \+- ([0-9.]+) kW \(DEM\), residence time 20 min, "
                     r"yield ([0-9.]+) %", printed[0], re.MULTILINE)
    assert line, printed[0]
    assert float(line[1]) == pytest.approx(record["dem_power_w"] / 1e3, rel=5e-4)
    assert float(line[2]) == pytest.approx(record["dem_power_se_w"] / 1e3, rel=5e-2)
    assert float(line[3]) == pytest.approx(record["yield_percent"], rel=5e-3)
    power, se = map(float, hooks().numbers()["bpr19_steady_power"]["value"].split("+-"))
    assert record["dem_power_w"] / 1e3 == pytest.approx(power, abs=2 * se)
    assert "outputs/report/design.md" in printed[2].splitlines()
    assert printed[2].splitlines()[-1] == "Every table and figure: outputs/report/index.md"
    assert "2 finished, 0 failed" in (tmp_path / "outputs/report/design.md").read_text()


def test_the_first_sweep_tutorial_runs_two_jobs_and_reports_them(tmp_path):
    """Run again, the sweep skips both finished jobs; the report prints where it went."""
    first, again, report = run_tutorial("first-sweep", tmp_path)
    assert len(list((tmp_path / "outputs/sweeps/fig3b").glob("*/record.json"))) == 2
    assert (first.stdout + first.stderr).count("skipped") == 0 and (again.stdout + again.stderr).count("skipped") == 2
    assert "outputs/report/fig3b.md" in report.stdout.splitlines()
    assert report.stdout.splitlines()[-1] == "Every table and figure: outputs/report/index.md"
    assert "2 finished, 0 failed" in (tmp_path / "outputs/report/fig3b.md").read_text()


def test_the_lab_chain_tutorial_recovers_the_filmed_pair_and_validates(tmp_path):
    """Both videos filmed; the tracker's printed mean speed is its table's; the calibration prints
    its best.json and finds the filmed pair (0.6, 0.3) exactly."""
    printed = [proc.stdout for proc in run_tutorial("lab-chain", tmp_path)]
    assert printed[0].splitlines()[-1] == "outputs/lab/videos: 2 videos, manifest videos.csv"
    track = pd.read_csv(tmp_path / "outputs/lab/videos/mm400_000.avi.track.csv")
    assert not track.lost.any()
    assert f"mean speed {track.frame_speed_m_per_s.mean():.3f} m/s" in printed[1]
    best = json.loads((tmp_path / "outputs/lab/calibration/best.json").read_text())
    assert json.loads(printed[2][printed[2].index("{"):]) == best  # after Taichi's banner
    assert (best["wall_restitution"], best["wall_friction"]) == (0.6, 0.3)
    assert "2 finished, 0 failed" in (tmp_path / "outputs/report/lab_validation.md").read_text()
