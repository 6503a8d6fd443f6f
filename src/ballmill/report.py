"""Sweep folders -> tables (Parquet + CSV), figures (PNG + SVG) and a Markdown report.

Run it any time, also on an unfinished or partly failed sweep: it reads whatever records
exist and lists the failed jobs.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from omegaconf import OmegaConf

from .config import MM400_GEOMETRY, OPTION_GROUPS, ConfigError, RtdConfig, StudyConfig, StudyReport, one_line, to_object
from .data import table
from .dose import dose_rates
from .files import read_json, read_parquet
from .impacts import energy_spectrum
from .kinetics import PARAMS, TIME_SPAN, FittedCurve, lab_time_curves, rtd_table
from .plots import (
    FIGURES,
    plot_dissipation_spectra,
    plot_impact_spectra,
    plot_lab_validation,
    plot_measured_power,
    plot_options_front,
    plot_parity,
    plot_residuals,
    plot_tornado,
    plot_yield_time,
    save_figure,
    with_rule_labels,
)
from .yields import pet_fraction

SOURCES = ["prices.csv", "cepci.csv", "molar_masses.csv", "napcor_2018.csv", "population_2018.csv",
           "yield_lab_conditions.csv", "cost_correlations.csv", "macrs_7yr.csv", "plant_uncertainty.csv",
           "plant_chemicals.csv", "staffing.csv", "ghg_factors.csv", "egrid2022_states.csv", "published_anchors.csv",
           "measured_mill_power.csv", "yield_experiments.csv", "mill_rtd.csv", "haulage.csv", "population_centres.csv"]


def collect(sweep_dir: Path) -> pd.DataFrame:
    """One row per job folder holding a record.json (failed jobs included)."""
    if not sweep_dir.is_dir():
        raise FileNotFoundError(f"sweeps: {sweep_dir} is not a folder; give a sweep folder of `ballmill run -m`")
    rows = []
    for path in sorted(sweep_dir.glob("*/record.json")):
        rec = read_json(path)
        if rec is None or "status" not in rec:  # interrupted or corrupted: the job reruns on resume
            rec = {"study": "?", "status": "failed", "error": f"{path.name} unreadable: rerun the sweep to redo it"}
        rec["job_dir"] = str(path.parent)
        rows.append(rec)
    if not rows:
        raise FileNotFoundError(f"sweeps: no */record.json under {sweep_dir}; is it a sweep folder of `ballmill run -m`?")
    df = pd.DataFrame(rows)
    known = df[df.study != "?"]
    if len(known):
        df["study"] = known.study.iloc[0]
    return df


def provenance() -> dict:
    """Source, year and URL of every literature table the numbers depend on."""
    out = {}
    for name in SOURCES:
        df = table(name)
        out[name] = sorted({f"{r.source} ({r.year}) {r.url if isinstance(r.url, str) else ''}".strip()
                            for r in df.itertuples()})
    return out


def write_table(df: pd.DataFrame, stem: Path) -> None:
    """Parquet (with provenance in its metadata) and a CSV copy, plus a provenance sidecar."""
    meta = json.dumps(provenance())
    tbl = pa.Table.from_pandas(df, preserve_index=False)
    tbl = tbl.replace_schema_metadata({**(tbl.schema.metadata or {}), b"ballmill.provenance": meta.encode()})
    pq.write_table(tbl, stem.with_suffix(".parquet"))
    df.to_csv(stem.with_suffix(".csv"), index=False)
    stem.with_suffix(".provenance.json").write_text(json.dumps(provenance(), indent=2))


def paper_comparison(name: str, ok: pd.DataFrame, spec: StudyReport) -> list[str]:
    """The paper's reported numbers of case `spec.compare` (data/paper2023_reported.csv) beside ours."""
    if not spec.compare:
        return []
    rows = table("paper2023_reported.csv")
    lines = ["## Against the paper", "", "| quantity | paper | ours |", "|---|---|---|"]
    for r in rows[rows.case.isin([spec.compare, "both"])].itertuples():
        hit = ok[(ok.bpr - r.at_bpr).abs() < 1e-9] if pd.notna(r.at_bpr) else ok
        ours = f"{hit[r.column].iloc[0]:,.{int(r.digits)}f}" if len(hit) and r.column in hit else "n/a"
        lines.append(f"| {r.label} | {r.value:,.{int(r.digits)}f} | {ours} |")
    return [*lines, ""]


def shape_rule_table(name: str, ok: pd.DataFrame, spec: StudyReport) -> list[str]:
    """Mill diameter, speed and electricity at BPR 19 and 22.9 for each shape rule, beside the paper's."""
    paper = table("paper2023_reported.csv").set_index("quantity")["value"]
    lines = ["## Shape rules", "", (f"| shape rule | L/D | D at BPR 19 (m) | % of critical | $/t PET at BPR 19 (paper "
                                    f"{paper['electricity_bpr_19']:g}) | at BPR 22.9 (paper "
                                    f"{paper['electricity_bpr_22.9']:g}) |"), "|---|---|---|---|---|---|"]
    ok = ok.assign(ld=np.where(ok.shape_rule == "length_to_diameter", (ok.length_m / ok.diameter_m).round(2), np.nan))
    for (rule, ld), g in ok.groupby(["shape_rule", "ld"], dropna=False):
        g = g.drop_duplicates("bpr")  # the L/D column does not enter the other rule
        g = g.set_index(g.bpr.round(1))
        lines.append(f"| {rule} | {'-' if np.isnan(ld) else f'{ld:g}'} | {g.diameter_m.get(19.0, np.nan):.2f} | "
                     f"{100 * g.fraction_of_critical.get(19.0, np.nan):.0f} | "
                     f"{g.electricity_usd_per_t_pet.get(19.0, np.nan):.2f} | "
                     f"{g.electricity_usd_per_t_pet.get(22.9, np.nan):.2f} |")
    return [*lines, ""]


def design_table(name: str, ok: pd.DataFrame, spec: StudyReport) -> list[str]:
    """The headline columns of every finished job."""
    cols = [c for c in COLUMNS if c in ok.columns]
    return [ok[cols].to_markdown(index=False, floatfmt=".4g"), ""] if cols else []


COLUMNS = ["bpr", "region", "shape_rule", "pet_feed_kg_per_h", "naoh_feed_kg_per_h", "diameter_m", "length_m",
           "ball_count", "fraction_of_critical", "dem_dt_s", "dem_power_w", "dem_power_se_w", "bond_rowland_power_w",
           "electricity_usd_per_yr", "electricity_usd_per_t_pet", "purchase_cost_usd", "purchase_cost_usd_per_kg_per_h", "yield_percent",
           "dem_steady"]
IMPACT_COLUMNS = ["dem_collisions_per_s", "dem_ball_ball_impact_energy_mean_j", "dem_ball_ball_impact_energy_p90_j",
                  "dem_ball_wall_drum_impact_energy_mean_j", "dem_ball_wall_drum_impact_energy_p90_j",
                  "dem_specific_dissipated_power_w_per_kg", "collision_power_w_per_kg_pet",
                  "collision_power_w_per_kg_pet_se", "impact_threshold_j", "impact_power_w_per_kg_pet",
                  "collision_dose_kj_per_kg_pet", "collision_power_w_per_kg_balls", "impact_power_w_per_kg_balls"]


def case_label(rec) -> str:
    if isinstance(rec.get("region"), str):
        return rec["region"]
    if pd.notna(rec.get("bpr")):
        return f"BPR {rec['bpr']:g}"
    return Path(rec["job_dir"]).name


def impact_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """The spectra figure (one curve per case) and the impact statistics of each case."""
    spectra = []
    for rec in ok.to_dict("records"):
        path = Path(str(rec.get("dem_dir", ""))) / "collisions.parquet"
        if path.exists():
            after = rec.get("dem_averaging_from_s", 0.0)
            spectra.append(energy_spectrum(read_parquet(path), after).assign(case=case_label(rec)))
    if not spectra:
        return []
    table = pd.concat(spectra, ignore_index=True)
    write_table(table, out_dir / f"{name}_impact_spectra")
    save_figure(plot_impact_spectra(table), out_dir / f"{name}_impact_spectra")
    cols = [c for c in IMPACT_COLUMNS if c in ok]
    return ["## Impacts", "", f"![impact spectra]({name}_impact_spectra.png)", "",
            ok.assign(case=[case_label(r) for r in ok.to_dict("records")])[["case", *cols]].to_markdown(
                index=False, floatfmt=".4g"), ""]


def lab_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
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
                        "video_collisions_per_s", "ball_wall_collisions_per_s", "mean_impact_energy_j",
                        "collision_power_w_per_kg_balls", "impact_power_w_per_kg_balls"] if c in sim]
    lines = [f"![{name}]({name}.png)", "", sim[cols].to_markdown(index=False, floatfmt=".4g"), ""]
    if swept:  # the response can be far from linear (a ball that never reaches the jar's ends)
        lines += ["Mean ball speed (m/s) by the value of each swept input, averaged over the others:", ""]
        for k in swept:
            means = sim.groupby(k).mean_speed_m_per_s.mean()
            lines.append(f"- {k}: " + ", ".join(f"{v:g} -> {m:.3f}" for v, m in means.items()))
        lines.append("")
    return lines


RULE_COLUMNS = ["rule", "bpr", "residence_time_min", "residence_time_se_min", "fixed_point_iterations", "diameter_m",
                "length_m", "ball_count", "fraction_of_critical", "dem_power_w", "electricity_usd_per_t_pet",
                "purchase_cost_usd", "yield_percent", "collision_power_w_per_kg_pet", "impact_power_w_per_kg_pet",
                "collision_dose_kj_per_kg_pet", "impact_dose_kj_per_kg_pet"]


def scaleup_rule_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """Each yield rule's mill per BPR; at BPR 19 against the paper's, and the mechanics behind the
    difference: the lab's and the paper's mill's dose rates and dissipation spectra side by side."""
    ok = with_rule_labels(ok)
    table = ok[[c for c in RULE_COLUMNS if c in ok]].sort_values(["rule", "bpr"])
    write_table(table, out_dir / f"{name}_designs")
    lines = ["## Yield rules: the mill each asks for", "", table.to_markdown(index=False, floatfmt=".4g"), ""]
    at19 = ok[(ok.bpr - 19).abs() < 1e-9].set_index("rule")
    if "bpr_line" not in at19.index:
        return lines
    seed = at19.loc["bpr_line"]
    head = ("| rule | residence time (min) | D x L (m) | balls | power (kW) | electricity ($/t PET) | purchase cost ($) "
            "| x paper's residence time | x paper's power |")
    lines += ["### BPR 19 against the paper's design", "", head, "|---|---|---|---|---|---|---|---|---|"]
    for rule, r in at19.iterrows():
        lines.append(f"| {rule} | {r.residence_time_min:.4g} | {r.diameter_m:.2f} x {r.length_m:.2f} | "
                     f"{r.ball_count:.0f} | {r.dem_power_w / 1e3:.4g} | {r.electricity_usd_per_t_pet:.3g} | "
                     f"{r.purchase_cost_usd:,.0f} | {r.residence_time_min / seed.residence_time_min:.3g} | "
                     f"{r.dem_power_w / seed.dem_power_w:.3g} |")
    lines.append("")
    return lines + mechanics_lines(name, ok, seed, out_dir)


def mechanics_lines(name: str, ok: pd.DataFrame, seed: pd.Series, out_dir: Path) -> list[str]:
    """The lab's nominal condition beside the paper's mill at BPR 19: dose rates per kg of balls and
    of PET, and where the dissipation falls on the impact-energy axis."""
    energy = ok[ok.calibration_dir.notna()] if "calibration_dir" in ok else ok.iloc[:0]
    if energy.empty:
        return []
    folder = Path(energy.calibration_dir.iloc[0])
    conds = pd.read_csv(folder / "conditions.csv")
    lab_dir = Path(conds[conds.nominal].iloc[0].lab_dem_dir)
    meta = read_json(lab_dir / "condition.json")
    lab_log = read_parquet(lab_dir / "collisions.parquet")
    mill_log = read_parquet(Path(seed.dem_dir) / "collisions.parquet")
    thresholds = sorted(ok.impact_threshold_j[ok.yield_rule == "impact_threshold"].unique())
    pet_fraction_lab = pet_fraction(read_json(folder / "calibration.json")["lab"]["bpr_basis"],
                                    seed.naoh_feed_kg_per_h / seed.pet_feed_kg_per_h)
    seed_pet_kg = seed.pet_feed_kg_per_h * seed.residence_time_min / 60
    rows = []
    for label, log_, after, until, balls_kg, pet_kg in (
            ("lab (nominal), BPR 19", lab_log, meta["settle_s"], meta["duration_s"], meta["ball_mass_kg"],
             meta["ball_mass_kg"] / 19 * pet_fraction_lab),
            ("mill, seed design, BPR 19", mill_log, seed.dem_averaging_from_s, seed.dem_simulated_s, seed.ball_mass_kg,
             seed_pet_kg)):
        rates = {e: dose_rates(log_, after, until, balls_kg, e) for e in (thresholds or [1e-2])}
        first = next(iter(rates.values()))
        rows.append({"case": label, "collision power (W/kg balls)": first["collision_power_w_per_kg"],
                     "per kg PET (W/kg)": first["collision_power_w_per_kg"] * balls_kg / pet_kg,
                     "collisions (1/s per kg balls)": first["collision_frequency_per_s_per_kg"],
                     **{f"share above {1e3 * e:g} mJ": r["impact_power_w_per_kg"] / r["collision_power_w_per_kg"]
                        for e, r in rates.items()}})
    spectra = pd.concat([energy_spectrum(lab_log, meta["settle_s"], weight="dissipated_j").assign(case=rows[0]["case"]),
                         energy_spectrum(mill_log, seed.dem_averaging_from_s, weight="dissipated_j")
                         .assign(case=rows[1]["case"])], ignore_index=True)
    write_table(spectra, out_dir / f"{name}_dissipation_spectra")
    save_figure(plot_dissipation_spectra(spectra, thresholds), out_dir / f"{name}_dissipation_spectra")
    return ["### Why: the two mills' collisions", "", pd.DataFrame(rows).to_markdown(index=False, floatfmt=".3g"), "",
            f"![dissipation spectra]({name}_dissipation_spectra.png)", ""]


def yield_calibration_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """The lab dose rates per assumed condition, relative to the nominal one: an energy rule's
    residence time scales with the lab's dose rate."""
    lines = []
    for rec in ok.itertuples():
        table = pd.read_csv(Path(rec.job_dir) / "lab_dose.csv")
        write_table(table, out_dir / f"{name}_lab_dose")
        cols = ["balls", "frequency_hz", "ball_diameter_m", "jar_inner_diameter_m", "jar_inner_length_m", "nominal",
                "collision_power_w_per_kg", "collision_power_w_per_kg_se", "collision_power_w_per_kg_relative",
                "impact_power_w_per_kg", "impact_power_w_per_kg_relative", "largest_impact_j", "collision_log_share"]
        text = (f"E* = {rec.impact_threshold_j} J; specific_energy: Y = {rec.specific_energy_yield_a_percent:.4g} + "
                f"{rec.specific_energy_yield_b_percent_per_kj_per_kg:.4g} D (% per kJ/kg PET); impact_threshold: "
                f"Y = {rec.impact_threshold_yield_a_percent:.4g} + "
                f"{rec.impact_threshold_yield_b_percent_per_kj_per_kg:.4g} D. Dose rates per kg of balls; "
                "'relative' = against the nominal condition, the factor by which an energy rule's residence time "
                "moves if that condition were the experiments' instead.")
        lines += ["## Lab calibration of the dose line", "", text, "", table[cols].to_markdown(index=False, floatfmt=".4g"),
                  ""]
    return lines


def interval(c: pd.Series, parameters: tuple[str, ...]) -> str:
    """A candidate's parameters with their intervals, as text."""
    return "; ".join(f"{p} = {c[p]:.4g} [{c[f'{p}_lo']:.4g}, {c[f'{p}_hi']:.4g}]" for p in parameters
                     if p in c and pd.notna(c[p]))


def yield_fit_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """The fit behind the records' yield_model=fitted (their fit_dir): each candidate's
    cross-validated error, fit and parameters with their intervals, the choice; parity and the
    residuals per condition; yield against time in the lab; what each RTD of the sensitivity
    lists costs against plug flow at the target."""
    lines = []
    for folder in map(Path, ok.fit_dir.dropna().unique() if "fit_dir" in ok else ()):
        candidates, predictions, rows = (pd.read_csv(folder / f"{n}.csv") for n in ("candidates", "predictions", "rows"))
        curve = FittedCurve.read(folder)
        chosen = candidates[candidates.chosen].iloc[0]
        write_table(candidates, out_dir / f"{name}_candidates")
        shown = candidates.assign(parameters=[interval(c, PARAMS[c.model]) for _, c in candidates.iterrows()],
                                  note=candidates.note.fillna(""))
        shown = shown[["candidate", "cv_rmse_percent", "cv_rmse_se_percent", "chi2", "aic", "within_one_se", "chosen",
                       "parameters", "note"]]
        mine = predictions[predictions.candidate == chosen.candidate].assign(
            residual_percent=lambda d: d.yield_percent - d.cv_predicted_percent)
        per_condition = mine.groupby("condition").agg(
            experiments=("experiment", ", ".join), times_min=("time_min", lambda t: " ".join(f"{x:g}" for x in t)),
            yield_percent=("yield_percent", "mean"), cv_residual_rms_percent=(
                "residual_percent", lambda r: float(np.sqrt(np.mean(r**2))))).reset_index()
        write_table(per_condition, out_dir / f"{name}_residuals")
        save_figure(plot_parity(predictions, candidates), out_dir / f"{name}_parity")
        save_figure(plot_residuals(mine), out_dir / f"{name}_residuals")
        evidence = ", ".join(f"{n} {e}" for e, n in rows.evidence.value_counts().items())
        lines += ["## The fit of the kinetics experiments", "",
                  (f"`{read_json(folder / 'fit.json')['experiments']}`: {len(rows)} rows ({evidence}), "
                   f"{rows.condition.nunique()} conditions, {rows.dem_condition.nunique()} lab DEM conditions. Chosen: "
                   f"**{chosen.candidate}** (CV RMSE {chosen.cv_rmse_percent:.3g} %), "
                   f"{int(candidates.within_one_se.sum())} candidates within one standard error of the lowest CV "
                   f"error. Parameters with their {read_json(folder / 'fit.json')['fit']['confidence']:.0%} "
                   "intervals; a candidate the data cannot cross-validate says why."), "",
                  shown.to_markdown(index=False, floatfmt=".4g"), "",
                  f"![parity]({name}_parity.png)", "", "Residuals per condition (measured - CV prediction):", "",
                  per_condition.to_markdown(index=False, floatfmt=".4g"), "", f"![residuals]({name}_residuals.png)", ""]
        if curve.time_free:
            continue
        target = float(ok.target_yield_percent.dropna().iloc[0]) if "target_yield_percent" in ok else (
            float(ok.bpr_line_yield_percent.iloc[0]))
        curves = lab_time_curves(curve, rows, TIME_SPAN * rows.time_min.max())
        save_figure(plot_yield_time(curves, rows), out_dir / f"{name}_lab_time")
        rtd = rtd_table(curve, target, RtdConfig())
        write_table(rtd, out_dir / f"{name}_rtd")
        lines += [f"![yield against time in the lab]({name}_lab_time.png)", "",
                  (f"What the mill's residence-time distribution costs at {target:.4g} %: the mean dose it needs / "
                   "plug flow's (the residence time scales with it, less the mill-size feedback), and the yield "
                   "plug flow's dose gives under it."), "", rtd.to_markdown(index=False, floatfmt=".4g"), ""]
    return lines


DESIGN_RTD_COLUMNS = ["rtd_kind", "rtd_tanks", "rtd_peclet", "rtd_dose_factor", "target_dose_kj_per_kg_pet",
                      "residence_time_min", "residence_time_se_min", "fixed_point_root", "diameter_m", "length_m",
                      "ball_count", "dem_power_w", "electricity_usd_per_t_pet", "purchase_cost_usd", "yield_percent"]


def yield_design_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """The designs under the fitted model, one per residence-time distribution, against plug flow's."""
    table = ok[[c for c in DESIGN_RTD_COLUMNS if c in ok]].sort_values("rtd_dose_factor")
    plug = table[table.rtd_kind == "plug"]
    if len(plug):
        for col in ("residence_time_min", "dem_power_w", "purchase_cost_usd"):
            table[f"{col}_x_plug"] = table[col] / plug[col].iloc[0]
    write_table(table, out_dir / f"{name}_designs")
    return ["## The mill under the fitted model, by residence-time distribution", "",
            table.to_markdown(index=False, floatfmt=".4g"), ""]


PLANT_COLUMNS = ["bpr", "region", "plant_fresh_pet_kg_per_h", "plant_bales_kg_per_h", "plant_mill_pet_kg_per_h",
                 "yield_percent", "plant_rtpa_t_per_yr", "plant_staff", "plant_fixed_capital_usd", "msp_usd_per_kg",
                 "msp_p5_usd_per_kg", "msp_p50_usd_per_kg", "msp_p95_usd_per_kg", "gwp_total_kg_per_kg",
                 "gwp_p5_kg_per_kg", "gwp_p50_kg_per_kg", "gwp_p95_kg_per_kg", "gwp_mass_allocation_kg_per_kg",
                 "gwp_economic_allocation_kg_per_kg", "msp_mill_share"]
SECTION_OF_AREA = {"1": "feed preparation", "2": "reaction", "3": "TPA", "4": "salt and EG", "5": "wastewater",
                   "6": "storage", "C": "cooling tower"}


def plant_sections(units: pd.DataFrame) -> pd.DataFrame:
    """Installed cost, power and heat by section of the plant (a unit's area: its ID's first digit)."""
    area = units.unit.str.extract(r"^[A-Z]+(\d)")[0].fillna(units.unit.str[0])
    cols = ["purchase_cost_usd", "installed_cost_usd", "power_kw", "heating_kw", "cooling_kw"]
    out = units.assign(section=area.map(SECTION_OF_AREA)).groupby("section", sort=False)[cols].sum()
    return out.reset_index()


def items(case: pd.Series, prefix: str, suffix: str, exclude: tuple[str, ...]) -> pd.Series:
    """The breakdown of a record: prefix<item>suffix columns, less the Monte Carlo's percentiles."""
    out = {}
    for k, v in case.items():
        item = k[len(prefix):-len(suffix)] if k.startswith(prefix) and k.endswith(suffix) else ""
        if item and item not in exclude and not re.fullmatch(r"p\d+", item) and pd.notna(v):
            out[item] = v
    return pd.Series(out, dtype=float)


def plant_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """MSP and footprint per case with their bands; for one case (the paper's BPR 19, else the
    largest feed): the breakdowns, the units and their cross-checked prices by section, what
    each modelling choice moves, the tornado, the rank correlations, and the published anchors."""
    cols = [c for c in PLANT_COLUMNS if c in ok and ok[c].notna().any()]
    breakdown = [c for c in ok if c.startswith(("msp_", "gwp_")) and c not in cols]
    write_table(ok[cols + breakdown], out_dir / f"{name}_msp")
    at19 = ok[(ok.bpr - 19).abs() < 1e-9] if ok.region.isna().all() else ok.iloc[:0]
    case = (at19 if len(at19) else ok.sort_values("plant_fresh_pet_kg_per_h")).iloc[-1]
    job = Path(case.job_dir)
    tables = {stem: pd.read_csv(job / f"{stem}.csv") for stem in ("units", "variants", "tornado", "rank_correlations",
                                                                   "what_it_takes")
              if (job / f"{stem}.csv").is_file()}
    tables["sections"] = plant_sections(tables["units"])
    tables["streams"] = pd.read_csv(job / "streams.csv")
    for stem, frame in tables.items():
        write_table(frame, out_dir / f"{name}_{stem}")
    save_figure(plot_tornado(tables["tornado"], case.msp_usd_per_kg), out_dir / f"{name}_tornado")
    label = case_label(case.to_dict())
    msp = items(case, "msp_", "_usd_per_kg", ("mill_section",))
    gwp = items(case, "gwp_", "_kg_per_kg", ("total", "mass_allocation", "economic_allocation"))
    anchors = table("published_anchors.csv")
    band = {k: case.get(k, np.nan) for k in ("msp_p5_usd_per_kg", "msp_p50_usd_per_kg", "msp_p95_usd_per_kg",
                                             "gwp_p5_kg_per_kg", "gwp_p50_kg_per_kg", "gwp_p95_kg_per_kg")}
    headline = (f"MSP {case.msp_usd_per_kg:.3f} $/kg rTPA (Monte Carlo median {band['msp_p50_usd_per_kg']:.3f}, "
                f"5-95 % {band['msp_p5_usd_per_kg']:.3f}-{band['msp_p95_usd_per_kg']:.3f}); footprint "
                f"{case.gwp_total_kg_per_kg:.2f} kg CO2e/kg (median {band['gwp_p50_kg_per_kg']:.2f}, 5-95 % "
                f"{band['gwp_p5_kg_per_kg']:.2f}-{band['gwp_p95_kg_per_kg']:.2f}); virgin TPA: "
                f"{case.virgin_tpa_usd_per_kg:.3f} $/kg and {case.virgin_tpa_gwp_kg_per_kg:.2f} kg CO2e/kg.")
    units_title = ("Units (purchase cost by BioSTEAM or the cited correlation; a second published correlation beside "
                   "the large ones):")
    lines = ["## Whole plant: minimum selling price and footprint of rTPA", "",
             ok[cols].to_markdown(index=False, floatfmt=".4g"), "",
             f"### {label}", "", headline, "",
             "MSP by item ($/kg rTPA; credits negative):", "",
             msp.sort_values(key=abs, ascending=False).to_frame("usd_per_kg").to_markdown(floatfmt=".4f"), "",
             "Footprint by item (kg CO2e/kg rTPA; credits negative):", "",
             gwp.sort_values(key=abs, ascending=False).to_frame("kg_per_kg").to_markdown(floatfmt=".4f"), "",
             "By section:", "", tables["sections"].to_markdown(index=False, floatfmt=".4g"), "",
             units_title, "", tables["units"].to_markdown(index=False, floatfmt=".4g"), "",
             "What each modelling choice moves (each undone alone):", "",
             tables["variants"].to_markdown(index=False, floatfmt=".4f"), "",
             f"![tornado]({name}_tornado.png)", ""]
    if "rank_correlations" in tables:
        top = tables["rank_correlations"].reindex(tables["rank_correlations"].msp_rho.abs().sort_values(
            ascending=False).index).head(10)
        lines += ["Spearman rank correlations with the MSP and the footprint (the ten strongest on the MSP):", "",
                  top.to_markdown(index=False, floatfmt=".3f"), ""]
    if "what_it_takes" in tables:
        lines += [("What it takes: each lever alone, the value at which the MSP meets virgin TPA's price and the one at "
                   "which the footprint meets virgin PTA's (empty: not reached between the base over and times "
                   "plant.what_it_takes_span; _p5/_p95: the 5-95 % band over the Monte Carlo's draws, to first "
                   "order in the lever):"), "",
                  tables["what_it_takes"].to_markdown(index=False, floatfmt=".4g"), ""]
    lines += options_lines(name, ok, out_dir)
    lines += ["Published values beside ours:", "", anchors.to_markdown(index=False), ""]
    return lines


def best_options(label: str, t: pd.DataFrame) -> pd.DataFrame:
    """A case's best plants among its option combinations: the cheapest, the cleanest, and the
    cheapest of those below virgin TPA's price, footprint, and both (where any is)."""
    picks = {"cheapest": t, "cleanest": t.sort_values("gwp_kg_per_kg").head(1),
             "cheapest below virgin price": t[t.below_virgin_price],
             "cheapest below virgin footprint": t[t.below_virgin_footprint],
             "cheapest below both": t[t.below_virgin_price & t.below_virgin_footprint]}
    rows = [{"case": label, "best": name, **pick.sort_values("msp_usd_per_kg").iloc[0].to_dict()}
            for name, pick in picks.items() if len(pick)]
    options = [c for c in OPTION_GROUPS if c in t]
    return pd.DataFrame(rows)[["case", "best", *options, "msp_usd_per_kg", "gwp_kg_per_kg"]]


def options_lines(name: str, ok: pd.DataFrame, out_dir: Path) -> list[str]:
    """Where the jobs crossed the plant's options (options.csv): MSP against footprint per case
    with its Pareto front, and each case's best plants."""
    cases = ok.sort_values("plant_fresh_pet_kg_per_h", ascending=False)
    fronts = {case_label(rec.to_dict()): pd.read_csv(Path(rec.job_dir) / "options.csv")
              for _, rec in cases.iterrows() if (Path(rec.job_dir) / "options.csv").is_file()}
    if not fronts:
        return []
    first = cases.iloc[0]
    save_figure(plot_options_front(fronts, first.virgin_tpa_usd_per_kg, first.virgin_tpa_gwp_kg_per_kg),
                out_dir / f"{name}_options")
    best = pd.concat([best_options(label, t) for label, t in fronts.items()], ignore_index=True)
    on_front = pd.concat([t[t.on_front].assign(case=label) for label, t in fronts.items()], ignore_index=True)
    write_table(best, out_dir / f"{name}_best_plants")
    write_table(on_front, out_dir / f"{name}_options_front")
    seconds = ok.plant_options_s.median() if "plant_options_s" in ok else float("nan")
    return [(f"Options crossed around each case's mill (plant.options_front; {len(next(iter(fronts.values())))} "
             f"combinations, {seconds:.1f} s a case): MSP against footprint, the Pareto front in red:"), "",
            f"![options]({name}_options.png)", "", "Each case's best plants:", "",
            best.to_markdown(index=False, floatfmt=".3f"), ""]


def feed(kg_per_h: float) -> str:
    """A break-even feed in words: its kg/h of fresh PET, or that no feed searched reaches it."""
    return "no feed searched" if math.isnan(kg_per_h) else f"{kg_per_h:,.0f} kg/h of fresh PET"


def regional_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """One plant for the states against a plant each (study=regional): the sites, each state joined
    to its nearest larger neighbour or not, the figure."""
    lines = []
    for _, rec in ok.iterrows():
        job = Path(rec.job_dir)
        sites, states = pd.read_csv(job / "sites.csv"), pd.read_csv(job / "states.csv")
        scales = pd.read_csv(job / "scale.csv")
        write_table(scales, out_dir / f"{name}_scale")
        write_table(sites, out_dir / f"{name}_sites")
        write_table(states, out_dir / f"{name}_states")
        shutil.copy(job / "regional.png", out_dir / f"{name}.png")
        lines += [f"## One plant for {rec.regional_states} against a plant each (BPR {rec.bpr:g})", "",
                  (f"The plant for all at {rec.regional_site}'s centre of population: MSP {rec.regional_msp_usd_per_kg:.3f} "
                   f"$/kg rTPA, {rec.regional_gwp_kg_per_kg:.2f} kg CO2e/kg, the bales hauled {rec.regional_haul_km:.0f} "
                   f"km on average ({rec.regional_haul_usd_per_t_bales:.1f} $ and "
                   f"{rec.regional_haul_kg_co2e_per_t_bales:.1f} kg CO2e per t of bales at "
                   f"{rec.haul_usd_per_t_km:.4f} $/t-km and {rec.haul_kg_co2e_per_t_km:.4f} kg CO2e/t-km); a plant "
                   f"each: {rec.apart_msp_usd_per_kg:.3f} $/kg and {rec.apart_gwp_kg_per_kg:.2f} kg CO2e/kg "
                   f"(rTPA-weighted); virgin TPA {rec.virgin_tpa_usd_per_kg:.3f} $/kg, "
                   f"{rec.virgin_tpa_gwp_kg_per_kg:.2f} kg CO2e/kg ({rec.regional_s:.1f} s)."), "",
                  (f"Scale: one plant (US grid, no haul) meets virgin TPA's price at {feed(rec.break_even_fresh_pet_kg_per_h)} "
                   f"and virgin PTA's footprint at {feed(rec.break_even_gwp_fresh_pet_kg_per_h)}:"), "",
                  scales.to_markdown(index=False, floatfmt=".4g"), "",
                  "The plant for all at each candidate site:", "",
                  sites[["site", "haul_km", "haul_usd_per_t_bales", "haul_kg_co2e_per_t_bales", "msp_usd_per_kg",
                         "gwp_kg_per_kg"]].to_markdown(index=False, floatfmt=".3f"), "",
                  ("Each state's own plant against sharing its nearest larger neighbour's (its bales hauled there; "
                   "apart: the two plants' rTPA-weighted values):"), "",
                  states.to_markdown(index=False, floatfmt=".3f"), "", f"![regional]({name}.png)", ""]
    return lines


def cheapest_mill_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """Per case: the paper's mill against the cheapest (knobs, residence time, power, annualised
    cost) by the surrogate and by the DEM confirmation; the cost saved; what each knob is worth."""
    rows = []
    for rec in ok.to_dict("records"):
        label = f"{case_label(rec)} ({rec['yield_rule']})"
        for mill in ("paper", "optimum"):
            dem = rec.get(f"{mill}_dem_annualised_cost_usd_per_yr", np.nan)
            rows.append({"case": label, "mill": mill, "speed / critical": rec[f"{mill}_fraction_of_critical"],
                         "fill": rec[f"{mill}_fill_fraction"],
                         "ball radius (m)": rec[f"{mill}_ball_radius_m"],
                         "L/D": rec[f"{mill}_length_m"] / rec[f"{mill}_diameter_m"],
                         "D (m)": rec[f"{mill}_diameter_m"], "residence (min)": rec[f"{mill}_residence_time_min"],
                         "balls": rec[f"{mill}_ball_count"], "power kW (surrogate)": rec[f"{mill}_dem_power_w"] / 1e3,
                         "power kW (DEM)": rec.get(f"{mill}_dem_dem_power_w", np.nan) / 1e3,
                         "k$/yr (surrogate)": rec[f"{mill}_annualised_cost_usd_per_yr"] / 1e3,
                         "k$/yr (DEM)": dem / 1e3, "inside hull": rec[f"{mill}_dem_inside_hull"]})
    table = pd.DataFrame(rows)
    write_table(table, out_dir / f"{name}_mills")
    knobs = ok[["region", "bpr", "yield_rule", "cost_saved_fraction",
                *[c for c in ("cost_saved_fraction_dem",) if c in ok],
                *[c for c in ok if c.startswith("knob_")]]]
    return ["## The cheapest mill", "", table.to_markdown(index=False, floatfmt=".4g"), "",
            "Cost saved, and the optimum's cost increase with one knob back at the paper's value:", "",
            knobs.rename(columns=lambda c: c.removeprefix("knob_").removesuffix("_cost_increase_fraction")).to_markdown(
                index=False, floatfmt=".3g"), ""]


def measured_power_lines(name: str, ok: pd.DataFrame, spec: StudyReport, out_dir: Path) -> list[str]:
    """Each run's DEM power against every measurement of its experiment (data/measured_mill_power.csv),
    per wall restitution and friction, with the charge shape and the empirical models beside."""
    measured = table("measured_mill_power.csv")
    rows = []
    for rec in ok.to_dict("records"):
        for m in measured[measured.experiment == rec.get("experiment")].itertuples():
            rows.append({
                "experiment": m.experiment, "measurement": m.condition, "in the mill": m.charge_present,
                "wall restitution": rec["wall_restitution"], "wall friction": rec["wall_friction"],
                "measured W": m.measured_power_w, "DEM W": rec["dem_power_w"], "DEM SE W": rec["dem_power_se_w"],
                "DEM / measured": rec["dem_power_w"] / m.measured_power_w,
                "torque arm W": rec["dem_torque_arm_power_w"], "Morrell C-model W": rec["dem_morrell_net_power_w"],
                "Bond/Rowland W": rec["bond_rowland_power_w"], "toe deg": rec["dem_charge_toe_deg"],
                "shoulder deg": rec["dem_charge_shoulder_deg"], "Morrell toe deg": rec["dem_morrell_toe_deg"],
                "Morrell shoulder deg": rec["dem_morrell_shoulder_deg"], "regime": rec["dem_charge_regime"]})
    if not rows:
        return ["No run names an experiment of data/measured_mill_power.csv (study.experiment).", ""]
    frame = pd.DataFrame(rows).sort_values(["measurement", "wall restitution", "wall friction"])
    write_table(frame, out_dir / f"{name}_measured")
    save_figure(plot_measured_power(frame), out_dir / f"{name}_measured")
    sources = measured[measured.experiment.isin(frame.experiment)]
    return ["## Predicted against measured mill power", "", f"![measured]({name}_measured.png)", "",
            frame.to_markdown(index=False, floatfmt=".3g"), "", "What was measured and what had to be assumed:", "",
            *[f"- {m.experiment}, {m.condition}: {m.measured_as}; {m.source} ({m.year}, {m.location}), {m.url}. "
              f"Assumed: {m.assumed}" for m in sources.itertuples()], ""]


# The parts a study's report may name (study.report.sections), in the order it lists them.
SECTIONS = {
    "design_table": lambda name, ok, spec, out: design_table(name, ok, spec),
    "paper_comparison": lambda name, ok, spec, out: paper_comparison(name, ok, spec),
    "shape_rule": lambda name, ok, spec, out: shape_rule_table(name, ok, spec),
    "impacts": impact_lines,
    "lab": lab_lines,
    "scaleup_rule": scaleup_rule_lines,
    "yield_calibration": yield_calibration_lines,
    "yield_fit": yield_fit_lines,
    "yield_designs": yield_design_lines,
    "plant": plant_lines,
    "cheapest_mill": cheapest_mill_lines,
    "regional": regional_lines,
    "measured_power": measured_power_lines,
}


def study_report(ok: pd.DataFrame) -> StudyReport:
    """The report spec of the sweep's study, from the resolved config of its first finished job
    (none finished: the failures alone are listed)."""
    if ok.empty:
        return StudyReport()
    path = Path(ok.job_dir.iloc[0]) / "config_resolved.yaml"
    try:
        study = OmegaConf.load(path).study
    except Exception as exc:  # missing, truncated or not YAML
        raise ConfigError(f"{path}: cannot read the study's config ({one_line(exc)}); run the sweep again") from exc
    return to_object(study, StudyConfig, "study").report


def band(ok: pd.DataFrame, value: str, low: str, high: str, digits: int) -> pd.Series:
    """Each case's value with its Monte Carlo's 5-95 % band, `value (low-high)`, when there is one."""
    shown = f"{{:.{digits}f}}".format
    text = ok[value].map(shown)
    return text + " (" + ok[low].map(shown) + "-" + ok[high].map(shown) + ")" if low in ok else text


def headline(ok: pd.DataFrame) -> list[str]:
    """The figures a reader wants first, one row per case: a plant's MSP and footprint with their
    Monte Carlo bands, else a mill's power, electricity and purchase cost."""
    cases = ok.apply(lambda rec: case_label(rec.to_dict()), axis=1) if len(ok) else pd.Series(dtype=str)
    if "msp_usd_per_kg" in ok and "gwp_total_kg_per_kg" in ok:
        frame = pd.DataFrame({
            "case": cases,
            "MSP $/kg rTPA (5-95 %)": band(ok, "msp_usd_per_kg", "msp_p5_usd_per_kg", "msp_p95_usd_per_kg", 3),
            "footprint kg CO2e/kg rTPA (5-95 %)": band(ok, "gwp_total_kg_per_kg", "gwp_p5_kg_per_kg",
                                                       "gwp_p95_kg_per_kg", 2)})
    elif {"dem_power_w", "dem_power_se_w", "electricity_usd_per_t_pet", "purchase_cost_usd"} <= set(ok):
        frame = pd.DataFrame({"case": cases, "power kW": (ok.dem_power_w / 1e3).map("{:.2f}".format) + " +- "
                              + (ok.dem_power_se_w / 1e3).map("{:.2f}".format),
                              "electricity $/t PET": ok.electricity_usd_per_t_pet.map("{:.2f}".format),
                              "purchase cost $": ok.purchase_cost_usd.map("{:,.0f}".format)})
    else:
        return []
    return ["## Headline", "", frame.to_markdown(index=False), ""]


def report(sweep_dir: Path, out_dir: Path) -> Path:
    """Tables (Parquet + CSV with provenance), figures and <study>.md for one sweep folder."""
    df = collect(sweep_dir)
    name = str(df.study.iloc[0])
    ok = df[df.status == "ok"]
    failed = df[df.status != "ok"]
    spec = study_report(ok)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_table(df, out_dir / name)
    lines = [f"# {name}: {len(ok)} finished, {len(failed)} failed runs", "", f"Sweep folder: `{sweep_dir}`", "",
             *headline(ok)]
    if len(ok) and spec.figure:
        save_figure(FIGURES[spec.figure](ok), out_dir / name)
        lines += [f"![{name}]({name}.png)", ""]
    for section in spec.sections if len(ok) else ():
        lines += SECTIONS[section](name, ok, spec, out_dir)
    for rec in failed.itertuples():
        lines.append(f"- FAILED `{rec.job_dir}`: {rec.error}")
    for rec in ok[ok.dem_steady.eq(False)].itertuples() if "dem_steady" in ok else ():
        lines.append(f"- UNSTEADY `{rec.job_dir}`: the power is not the steady one: {rec.dem_unsteady_reason}")
    path = out_dir / f"{name}.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def finished(out_dir: Path, name: str) -> pd.DataFrame:
    """The finished runs of a report in out_dir (its <name>.parquet)."""
    df = read_parquet(out_dir / f"{name}.parquet")
    return df[df.status == "ok"]


def index(out_dir: Path) -> Path:
    """out_dir/index.md: each report in the folder with its headline, and a link to each of its
    tables and figures (a file belongs to the report whose name is the longest prefix of its own)."""
    reports = sorted(p.stem for p in out_dir.glob("*.md") if p.name != "index.md" and (out_dir / f"{p.stem}.parquet").is_file())
    files: dict[str, list[str]] = {name: [] for name in reports}
    for path in sorted(out_dir.iterdir()):
        owner = max((n for n in reports if path.name.startswith((f"{n}.", f"{n}_"))), key=len, default=None)
        if owner and path.suffix != ".md":
            files[owner].append(path.name)
    lines = ["# Report", "", f"Every table (Parquet, CSV) and figure (PNG, SVG) in `{out_dir}`, by report.", ""]
    for name in reports:
        title = (out_dir / f"{name}.md").read_text().splitlines()[0].removeprefix("# ")
        lines += [f"## [{title}]({name}.md)", "",
                  *(f"#{line}" if line.startswith("## ") else line for line in headline(finished(out_dir, name))),
                  "Files: " + ", ".join(f"[{f}]({f})" for f in files[name]), ""]
    path = out_dir / "index.md"
    path.write_text("\n".join(lines) + "\n")
    return path
