"""One plant: the BioSTEAM system around a designed mill, its TEA and footprint, as a record
and tables (streams, units, the cross-check of the large units' prices, variants).

`Plant.evaluate()` simulates and solves the minimum selling price (MSP); the Monte Carlo and
the tornado (uncertainty.py) vary the same objects in place.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import biosteam as bst
import pandas as pd

from .correlations import price
from .footprint import STEAM, allocation_kg_per_kg, breakdown_kg_per_kg, characterize, factors
from .system import MillSpec, PlantSystem, build
from .tea import PlantTEA, cepci, configure_utilities, prices_usd_per_kg

# the large units priced a second way: unit ID -> (correlation key, its size from the unit)
CROSS_CHECKS = {
    "R201": ("ball_mill_towler_2010", lambda u: u.ins[0].F_mass),
    "T201": ("jacketed_agitated_reactor_towler_2010", lambda u: u.design_results["Total volume"] / u.parallel.get("self", 1)),
    "R301": ("jacketed_agitated_reactor_towler_2010", lambda u: u.design_results["Total volume"] / u.parallel.get("self", 1)),
    "S201": ("vacuum_drum_filter_towler_2010", lambda u: u.design_results["Area"] * 0.09290304),
    "S301": ("vacuum_drum_filter_towler_2010", lambda u: u.design_results["Area"] * 0.09290304),
    "D301": ("direct_rotary_dryer_towler_2010", lambda u: u.design_results["Peripheral drum area"]),
    "E401": ("vertical_tube_evaporator_towler_2010", None),
    "C401": ("draft_tube_crystallizer_seider_2017", lambda u: u.design_results["Crystals"]),
}
ITEMS = {"E401": "Evaporators"}  # the cost item a cross-check replaces (else the unit's whole purchase cost)


@dataclass
class Plant:
    """A built plant: the system, its TEA, the prices and factors it was built with."""

    ps: PlantSystem
    tea: PlantTEA
    mill: MillSpec
    cfg: object
    econ: object
    region: str | None
    prices: dict[str, float]
    cf: dict[str, float]
    warnings: list[str] = field(default_factory=list)

    @property
    def rtpa(self) -> bst.Stream:
        return self.ps.streams["rTPA"]

    def evaluate(self) -> dict[str, float]:
        """Simulate, then the MSP ($/kg rTPA) and the footprint (kg CO2e/kg rTPA)."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.ps.system.simulate()
        self.warnings = sorted({str(w.message).replace("\x1b", "") for w in caught})
        return self.indicators()

    def indicators(self) -> dict[str, float]:
        """The MSP ($/kg rTPA) and the footprint (kg CO2e/kg rTPA) of the last simulation."""
        return {"msp_usd_per_kg": self.tea.solve_price(self.rtpa), "gwp_kg_per_kg": self.footprint()["total"]}

    def footprint(self) -> dict[str, float]:
        return breakdown_kg_per_kg(self.ps.system, self.ps.streams, self.rtpa)

    def units_table(self) -> pd.DataFrame:
        """Per unit: type, purchase and installed cost ($), power (kW), heat duty (kW) and the
        second correlation's purchase cost where one is cross-checked."""
        rows = []
        for u in sorted(self.ps.system.cost_units, key=lambda u: u.ID):
            check = self.cross_check(u)
            rows.append({"unit": u.ID, "type": type(u).__name__, "parallel": int(u.parallel.get("self", 1)),
                         "purchase_cost_usd": u.purchase_cost, "installed_cost_usd": u.installed_cost,
                         "priced_below_range": getattr(u, "below_range", None), "power_kw": u.power_utility.rate,
                         "heating_kw": sum(h.duty for h in u.heat_utilities if h.duty > 0 and h.agent.ID in STEAM) / 3600,
                         "cooling_kw": -sum(h.duty for h in u.heat_utilities if h.duty < 0) / 3600.0,
                         **check})
        return pd.DataFrame(rows)

    def cross_check(self, u) -> dict:
        """The unit's purchase cost by its second correlation (cost year $), if it has one and is priced."""
        if u.ID not in CROSS_CHECKS or not u.purchase_cost:
            return {}
        key, size = CROSS_CHECKS[u.ID]
        index = cepci(self.cfg.cost_year)
        sizes = u.body_areas_m2() if size is None else [size(u)]  # the evaporator: body by body
        parts = [price(key, each, index) for each in sizes]
        base = u.purchase_costs.get(ITEMS.get(u.ID), u.purchase_cost) / (u.cost_factor * u.material_factor)
        second = sum(p.usd for p in parts)
        return {"second_correlation": key, "second_purchase_cost_usd": second, "second_over_base": second / base,
                "second_below_range": any(p.below_range for p in parts)}

    def stream_table(self) -> pd.DataFrame:
        """kg/h of each chemical in each of the plant's streams that cross its boundary or join units."""
        s = self.ps.system
        table = {st.ID: {c.ID: st.imass[c.ID] for c in st.chemicals} for st in s.streams if st.F_mass > 0}
        df = pd.DataFrame(table)
        df.loc["total"] = df.sum()
        return df.rename_axis("chemical_kg_per_h")

    def record(self, msp: float) -> dict:
        """Flat record: flows, capital, yearly costs, staff, the MSP and its breakdown ($/kg) and
        the footprint's (kg CO2e/kg)."""
        t, streams = self.tea, self.ps.streams
        kg_per_yr = self.rtpa.F_mass * t.operating_hours
        voc = {s.ID: s.cost * t.operating_hours for s in t.feeds if s.price}
        sales = {s.ID: -s.cost * t.operating_hours for s in t.products if s.price and s is not self.rtpa}
        utilities = {"electricity": t.system.power_utility.cost * t.operating_hours,
                     "steam": sum(h.cost for h in t.system.heat_utilities) * t.operating_hours}
        costs = {**voc, **sales, **utilities, "fixed_operating": t.FOC}  # $/yr; credits negative
        mill = self.ps.units["R201"]
        out = {"plant_bales_kg_per_h": streams["bales"].F_mass, "plant_mill_pet_kg_per_h": mill.ins[0].imass["PET"],
               "plant_rtpa_t_per_yr": kg_per_yr / 1000.0, "plant_eg_kg_per_h": streams["EG"].F_mass,
               "plant_na2so4_kg_per_h": streams["Na2SO4"].F_mass, "plant_staff": t.staff,
               "plant_purchase_cost_usd": t.purchase_cost, "plant_installed_cost_usd": t.installed_equipment_cost,
               "plant_fixed_capital_usd": t.FCI, "plant_working_capital_usd": t.working_capital,
               "plant_total_capital_usd": t.TCI, "plant_voc_usd_per_yr": t.VOC, "plant_foc_usd_per_yr": t.FOC,
               "plant_labour_usd_per_yr": t.labour_usd_per_yr * (1 + self.cfg.labour_burden),
               "plant_electricity_kw": t.system.power_utility.rate, "plant_mill_power_kw": mill.power_utility.rate,
               "plant_steam_kw": sum(h.duty for h in t.system.heat_utilities if h.duty > 0) / 3600.0,
               "msp_usd_per_kg": msp, "msp_capital_usd_per_kg": msp - sum(costs.values()) / kg_per_yr}
        out |= {f"msp_{name.lower()}_usd_per_kg": usd / kg_per_yr for name, usd in costs.items()}
        share = mill.installed_cost / t.installed_equipment_cost
        maintenance = t.maintenance_usd_per_yr(t.FCI) * mill.installed_cost / t.isbl_installed_usd
        section = (out["msp_capital_usd_per_kg"] * share + (maintenance + mill.power_utility.cost * t.operating_hours)
                   / kg_per_yr)
        out |= {"msp_mill_section_usd_per_kg": section, "msp_mill_share": section / msp,
                "virgin_tpa_usd_per_kg": self.prices["tpa"], "virgin_tpa_gwp_kg_per_kg": self.cf["virgin_tpa"]}
        parts = self.footprint()
        out |= {f"gwp_{k.lower()}_kg_per_kg": v for k, v in parts.items()}
        products = {"rTPA": (self.rtpa.F_mass, self.prices["tpa"])} | {
            ID: (streams[ID].F_mass, max(0.0, streams[ID].price)) for ID in ("EG", "Na2SO4") if streams[ID].isproduct()}
        out |= {f"gwp_{k}_allocation_kg_per_kg": v for k, v in allocation_kg_per_kg(parts, products).items()}
        return out


def inputs(cfg, econ) -> tuple[dict[str, float], dict[str, float]]:
    """The plant's prices ($/kg, econ.prices_file's) and greenhouse-gas factors (data/ghg_factors.csv's),
    cfg's one-by-one overrides (plant.prices_usd_per_t in $/t, plant.ghg_kg_co2e) on top."""
    prices = prices_usd_per_kg(econ.prices_file) | {k: v / 1000.0 for k, v in cfg.prices_usd_per_t.items()}
    return prices, factors() | dict(cfg.ghg_kg_co2e)


def plant(mill: MillSpec, cfg, econ, region: str | None = None, name: str = "plant") -> Plant:
    """The plant around `mill` (cfg: PlantConfig, copied: the uncertainty varies the copy;
    econ: EconomicsConfig; region: a state code for its grid)."""
    cfg = replace(cfg)
    index = cepci(cfg.cost_year)
    prices, cf = inputs(cfg, econ)
    prices["na2so4"] = cfg.na2so4_usd_per_t / 1000.0
    configure_utilities(prices, econ.electricity_usd_per_kwh, index)
    ps = build(mill, cfg, prices, index, name)
    characterize(ps.streams, cf, region, cfg.landfill)
    tea = PlantTEA(ps.system, cfg, econ.hours_per_year, cfg.cost_year)
    return Plant(ps, tea, mill, cfg, econ, region, prices, cf)
