"""Costs of a mill (Anglou et al. 2023, Eq. 1-3) and the raw-material margin.

Electricity: P x price x hours.  Purchase cost: C = a W^b (Seider, Seader, Lewin & Widagdo
2004), W the capacity, escalated by CEPCI from the correlation's base year (the yield is the
yield model's: yields.py).  Margin per tonne TPA: products (TPA, EG) less reactants (PET, NaOH, H2SO4) by stoichiometry.
"""

from __future__ import annotations

from .config import EconomicsConfig
from .data import lookup

SHORT_TON_KG = 907.18474


def electricity(power_w: float, pet_feed_kg_per_h: float, cfg: EconomicsConfig) -> dict:
    kw = power_w / 1000.0
    return {
        "electricity_usd_per_yr": kw * cfg.hours_per_year * cfg.electricity_usd_per_kwh,
        "electricity_usd_per_t_pet": kw * cfg.electricity_usd_per_kwh / (pet_feed_kg_per_h / 1000.0),
    }


def cepci(year: int, cfg: EconomicsConfig) -> float:
    return lookup(cfg.cepci_file, "year", year, "cepci")


def purchase_cost_usd(pet_kg_per_h: float, naoh_kg_per_h: float, cfg: EconomicsConfig,
                      residence_time_min: float | None = None) -> float:
    """Purchase cost (target-year $) of a ball mill of the given feed capacity (with
    capacity_scaling=holdup, scaled by its residence time against the reference one)."""
    kg_per_h = pet_kg_per_h + (naoh_kg_per_h if cfg.capacity_basis == "pet_plus_naoh" else 0.0)
    if cfg.capacity_scaling == "holdup" and residence_time_min is not None:
        kg_per_h *= residence_time_min / cfg.reference_residence_time_min
    w = kg_per_h / (SHORT_TON_KG if cfg.capacity_unit == "short_ton_per_h" else 1000.0)
    base = cfg.cost_coefficient_usd * w**cfg.cost_exponent
    return base * cepci(cfg.cepci_target_year, cfg) / cepci(cfg.cepci_base_year, cfg)


def margin_usd_per_t_tpa(cfg: EconomicsConfig) -> dict:
    """Raw-material margin per tonne of TPA at full conversion, with the mass balance (t/t TPA)."""
    def mm(s):
        return lookup(cfg.molar_masses_file, "species", s, "molar_mass_g_per_mol")

    def price(s):
        return lookup(cfg.prices_file, "item", s, "price_usd_per_t")

    mol = 1e6 / mm("tpa")  # mol of repeat units per tonne TPA
    tonnes = {
        "pet": mol * mm("pet_repeat_unit") / 1e6, "naoh": 2 * mol * mm("naoh") / 1e6,
        "h2so4": mol * mm("h2so4") / 1e6, "eg": mol * mm("eg") / 1e6,
    }
    margin = (
        price("tpa") + tonnes["eg"] * price("eg")
        - tonnes["pet"] * price("pet_bale") - tonnes["naoh"] * price("naoh") - tonnes["h2so4"] * price("h2so4")
    )
    return {"margin_usd_per_t_tpa": margin, **{f"{k}_t_per_t_tpa": v for k, v in tonnes.items()}}


def bond_rowland_power_w(diameter_m: float, ball_mass_kg: float, fill_fraction: float,
                         fraction_of_critical: float, ball_diameter_m: float) -> float:
    """Empirical ball-mill power (W): kWb per tonne of balls (Rowland 1972 form of Bond),
    kWb = 4.879 D^0.3 (3.2 - 3 Vp) fCs (1 - 0.1 / 2^(9 - 10 fCs)) + Ss, with the ball-size
    term Ss = 1.102 (B - 12.5 D) / 50.8 (B ball diameter in mm) taken only where positive."""
    d, f = diameter_m, fraction_of_critical
    kwb = 4.879 * d**0.3 * (3.2 - 3 * fill_fraction) * f * (1 - 0.1 / 2 ** (9 - 10 * f))
    kwb += max(0.0, 1.102 * (1000 * ball_diameter_m - 12.5 * d) / 50.8)
    return 1000.0 * kwb * ball_mass_kg / 1000.0


def evaluate(power_w: float, yield_percent: float, pet_kg_per_h: float, naoh_kg_per_h: float,
             residence_time_min: float, cfg: EconomicsConfig) -> dict:
    """All economic outputs of one mill as a flat record (the yield from the yield model)."""
    cost = purchase_cost_usd(pet_kg_per_h, naoh_kg_per_h, cfg, residence_time_min)
    return {
        **electricity(power_w, pet_kg_per_h, cfg),
        "purchase_cost_usd": cost,
        "purchase_cost_usd_per_kg_per_h": cost / pet_kg_per_h,
        "yield_percent": yield_percent,
        **margin_usd_per_t_tpa(cfg),
        "cepci_base": cepci(cfg.cepci_base_year, cfg), "cepci_target": cepci(cfg.cepci_target_year, cfg),
    }


