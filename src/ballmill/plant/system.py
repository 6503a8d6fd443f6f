"""The plant as a BioSTEAM system: streams from the chemicals, units sized and priced from them.

    100 feed preparation  bales -> conveyor -> granulator -> sorting (non-PET and fines out)
                          [-> pulveriser -> fines out, with feed_form=powder]
    200 reaction          ball mill (PET + 2 NaOH, with the recycled PET) -> dissolver (water)
                          -> PET filter: unreacted PET back to the mill, less a purge
    300 TPA               acidifier (H2SO4) -> TPA filter (wash water) -> steam dryer -> rTPA
    400 salt and EG       mother liquor -> evaporator (plant.evaporation) -> Na2SO4 crystallizer
                          (the last body, or a unit of its own) -> centrifuge -> steam dryer ->
                          Na2SO4; liquor -> EG stripper (flash) -> EG column (water off the
                          top, EG from the bottom); residue
    500 wastewater        condensates and the column's water -> treatment (priced by COD; its
                          organics oxidised to fossil CO2); with plant.condensate_reuse the
                          evaporator's condensate dissolves the Na2TPA first (fresh water tops up)
    600 storage, cooling  acid and EG tanks, cooling tower; steam bought or made on site (plant.heat);
                          with plant.heat_integration a heat-exchanger network (BioSTEAM's pinch
                          synthesis over the heat exchangers, condensers and reboilers)

The mill's PET throughput is the designed one: the bale feed follows from the conversion per
pass, the purge, the bale's PET content and the fines lost, so that the recycle loop closes at
it.  Prices ($/kg) are those of the PlantPrices given; utilities are set by tea.configure.
The units in acidic sulfate brine (BRINE_UNITS) carry the material factor of plant.brine_material.
"""

from __future__ import annotations

from dataclasses import dataclass

import biosteam as bst

from ..data import lookup
from .chemicals import create_chemicals, value
from .evaporation import EVAPORATORS
from .heat import SOURCES
from .sodium import FATES
from .units import (
    Acidifier,
    BallMillReactor,
    SaltCrystallizer,
    SizeReduction,
    VapourFraction,
    WastewaterTreatment,
    scaled,
)

RECYCLE_TOLERANCE_KMOL_PER_H = 1e-7
RECYCLE_RELATIVE_TOLERANCE = 1e-9
BRINE_UNITS = ("S301", "E401", "C401", "S401")  # acidified liquor: TPA filter, evaporator, crystallizer, centrifuge
NAOH_DOSED_ON = {"whole_feed": lambda conversion: 1.0, "converting_pet": lambda conversion: conversion}


@dataclass(frozen=True)
class MillSpec:
    """The designed mill as the plant sees it: PET through it (kg/h), conversion per pass
    (0-1], NaOH fed / stoichiometric, power (kW), purchase cost ($, cost year) and its design
    (for the record)."""

    pet_kg_per_h: float
    conversion: float
    naoh_to_stoichiometric: float
    power_kw: float
    purchase_cost_usd: float
    design: dict


@dataclass
class PlantSystem:
    """The system and the streams and units a study reads or varies."""

    system: bst.System
    flowsheet: bst.Flowsheet
    streams: dict[str, bst.Stream]
    units: dict[str, bst.Unit]


def fresh_pet_kg_per_h(mill_pet_kg_per_h: float, conversion: float, purge: float) -> float:
    """Clean PET the mill needs from outside at a conversion per pass and a purge of the unreacted."""
    return mill_pet_kg_per_h * (1.0 - (1.0 - purge) * (1.0 - conversion))


def build(mill: MillSpec, cfg, prices: dict[str, float], cepci: float, name: str = "plant") -> PlantSystem:
    """The plant around `mill` (cfg: PlantConfig; prices: item -> $/kg; cepci: the cost year's)."""
    bst.settings.set_thermo(create_chemicals())
    fs = bst.Flowsheet(name)
    bst.main_flowsheet.set_flowsheet(fs)
    S = bst.Stream
    bale = S("bales", PET=cfg.bale_pet_fraction, Polyolefin=1 - cfg.bale_pet_fraction, units="kg/hr",
             price=prices["pet_bale"])
    naoh = S("NaOH", NaOH=1.0, units="kg/hr", price=prices["naoh"])
    h2so4 = S("sulfuric_acid", H2SO4=1.0, units="kg/hr", price=prices["h2so4"])
    water = S("dissolution_water", Water=1.0, units="kg/hr", price=prices["process_water"])
    wash = S("wash_water", Water=1.0, units="kg/hr", price=prices["process_water"])
    recycle = S("recycled_PET", PET=mill.pet_kg_per_h * (1 - mill.conversion), units="kg/hr")
    rtpa, eg, salt = S("rTPA"), S("EG", price=prices["eg"] * cfg.eg_price_fraction), S("Na2SO4", price=prices["na2so4"])
    residue_price = -prices["disposal"]

    # 100 feed preparation
    U101 = bst.ConveyingBelt("U101", ins=bale)
    U102 = SizeReduction("U102", ins=U101 - 0, key=cfg.granulator_cost, energy_kwh_per_t=cfg.granulation_kwh_per_t,
                         cepci=cepci)
    S101 = bst.Splitter("S101", ins=U102 - 0, outs=("flake", S("sorting_residue", price=residue_price)),
                        split={"PET": 1 - cfg.flake_loss_fraction, "Polyolefin": 0.0})
    feed = S101 - 0
    if cfg.feed_form == "powder":
        U103 = SizeReduction("U103", ins=feed, key=cfg.pulveriser_cost, energy_kwh_per_t=cfg.pulverising_kwh_per_t,
                             cepci=cepci)
        S102 = bst.Splitter("S102", ins=U103 - 0, outs=("powder", S("grinding_fines", price=residue_price)),
                            split={"PET": 1 - cfg.powder_loss_fraction})
        feed = S102 - 0
    clean = (1 - cfg.flake_loss_fraction) * (1 - (cfg.powder_loss_fraction if cfg.feed_form == "powder" else 0.0))

    @U101.add_specification(run=True)
    def bales_for_the_mill():
        m = R201  # the mill's throughput is the designed one: the bales follow from its conversion
        bale.F_mass = fresh_pet_kg_per_h(mill.pet_kg_per_h, m.conversion, cfg.recycle_purge_fraction) / (
            cfg.bale_pet_fraction * clean)
        bale.imass["PET", "Polyolefin"] = bale.F_mass * cfg.bale_pet_fraction, bale.F_mass * (1 - cfg.bale_pet_fraction)

    # 200 reaction
    M201 = bst.Mixer("M201", ins=(feed, recycle))
    R201 = BallMillReactor("R201", ins=(M201 - 0, naoh), conversion=mill.conversion, power_kw=mill.power_kw,
                           purchase_cost_usd=mill.purchase_cost_usd, design=mill.design)
    R201.F_BM["Ball mill"] = cfg.mill_bare_module_factor

    @R201.add_specification(run=True)
    def naoh_for_the_pet():
        share = NAOH_DOSED_ON[cfg.naoh_dosing](R201.conversion)
        naoh.imol["NaOH"] = 2 * mill.naoh_to_stoichiometric * share * R201.ins[0].imol["PET"]

    reused = S("reused_condensate")
    M202 = bst.Mixer("M202", ins=(water, reused)) if cfg.condensate_reuse else None
    T201 = scaled(bst.MixTank)("T201", ins=(R201 - 0, M202 - 0 if M202 else water), tau=cfg.tank_residence_time_h)

    def water_to_dissolve_kg_per_h() -> float:
        return cfg.dissolution_water_kg_per_kg_na2tpa * R201.outs[0].imass["Na2TPA"]

    @T201.add_specification(run=True)
    def water_to_dissolve():  # fresh water tops up what the reused condensate brings
        water.imass["Water"] = max(0.0, water_to_dissolve_kg_per_h() - reused.imass["Water"])
        if M202:
            M202.run()

    P201 = bst.Pump("P201", ins=T201 - 0)
    S201 = scaled(bst.RotaryVacuumFilter)("S201", ins=P201 - 0, outs=("PET_cake", "Na2TPA_liquor"),
                                          split={"PET": 1.0}, moisture_content=cfg.pet_cake_moisture)
    bst.Splitter("S202", ins=S201 - 0, outs=(recycle, S("purged_PET", price=residue_price)),
                 split=1 - cfg.recycle_purge_fraction)

    # 300 TPA
    T601 = bst.StorageTank("T601", ins=h2so4, vessel_material="Stainless steel")
    heat = {c: value(c, "neutralisation_heat_kj_per_mol") for c in ("Na2TPA", "NaOH")} if cfg.neutralisation_heat else {}
    R301 = Acidifier("R301", ins=(S201 - 1, T601 - 0), tau=cfg.tank_residence_time_h, heat_kj_per_mol=heat)

    @R301.add_specification(run=True)
    def acid_for_the_salt():
        liquor = R301.ins[0]
        h2so4.imol["H2SO4"] = cfg.h2so4_to_stoichiometric * (liquor.imol["Na2TPA"] + liquor.imol["NaOH"] / 2)

    P301 = bst.Pump("P301", ins=R301 - 0)
    S301 = scaled(bst.RotaryVacuumFilter)("S301", ins=(P301 - 0, wash), outs=("TPA_cake", "mother_liquor"),
                                          split={"TPA": cfg.tpa_recovery}, moisture_content=cfg.tpa_cake_moisture)

    @S301.add_specification(run=True)
    def wash_the_cake():
        wash.imass["Water"] = cfg.wash_water_kg_per_kg_tpa * cfg.tpa_recovery * S301.ins[0].imass["TPA"]

    scaled(bst.DrumDryer)("D301", ins=(S301 - 0, "dryer_air", "dryer_gas"), outs=(rtpa, "dryer_exhaust", ""),
                                 split={"Water": 1.0}, moisture_content=cfg.dry_moisture, utility_agent="Steam")

    # 400 salt and EG
    P401 = bst.Pump("P401", ins=S301 - 1)
    E401, condensate = EVAPORATORS[cfg.evaporation.kind]("E401", P401 - 0, cfg, cepci)
    C401 = SaltCrystallizer("C401", ins=E401 - 0, solubility=value("Na2SO4", "solubility_kg_per_kg_water"),
                            key=cfg.crystallizer_cost, cepci=cepci, priced=cfg.crystallizer == "separate")
    S401 = scaled(bst.SolidsCentrifuge)("S401", ins=C401 - 0, outs=("salt_cake", "EG_liquor"), split={"Na2SO4": 1.0},
                                solids=("Na2SO4",), moisture_content=cfg.salt_cake_moisture)

    @S401.add_specification(run=True)
    def crystals_only():
        total = S401.ins[0].imass["Na2SO4"]
        S401.isplit["Na2SO4"] = C401.crystals_kg_per_h / total if total else 0.0

    scaled(bst.DrumDryer)("D401", ins=(S401 - 0, "salt_dryer_air", "salt_dryer_gas"),
                          outs=(salt, "salt_dryer_exhaust", ""), split={"Water": 1.0, "EthyleneGlycol": 1.0},
                          moisture_content=cfg.dry_moisture, utility_agent="Steam")
    F401 = scaled(bst.Flash)("F401", ins=S401 - 1, outs=("EG_vapour", S("residue", price=residue_price)),
                             V=0.5, P=cfg.eg_stripper_pressure_pa)

    eg_share = VapourFraction("EthyleneGlycol")

    @F401.add_specification(run=True)
    def strip_the_eg():
        F401.V = eg_share(F401.ins[0], F401.P, cfg.eg_stripper_recovery)

    D402 = scaled(bst.BinaryDistillation)("D402", ins=F401 - 0, outs=("column_water", "EG_product"),
                                          LHK=("Water", "EthyleneGlycol"), Lr=cfg.eg_column_water_recovery,
                                          Hr=cfg.eg_column_eg_recovery, k=cfg.eg_column_reflux_to_minimum,
                                          P=cfg.eg_column_pressure_pa, vessel_material="Stainless steel 304")

    if cfg.condensate_reuse:
        S501 = bst.Splitter("S501", ins=condensate, outs=(reused, "surplus_condensate"), split=1.0)

        @S501.add_specification(run=True)
        def reuse_what_dissolving_needs():
            have = S501.ins[0].imass["Water"]
            S501.split[:] = min(1.0, water_to_dissolve_kg_per_h() / have) if have else 0.0

        condensate = S501 - 1

    # 500 wastewater, 600 storage and cooling
    M501 = bst.Mixer("M501", ins=(condensate, D402 - 0))
    WastewaterTreatment("W501", ins=(M501 - 0, S("treatment_air")), outs=(S("treated_water"), S("treatment_CO2")),
                        usd_per_kg_cod=prices["cod_removal"])
    bst.StorageTank("T602", ins=D402 - 1, outs=eg, vessel_material="Stainless steel")
    CT = bst.CoolingTower("CT")
    CT.ins[2].price = prices["cooling_tower_chemicals"]
    FATES[cfg.sodium.kind]({s.ID: s for s in fs.stream}, cfg, prices, cepci)
    SOURCES[cfg.heat.kind]({s.ID: s for s in fs.stream}, cfg, cepci)
    if cfg.heat_integration:
        bst.HeatExchangerNetwork("HXN", T_min_app=cfg.hxn_min_approach_k)
    system = fs.create_system("plant")
    # BioSTEAM's defaults (1 kmol/h, 1 %) leave the PET recycle (~2 kmol/h) path-dependent by ~1 % of the MSP
    system.set_tolerance(mol=RECYCLE_TOLERANCE_KMOL_PER_H, rmol=RECYCLE_RELATIVE_TOLERANCE, subsystems=True)
    streams = {s.ID: s for s in fs.stream}
    units = {u.ID: u for u in fs.unit}
    for ID in BRINE_UNITS:
        units[ID].material_factor = lookup("material_factors.csv", "material", cfg.brine_material, "factor")
    return PlantSystem(system, fs, streams, units)
