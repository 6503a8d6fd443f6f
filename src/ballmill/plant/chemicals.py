"""The plant's chemicals: thermosteam's database, and PET and disodium terephthalate defined
from data/plant_chemicals.csv (each property with its source).

Phases: water and ethylene glycol are volatile (vapour-liquid equilibrium in the evaporator
and the EG column); the salts, acids and polymer are locked to the phase they stay in (solid
PET, TPA and Na2SO4; NaOH, H2SO4 and Na2TPA in solution), so no equilibrium moves them.
Heats of solution and of the aqueous reactions are not modelled (see docs: the plant's
assumptions).
"""

from __future__ import annotations

from functools import cache

from ..data import table

FILE = "plant_chemicals.csv"
# database chemicals and the phase each is locked to (None: volatile)
DATABASE = {"Water": None, "EthyleneGlycol": None, "NaOH": "l", "H2SO4": "l", "TerephthalicAcid": "s",
            "Na2SO4": "s", "O2": None, "N2": None,
            "CO2": "g"}
DEFINED = {"PET": "s", "Na2TPA": "l", "Polyolefin": "s"}
SYNONYMS = {"EthyleneGlycol": "EG", "TerephthalicAcid": "TPA"}


def _solid(chemical, prop: str, *args) -> float:
    handle = getattr(chemical, prop)
    return handle(*args) if chemical.locked_state else handle.s(*args)


def _defined(ID: str, known: dict):
    """A chemical of data/plant_chemicals.csv: its formula, and its density and solid heat
    capacity either given or taken per gram from the chemical it is `like` (in `known`)."""
    import thermosteam as tmo

    props = table(FILE).query("chemical == @ID").set_index("property").value
    c = tmo.Chemical(ID, search_db=False, formula=props["formula"], phase=DEFINED[ID])
    reference = known.get(props.get("like"))
    if "heat_capacity" in props:
        c.Cn.add_model(float(props["heat_capacity"]) * c.MW)  # J/(g K) -> J/(mol K)
    else:
        per_gram = _solid(reference, "Cn", 298.15) / reference.MW
        c.Cn.add_model(per_gram * c.MW)
    rho = float(props["density"]) if "density" in props else reference.MW / _solid(reference, "V", 298.15, 101325.0) / 1e3
    c.V.add_model(c.MW / rho / 1e3)  # m3/mol
    c.default()  # what is still missing (viscosity, conductivity, ...) is water's, as BioSTEAM's biorefineries do
    return c


def value(chemical: str, prop: str) -> float:
    """A numeric property of data/plant_chemicals.csv (e.g. Na2SO4's solubility_kg_per_kg_water)."""
    return float(table(FILE).query("chemical == @chemical and property == @prop").value.iloc[0])


@cache
def create_chemicals():
    """The compiled thermosteam Chemicals of the plant (built once per process)."""
    import thermosteam as tmo

    db = {ID: tmo.Chemical(ID) for ID in DATABASE}
    chems = [c.at_state(DATABASE[ID], copy=True) if DATABASE[ID] else c for ID, c in db.items()]
    for c in chems:
        if c.locked_state:  # a dissolved or suspended solid: the liquor's viscosity is water's
            c.copy_models_from(db["Water"], ["mu"])
    for ID in DEFINED:
        db[ID] = _defined(ID, db)
        chems.append(db[ID])
    chemicals = tmo.Chemicals(chems)
    chemicals.compile()
    for ID, synonym in SYNONYMS.items():
        chemicals.set_synonym(ID, synonym)
    return chemicals
