"""Discounted cash flow and the minimum selling price (MSP) of the product.

Years 0 .. C-1: construction, the fixed capital spent by `construction_fractions`; working
capital at the start of operation (year C), returned at the end; years C .. C+L-1: operation.
Taxable income = revenue - operating cost - depreciation (MACRS, data table); the tax is
taken as a credit when negative (the plant belongs to a larger taxpayer, the NREL convention),
so the net present value is linear in the price and the MSP is exact.  Discounting by
numpy-financial's npv (cash flows at the end of each year, year 0 undiscounted).
"""

from __future__ import annotations

import numpy as np
import numpy_financial as npf

from ..config import PlantConfig
from ..data import table


def cash_flows(price_usd_per_t: float, product_t_per_yr: float, opex_usd_per_yr: float, fixed_usd: float,
               working_usd: float, cfg: PlantConfig) -> np.ndarray:
    """Yearly after-tax cash flows ($), construction first."""
    build = len(cfg.construction_fractions)
    years = build + cfg.plant_life_yr
    flows = np.zeros(years)
    flows[:build] -= fixed_usd * np.asarray(cfg.construction_fractions)
    depreciation = np.zeros(years)
    schedule = table(cfg.depreciation_file).fraction.to_numpy()
    span = min(len(schedule), cfg.plant_life_yr)
    depreciation[build:build + span] = fixed_usd * schedule[:span]
    margin = np.zeros(years)
    margin[build:] = price_usd_per_t * product_t_per_yr - opex_usd_per_yr
    flows += margin - cfg.tax_rate * (margin - depreciation)
    flows[build] -= working_usd
    flows[-1] += working_usd
    return flows


def npv_usd(flows: np.ndarray, rate: float) -> float:
    return float(npf.npv(rate, flows))


def minimum_selling_price(product_t_per_yr: float, opex_usd_per_yr: float, fixed_usd: float, working_usd: float,
                          cfg: PlantConfig) -> float:
    """The product price ($/t) at which the net present value is zero."""
    def npv(price):
        return npv_usd(cash_flows(price, product_t_per_yr, opex_usd_per_yr, fixed_usd, working_usd, cfg),
                       cfg.discount_rate)

    at_zero = npv(0.0)
    return -at_zero / (npv(1.0) - at_zero)
