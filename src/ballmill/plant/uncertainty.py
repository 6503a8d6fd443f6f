"""The plant's uncertainty on BioSTEAM's Model: the parameters of data/plant_uncertainty.csv
(each with its range and basis), the large units' purchase costs between their two published
correlations, the DEM power's standard error; Latin-hypercube Monte Carlo of the MSP and the
footprint, Spearman rank correlations, and the one-at-a-time tornado (BioSTEAM's
single-point sensitivity).

Ranges are absolute (in the parameter's own unit) except `factor` rows, which scale the base.
The DEM is never rerun: every draw re-simulates the plant around the same built mill.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Callable

import biosteam as bst
import chaospy
import numpy as np
import pandas as pd

from ..config import ConfigError, PlantConfig
from ..data import table
from .footprint import characterize
from .model import CROSS_CHECKS, Plant, inputs

FILE = "plant_uncertainty.csv"
PRICED_STREAMS = {"pet_bale": ("bales",), "naoh": ("NaOH",), "h2so4": ("sulfuric_acid",),
                  "disposal": ("sorting_residue", "grinding_fines", "purged_PET", "residue")}
STEAM = ("low_pressure_steam", "medium_pressure_steam", "high_pressure_steam")
# parameters read only after the simulation (stream prices, the TEA's rates; and the footprint's
# factors, ghg.*): a tornado point that moves only these solves the TEA without re-simulating.
# Not the steam and electricity prices: the simulation books the utilities' costs.
READ_AFTER_SIMULATION = {"price.pet_bale", "price.naoh", "price.h2so4", "price.eg", "price.disposal",
                         "plant.eg_price_fraction", "plant.na2so4_usd_per_t", "plant.operator_wage_usd_per_yr",
                         "plant.supervision_fraction", "plant.maintenance_fraction", "plant.discount_rate"}


def setters(p: Plant, power_se_kw: float) -> dict[str, tuple[float, Callable[[float], None]]]:
    """parameter -> (its base value, a function that sets it in the built plant)."""
    s, u, cfg = p.ps.streams, p.ps.units, p.cfg
    mill = u["R201"]
    base_power, base_x = mill.power_kw, mill.conversion
    out = {}

    def price(item: str, ids: tuple[str, ...], sign: float = 1.0):
        def set_(v):
            for ID in ids:
                if ID in s:
                    s[ID].price = sign * v / 1000.0
        return p.prices[item] * 1000.0, set_

    for item, ids in PRICED_STREAMS.items():
        out[f"price.{item}"] = price(item, ids, -1.0 if item == "disposal" else 1.0)

    def eg_price(v=None, fraction=None):
        p.prices["eg"] = v / 1000.0 if v is not None else p.prices["eg"]
        cfg.eg_price_fraction = fraction if fraction is not None else cfg.eg_price_fraction
        s["EG"].price = p.prices["eg"] * cfg.eg_price_fraction

    out["price.eg"] = (p.prices["eg"] * 1000.0, lambda v: eg_price(v=v))
    out["plant.eg_price_fraction"] = (cfg.eg_price_fraction, lambda v: eg_price(fraction=v))
    out["plant.na2so4_usd_per_t"] = (cfg.na2so4_usd_per_t, lambda v: setattr(s["Na2SO4"], "price", v / 1000.0))

    def steam(f):
        for agent in STEAM:
            bst.HeatUtility.get_agent(agent).regeneration_price = p.prices[agent] * f * 18.01528
    out["price.steam_factor"] = (1.0, steam)
    out["economics.electricity_usd_per_kwh"] = (bst.PowerUtility.price, lambda v: setattr(bst.PowerUtility, "price", v))
    out["dem.power"] = (0.0, lambda z: setattr(mill, "power_kw", max(0.0, base_power + z * power_se_kw)))
    out["yield.conversion"] = (1.0, lambda f: setattr(mill, "conversion", min(1.0, base_x * f)))
    out["plant.granulation_kwh_per_t"] = (u["U102"].energy_kwh_per_t, lambda v: setattr(u["U102"], "energy_kwh_per_t", v))

    def tpa_recovery(v):
        cfg.tpa_recovery = v
        u["S301"].isplit["TPA"] = v
    out["plant.tpa_recovery"] = (cfg.tpa_recovery, tpa_recovery)
    for name in ("bale_pet_fraction", "eg_stripper_recovery", "dissolution_water_kg_per_kg_na2tpa",
                 "operator_wage_usd_per_yr", "supervision_fraction", "maintenance_fraction"):
        out[f"plant.{name}"] = (getattr(cfg, name), lambda v, n=name: setattr(cfg, n, v))
    out["plant.discount_rate"] = (p.tea.IRR, lambda v: setattr(p.tea, "IRR", v))
    for ID in CROSS_CHECKS:
        out[f"equipment.{ID}"] = (1.0, lambda f, unit=u[ID]: setattr(unit, "cost_factor", f))

    def ghg(item):
        def set_(v):
            p.cf[item] = v
            characterize(s, p.cf, p.region, cfg.landfill)
        return p.cf[item], set_
    for item in p.cf:
        out[f"ghg.{item}"] = ghg(item)
    return out


def table_values(p: Plant) -> dict[str, float]:
    """parameter -> the value the data tables and defaults give it, for the parameters whose base
    the config overrides (`plant.prices_usd_per_t`, `plant.ghg_kg_co2e`, a plant field)."""
    defaults = PlantConfig()
    prices, cf = inputs(defaults, p.econ)
    out = {f"price.{k}": prices[k] * 1000.0 for k in p.cfg.prices_usd_per_t} | {f"ghg.{k}": cf[k] for k in p.cfg.ghg_kg_co2e}
    return out | {f"plant.{f.name}": getattr(defaults, f.name) for f in dataclasses.fields(PlantConfig)
                  if isinstance(getattr(defaults, f.name), float) and getattr(p.cfg, f.name) != getattr(defaults, f.name)}


def ranges(p: Plant) -> pd.DataFrame:
    """The uncertain parameters: data/plant_uncertainty.csv, and each cross-checked unit's
    purchase cost uniform between its two correlations (as factors on the base).  An absolute
    range of a parameter whose base the config overrides becomes factors on the table's value,
    so that a price or factor of one's own keeps the table's relative band."""
    rows = table(FILE).copy()
    for parameter, value in table_values(p).items():
        at = (rows.parameter == parameter) & (rows.scale == "absolute")
        if value and at.any():
            rows.loc[at, ["low", "high"]] = rows.loc[at, ["low", "high"]] / value
            rows.loc[at, "scale"] = "factor"
    checks = p.units_table().dropna(subset=["second_over_base"])
    extra = pd.DataFrame({"parameter": "equipment." + checks.unit, "distribution": "uniform", "scale": "factor",
                          "low": np.minimum(1.0, checks.second_over_base),
                          "high": np.maximum(1.0, checks.second_over_base),
                          "basis": "between BioSTEAM's price and " + checks.second_correlation, "source": "",
                          "year": np.nan, "url": ""})
    return pd.concat([rows, extra], ignore_index=True)


def distribution(row, base: float):
    if row.distribution == "normal":
        return chaospy.Normal(0.0, 1.0)
    lo, hi = (row.low * base, row.high * base) if row.scale == "factor" else (row.low, row.high)
    if not lo <= base <= hi:
        raise ConfigError(f"data/{FILE}: {row.parameter}'s range [{lo:g}, {hi:g}] does not hold its base {base:g}")
    if lo == hi:
        return None
    return chaospy.Triangle(lo, base, hi) if row.distribution == "triangular" else chaospy.Uniform(lo, hi)


def model(p: Plant, power_se_kw: float) -> bst.Model:
    """BioSTEAM's Model of the plant: its parameters and the MSP and footprint as indicators."""
    m = bst.Model(p.ps.system)
    known = setters(p, power_se_kw)
    for row in ranges(p).itertuples():
        if row.parameter not in known:
            raise ConfigError(f"data/{FILE}: unknown parameter {row.parameter!r}; known: {sorted(known)}")
        base, setter = known[row.parameter]
        dist = distribution(row, base)
        if dist is None:
            continue
        bounds = (-2.0, 2.0) if row.distribution == "normal" else (float(dist.lower[0]), float(dist.upper[0]))
        q = m.parameter(setter, name=row.parameter, distribution=dist, baseline=base, bounds=bounds,
                        coupled=row.parameter.split(".")[0] in ("yield", "plant"), description=row.basis)
        q.name = row.parameter  # BioSTEAM titles names ("Price.pet bale"): keep the table's
    m.indicator(lambda: p.tea.solve_price(p.rtpa), "MSP", "USD/kg")
    m.indicator(lambda: p.footprint()["total"], "GWP", "kg CO2e/kg")
    return m


def monte_carlo(m: bst.Model, draws: int, seed: int) -> tuple[pd.DataFrame, float]:
    """Latin-hypercube draws of every parameter: the table of inputs and indicators, and the
    seconds it took.  chaospy draws from NumPy's global generator, hence its seeding here."""
    started = time.perf_counter()
    np.random.seed(seed)
    samples = m.sample(draws, "L")
    m.load_samples(samples, sort=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a draw's design warnings: the base case's are recorded
        m.evaluate()
    out = m.table.copy()
    out.columns = [c[1].split(" [")[0] for c in out.columns]
    return out, time.perf_counter() - started


def rank_correlations(m: bst.Model) -> pd.DataFrame:
    """Spearman's rho of each parameter with the MSP and the footprint."""
    rho, _ = m.spearman_r()
    rho.index = [i[1] for i in rho.index]
    rho.columns = ["msp_rho", "gwp_rho"]
    return rho.rename_axis("parameter").reset_index()


def read_after_simulation(parameter: str) -> bool:
    return parameter in READ_AFTER_SIMULATION or parameter.startswith("ghg.")


def tornado(m: bst.Model) -> pd.DataFrame:
    """The MSP and footprint at each parameter's low and high end, the others at base; largest
    MSP swing first.  A point that differs from the last simulation only in parameters read
    after it (READ_AFTER_SIMULATION, the footprint's factors) is not simulated again (BioSTEAM's
    own method re-simulates every point)."""
    simulated = {}  # parameter read in the simulation -> its value there

    def evaluate(sample, **kwargs):
        for q, v in zip(m.parameters, sample):
            q.setter(v)
        read = {q.name: v for q, v in zip(m.parameters, sample) if not read_after_simulation(q.name)}
        if read != simulated:
            m.system.simulate(**kwargs)
            simulated.update(read)
        return [indicator() for indicator in m.indicators]

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, lower, upper = m.single_point_sensitivity(evaluate=evaluate)
    names = [q.name for q in m.parameters]
    out = pd.DataFrame({"parameter": names,
                        "low": [q.bounds[0] for q in m.parameters], "high": [q.bounds[1] for q in m.parameters],
                        "msp_low_usd_per_kg": lower.iloc[:, 0].to_numpy(),
                        "msp_high_usd_per_kg": upper.iloc[:, 0].to_numpy(),
                        "gwp_low_kg_per_kg": lower.iloc[:, 1].to_numpy(),
                        "gwp_high_kg_per_kg": upper.iloc[:, 1].to_numpy()})
    out["msp_swing_usd_per_kg"] = (out.msp_high_usd_per_kg - out.msp_low_usd_per_kg).abs()
    return out.sort_values("msp_swing_usd_per_kg", ascending=False, ignore_index=True)
