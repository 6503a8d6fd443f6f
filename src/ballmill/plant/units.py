"""The plant's own units, where BioSTEAM has none or prices one on another basis.

- BallMillReactor: the mill as a continuous reactor; conversion, power and price come from
  ballmill's design (DEM or surrogate, yield model, the paper's cost correlation).
- SizeReduction: a granulator or pulveriser: energy per tonne and a cited cost correlation.
- Acidifier: a stirred tank (BioSTEAM's MixTank) with the acidification reactions.
- Evaporator: BioSTEAM's MultiEffectEvaporator with its bodies priced by Seider's
  forced-circulation correlation, one body at a time (BioSTEAM's own price is kept beside).
- VapourRecompressionEvaporator: one body heated by its own vapour, recompressed on electricity.
- SaltCrystallizer: Na2SO4 above its solubility leaves the liquor as crystals.
- WastewaterTreatment: effluent priced by its chemical oxygen demand; its organics oxidised
  to CO2 and water with the air's oxygen.
- SaltSplitting: bipolar-membrane electrodialysis of Na2SO4 back to NaOH and H2SO4.
- ElectricBoiler, ResidueBoiler: facilities that make the steam the other units ask for (all of
  it on electricity; or what burning a waste stream covers), so less or none is bought.

Every unit's `cost_factor` scales its purchase cost (the Monte Carlo draws it between the
published correlations of data/cost_correlations.csv), and its `material_factor` (its
material's, data/material_factors.csv) too.
"""

from __future__ import annotations

from typing import ClassVar

import biosteam as bst
import thermosteam as tmo
from scipy.optimize import brentq

from .correlations import price

SIZE_REDUCTION_BARE_MODULE = 2.3  # as BioSTEAM's HammerMill and CrushingMill carry
VAPOUR_FRACTION_TOLERANCE = 1e-12
STEAM_AGENTS = ("low_pressure_steam", "medium_pressure_steam", "high_pressure_steam")


class VapourFraction:
    """The molar vapour fraction V at which `recovery` (0-1) of `chemical` in a feed leaves as
    vapour in an equilibrium flash at P (Pa).  V counts only the chemicals that take part in the
    equilibrium (the salts are locked in their phase), so it is solved for, not summed.

    One solver serves one unit: it keeps its flash and its last root, so that inside a recycle
    loop or a Monte Carlo, where the feed moves little between calls, secant steps from the last
    root converge in a few flashes (to VAPOUR_FRACTION_TOLERANCE in V); a step that leaves (0, 1)
    or stalls falls back to Brent's method on the whole range."""

    def __init__(self, chemical: str):
        self.chemical, self.V, self.mixed = chemical, None, None

    def __call__(self, feed: bst.Stream, P: float, recovery: float) -> float:
        if not feed.imol[self.chemical]:
            return 0.0
        if self.mixed is None or self.mixed.chemicals is not feed.chemicals:
            self.mixed = tmo.MultiStream(None, thermo=feed.thermo)
        self.mixed.copy_flow(feed)
        into = feed.imol[self.chemical]

        def short_of(V: float) -> float:
            self.mixed.vle(P=P, V=V)
            return self.mixed.imol["g", self.chemical] / into - recovery

        V = self.V is not None and secant(short_of, self.V)
        self.V = V if V is not False else brentq(short_of, 0.0, 1.0, xtol=VAPOUR_FRACTION_TOLERANCE)
        return self.V


def secant(f, V: float, step: float = 1e-6, iterations: int = 12) -> float | bool:
    """The root of f by secant steps from V (the first of `step`), or False where a step leaves
    (0, 1) or stalls."""
    a, fa = V, f(V)
    b = V - step if V + step >= 1.0 else V + step
    for _ in range(iterations):
        if fa == 0.0:
            return a
        fb = f(b)
        if fb == fa:
            return False
        a, fa, b = b, fb, b - fb * (b - a) / (fb - fa)
        if not 0.0 < b < 1.0:
            return False
        if abs(b - a) < VAPOUR_FRACTION_TOLERANCE:
            return b
    return False


def scaled(cls):
    """`cls` whose purchase costs are multiplied by its `cost_factor` and its `material_factor`
    (each 1 by default)."""

    class Scaled(cls):
        cost_factor = 1.0
        material_factor = 1.0

        def _cost(self):
            super()._cost()
            for item in self.baseline_purchase_costs:
                self.baseline_purchase_costs[item] *= self.cost_factor * self.material_factor

    Scaled.__name__ = cls.__name__
    Scaled.__qualname__ = cls.__qualname__
    return Scaled


@scaled
class BallMillReactor(bst.Unit):
    """PET + 2 NaOH -> Na2TPA + EG at `conversion` per pass (0-1]; `power_kw` and
    `purchase_cost_usd` (cost year) are the designed mill's; `design` its size for the record."""

    _N_ins = 2
    _N_outs = 1
    _F_BM_default: ClassVar[dict] = {"Ball mill": SIZE_REDUCTION_BARE_MODULE}
    _units: ClassVar[dict] = {"Power": "kW"}

    def _init(self, conversion: float, power_kw: float, purchase_cost_usd: float, design: dict | None = None):
        self.reaction = tmo.Reaction("PET + 2NaOH -> Na2TPA + EG", "PET", conversion)
        self.power_kw, self.purchase_cost_usd, self.design = power_kw, purchase_cost_usd, design or {}

    @property
    def conversion(self) -> float:
        return self.reaction.X

    @conversion.setter
    def conversion(self, x: float) -> None:
        self.reaction.X = x

    def _run(self):
        out = self.outs[0]
        out.mix_from(self.ins)
        self.reaction(out)

    def _design(self):
        self.design_results.update(self.design)
        self.design_results["Power"] = self.power_kw
        self.add_power_utility(self.power_kw)

    def _cost(self):
        self.baseline_purchase_costs["Ball mill"] = self.purchase_cost_usd


@scaled
class SizeReduction(bst.Unit):
    """Size reduction of the PET: `energy_kwh_per_t` of feed, priced by the correlation `key`
    (kg/h of feed) at `cepci` (the cost year's index)."""

    _N_ins = 1
    _N_outs = 1
    _F_BM_default: ClassVar[dict] = {"Size reduction": SIZE_REDUCTION_BARE_MODULE}
    _units: ClassVar[dict] = {"Feed": "kg/hr"}

    def _init(self, key: str, energy_kwh_per_t: float, cepci: float):
        self.key, self.energy_kwh_per_t, self.cepci = key, energy_kwh_per_t, cepci

    def _run(self):
        self.outs[0].copy_like(self.ins[0])

    def _design(self):
        self.design_results["Feed"] = feed = self.ins[0].F_mass
        self.add_power_utility(self.energy_kwh_per_t * feed / 1000.0)

    def _cost(self):
        p = price(self.key, self.design_results["Feed"], self.cepci)
        self.baseline_purchase_costs["Size reduction"] = p.usd
        self.below_range = p.below_range


@scaled
class Acidifier(bst.MixTank):
    """Na2TPA + H2SO4 -> TPA + Na2SO4 and 2 NaOH + H2SO4 -> Na2SO4 + 2 H2O, to completion; with
    `heat_kj_per_mol` (reactant -> kJ/mol reacted, negative: released) the tank is adiabatic and
    that heat warms its outlet (else the outlet leaves at the mixed feed's temperature)."""

    def _init(self, heat_kj_per_mol: dict[str, float] | None = None, **kwargs):
        super()._init(**kwargs)
        self.heat_kj_per_mol = heat_kj_per_mol or {}
        self.reactions = tmo.ParallelReaction([tmo.Reaction("Na2TPA + H2SO4 -> TPA + Na2SO4", "Na2TPA", 1.0),
                                               tmo.Reaction("2NaOH + H2SO4 -> Na2SO4 + 2Water", "NaOH", 1.0)])

    def _run(self):
        super()._run()
        out = self.outs[0]
        H = out.H
        reacted = {c: out.imol[c] for c in self.heat_kj_per_mol}  # kmol/h, all of it reacts
        self.reactions(out)
        self.heat_released_kw = -sum(n * self.heat_kj_per_mol[c] for c, n in reacted.items()) / 3.6  # kmol/h x kJ/mol
        if self.heat_kj_per_mol:
            out.H = H + self.heat_released_kw * 3600.0


@scaled
class Evaporator(bst.MultiEffectEvaporator):
    """Multiple-effect evaporator whose bodies are priced one by one by the correlation `key`
    (m2 of each body) at `cepci`; BioSTEAM's own price of the bodies is kept in
    design_results['BioSTEAM bodies']."""

    def _init(self, key: str, cepci: float, **kwargs):
        super()._init(**kwargs)
        self.key, self.cepci = key, cepci

    def body_areas_m2(self) -> list[float]:
        return [area for area in self._As if area > 0]

    def _cost(self):
        own = self.baseline_purchase_costs.get("Evaporators", 0.0)
        self.design_results["BioSTEAM bodies"] = own
        bodies = [price(self.key, area, self.cepci) for area in self.body_areas_m2()]
        self.baseline_purchase_costs["Evaporators"] = sum(p.usd for p in bodies)
        self.below_range = any(p.below_range for p in bodies)
        self.parallel["Evaporators"] = 1


@scaled
class SaltCrystallizer(bst.Unit):
    """Na2SO4 above `solubility` (kg per kg water) crystallises (the solid leaves with the
    slurry; the centrifuge after it splits crystals from liquor); priced by the correlation `key`
    (kg/h of crystals) at `cepci`, or not at all where `priced` is false (the evaporator's last
    body is the crystallizer)."""

    _N_ins = 1
    _N_outs = 1
    _F_BM_default: ClassVar[dict] = {"Crystallizer": 2.0}
    _units: ClassVar[dict] = {"Crystals": "kg/hr"}

    def _init(self, solubility: float, key: str, cepci: float, priced: bool = True):
        self.solubility, self.key, self.cepci, self.priced = solubility, key, cepci, priced

    def _run(self):
        self.outs[0].copy_like(self.ins[0])

    @property
    def crystals_kg_per_h(self) -> float:
        feed = self.ins[0]
        return max(0.0, feed.imass["Na2SO4"] - self.solubility * feed.imass["Water"])

    def _design(self):
        self.design_results["Crystals"] = self.crystals_kg_per_h

    def _cost(self):
        p = price(self.key, self.design_results["Crystals"], self.cepci)
        self.baseline_purchase_costs["Crystallizer"] = p.usd if self.priced else 0.0
        self.below_range = p.below_range and self.priced


@scaled
class VapourRecompressionEvaporator(bst.Unit):
    """Mechanical vapour recompression: one forced-circulation body at `P` (Pa) sends
    `water_share` of the feed's water to the condensate (outs[1]), the rest with the salts to the
    concentrate (outs[0]); its vapour, recompressed on `kwh_per_t_water` of electricity, heats it
    (the feed preheated by the condensate: no steam).  The body's area: the latent heat over
    `u_w_per_m2_k` x `temperature_difference_k`, priced by the correlation `body_key`; the
    compressor by `compressor_key` (kW of shaft power); both at `cepci`."""

    _N_ins = 1
    _N_outs = 2
    _F_BM_default: ClassVar[dict] = {"Evaporators": bst.MultiEffectEvaporator._F_BM_default["Evaporators"],
                                     "Compressor": bst.units.IsentropicCompressor._F_BM_default["Compressor(s)"]}
    _units: ClassVar[dict] = {"Area": "m2", "Water evaporated": "kg/hr", "Power": "kW"}

    def _init(self, P: float, water_share: float, kwh_per_t_water: float, temperature_difference_k: float,
              u_w_per_m2_k: float, body_key: str, compressor_key: str, cepci: float):
        self.P, self.water_share, self.kwh_per_t_water = P, water_share, kwh_per_t_water
        self.temperature_difference_k, self.u_w_per_m2_k = temperature_difference_k, u_w_per_m2_k
        self.body_key, self.compressor_key, self.cepci = body_key, compressor_key, cepci
        self.vapour_fraction = VapourFraction("Water")

    def _run(self):
        feed = self.ins[0]
        concentrate, condensate = self.outs
        mixed = tmo.MultiStream(None, thermo=feed.thermo)
        mixed.copy_flow(feed)
        mixed.vle(P=self.P, V=self.vapour_fraction(feed, self.P, self.water_share))
        concentrate.mol[:] = mixed.imol["l"]
        condensate.mol[:] = mixed.imol["g"]
        concentrate.phase = condensate.phase = "l"
        concentrate.T = condensate.T = mixed.T
        concentrate.P = condensate.P = self.P

    def body_areas_m2(self) -> list[float]:
        return [self.design_results["Area"]]

    def _design(self):
        condensate = self.outs[1]
        latent_kw = condensate.Hvap / 3600.0  # kJ/h -> kW
        self.design_results["Water evaporated"] = evaporated = condensate.F_mass
        self.design_results["Area"] = latent_kw * 1000.0 / (self.u_w_per_m2_k * self.temperature_difference_k)
        self.design_results["Power"] = power = self.kwh_per_t_water * evaporated / 1000.0
        self.add_power_utility(power)

    def _cost(self):
        body = price(self.body_key, self.design_results["Area"], self.cepci)
        compressor = price(self.compressor_key, self.design_results["Power"], self.cepci)
        self.baseline_purchase_costs["Evaporators"] = body.usd
        self.baseline_purchase_costs["Compressor"] = compressor.usd
        self.below_range = body.below_range or compressor.below_range


FARADAY_C_PER_MOL = 96485.332


@scaled
class SaltSplitting(bst.Unit):
    """Bipolar-membrane electrodialysis: Na2SO4 (ins[0]) + 2 H2O (ins[1], with the water that
    dilutes the products to `product_wt_fraction`) -> 2 NaOH (outs[0]) + H2SO4 (outs[1]) on
    `kwh_per_kg_naoh`; the products' water evaporated (outs[2], the condensate) in `effects`
    effects on steam.
    Bipolar membrane: the current (NaOH made x Faraday / `current_efficiency`) over
    `current_density_a_per_m2`, priced by the correlation `key` (m2) x `stack_to_membrane`,
    bought again every `life_yr` years."""

    _N_ins = 2
    _N_outs = 3
    _units: ClassVar[dict] = {"Membrane area": "m2", "Power": "kW", "Water evaporated": "kg/hr"}
    _F_BM_default: ClassVar[dict] = {"Stack": 1.0}

    def _init(self, kwh_per_kg_naoh: float, current_efficiency: float, current_density_a_per_m2: float,
              stack_to_membrane: float, life_yr: int, product_wt_fraction: float, effects: int, key: str,
              cepci: float):
        self.kwh_per_kg_naoh, self.current_efficiency = kwh_per_kg_naoh, current_efficiency
        self.current_density_a_per_m2, self.stack_to_membrane = current_density_a_per_m2, stack_to_membrane
        self.product_wt_fraction, self.effects, self.key, self.cepci = product_wt_fraction, effects, key, cepci
        self._default_equipment_lifetime = {"Stack": life_yr}

    def _run(self):
        salt, water = self.ins
        naoh, acid, condensate = self.outs
        n = salt.imol["Na2SO4"]
        condensate.copy_flow(salt)  # what came with the salt but Na2SO4 and H2SO4 (EG, TPA) leaves with the condensate
        condensate.imol["Na2SO4", "H2SO4"] = 0.0
        naoh.empty()
        acid.empty()
        naoh.imol["NaOH"] = 2 * n
        acid.imol["H2SO4"] = n + salt.imol["H2SO4"]
        dilution = (naoh.F_mass + acid.F_mass) * (1.0 / self.product_wt_fraction - 1.0) / 18.01528  # kmol/h
        water.imol["Water"] = max(0.0, 2 * n - salt.imol["Water"]) + dilution
        condensate.imol["Water"] = salt.imol["Water"] + water.imol["Water"] - 2 * n

    def _design(self):
        naoh_kg = self.outs[0].imass["NaOH"]
        current_a = self.outs[0].imol["NaOH"] / 3.6 * FARADAY_C_PER_MOL / self.current_efficiency  # kmol/h -> mol/s
        self.design_results["Membrane area"] = current_a / self.current_density_a_per_m2
        self.design_results["Power"] = power = self.kwh_per_kg_naoh * naoh_kg
        evaporated = self.outs[2]
        self.design_results["Water evaporated"] = evaporated.imass["Water"]
        self.add_power_utility(power)
        latent_kj_per_kmol = evaporated.chemicals.Water.Hvap(373.15)  # J/mol = kJ/kmol
        self.add_heat_utility(evaporated.imol["Water"] * latent_kj_per_kmol / self.effects, T_in=373.15)

    def _cost(self):
        p = price(self.key, self.design_results["Membrane area"], self.cepci)
        self.baseline_purchase_costs["Stack"] = p.usd * self.stack_to_membrane
        self.below_range = p.below_range


class OnSiteSteam(bst.Facility, isabstract=True):
    """Makes `share()` of the steam the plant's other units ask for (each steam agent's utility
    mixed and reversed, so that steam is not bought); sized and priced per kW of steam heat by
    the correlation `key` at `cepci`."""

    network_priority = 1
    _units: ClassVar[dict] = {"Steam heat": "kW"}
    _F_BM_default: ClassVar[dict] = {"Boiler": 1.0}

    def _init(self, key: str, cepci: float):
        self.key, self.cepci = key, cepci

    def steam_kw(self) -> float:
        """Steam heat the other units ask for (kW)."""
        return sum(hu.duty for u in self.other_units for hu in u.heat_utilities
                   if hu.agent is not None and hu.agent.ID in STEAM_AGENTS and hu.duty > 0) / 3600.0

    def _design(self):
        asked = self.steam_kw()
        made = self.steam_made_kw(asked)
        for agent in STEAM_AGENTS:
            users = [hu for u in self.other_units for hu in u.heat_utilities if hu.agent is not None
                     and hu.agent.ID == agent and hu.duty > 0]
            if users and asked:
                hu = self.create_heat_utility()
                hu.mix_from(users)
                hu.scale(made / asked)
                hu.reverse()
        self.design_results["Steam heat"] = made

    def _cost(self):
        p = price(self.key, self.design_results["Steam heat"], self.cepci)
        self.baseline_purchase_costs["Boiler"] = p.usd
        self.below_range = p.below_range


class ElectricBoiler(OnSiteSteam):
    """All the plant's steam from electricity at `efficiency` (steam heat / electricity)."""

    _N_ins = 0
    _N_outs = 0

    def _init(self, key: str, cepci: float, efficiency: float):
        super()._init(key, cepci)
        self.efficiency = efficiency

    def _run(self):
        pass

    def steam_made_kw(self, asked_kw: float) -> float:
        self.add_power_utility(asked_kw / self.efficiency)
        return asked_kw


class ResidueBoiler(OnSiteSteam):
    """Burns its fuel (ins[0], a waste stream) with the air's oxygen (ins[1]) to water (outs[0])
    and CO2 (outs[1]): its lower heating value (`lhv_mj_per_kg`: chemical -> MJ/kg) x `efficiency`
    makes steam, up to what the plant asks for; the rest is bought.  Installed at 1.8 x purchase
    (Humbird et al. 2011's boiler)."""

    _N_ins = 2
    _N_outs = 2
    _F_BM_default: ClassVar[dict] = {"Boiler": 1.8}

    def _init(self, key: str, cepci: float, efficiency: float, lhv_mj_per_kg: dict[str, float]):
        super()._init(key, cepci)
        self.efficiency, self.lhv_mj_per_kg = efficiency, lhv_mj_per_kg

    def _run(self):
        fuel, air = self.ins
        self.fuel_kw = sum(fuel.imass[c] * mj for c, mj in self.lhv_mj_per_kg.items()) / 3.6
        oxidise(fuel, air, *self.outs)

    def steam_made_kw(self, asked_kw: float) -> float:
        return min(asked_kw, self.fuel_kw * self.efficiency)


def oxidise(feed: bst.Stream, air: bst.Stream, water_out: bst.Stream, co2_out: bst.Stream) -> None:
    """`feed` into `water_out` with its organics (CxHyOz) oxidised: their water joins it, their CO2
    goes to `co2_out`, the oxygen they take is set on `air`."""
    water_out.copy_like(feed)
    co2_out.empty()
    co2_out.phase = "g"
    air.empty()
    for c in feed.available_chemicals:
        n = feed.imol[c.ID]
        if cod_kg_per_kg(c) and n:
            atoms = c.atoms
            water_out.imol[c.ID] = 0.0
            water_out.imol["Water"] += n * atoms["H"] / 2
            co2_out.imol["CO2"] += n * atoms["C"]
            air.imol["O2"] += n * (atoms["C"] + atoms["H"] / 4 - atoms.get("O", 0) / 2)


def cod_kg_per_kg(chemical) -> float:
    """Chemical oxygen demand of a CxHyOz chemical: (x + y/4 - z/2) mol O2 per mol (0 for others)."""
    atoms = chemical.atoms
    if set(atoms) - {"C", "H", "O"} or "C" not in atoms:
        return 0.0
    o2 = atoms["C"] + atoms.get("H", 0) / 4 - atoms.get("O", 0) / 2
    return o2 * 31.998 / chemical.MW


class WastewaterTreatment(bst.Unit):
    """The plant's effluent (ins[0]), treated at `usd_per_kg_cod` of its chemical oxygen demand
    (charged as the negative price of the treated water, outs[0]); its organics (CxHyOz) are
    oxidised to CO2 (outs[1], fossil carbon) and water with the oxygen of the air (ins[1])."""

    _N_ins = 2
    _N_outs = 2
    _units: ClassVar[dict] = {"COD": "kg/hr", "Flow": "m3/hr"}

    def _init(self, usd_per_kg_cod: float):
        self.usd_per_kg_cod = usd_per_kg_cod

    def _run(self):
        effluent, air = self.ins
        treated, offgas = self.outs
        self.cod_kg_per_h = sum(effluent.imass[c.ID] * cod_kg_per_kg(c) for c in effluent.available_chemicals)
        oxidise(effluent, air, treated, offgas)
        treated.price = -self.usd_per_kg_cod * self.cod_kg_per_h / treated.F_mass if treated.F_mass else 0.0

    def _design(self):
        self.design_results["COD"] = self.cod_kg_per_h
        self.design_results["Flow"] = self.ins[0].F_vol
