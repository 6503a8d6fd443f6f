"""study=plant: the mill that converts a fresh feed with the recycle closed, designed as in
study=design, and the plant around it on BioSTEAM (plant/study.py)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from .. import yield_rules
from ..config import ConfigError
from ..data import lookup, table
from ..scaleup import design_mill
from ..scenario import Scenario
from ..yields import bpr_line_yield
from .design import plan_design
from .plan import Plan


def mill_throughput_kg_per_h(fresh_pet_kg_per_h: float, conversion: float, purge: float) -> float:
    """PET through the mill for a fresh feed, a conversion per pass and a purge of the unreacted PET."""
    return fresh_pet_kg_per_h / (1.0 - (1.0 - purge) * (1.0 - conversion))


PLANT_PRICES = {"pet_bale", "naoh", "h2so4", "tpa", "eg", "low_pressure_steam", "medium_pressure_steam",
                "high_pressure_steam", "cooling_tower_chemicals", "process_water", "cod_removal", "disposal",
                "na2so4_sale"}


def check_plant_tables(plant, prices_file: str) -> None:
    """The plant's data tables hold the columns and rows its config names (before BioSTEAM is
    imported)."""
    keys = set(table("cost_correlations.csv").key)
    rows = {f"plant.{name}": getattr(plant, name) for name in ("granulator_cost", "pulveriser_cost", "evaporator_cost",
                                                                "crystallizer_cost")}
    for name, key in (rows | {"plant.evaporation.compressor_cost": plant.evaporation.compressor_cost}).items():
        if key not in keys:
            raise ConfigError(f"{name}={key!r} is not a row of data/cost_correlations.csv; have {sorted(keys)}")
    for name, columns in ((prices_file, ["item", "price_usd_per_t"]), ("ghg_factors.csv", ["item", "kg_co2e"]),
                          ("staffing.csv", ["unit", "workers_per_unit_per_shift"]),
                          ("plant_chemicals.csv", ["chemical", "property", "value"]),
                          ("plant_uncertainty.csv", ["parameter", "distribution", "scale", "low", "high"]),
                          ("egrid2022_states.csv", ["region", "co2e_lb_per_mwh"]), (plant.depreciation_file, ["fraction"])):
        missing = [c for c in columns if c not in table(name)]
        if missing:
            raise ConfigError(f"data table {name} lacks the columns {missing}")
    missing = sorted(PLANT_PRICES - set(table(prices_file).item))
    if missing:
        raise ConfigError(f"economics.prices_file={prices_file}: no price for {missing} (the plant needs them)")
    lookup("cepci.csv", "year", plant.cost_year, "cepci")
    lookup("material_factors.csv", "material", plant.brine_material, "factor")
    levers = set(table("plant_uncertainty.csv").parameter)
    unknown = sorted(set(plant.what_it_takes) - levers)
    if unknown:
        raise ConfigError(f"plant.what_it_takes: {unknown} are not parameters of data/plant_uncertainty.csv; have "
                          f"{sorted(levers)}")
    for name, file, column in (("prices_usd_per_t", prices_file, "item"), ("ghg_kg_co2e", "ghg_factors.csv", "item")):
        unknown = sorted(set(getattr(plant, name)) - set(table(file)[column]))
        if unknown:
            raise ConfigError(f"plant.{name}: no item {unknown} in data/{file}; have {sorted(table(file)[column])}")



def conversion_per_pass(s: Scenario) -> float:
    """The mill's conversion per pass (0-1]: the yield target under a dose rule, else the BPR
    line's; refused where the NaOH or the yield cannot make the plant (before any simulation)."""
    model, scale = s.yield_model, s.scaleup
    dose_rule = yield_rules.rule_of(model.rule).dose
    if dose_rule and model.mode == "fixed_time":
        raise ConfigError("study=plant: yield_model.mode=fixed_time leaves the conversion, hence the mill's "
                          "throughput, unknown until the DEM; use yield_model.mode=target_yield")
    line_y, _ = bpr_line_yield(scale.bpr, model)
    conversion = (model.target_yield_percent or line_y if dose_rule else line_y) / 100.0
    if scale.naoh_feed_kg_per_h is not None:
        raise ConfigError("study=plant: give the NaOH as scaleup.naoh_to_stoichiometric (the mill's NaOH follows its "
                          f"throughput), not scaleup.naoh_feed_kg_per_h={scale.naoh_feed_kg_per_h}")
    if not 0.0 < conversion <= 1.0:
        raise ConfigError(f"study=plant: the mill's conversion per pass is {conversion:.3g}; it must lie in (0, 1] "
                          "(a yield of 0 % makes no product: raise the BPR or the residence time)")
    least = conversion if s.plant.naoh_dosing == "whole_feed" else 1.0  # NaOH per PET through the mill, or converting
    if scale.naoh_to_stoichiometric < least:
        raise ConfigError(f"scaleup.naoh_to_stoichiometric={scale.naoh_to_stoichiometric} is below {least:.3g} with "
                          f"plant.naoh_dosing={s.plant.naoh_dosing}: the mill would run out of NaOH")
    check_plant_tables(s.plant, s.economics.prices_file)
    return conversion


def to_cost_year(s: Scenario) -> float:
    """CEPCI of the plant's cost year over the economics' target year (the mill's price is in the latter)."""
    return (lookup("cepci.csv", "year", s.plant.cost_year, "cepci")
            / lookup("cepci.csv", "year", s.economics.cepci_target_year, "cepci"))


def plan_plant(s: Scenario) -> Plan:
    """The whole plant for a fresh PET feed: the mill that converts it with the recycle closed
    (its throughput from the conversion per pass and the purge), designed and simulated as in
    `design`; then the plant around it on BioSTEAM (plant/study.py): MSP and footprint, their
    Monte Carlo band, the tornado and the tables."""
    scale = s.scaleup
    fresh = design_mill(scale).pet_feed_kg_per_h
    conversion = conversion_per_pass(s)
    mill_pet = mill_throughput_kg_per_h(fresh, conversion, s.plant.recycle_purge_fraction)
    mill_plan = plan_design(replace(s, scaleup=replace(scale, pet_feed_kg_per_h=mill_pet, region=None)))

    def execute(out_dir: Path) -> dict:
        from ..plant.study import run as run_plant  # BioSTEAM: seconds to import, only here
        from ..plant.system import MillSpec

        rec = mill_plan.execute(out_dir)
        mill = MillSpec(mill_pet, rec["yield_percent"] / 100.0, scale.naoh_to_stoichiometric,
                        rec["dem_power_w"] / 1000.0, rec["purchase_cost_usd"] * to_cost_year(s),
                        {"Diameter": rec["diameter_m"], "Length": rec["length_m"], "Balls": rec["ball_count"],
                         "Residence time": rec["residence_time_min"]})
        return rec | run_plant(mill, s.plant, s.economics, scale.region, rec["dem_power_se_w"] / 1000.0, out_dir)

    return Plan(mill_plan.record | {"region": scale.region, "plant_fresh_pet_kg_per_h": fresh,
                                    "plant_mill_pet_kg_per_h": mill_pet,
                                    "recycle_purge_fraction": s.plant.recycle_purge_fraction}, execute)
