"""The plant's techno-economics in NREL's nth-plant convention (Humbird et al. 2011,
NREL/TP-5100-47764, as BioSTEAM's cellulosic biorefineries code it), on BioSTEAM's TEA.

Capital: installed equipment (each unit's purchase cost x its bare-module factor) + warehouse,
site development and additional piping on the inside-battery-limits (ISBL) part = direct cost;
+ prorateable, field, construction and contingency = depreciable capital; + other indirect =
fixed capital; working capital a share of it.  Fixed operating cost: labour (the staffing rule
below) with its burden, maintenance on ISBL installed cost (NREL) or on the fixed capital
(plant.maintenance_basis), property insurance on fixed capital.  Variable
cost: the streams' prices and the utilities.  `solve_price` finds the rTPA price at which the
net present value at the internal rate of return is zero (the minimum selling price).

Staffing: operators per shift = sum over units of Peters, Timmerhaus & West's workers per unit
per shift (data/staffing.csv) x parallel units; staff = that x the shift factor (Turton et al.:
4.5 operators per position around the clock), paid the operators' wage with supervision on top.
"""

from __future__ import annotations

import math

import biosteam as bst
import flexsolve as flx
import numpy as np
from biosteam._tea import NPV_with_sales

from ..data import lookup, table
from .units import OnSiteSteam

STAFFING_FILE = "staffing.csv"
SALES_TOLERANCE_USD_PER_YR = 1e-4  # BioSTEAM stops within 10 $/yr of sales, ~1e-6 of the MSP: start-dependent
OSBL = (bst.StorageTank, bst.CoolingTower, OnSiteSteam)  # outside the battery limits: no warehouse/site/piping add-on


def operators_per_shift(units) -> float:
    """Sum of workers per unit per shift (data/staffing.csv) over the units and their parallel copies."""
    per_unit = table(STAFFING_FILE).set_index("unit").workers_per_unit_per_shift
    total = 0.0
    for u in units:
        name = type(u).__name__
        if name in per_unit:
            total += float(per_unit[name]) * int(u.parallel.get("self", 1))
    return total


def staff(units, cfg) -> int:
    """Operating staff around the clock: operators per shift x the shift factor, rounded up
    (plant.staff with plant.staffing=fixed)."""
    if cfg.staffing == "fixed":
        return cfg.staff
    return math.ceil(operators_per_shift(units) * cfg.operators_per_position)


class PlantTEA(bst.TEA):
    """NREL's convention on BioSTEAM's TEA (cfg: PlantConfig)."""

    def __init__(self, system: bst.System, cfg, hours_per_year: float, start_year: int):
        super().__init__(
            system=system, IRR=cfg.discount_rate, duration=(start_year, start_year + cfg.plant_life_yr),
            depreciation=table(cfg.depreciation_file).fraction.to_numpy(), income_tax=cfg.tax_rate,
            operating_days=hours_per_year / 24.0, lang_factor=None,
            construction_schedule=tuple(cfg.construction_fractions), startup_months=cfg.startup_months,
            startup_FOCfrac=1.0, startup_VOCfrac=0.75, startup_salesfrac=0.5,
            WC_over_FCI=cfg.working_capital_fraction, finance_interest=cfg.loan_interest,
            finance_years=cfg.loan_years, finance_fraction=cfg.loan_fraction)
        self.cfg = cfg

    def solve_sales(self) -> float:
        """Yearly sales ($) to add for NPV = 0: BioSTEAM's answer refined by secant steps to
        SALES_TOLERANCE_USD_PER_YR, so that the MSP does not depend on where the solver started."""
        rough = super().solve_sales()
        years = self._get_duration_array()
        coefficients = np.ones_like(years, dtype=float)
        coefficients[:self._start] = 0.0
        coefficients[self._start] = self._startup_time * self.startup_salesfrac + 1.0 - self._startup_time
        args = (*self._taxable_nontaxable_depreciation_cashflows(), coefficients, (1 + self.IRR) ** years,
                self._fill_tax_and_incentives)
        self._sales = flx.aitken_secant(NPV_with_sales, rough, rough + 1.0, xtol=SALES_TOLERANCE_USD_PER_YR,
                                        ytol=SALES_TOLERANCE_USD_PER_YR, maxiter=100, args=args, checkiter=True)
        return self._sales

    @property
    def isbl_installed_usd(self) -> float:
        return sum(u.installed_cost for u in self.units if not isinstance(u, OSBL))

    @property
    def staff(self) -> int:
        return staff(self.units, self.cfg)

    @property
    def labour_usd_per_yr(self) -> float:
        """Salaries of the operating staff with supervision (before the burden)."""
        c = self.cfg
        return self.staff * c.operator_wage_usd_per_yr * (1.0 + c.supervision_fraction)

    def _DPI(self, installed_equipment_cost):
        c = self.cfg
        return installed_equipment_cost + self.isbl_installed_usd * (c.warehouse + c.site_development
                                                                     + c.additional_piping)

    def _TDC(self, DPI):
        c = self.cfg
        return DPI * (1.0 + c.prorateable + c.field_expenses + c.construction + c.contingency)

    def _FCI(self, TDC):
        return TDC + self.DPI * self.cfg.other_indirect

    def maintenance_usd_per_yr(self, FCI: float) -> float:
        c = self.cfg
        basis = {"isbl_installed": self.isbl_installed_usd, "fixed_capital": FCI}[c.maintenance_basis]
        return basis * c.maintenance_fraction

    def _FOC(self, FCI):
        c = self.cfg
        return (FCI * c.insurance_fraction + self.maintenance_usd_per_yr(FCI)
                + self.labour_usd_per_yr * (1.0 + c.labour_burden))


def configure_utilities(prices: dict[str, float], electricity_usd_per_kwh: float, cepci: float) -> None:
    """BioSTEAM's global prices: steam agents ($/kg -> $/kmol), electricity, the cost index."""
    bst.CE = cepci
    bst.PowerUtility.price = electricity_usd_per_kwh
    for agent in ("low_pressure_steam", "medium_pressure_steam", "high_pressure_steam"):
        a = bst.HeatUtility.get_agent(agent)
        a.regeneration_price = prices[agent] * a.MW  # $/kg x kg/kmol


def prices_usd_per_kg(file: str = "prices.csv") -> dict[str, float]:
    """A prices table (data/prices.csv's form) in $/kg."""
    return {r.item: float(r.price_usd_per_t) / 1000.0 for r in table(file).itertuples()}


def cepci(year: int) -> float:
    return lookup("cepci.csv", "year", year, "cepci")

