"""The plant's own units, where BioSTEAM has none or prices one on another basis.

- BallMillReactor: the mill as a continuous reactor; conversion, power and price come from
  ballmill's design (DEM or surrogate, yield model, the paper's cost correlation).
- SizeReduction: a granulator or pulveriser: energy per tonne and a cited cost correlation.
- Acidifier: a stirred tank (BioSTEAM's MixTank) with the acidification reactions.
- Evaporator: BioSTEAM's MultiEffectEvaporator with its bodies priced by Seider's
  forced-circulation correlation, one body at a time (BioSTEAM's own price is kept beside).
- SaltCrystallizer: Na2SO4 above its solubility leaves the liquor as crystals.
- WastewaterTreatment: effluent priced by its chemical oxygen demand; its organics oxidised
  to CO2 and water with the air's oxygen.

Every unit's `cost_factor` scales its purchase cost (the Monte Carlo draws it between the
published correlations of data/cost_correlations.csv), and its `material_factor` (its
material's, data/material_factors.csv) too.
"""

from __future__ import annotations

from typing import ClassVar

import biosteam as bst
import thermosteam as tmo

from .correlations import price

SIZE_REDUCTION_BARE_MODULE = 2.3  # as BioSTEAM's HammerMill and CrushingMill carry


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
    """Na2TPA + H2SO4 -> TPA + Na2SO4 and 2 NaOH + H2SO4 -> Na2SO4 + 2 H2O, to completion."""

    def _init(self, **kwargs):
        super()._init(**kwargs)
        self.reactions = tmo.ParallelReaction([tmo.Reaction("Na2TPA + H2SO4 -> TPA + Na2SO4", "Na2TPA", 1.0),
                                               tmo.Reaction("2NaOH + H2SO4 -> Na2SO4 + 2Water", "NaOH", 1.0)])

    def _run(self):
        super()._run()
        self.reactions(self.outs[0])


@scaled
class Evaporator(bst.MultiEffectEvaporator):
    """Multiple-effect evaporator whose bodies are priced one by one by the correlation `key`
    (m2 of each body) at `cepci`; BioSTEAM's own price of the bodies is kept in
    design_results['BioSTEAM bodies']."""

    def _init(self, key: str, cepci: float, **kwargs):
        super()._init(**kwargs)
        self.key, self.cepci = key, cepci

    def _cost(self):
        own = self.baseline_purchase_costs.get("Evaporators", 0.0)
        self.design_results["BioSTEAM bodies"] = own
        bodies = [price(self.key, area, self.cepci) for area in self._As if area > 0]
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
        treated.copy_like(effluent)
        offgas.empty()
        offgas.phase = "g"
        air.empty()
        self.cod_kg_per_h = sum(treated.imass[c.ID] * cod_kg_per_kg(c) for c in treated.available_chemicals)
        for c in treated.available_chemicals:
            if cod_kg_per_kg(c) and treated.imol[c.ID]:
                n, atoms = treated.imol[c.ID], c.atoms
                treated.imol[c.ID] = 0.0
                treated.imol["Water"] += n * atoms["H"] / 2
                offgas.imol["CO2"] += n * atoms["C"]
                air.imol["O2"] += n * (atoms["C"] + atoms["H"] / 4 - atoms.get("O", 0) / 2)
        treated.price = -self.usd_per_kg_cod * self.cod_kg_per_h / treated.F_mass if treated.F_mass else 0.0

    def _design(self):
        self.design_results["COD"] = self.cod_kg_per_h
        self.design_results["Flow"] = self.ins[0].F_vol
