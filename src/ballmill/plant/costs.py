"""Equipment purchase costs, capital and operating costs of the plant.

Purchase costs: one correlation per unit (data/equipment_costs.csv: C = a + b S^n or
C = exp(a + b ln S + n ln^2 S), its size range and cost index), brought to the target year by
CEPCI; a unit larger than the correlation's range is split into equal parallel units, one below
it is costed at the smallest size.  Capital (Towler & Sinnott 2012, Table 7.4, mixed
fluid-solid plants): ISBL = sum C [(1 + fp) fm + f_rest], fp = 0.6 piping, fm the material
factor; direct cost = ISBL (1 + site); fixed capital = direct cost (1 + indirect) (NREL
factors, see conf/plant/nrel.yaml); working capital a share of it.
"""

from __future__ import annotations

import math
from functools import cache

from ..config import EconomicsConfig, PlantConfig
from ..data import lookup, table
from ..economics import cepci

PIPING_FACTOR = 0.6  # fp of Towler & Sinnott Table 7.4, fluid-solid plants: the material factor applies to it too


def correlation_cost(row, size: float) -> float:
    s = size * row.to_correlation_unit
    if row.form == "exp_quadratic":
        return math.exp(row.a + row.b * math.log(s) + row.n * math.log(s) ** 2)
    return row.a + row.b * s**row.n


@cache
def correlations(name: str) -> dict:
    """unit -> its correlation row (a named tuple) of the cost table `name`."""
    return {row.unit: row for row in table(name).itertuples()}


def purchase_costs(sizes: dict[str, float], cfg: PlantConfig, econ: EconomicsConfig) -> list[dict]:
    """One row per unit: size, parallel units, purchase cost in the target year ($).  Plain rows,
    not a DataFrame: the Monte Carlo costs the plant thousands of times."""
    target = cepci(econ.cepci_target_year, econ)
    rows = []
    for unit, size in sizes.items():
        row = correlations(cfg.cost_file)[unit]
        lo, hi = row.s_min / row.to_correlation_unit, row.s_max / row.to_correlation_unit
        count = max(1, math.ceil(size / hi))
        each = max(size / count, lo)
        cost = count * correlation_cost(row, each) * target / row.cost_index * cfg.equipment_cost_factor
        rows.append({"unit": unit, "size": size, "size_unit": row.size_si_unit, "parallel_units": count,
                     "below_range": size / count < lo, "material": row.material, "purchase_cost_usd": cost})
    return rows


def capital(equipment: list[dict], cfg: PlantConfig) -> dict:
    """ISBL per unit (added to each row of `equipment`), direct and fixed capital and working
    capital ($)."""
    for row in equipment:
        fm = cfg.stainless_factor if row["material"] == "stainless" else 1.0
        row["isbl_usd"] = row["purchase_cost_usd"] * (cfg.installation_factor + (1 + PIPING_FACTOR) * (fm - 1))
    isbl = math.fsum(row["isbl_usd"] for row in equipment)
    direct = isbl * (1 + cfg.site_factor)
    fixed = direct * (1 + cfg.indirect_factor)
    return {"purchase_cost_total_usd": math.fsum(row["purchase_cost_usd"] for row in equipment), "isbl_usd": isbl,
            "direct_cost_usd": direct, "fixed_capital_usd": fixed,
            "working_capital_usd": cfg.working_capital_fraction * fixed}


def operating_costs(streams: dict, utilities: dict, mill_power_w: float, isbl_usd: float, fixed_usd: float,
                    cfg: PlantConfig, econ: EconomicsConfig, prices: dict[str, float]) -> dict[str, float]:
    """Yearly costs ($/yr, positive) and credits (negative) by category; `prices` overrides rows
    of data/prices.csv ($/t)."""
    t_per_yr = econ.hours_per_year / 1000.0  # kg/h -> t/yr

    def tonnes(stream: str, component: str) -> float:
        return streams[stream].get(component, 0.0) * t_per_yr

    def price_usd_per_t(item: str) -> float:
        return prices[item] if item in prices else lookup("prices.csv", "item", item, "price_usd_per_t")

    kwh = econ.hours_per_year * econ.electricity_usd_per_kwh / 1000.0  # $ per W-year
    waste = tonnes("purged PET", "pet") + sum(streams["EG column residue"].values()) * t_per_yr
    return {
        "pet_bale": tonnes("bale PET", "pet") * price_usd_per_t("pet_bale"),
        "naoh": tonnes("NaOH", "naoh") * price_usd_per_t("naoh"),
        "h2so4": tonnes("sulfuric acid", "h2so4") * price_usd_per_t("h2so4"),
        "process_water": utilities["process_water_t_per_h"] * econ.hours_per_year * cfg.process_water_usd_per_t,
        "electricity_mill": mill_power_w * kwh,
        "electricity_shredder": 1000.0 * utilities["shredder_electricity_kw"] * kwh,
        "steam": utilities["steam_kg_per_h"] * t_per_yr * cfg.steam_usd_per_t,
        "cooling_water": utilities["cooling_water_t_per_h"] * econ.hours_per_year * cfg.cooling_water_usd_per_t,
        "waste_disposal": -waste * cfg.residue_usd_per_t,
        "labour": cfg.staff * cfg.salary_usd_per_yr * (1 + cfg.labour_burden),
        "maintenance": cfg.maintenance_fraction * isbl_usd,
        "insurance_and_tax": cfg.insurance_fraction * fixed_usd,
        "eg_credit": -tonnes("EG", "eg") * price_usd_per_t("eg"),
        "na2so4_credit": -tonnes("Na2SO4 crystals", "na2so4") * cfg.na2so4_usd_per_t,
    }
