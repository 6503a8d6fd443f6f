"""From a PET feed and a ball charge to the size of a continuous rotating mill.

Hold-up = (PET + NaOH) feed x residence time; balls = BPR x hold-up; the ball bed
(balls / (1 - porosity)) fills `fill_fraction` of the mill.  The mill's shape is fixed by
one rule: a length-to-diameter ratio, or running `speed_rpm` at a fraction of the critical
speed N_c = 42.3 / sqrt(D - d) rpm.  With the first rule, speed_rpm null runs the mill at that
fraction of its critical speed.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, fields

from .config import ConfigError, ScaleupConfig
from .data import lookup, table

POUND_KG = 0.45359237
CHARGE_COLUMN = re.compile(r"charge_([0-9.]+)mm_balls")  # a graded charge's size in a record


def stoichiometric_naoh_kg_per_h(pet_kg_per_h: float) -> float:
    """2 mol NaOH per mol of PET repeat unit (PET + 2 NaOH -> Na2TPA + EG)."""
    pet = lookup("molar_masses.csv", "species", "pet_repeat_unit", "molar_mass_g_per_mol")
    naoh = lookup("molar_masses.csv", "species", "naoh", "molar_mass_g_per_mol")
    return pet_kg_per_h * 2 * naoh / pet


def regional_pet_feed_kg_per_h(region: str, napcor_quantity: str, hours_per_year: float) -> float:
    """NAPCOR 2018 national PET (million lb/yr) x the region's share of the 2018 US population."""
    pop = table("population_2018.csv")
    if region not in set(pop.code):
        raise ConfigError(f"scaleup.region={region!r} is not one of {sorted(pop.code)}")
    share = lookup("population_2018.csv", "code", region, "population") / lookup(
        "population_2018.csv", "code", "US", "population")
    national_kg = lookup("napcor_2018.csv", "quantity", napcor_quantity, "value_million_lb") * 1e6 * POUND_KG
    return national_kg * share / hours_per_year


def critical_speed_rpm(mill_diameter_m: float, ball_diameter_m: float) -> float:
    """N_c = 42.3 / sqrt(D - d) rpm (D, d in m)."""
    return 42.3 / math.sqrt(mill_diameter_m - ball_diameter_m)


@dataclass(frozen=True)
class MillDesign:
    pet_feed_kg_per_h: float
    naoh_feed_kg_per_h: float
    residence_time_min: float
    holdup_kg: float
    ball_mass_kg: float
    ball_count: int
    ball_radius_m: float
    mill_volume_m3: float
    diameter_m: float
    length_m: float
    speed_rpm: float
    critical_speed_rpm: float
    fraction_of_critical: float
    charge_diameters_m: tuple[float, ...] = ()  # a graded charge: its sizes and counts
    charge_counts: tuple[int, ...] = ()

    def as_record(self) -> dict:
        """Flat record; a graded charge as one column per size (charge_<d mm>mm_balls)."""
        rec = asdict(self)
        sizes = zip(rec.pop("charge_diameters_m"), rec.pop("charge_counts"))
        return rec | {f"charge_{1000 * d:g}mm_balls": n for d, n in sizes}

    @classmethod
    def from_record(cls, rec: dict) -> MillDesign:
        """The design `as_record` flattened (a row of a sweep's table, whose other jobs' charge
        columns are NaN here)."""
        sizes = sorted(((float(m[1]) / 1000, int(n)) for k, n in rec.items()
                        if (m := CHARGE_COLUMN.fullmatch(k)) and not math.isnan(n)), reverse=True)
        return cls(**{f.name: rec[f.name] for f in fields(cls) if not f.name.startswith("charge_")},
                   charge_diameters_m=tuple(d for d, _ in sizes), charge_counts=tuple(n for _, n in sizes))


def design_mill(cfg: ScaleupConfig) -> MillDesign:
    """The mill for a feed (explicit, or a region's share of the national PET) at cfg's BPR and shape."""
    if (cfg.region is None) == (cfg.pet_feed_kg_per_h is None):
        raise ConfigError(f"scaleup: give either pet_feed_kg_per_h (now {cfg.pet_feed_kg_per_h}) or region "
                          f"(now {cfg.region}), not both or neither (set the other to null)")
    pet = cfg.pet_feed_kg_per_h
    if cfg.region is not None:
        pet = regional_pet_feed_kg_per_h(cfg.region, cfg.napcor_quantity, cfg.operating_hours_per_year)
    naoh = cfg.naoh_feed_kg_per_h
    if naoh is None:
        naoh = cfg.naoh_to_stoichiometric * stoichiometric_naoh_kg_per_h(pet)
    holdup = (pet + naoh) * cfg.residence_time_min / 60.0
    ball_mass = cfg.bpr * holdup
    volume = ball_mass / cfg.ball_density_kg_per_m3 / (1 - cfg.bed_porosity) / cfg.fill_fraction
    sizes = sorted(cfg.charge, key=lambda c: -c.diameter_m)
    diameters = tuple(c.diameter_m for c in sizes) or (2 * cfg.ball_radius_m,)
    fractions = [c.mass_fraction for c in sizes] or [1.0]
    counts = tuple(max(1, round(f * ball_mass / (cfg.ball_density_kg_per_m3 * math.pi / 6 * d**3)))
                   for f, d in zip(fractions, diameters))
    d_ball = sum(f * d for f, d in zip(fractions, diameters))  # mass-weighted mean: the critical speed's d
    if cfg.shape_rule == "length_to_diameter":
        diameter = (4 * volume / (math.pi * cfg.length_to_diameter)) ** (1 / 3)
    elif cfg.speed_rpm is None:
        raise ConfigError("scaleup.shape_rule=fraction_of_critical sizes the diameter from scaleup.speed_rpm: give it "
                          "(null runs the mill at fraction_of_critical with the length_to_diameter rule)")
    else:
        diameter = d_ball + (42.3 * cfg.fraction_of_critical / cfg.speed_rpm) ** 2
    length = volume / (math.pi / 4 * diameter**2)
    if diameters[0] >= min(diameter, length) / 2:
        name = "charge" if cfg.charge else f"ball_radius_m={cfg.ball_radius_m}"
        raise ConfigError(f"scaleup.{name}: balls of {diameters[0]:g} m do not fit a mill of "
                          f"D {diameter:.3g} m x L {length:.3g} m (at most a quarter of the smaller side)")
    n_crit = critical_speed_rpm(diameter, d_ball)
    speed = cfg.speed_rpm if cfg.speed_rpm is not None else cfg.fraction_of_critical * n_crit
    return MillDesign(
        pet_feed_kg_per_h=pet, naoh_feed_kg_per_h=naoh, residence_time_min=cfg.residence_time_min, holdup_kg=holdup,
        ball_mass_kg=ball_mass, ball_count=sum(counts), ball_radius_m=d_ball / 2,
        mill_volume_m3=volume, diameter_m=diameter, length_m=length, speed_rpm=speed,
        critical_speed_rpm=n_crit, fraction_of_critical=speed / n_crit,
        charge_diameters_m=diameters if cfg.charge else (), charge_counts=counts if cfg.charge else (),
    )
