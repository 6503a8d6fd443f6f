"""One plant: the flowsheet around a built mill, its costs and the minimum selling price of rTPA.

The mill is the DEM's (its PET throughput, power and purchase cost come from the design);
the fresh feed follows from its conversion per pass and the purge.  `evaluate` is cheap (no
DEM), so the Monte Carlo and the sensitivity study call it thousands of times.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from ..config import EconomicsConfig, PlantConfig
from .costs import capital, operating_costs, purchase_costs
from .dcf import minimum_selling_price
from .flowsheet import Flowsheet, flowsheet
from .streams import stream_table

MILL = "ball mill"
MILL_CATEGORIES = ("electricity_mill",)


@dataclass(frozen=True)
class Mill:
    """The built mill: PET throughput (kg/h), conversion per pass (0-1], NaOH ratio, power (W)
    and purchase cost ($, target year)."""

    pet_kg_per_h: float
    conversion: float
    naoh_to_stoichiometric: float
    power_w: float
    purchase_cost_usd: float


@dataclass
class Plant:
    flows: Flowsheet
    units: list[dict]  # one row per unit (costs.purchase_costs), the mill first
    capital: dict
    opex: dict[str, float]
    rtpa_t_per_yr: float
    msp_usd_per_t: float

    def record(self) -> dict:
        """Flat record: feeds, products, capital, yearly costs and the MSP with its breakdown ($/kg rTPA)."""
        t = self.rtpa_t_per_yr
        opex_total = sum(self.opex.values())
        capital_part = self.msp_usd_per_t - opex_total / t
        isbl = {row["unit"]: row["isbl_usd"] for row in self.units}
        mill_share = isbl[MILL] / self.capital["isbl_usd"]
        mill_section = (capital_part + self.opex["maintenance"] / t) * mill_share + self.opex["electricity_mill"] / t
        return {
            "plant_fresh_pet_kg_per_h": self.flows.streams["bale PET"]["pet"],
            "plant_mill_pet_kg_per_h": self.flows.mill_pet_kg_per_h,
            "plant_rtpa_t_per_yr": t, "plant_eg_kg_per_h": self.flows.streams["EG"]["eg"],
            **{f"plant_{k}": v for k, v in self.capital.items()},
            **{f"plant_isbl_{u.lower().replace(' ', '_')}_usd": v for u, v in isbl.items()},
            **{f"plant_{k}": v for k, v in self.flows.utilities.items()},
            "plant_opex_usd_per_yr": opex_total, **{f"plant_opex_{k}_usd_per_yr": v for k, v in self.opex.items()},
            "msp_usd_per_kg": self.msp_usd_per_t / 1000.0,
            "msp_capital_usd_per_kg": capital_part / 1000.0,
            **{f"msp_{k}_usd_per_kg": v / t / 1000.0 for k, v in self.opex.items()},
            "msp_mill_section_usd_per_kg": mill_section / 1000.0,
            "msp_mill_share": mill_section / self.msp_usd_per_t,
        }

    @property
    def equipment(self) -> pd.DataFrame:
        """The units as a table: size, parallel units, purchase cost and ISBL ($)."""
        return pd.DataFrame(self.units)

    def stream_table(self) -> pd.DataFrame:
        return stream_table(self.flows.streams)


def evaluate(mill: Mill, cfg: PlantConfig, econ: EconomicsConfig, prices: dict[str, float] | None = None) -> Plant:
    """The plant around `mill`; `prices` overrides rows of data/prices.csv ($/t)."""
    fresh = mill.pet_kg_per_h * (1.0 - (1.0 - cfg.recycle_purge_fraction) * (1.0 - mill.conversion))
    flows = flowsheet(fresh, mill.conversion, mill.naoh_to_stoichiometric, cfg)
    equipment = [{"unit": MILL, "size": mill.pet_kg_per_h / 1000.0, "size_unit": "t/h PET", "parallel_units": 1,
                  "below_range": False, "material": "carbon_steel",
                  "purchase_cost_usd": mill.purchase_cost_usd * cfg.equipment_cost_factor},
                 *purchase_costs(flows.sizes, cfg, econ)]
    cap = capital(equipment, cfg)
    opex = operating_costs(flows.streams, flows.utilities, mill.power_w, cap["isbl_usd"], cap["fixed_capital_usd"],
                           cfg, econ, prices or {})
    rtpa = flows.streams["rTPA"]["tpa"] * econ.hours_per_year / 1000.0
    msp = minimum_selling_price(rtpa, sum(opex.values()), cap["fixed_capital_usd"], cap["working_capital_usd"], cfg)
    return Plant(flows, equipment, cap, opex, rtpa, msp)
