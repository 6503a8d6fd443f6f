"""Sweep folders -> tables (Parquet + CSV), figures (PNG + SVG) and a Markdown report.

Run it any time, also on an unfinished or partly failed sweep: it reads whatever records
exist and lists the failed jobs.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from .config import MM400_GEOMETRY
from .data import DATA_DIR, table
from .impacts import energy_spectrum
from .plots import plot_fig3b, plot_fig4, plot_impact_spectra, plot_lab_validation, save_figure

FIGURES = {"fig3b": plot_fig3b, "fig4": plot_fig4}
SOURCES = ["prices.csv", "cepci.csv", "molar_masses.csv", "napcor_2018.csv", "population_2018.csv"]


def collect(sweep_dir: Path) -> pd.DataFrame:
    """One row per job folder holding a record.json (failed jobs included)."""
    rows = []
    for path in sorted(sweep_dir.glob("*/record.json")):
        rec = json.loads(path.read_text())
        rec["job_dir"] = str(path.parent)
        rows.append(rec)
    if not rows:
        raise FileNotFoundError(f"no */record.json under {sweep_dir}: is it a sweep folder of `ballmill run -m`?")
    return pd.DataFrame(rows)


def provenance() -> dict:
    """Source, year and URL of every literature table the numbers depend on."""
    out = {}
    for name in SOURCES:
        df = table(name)
        out[name] = sorted({f"{r.source} ({r.year}) {r.url}" for r in df.itertuples()})
    return out


def write_table(df: pd.DataFrame, stem: Path) -> None:
    """Parquet (with provenance in its metadata) and a CSV copy, plus a provenance sidecar."""
    meta = json.dumps(provenance())
    tbl = pa.Table.from_pandas(df, preserve_index=False)
    tbl = tbl.replace_schema_metadata({**(tbl.schema.metadata or {}), b"ballmill.provenance": meta.encode()})
    pq.write_table(tbl, stem.with_suffix(".parquet"))
    df.to_csv(stem.with_suffix(".csv"), index=False)
    stem.with_suffix(".provenance.json").write_text(json.dumps(provenance(), indent=2))


def paper_comparison(name: str, ok: pd.DataFrame) -> list[str]:
    paper = pd.read_csv(DATA_DIR / "paper2023_reported.csv").set_index("quantity")["value"]
    lines = ["| quantity | paper | ours |", "|---|---|---|"]

    def at_bpr(b, col):
        hit = ok[(ok.bpr - b).abs() < 1e-9]
        return f"{hit[col].iloc[0]:.2f}" if len(hit) else "n/a"

    if name == "fig3b":
        lines += [
            (f"| purchase cost, 1000 kg/h ($) | {paper['purchase_cost_1000_kg_per_h']:,.0f} | "
            f"{ok.purchase_cost_usd.iloc[0]:,.0f} |"),
            f"| yield at BPR 19 (%) | {paper['yield_bpr_19']} | {at_bpr(19, 'yield_percent')} |",
            (f"| electricity at BPR 19 ($/t PET) | {paper['electricity_bpr_19']} | "
            f"{at_bpr(19, 'electricity_usd_per_t_pet')} |"),
            (f"| electricity at BPR 22.9 ($/t PET) | {paper['electricity_bpr_22.9']} | "
            f"{at_bpr(22.9, 'electricity_usd_per_t_pet')} |"),
        ]
    if name == "shape_rule":
        lines = [("| shape rule | L/D | D at BPR 19 (m) | % of critical | $/t PET at BPR 19 (paper 1.62) | "
                 "at BPR 22.9 (paper 2.16) |"), "|---|---|---|---|---|---|"]
        ok = ok.assign(ld=np.where(ok.shape_rule == "length_to_diameter", (ok.length_m / ok.diameter_m).round(2), np.nan))
        for (rule, ld), g in ok.groupby(["shape_rule", "ld"], dropna=False):
            g = g.drop_duplicates("bpr")  # the L/D column does not enter the other rule
            g = g.set_index(g.bpr.round(1))
            lines.append(f"| {rule} | {'-' if np.isnan(ld) else f'{ld:g}'} | {g.diameter_m.get(19.0, np.nan):.2f} | "
                         f"{100 * g.fraction_of_critical.get(19.0, np.nan):.0f} | "
                         f"{g.electricity_usd_per_t_pet.get(19.0, np.nan):.2f} | "
                         f"{g.electricity_usd_per_t_pet.get(22.9, np.nan):.2f} |")
        return lines
    if name == "fig4":
        lines.append(f"| yield at BPR 20 (%) | {paper['yield_bpr_20']} | {ok.yield_percent.iloc[0]:.1f} |")
    lines.append(f"| margin ($/t TPA) | {paper['margin']} | {ok.margin_usd_per_t_tpa.iloc[0]:.0f} |")
    return lines


COLUMNS = ["bpr", "region", "shape_rule", "pet_feed_kg_per_h", "naoh_feed_kg_per_h", "diameter_m", "length_m",
           "ball_count", "fraction_of_critical", "dem_dt_s", "dem_power_w", "dem_power_se_w", "bond_rowland_power_w",
           "electricity_usd_per_yr", "electricity_usd_per_t_pet", "purchase_cost_usd", "purchase_cost_usd_per_kg_per_h", "yield_percent"]
IMPACT_COLUMNS = ["dem_collisions_per_s", "dem_ball_ball_impact_energy_mean_j", "dem_ball_ball_impact_energy_p90_j",
                  "dem_ball_wall_drum_impact_energy_mean_j", "dem_ball_wall_drum_impact_energy_p90_j",
                  "dem_specific_dissipated_power_w_per_kg"]


def case_label(rec) -> str:
    if isinstance(rec.get("region"), str):
        return rec["region"]
    if pd.notna(rec.get("bpr")):
        return f"BPR {rec['bpr']:g}"
    return Path(rec["job_dir"]).name


def impact_lines(name: str, ok: pd.DataFrame, out_dir: Path) -> list[str]:
    """The spectra figure (one curve per case) and the impact statistics of each case."""
    spectra = []
    for rec in ok.to_dict("records"):
        path = Path(str(rec.get("dem_dir", ""))) / "collisions.parquet"
        if path.exists():
            after = rec.get("dem_averaging_from_s", 0.0)
            spectra.append(energy_spectrum(pd.read_parquet(path), after).assign(case=case_label(rec)))
    if not spectra:
        return []
    table = pd.concat(spectra, ignore_index=True)
    write_table(table, out_dir / f"{name}_impact_spectra")
    save_figure(plot_impact_spectra(table), out_dir / f"{name}_impact_spectra")
    cols = [c for c in IMPACT_COLUMNS if c in ok]
    return ["## Impacts", "", f"![impact spectra]({name}_impact_spectra.png)", "",
            ok.assign(case=[case_label(r) for r in ok.to_dict("records")])[["case", *cols]].to_markdown(
                index=False, floatfmt=".4g"), ""]


def lab_lines(name: str, ok: pd.DataFrame, out_dir: Path) -> list[str]:
    """MM400 runs: their summaries in one table, the speed-vs-frequency figure, speed per swept geometry."""
    sim = pd.concat([pd.read_csv(Path(d) / "lab_summary.csv").assign(job_dir=d) for d in ok.job_dir],
                    ignore_index=True)
    swept = [k for k in MM400_GEOMETRY if k in sim and sim[k].nunique() > 1]
    write_table(sim, out_dir / f"{name}_conditions")
    paths = ok.observations.dropna().unique() if "observations" in ok else []
    observed = pd.read_csv(paths[0]) if len(paths) else None
    save_figure(plot_lab_validation(sim, observed), out_dir / name)
    cols = [c for c in ["balls", "frequency_hz", "ball_diameter_m", "wall_restitution", "wall_friction",
                        *swept, "mean_speed_m_per_s",
                        "video_collisions_per_s", "ball_wall_collisions_per_s", "mean_impact_energy_j"] if c in sim]
    lines = [f"![{name}]({name}.png)", "", sim[cols].to_markdown(index=False, floatfmt=".4g"), ""]
    if swept:  # the response can be far from linear (a ball that never reaches the jar's ends)
        lines += ["Mean ball speed (m/s) by the value of each swept input, averaged over the others:", ""]
        for k in swept:
            means = sim.groupby(k).mean_speed_m_per_s.mean()
            lines.append(f"- {k}: " + ", ".join(f"{v:g} -> {m:.3f}" for v, m in means.items()))
        lines.append("")
    return lines


def report(sweep_dir: Path, out_dir: Path) -> Path:
    df = collect(sweep_dir)
    name = str(df.study.iloc[0])
    out_dir.mkdir(parents=True, exist_ok=True)
    write_table(df, out_dir / name)
    ok = df[df.status == "ok"]
    failed = df[df.status != "ok"]
    lines = [f"# {name}: {len(ok)} finished, {len(failed)} failed runs", "", f"Sweep folder: `{sweep_dir}`", ""]
    if len(ok) and (ok.kind == "lab").all():
        lines += lab_lines(name, ok, out_dir)
    elif len(ok) and name in FIGURES:
        save_figure(FIGURES[name](ok), out_dir / name)
        lines += [f"![{name}]({name}.png)", ""]
    cols = [c for c in COLUMNS if c in ok.columns]
    if len(ok) and cols:
        lines += [ok[cols].to_markdown(index=False, floatfmt=".4g"), ""]
        if "margin_usd_per_t_tpa" in ok:
            lines += ["## Against the paper", ""] + paper_comparison(name, ok) + [""]
        lines += impact_lines(name, ok, out_dir)
    for rec in failed.itertuples():
        lines.append(f"- FAILED `{rec.job_dir}`: {rec.error}")
    path = out_dir / f"{name}.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog="ballmill report", description=__doc__)
    parser.add_argument("sweep_dirs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=Path("outputs/report"))
    args = parser.parse_args(argv)
    for d in args.sweep_dirs:
        print(report(d, args.out))
