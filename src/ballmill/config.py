"""The configuration schema: structured configs registered with Hydra.

Every field has a unit in its name (or is dimensionless) and, where a range applies, the
allowed range in its metadata.  `to_object` turns a composed config node into its dataclass and
checks every value against them (numbers must also be finite), naming the field, the value and
the range when one is off.  The run's groups (sim, mill, scaleup, economics, lab, study) come
first, then the options of the other commands (track, render, calibrate, report, bench).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import typing
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf

CONF_DIR = Path(str(files("ballmill") / "conf"))  # the YAML configs, packaged with the wheel


def rng(default, lo=None, hi=None, *, lo_open=False, hi_open=False, doc=""):
    """A field with an allowed range [lo, hi] (ends open where asked) and a docstring."""
    return field(default=default, metadata={"range": (lo, hi, lo_open, hi_open), "doc": doc})


class ConfigError(ValueError):
    """A config value outside its allowed range, an unknown name, or an input file that cannot be
    used: the user's to fix (the command line prints its message alone)."""


@dataclass
class MaterialConfig:
    """A material of balls, jars or walls (materials.NAME): its density and elastic constants."""

    density_kg_per_m3: float = rng(7900.0, 0.0, None, lo_open=True, doc="mass density")
    shear_modulus_pa: float = rng(77e9, 0.0, None, lo_open=True, doc="shear modulus G (Young's E = 2 G (1 + v))")
    poisson_ratio: float = rng(0.3, 0.0, 0.5, hi_open=True, doc="Poisson's ratio v")
    source: str = field(default="", metadata={"doc": "where the values come from"})


@dataclass
class InteractionConfig:
    """The contact of two materials (interactions.A-B): restitution and friction."""

    restitution: float = rng(0.5, 0.0, 1.0, lo_open=True, doc="normal coefficient of restitution of the pair")
    static_friction: float = rng(0.5, 0.0, None,
                                 doc="sliding (Coulomb) friction coefficient: tangential force capped at mu F_n")
    rolling_friction: float = rng(0.01, 0.0, None, doc="rolling friction coefficient (EDEM type A: torque mu_r F_n R)")
    source: str = field(default="", metadata={"doc": "where the values come from"})


@dataclass
class SimConfig:
    """Numerics of a DEM run: backend, time step, durations, sampling, outputs and guard rails."""

    arch: str = field(default="cpu", metadata={
        "choices": ("cpu", "cuda"), "doc": "Taichi backend; cuda never falls back to the CPU"})
    precision: str = field(default="f64", metadata={
        "choices": ("f64", "f32"), "doc": "floating point of the engine (f64 for reference runs)"})
    threads: int = rng(0, 0, None, doc="CPU threads for Taichi; 0 = all cores")
    seed: int = rng(0, 0, None, doc="seed of the initial state (which size takes which lattice site, jar starts)")
    dt_fraction: float = rng(0.2, 0.0, 1.0, lo_open=True, doc=(
        "time step as a fraction of the Rayleigh step (a warning above 0.4; 1 refused unless "
        "allow_unstable_time_step)"))
    dt_s: float | None = rng(None, 0.0, None, lo_open=True, doc="explicit time step (s), overrides dt_fraction")
    allow_unstable_time_step: bool = field(default=False, metadata={
        "doc": "run even at a time step at or above the Rayleigh step (refused otherwise)"})
    shear_modulus_scale: float = rng(1.0, 0.0, 1.0, lo_open=True, doc="stiffness reduction for speed (1 = physical)")
    settle_s: float = rng(0.5, 0.0, None, doc="time the charge settles before the vessel moves (s)")
    startup_revolutions: float | None = rng(1.0, 0.0, None, doc=(
        "drum: turning before the power is averaged, in revolutions of the drum (or steady_after_s)"))
    window_revolutions: float | None = rng(1.0, 0.0, None, lo_open=True, doc=(
        "drum: the averaging window, in revolutions of the drum (or duration_s)"))
    steady_after_s: float | None = rng(None, 0.0, None, doc=(
        "the power is averaged over samples later than this after settling (s), with duration_s in place of "
        "startup_revolutions and window_revolutions (null)"))
    duration_s: float | None = rng(None, 0.0, None, lo_open=True, doc=(
        "time simulated after settling (s), with steady_after_s in place of the revolutions"))
    sample_every_s: float = rng(0.01, 0.0, None, lo_open=True,
                                doc="time between two recorded samples of loads and energy (s)")
    power_se_target: float | None = rng(None, 0.0, 1.0, lo_open=True, doc=(
        "drum: stop once the mean power's standard error is below this fraction of it (after at least one "
        "revolution of averaging; null: always the whole duration)"))
    trajectory_every: int = rng(0, 0, None, doc="record particle states every n samples (0: never)")
    vtk_every: int = rng(0, 0, None, doc="write ParaView files (particles, walls) every n samples (0: never)")
    max_contacts_per_particle: int = rng(16, 1, 64, doc="neighbour-list and wall-contact slots per particle "
                                                       "(at most 64: one bit each in the engine's open-contact mask)")
    checkpoint_every_wall_s: float | None = rng(60.0, 0.0, None, lo_open=True, doc=(
        "wall-clock time between checkpoints of a drum run (s; a run shorter than this writes none); null: none"))
    neighbour_skin: float = rng(0.5, 0.0, None, lo_open=True,
                                doc="Verlet skin / largest ball radius (larger: fewer list rebuilds, more candidates)")
    event_capacity: int = rng(200_000, 1, None, doc=("finished collisions the engine holds (read at the first sample "
                                                     "that finds it half full, and at the end)"))
    max_overlap_fraction: float = rng(0.05, 0.0, 1.0, lo_open=True, doc="largest overlap / radius before a run stops")
    neighbour_search: str = field(default="auto", metadata={
        "choices": ("auto", "grid", "all_pairs"), "doc": "auto: a cell grid when a replica has more than 8 balls"})
    launch: str = field(default="auto", metadata={
        "choices": ("auto", "serial", "team", "parallel"),
        "doc": "serial: whole steps per launch (auto: replica batches, < 500 balls or one thread); team: "
               "whole steps per launch by all CPU threads (auto: larger systems on a CPU, on one thread while that "
               "is faster); parallel: a launch a step"})
    collision_log: bool = field(default=True, metadata={"doc": "record every finished contact (collisions table)"})
    progress_every_s: float = rng(30.0, 0.0, None, lo_open=True, doc="wall-clock time between progress log lines (s)")

    def __post_init__(self):
        seconds, turns = (self.steady_after_s, self.duration_s), (self.startup_revolutions, self.window_revolutions)
        if not ((None not in seconds and turns == (None, None)) or (None not in turns and seconds == (None, None))):
            raise ConfigError(
                f"sim: the start-up and the averaging window are given in revolutions (startup_revolutions="
                f"{self.startup_revolutions}, window_revolutions={self.window_revolutions}) or in seconds "
                f"(steady_after_s={self.steady_after_s}, duration_s={self.duration_s}): give one pair and set the "
                "other null, e.g. sim.window_revolutions=2, or sim.steady_after_s=1 sim.duration_s=5 "
                "sim.startup_revolutions=null sim.window_revolutions=null")


@dataclass
class LinerConfig:
    """The shell's inner profile: smooth, `count` lifter bars (trapezoids standing on the shell:
    height, top width, faces inclined `face_angle_deg` from the radial line, wider at the base)
    or a wave liner (`count` waves of peak-to-trough `height`).  Lengths in metres, or as
    fractions (height of the inner diameter, top width of the height) for mills sized by the
    scale-up; give one of each pair."""

    kind: str = field(default="smooth", metadata={
        "choices": ("smooth", "bars", "wave"), "doc": "shell profile: smooth cylinder, lifter bars or a wave liner"})
    count: int = rng(0, 0, None, doc="lifter bars or waves around the shell")
    height_m: float | None = rng(None, 0.0, None, lo_open=True, doc="bar height or wave peak-to-trough (m)")
    height_to_diameter: float | None = rng(None, 0.0, 0.25, lo_open=True,
                                           doc="height_m / inner diameter (mills sized by the scale-up)")
    top_width_m: float | None = rng(None, 0.0, None, lo_open=True, doc="bars: width of the bar's top")
    top_width_to_height: float | None = rng(None, 0.0, None, lo_open=True,
                                            doc="bars: top width / bar height (mills sized by the scale-up)")
    face_angle_deg: float = rng(0.0, 0.0, 60.0, doc="bars: each face's tilt from the radial line")
    first_angle_deg: float = rng(0.0, None, None, doc="angular position of the first bar or wave crest")

    def __post_init__(self):
        if self.kind not in ("bars", "wave"):  # smooth, or a wrong name the range check reports
            return
        if self.count < 1:
            raise ConfigError(f"liner.count={self.count}: a {self.kind} liner needs at least 1 bar or wave")
        if (self.height_m is None) == (self.height_to_diameter is None):
            raise ConfigError(f"liner: give one of height_m ({self.height_m}) and height_to_diameter "
                              f"({self.height_to_diameter}), the other null")
        if self.kind == "bars" and (self.top_width_m is None) == (self.top_width_to_height is None):
            raise ConfigError(f"liner: bars need one of top_width_m ({self.top_width_m}) and top_width_to_height "
                              f"({self.top_width_to_height}), the other null")


@dataclass
class BallSizeConfig:
    """One size of a graded charge: a diameter and either a ball count or a mass fraction."""

    diameter_m: float = rng(0.02, 0.0, None, lo_open=True, doc="ball diameter (m)")
    count: int | None = rng(None, 1, None, doc="balls of this size")
    mass_fraction: float | None = rng(None, 0.0, 1.0, lo_open=True, doc="this size's share of the charge's mass")


def check_charge(name: str, charge: list[BallSizeConfig]) -> None:
    """All sizes by count, or all by mass fraction summing to 1."""
    if not charge:
        return
    by_count = [c.count is not None for c in charge]
    by_mass = [c.mass_fraction is not None for c in charge]
    if not (all(by_count) and not any(by_mass)) and not (all(by_mass) and not any(by_count)):
        raise ConfigError(f"{name}: give every size a count, or every size a mass_fraction (not both, none or a mix)")
    if all(by_mass) and abs(sum(c.mass_fraction for c in charge) - 1.0) > 1e-6:
        raise ConfigError(f"{name}: the mass fractions sum to {sum(c.mass_fraction for c in charge):g}, not 1")


@dataclass
class DrumConfig:
    """A horizontal rotating drum (axis along y), flat ends, smooth or lined shell, balls of
    one size (ball_radius_m) or a graded charge."""

    inner_diameter_m: float = rng(0.4, 0.0, None, lo_open=True, doc="inside diameter of the shell (m)")
    inner_length_m: float = rng(0.2, 0.0, None, lo_open=True, doc="inside length between the end walls (m)")
    ball_radius_m: float = rng(0.005, 0.0, None, lo_open=True, doc="radius of every ball of a one-size charge (m)")
    fill_fraction: float = rng(0.3, 0.0, 1.0, lo_open=True, hi_open=True, doc="ball bed volume / mill volume")
    bed_porosity: float = rng(0.4, 0.0, 1.0, hi_open=True,
                              doc="void share of the ball bed: with fill_fraction, the ball count")
    ball_count: int | None = rng(None, 1, None, doc="overrides fill_fraction and bed_porosity")
    speed_rpm: float | None = rng(None, 0.0, None, lo_open=True, doc="explicit speed; else fraction_of_critical")
    fraction_of_critical: float = rng(0.7, 0.0, 1.5, lo_open=True,
                                      doc="speed / critical speed, N_c = 42.3 / sqrt(D - d) rpm (speed_rpm null)")
    geometry: str = field(default="analytic", metadata={
        "choices": ("analytic", "stl"), "doc": "shell as analytic cylinder and planes, or as a triangle mesh"})
    stl_path: str | None = field(default=None, metadata={
        "doc": "stl: a closed STL of the vessel; null: a mesh of the drum with stl_segments facets"})
    stl_segments: int = rng(128, 8, None, doc="facets around a generated drum mesh (STL drum, lined shell)")
    ball_material: str = field(default="steel", metadata={"doc": "a name of materials.* (conf/material/)"})
    wall_material: str = field(default="steel", metadata={"doc": "a name of materials.* (conf/material/)"})
    liner: LinerConfig = field(default_factory=LinerConfig, metadata={"doc": "the shell's profile (mill.liner.*)"})
    charge: list[BallSizeConfig] = field(default_factory=list, metadata={
        "doc": "graded charge (replaces ball_radius_m; with counts it replaces the fill too)"})

    def __post_init__(self):
        check_charge("mill.charge", self.charge)


@dataclass
class ScaleupConfig:
    """Feed and charge to mill size (paper: 20 min, 30 % fill, 80 mm ball radius, 15 rpm)."""

    pet_feed_kg_per_h: float | None = rng(1000.0, 0.0, None, lo_open=True, doc="PET feed; null when region is given")
    region: str | None = field(default=None, metadata={
        "doc": "state code: feed = national PET x population share (set pet_feed_kg_per_h=null)"})
    napcor_quantity: str = field(default="bottles_collected", metadata={
        "choices": ("bottles_collected", "bought_by_us_reclaimers", "available_for_recycling"),
        "doc": "which NAPCOR 2018 quantity is the national PET (data/napcor_2018.csv)"})
    operating_hours_per_year: float = rng(7920.0, 0.0, 8784.0, lo_open=True,
                                          doc="operating hours of the mill per year (h)")
    naoh_feed_kg_per_h: float | None = rng(None, 0.0, None, doc="explicit NaOH feed; else naoh_to_stoichiometric")
    naoh_to_stoichiometric: float = rng(1.0, 0.0, None, lo_open=True, doc="NaOH feed / 2 mol per PET repeat unit")
    bpr: float = rng(19.0, 0.0, None, lo_open=True, doc="ball mass / reactant (PET + NaOH) mass")
    residence_time_min: float = rng(20.0, 0.0, None, lo_open=True, doc="time the charge spends in the mill (min)")
    fill_fraction: float = rng(0.3, 0.0, 1.0, lo_open=True, hi_open=True, doc="ball bed volume / mill volume")
    bed_porosity: float = rng(0.4, 0.0, 1.0, hi_open=True, doc="void share of the ball bed")
    ball_radius_m: float = rng(0.08, 0.0, None, lo_open=True, doc="ball radius of a one-size charge (m)")
    ball_density_kg_per_m3: float = rng(7900.0, 0.0, None, lo_open=True, doc="ball material density")
    speed_rpm: float | None = rng(15.0, 0.0, None, lo_open=True, doc="null: fraction_of_critical x critical speed")
    shape_rule: str = field(default="length_to_diameter", metadata={
        "choices": ("length_to_diameter", "fraction_of_critical"),
        "doc": "the mill's proportions: a fixed L/D, or the diameter that puts speed_rpm at fraction_of_critical"})
    length_to_diameter: float = rng(1.5, 0.0, None, lo_open=True,
                                    doc="mill length / diameter (shape_rule=length_to_diameter)")
    fraction_of_critical: float = rng(0.7, 0.0, 1.5, lo_open=True,
                                      doc="speed / critical speed (shape_rule=fraction_of_critical, or speed_rpm null)")
    charge: list[BallSizeConfig] = field(default_factory=list, metadata={
        "doc": "graded charge by mass fraction (replaces ball_radius_m; the counts follow from the BPR)"})

    def __post_init__(self):
        check_charge("scaleup.charge", self.charge)
        if self.charge and self.charge[0].count is not None:
            raise ConfigError("scaleup.charge: give each size a mass_fraction; the counts follow from the BPR")


@dataclass
class EconomicsConfig:
    """Paper's Eq. 1-3 inputs; prices and indices are read from data/ files."""

    electricity_usd_per_kwh: float = rng(0.07, 0.0, None, doc="electricity price")
    hours_per_year: float = rng(7920.0, 0.0, 8784.0, lo_open=True, doc="operating hours per year (h)")
    cost_coefficient_usd: float = rng(64640.0, 0.0, None, lo_open=True,
                                      doc="C0 of the purchase cost C = C0 W^n (USD at cepci_base_year)")
    cost_exponent: float = rng(0.64, 0.0, 2.0, lo_open=True, doc="n of the purchase cost C = C0 W^n")
    capacity_unit: str = field(default="short_ton_per_h", metadata={
        "choices": ("short_ton_per_h", "tonne_per_h"), "doc": "unit of the correlation's capacity W"})
    capacity_basis: str = field(default="pet", metadata={
        "choices": ("pet", "pet_plus_naoh"), "doc": "what W counts: the PET feed, or PET + NaOH"})
    capacity_scaling: str = field(default="feed", metadata={
        "choices": ("feed", "holdup"),
        "doc": "W of the cost correlation: the feed (the paper), or the feed x residence time / "
               "reference_residence_time_min (a mill priced by the charge it holds)"})
    reference_residence_time_min: float = rng(20.0, 0.0, None, lo_open=True,
                                              doc="residence time at which the correlation's W is the feed")
    cepci_base_year: int = rng(2005, 1950, 2100, doc="CEPCI year of the correlation's costs")
    cepci_target_year: int = rng(2022, 1950, 2100, doc="CEPCI year costs are brought to")
    prices_file: str = field(default="prices.csv", metadata={"doc": "raw-material and product prices, a data/ table"})
    cepci_file: str = field(default="cepci.csv", metadata={"doc": "cost indices, a data/ table"})
    molar_masses_file: str = field(default="molar_masses.csv", metadata={
        "doc": "molar masses of the stoichiometry, a data/ table"})


@dataclass
class MM400Config:
    """Retsch MM400 jar and motion.  No citable source gave the 25 mL jar's inner size or the
    arm's geometry: defaults are estimates (docs/explanation/lab.md), each a field to sweep."""

    jar_volume_ml: float = rng(25.0, 0.0, None, lo_open=True,
                               doc="inner volume of the jar (mL); with the bore it sets the jar's length")
    jar_inner_diameter_m: float = rng(0.030, 0.0, None, lo_open=True, doc="end caps hemispherical")
    amplitude_m: float = rng(0.009, 0.0, None, doc="half stroke of the jar centre along its arc")
    pivot_radius_m: float = rng(0.11, 0.0, None, lo_open=True, doc="arm length: pivot to jar centre")
    frequencies_hz: list[float] = field(default_factory=lambda: [22.5, 25.0, 27.5, 30.0], metadata={
        "doc": "shaking frequencies simulated (Hz)"})
    ball_diameters_m: list[float] = field(default_factory=lambda: [0.0176, 0.0206], metadata={
        "doc": "ball diameters simulated (m)"})
    balls_per_jar: int = rng(1, 1, 2, doc="balls in each jar")
    wall_material: str = field(default="pmma", metadata={"doc": "jar material, a name of materials.*"})
    ball_material: str = field(default="steel", metadata={"doc": "ball material, a name of materials.*"})
    camera_fps: float = rng(2134.0, 0.0, None, lo_open=True,
                            doc="frame rate of the filmed speeds and collisions (frames/s)")
    duration_s: float = rng(2.0, 0.0, None, lo_open=True, doc="simulated shaking per condition (s)")
    settle_s: float = rng(0.2, 0.0, None, doc="start-up transient left out of the statistics")
    collision_speed_jump_m_per_s: float = rng(1.0, 0.0, None, lo_open=True,
                                              doc="frame-to-frame velocity change counted as a collision; "
                                                  "well above tracking noise (~0.2 m/s at 0.2 px)")

    def __post_init__(self):
        check_positive_lists(self, "lab", ("frequencies_hz", "ball_diameters_m"))


def check_positive_lists(obj, path: str, names: tuple[str, ...]) -> None:
    """Each named list field is non-empty and every entry a positive number."""
    for name in names:
        check_list(f"{path}.{name}", getattr(obj, name))


def check_list(name: str, values: list, hi: float | None = None, lo_open: bool = True) -> None:
    """A non-empty list of numbers in (0, hi] ([0, hi] when not lo_open)."""
    if not values:
        raise ConfigError(f"{name}=[] is empty: give at least one value")
    for i, v in enumerate(values):
        _check_field(f"{name}[{i}]", v, {"range": (0.0, hi, lo_open, False)})


@dataclass
class KineticsLabConfig:
    """The lab experiments behind the BPR line, as the lab DEM simulates them: an MM400 with
    balls of one size, the BPR set by the powder mass.  Which of these the literature states
    and which are assumed: data/yield_lab_conditions.csv.  The jar's nominal bore and volume are
    the lab group's (lab.jar_inner_diameter_m, lab.jar_volume_ml)."""

    frequency_hz: float = rng(30.0, 0.0, None, lo_open=True, doc="shaking frequency of the kinetics experiments (Hz)")
    balls_per_jar: int = rng(1, 1, 2, doc="balls in the jar")
    ball_diameter_m: float = rng(0.0206, 0.0, None, lo_open=True, doc="ball diameter (m)")
    jar_material: str = field(default="steel", metadata={"doc": "jar material, a name of materials.*"})
    bpr_basis: str = field(default="pet_plus_naoh", metadata={
        "choices": ("pet_plus_naoh", "pet"),
        "doc": "the BPR's powder: PET + NaOH (at the mill's NaOH:PET ratio), or PET alone"})
    duration_s: float = rng(3.0, 0.0, None, lo_open=True, doc="simulated milling of every lab condition (s)")
    settle_s: float = rng(0.5, 0.0, None, doc="start-up left out of the dose rate (s)")
    starts: int = rng(4, 1, None, doc=("starts of every lab condition, each with its own small random initial speed, "
                                       "pooled (a ball may slide in place from one start and bounce from another)"))
    frequencies_hz: list[float] = field(default_factory=lambda: [25.0, 30.0], metadata={
        "doc": "frequencies of the sensitivity run (the calibration's alternatives)"})
    ball_diameters_m: list[float] = field(default_factory=lambda: [0.0176, 0.0206], metadata={
        "doc": "ball sizes of the sensitivity run"})
    jar_inner_diameters_m: list[float] = field(default_factory=lambda: [0.028, 0.032], metadata={
        "doc": "jar bores of the sensitivity run, each at the nominal length and condition (m)"})
    jar_inner_lengths_m: list[float] = field(default_factory=lambda: [0.040, 0.050], metadata={
        "doc": "jar inner lengths, end to end, of the sensitivity run, each at the nominal bore and condition (m)"})

    def __post_init__(self):
        check_positive_lists(self, "yield_model.lab", ("frequencies_hz", "ball_diameters_m", "jar_inner_diameters_m",
                                                       "jar_inner_lengths_m"))


# The yield models of kinetics.py and the residence-time distributions of a continuous mill.
YIELD_MODELS = ("dose_linear", "saturating", "bpr_line")


@dataclass
class YieldFitConfig:
    """How the experiments table is fitted (study=yield_fit, kinetics.py): the candidate models,
    the dose measures (all collisions, and those of at least each E* of a grid), the level of the
    parameters' confidence intervals."""

    models: list[str] = field(default_factory=lambda: list(YIELD_MODELS), metadata={
        "doc": "candidate models, of dose_linear, saturating, bpr_line (the last only where every experiment has "
               "one milling time)"})
    thresholds_j: list[float] = field(default_factory=lambda: [0.001, 0.003, 0.01, 0.02], metadata={
        "doc": "E* of the impact-dose measures tried beside all collisions (J)"})
    confidence: float = rng(0.95, 0.0, 1.0, lo_open=True, hi_open=True,
                            doc="level of the parameters' confidence intervals (likelihood-ratio: profile likelihood)")

    def __post_init__(self):
        check_positive_lists(self, "yield_model.fit", ("thresholds_j",))
        if not self.models:
            raise ConfigError("yield_model.fit.models=[] is empty: give at least one of " + ", ".join(YIELD_MODELS))
        for i, m in enumerate(self.models):
            if m not in YIELD_MODELS:
                raise ConfigError(f"yield_model.fit.models[{i}]={m!r} is not one of {list(YIELD_MODELS)}")


@dataclass
class RtdConfig:
    """The continuous mill's residence-time distribution: the mill's yield is the yield averaged
    over it.  No measured RTD of a continuous ball mill could be read here (data/mill_rtd.csv lists
    the sources looked for): tanks and peclet are assumptions, their ranges swept in study=yield_fit."""

    kind: str = field(default="plug", metadata={
        "choices": ("plug", "tanks_in_series", "axial_dispersion"),
        "doc": "plug flow (every particle stays the mean time), n tanks in series, or axial dispersion"})
    tanks: float = rng(3.0, 1.0, None, doc="tanks_in_series: n (1: one perfectly mixed mill); assumed, not measured")
    peclet: float = rng(10.0, 0.0, None, lo_open=True,
                        doc="axial_dispersion: Pe = u L / E (large: near plug flow); assumed, not measured")
    sensitivity_tanks: list[float] = field(default_factory=lambda: [1.0, 2.0, 3.0, 5.0, 10.0, 30.0], metadata={
        "doc": "study=yield_fit: the n of tanks in series its RTD table tries"})
    sensitivity_peclets: list[float] = field(default_factory=lambda: [2.0, 5.0, 10.0, 20.0, 50.0], metadata={
        "doc": "study=yield_fit: the Peclet numbers its RTD table tries"})

    def __post_init__(self):
        check_positive_lists(self, "yield_model.rtd", ("sensitivity_tanks", "sensitivity_peclets"))
        for i, n in enumerate(self.sensitivity_tanks):
            _check_field(f"yield_model.rtd.sensitivity_tanks[{i}]", n, {"range": (1.0, None, False, False)})


def yield_rule_names() -> tuple[str, ...]:
    """The registered yield rules (yield_rules.RULES)."""
    from . import yield_rules  # the registry's modules import this one: read when a config is checked

    return tuple(yield_rules.RULES)


@dataclass
class YieldModelConfig:
    """TPA yield of the mill: the paper's BPR line, yield from the collision dose per kg of PET
    calibrated on the lab DEM, or a model fitted to kinetics experiments
    (docs/explanation/yield.md)."""

    rule: str = field(default="bpr_line", metadata={
        "choices": yield_rule_names,
        "doc": "bpr_line: yield from the BPR; specific_energy: from the collision dose; impact_threshold: from the "
               "dose of impacts of at least impact_threshold_j; fitted: the model and dose measure the experiments "
               "table chooses (study=yield_fit)"})
    bpr_slope_percent: float = field(default=6.38, metadata={
        "doc": "slope of the lab's yield line Y = slope BPR + intercept (% per unit BPR)"})
    bpr_intercept_percent: float = field(default=-46.35, metadata={"doc": "intercept of the lab's yield line (%)"})
    bpr_min: float = field(default=10.0, metadata={"doc": "lowest BPR of the line's experiments"})
    bpr_max: float = field(default=23.0, metadata={"doc": "highest BPR of the line's experiments"})
    lab_time_min: float = rng(20.0, 0.0, None, lo_open=True, doc="milling time of the BPR line's experiments")
    allow_extrapolation: bool = field(default=False, metadata={
        "doc": "use the line outside [bpr_min, bpr_max] (refused otherwise)"})
    impact_threshold_j: float = rng(0.01, 0.0, None, lo_open=True,
                                    doc="E*: collisions with a normal impact energy at least this count (J)")
    mill_stiffness: str = field(default="physical", metadata={
        "choices": ("physical", "sim"),
        "doc": "dose measures of impacts above E*: the mill's DEM at the materials' physical stiffness, as the lab's "
               "(the impact spectrum shifts with stiffness), or at the sim preset's shear_modulus_scale"})
    mode: str = field(default="target_yield", metadata={
        "choices": ("target_yield", "fixed_time"),
        "doc": "dose rules: solve the residence time for the target, or keep scaleup.residence_time_min"})
    target_yield_percent: float | None = rng(None, 0.0, 100.0, lo_open=True,
                                             doc="null: the BPR line's yield at this BPR")
    tolerance: float = rng(0.01, 0.0, 1.0, lo_open=True, doc="fixed point: relative change of the residence time")
    max_iterations: int = rng(8, 1, None, doc="fixed point: DEM runs at most")
    sensitivity_step: float = rng(0.2, 0.0, 1.0, lo_open=True,
                                  doc="fixed point: the mills at tau (1 + step)^-1 and tau (1 + step) around the root "
                                      "measure the dose rate's exponent and error (two DEM runs)")
    dose_batches: int = rng(10, 2, None, doc="averaging window split into this many batches for standard errors")
    lab: KineticsLabConfig = field(default_factory=KineticsLabConfig, metadata={
        "doc": "the lab experiments behind the line (yield_model.lab.*)"})
    experiments: str = field(default="yield_experiments.csv", metadata={
        "doc": "rule=fitted, study=yield_fit: the kinetics experiments, a data/ table or a path to one of the same "
               "columns (docs/how-to/yield-rules.md)"})
    fit: YieldFitConfig = field(default_factory=YieldFitConfig, metadata={
        "doc": "how the experiments are fitted (yield_model.fit.*)"})
    rtd: RtdConfig = field(default_factory=RtdConfig, metadata={
        "doc": "the mill's residence-time distribution (yield_model.rtd.*)"})


@dataclass
class EvaporationConfig:
    """How the mother liquor's water is evaporated (plant/evaporation=multi_effect|mvr; the options:
    plant/evaporation.py).  multi_effect: bodies at effect_pressures_pa heated by the plant's
    steam, the first by live steam; mvr: one forced-circulation body heated by its own vapour,
    recompressed on electricity (kwh_per_t_water, the feed preheated by the condensate)."""

    kind: str = field(default="multi_effect", metadata={"choices": ("multi_effect", "mvr"),
                                                         "doc": "multiple effects on steam, or vapour recompression"})
    effect_pressures_pa: list[float] = field(default_factory=lambda: [101325.0, 60000.0, 25000.0], metadata={
        "doc": "multi_effect: each body's pressure, falling (Pa; one to six effects)"})
    feed_preheat: bool = field(default=True, metadata={
        "doc": "multi_effect: the condensate heats the feed in a process exchanger before the first body"})
    approach_temperature_k: float = rng(5.0, 1.0, 30.0, doc="multi_effect, feed_preheat: the exchanger's approach (K)")
    kwh_per_t_water: float = rng(30.0, 10.0, 100.0, doc="mvr: electricity per tonne of water evaporated")
    pressure_pa: float = rng(101325.0, 20000.0, 300000.0, doc="mvr: the body's pressure (Pa)")
    temperature_difference_k: float = rng(6.0, 2.0, 20.0,
                                          doc="mvr: condensing vapour over boiling liquor, set by the compression (K)")
    u_w_per_m2_k: float = rng(2000.0, 300.0, 6000.0, doc="mvr: the body's overall heat-transfer coefficient")
    compressor_cost: str = field(default="centrifugal_compressor_seider_2017", metadata={
        "doc": "mvr: the compressor's cost correlation (kW of shaft power), a row of data/cost_correlations.csv"})

    def __post_init__(self):
        p = self.effect_pressures_pa
        if not 1 <= len(p) <= 6 or any(b >= a for a, b in itertools.pairwise(p)) or not 5000.0 <= min(p) <= max(p) <= 5e5:
            raise ConfigError(f"plant.evaporation.effect_pressures_pa={p}: give one to six falling pressures within "
                              "[5000.0, 500000.0] Pa")


@dataclass
class HeatConfig:
    """Where the plant's steam comes from (plant/heat=bought_steam|electric_boiler|residue_boiler;
    the options: plant/heat.py).  bought_steam: at its price and natural gas's factor; an electric
    boiler on the grid; a boiler burning the sorted-out plastics, topped up with bought steam."""

    kind: str = field(default="bought_steam", metadata={
        "choices": ("bought_steam", "electric_boiler", "residue_boiler"), "doc": "the steam's source"})
    electric_efficiency: float = rng(0.99, 0.5, 1.0, doc="electric_boiler: steam heat / electricity")
    boiler_efficiency: float = rng(0.80, 0.3, 0.95, doc="residue_boiler: steam heat / the fuel's lower heating value")


@dataclass
class SodiumConfig:
    """What becomes of the sodium (plant/sodium=salt|landfilled|bpmed; the options: plant/sodium.py).
    salt: Na2SO4 leaves at plant.na2so4_usd_per_t; landfilled: at the tip fee and the landfill's
    factor; bpmed: bipolar-membrane electrodialysis splits it
    back into NaOH and H2SO4 (Na2SO4 + 2 H2O -> 2 NaOH + H2SO4), which the plant then buys less of,
    their water evaporated in effects on steam."""

    kind: str = field(default="salt", metadata={"choices": ("salt", "landfilled", "bpmed"),
                                                 "doc": "salt at its value, landfilled, or split back"})
    kwh_per_kg_naoh: float = rng(4.72, 1.0, 20.0, doc="bpmed: the stack's electricity per kg NaOH made")
    current_efficiency: float = rng(0.364, 0.1, 1.0, doc="bpmed: NaOH made / the charge passed (Faraday)")
    current_density_a_per_m2: float = rng(500.0, 50.0, 2000.0, doc="bpmed: current per m2 of bipolar membrane")
    stack_to_membrane: float = rng(2.0, 1.0, 10.0, doc="bpmed: the stack's price / its bipolar membranes'")
    membrane_life_yr: int = rng(3, 1, 30, doc="bpmed: years before the stack is bought again")
    product_wt_fraction: float = rng(0.08, 0.01, 0.5, doc="bpmed: NaOH and H2SO4 in their dilute solutions")
    concentrating_effects: int = rng(3, 1, 8, doc="bpmed: effects that evaporate the solutions' water on steam")


@dataclass
class RegionalConfig:
    """study=regional: one plant for a group of states against a plant each, the bales hauled by
    truck from each state's centre of population (data/haulage.csv, data/population_centres.csv)."""

    states: list[str] = field(default_factory=lambda: ["FL", "GA", "NC", "VA", "MD", "SC", "WV", "DE", "DC"],
                              metadata={"doc": "the states (codes of data/population_centres.csv), each a candidate "
                                               "site of the regional plant; two at least"})
    scale_fresh_pet_kg_per_h: list[float] = field(default_factory=lambda: [100.0, 50000.0], metadata={
        "doc": "[low, high] fresh PET feeds (kg/h, within [10, 1e6]) searched for the one at which a plant meets "
               "virgin TPA's price and PTA's footprint (scale.csv)"})

    def __post_init__(self):
        if len(set(self.states)) < 2 or len(set(self.states)) < len(self.states):
            raise ConfigError(f"plant.regional.states={self.states}: give two or more different state codes")
        check_interval("plant.regional.scale_fresh_pet_kg_per_h", self.scale_fresh_pet_kg_per_h, 10.0, 1e6)


OPTION_GROUPS = ("evaporation", "heat", "sodium", "naoh_dosing")  # the plant's options a front can cross


@dataclass
class PlantConfig:
    """The plant around the mill, on BioSTEAM: feed preparation, the units' design choices, the
    cost year, NREL's TEA convention, the staffing rule and the Monte Carlo (defaults and their
    sources: conf/plant/nrel.yaml; prices, factors and ranges: data/)."""

    feed_form: str = field(default="flake", metadata={
        "choices": ("flake", "powder"),
        "doc": "what the mill takes: granulated flake, or flake pulverised to the fine powder the lab used"})
    bale_pet_fraction: float = rng(0.8, 0.5, 1.0,
                                   doc="PET in a tonne of bales (the rest, caps, labels and dirt, is sorted out)")
    granulation_kwh_per_t: float = rng(132.0, 0.0, 1000.0, doc="granulator's electricity per tonne of bales")
    flake_loss_fraction: float = rng(0.02, 0.0, 0.5, doc="PET lost as fines in granulating and sorting")
    pulverising_kwh_per_t: float = rng(200.0, 0.0, 2000.0, doc="pulveriser's electricity per tonne of flake (powder)")
    powder_loss_fraction: float = rng(0.02, 0.0, 0.5, doc="PET lost in pulverising (powder)")
    granulator_cost: str = field(default="hammer_mill_seider_2017", metadata={
        "doc": "the granulator's cost correlation, a row of data/cost_correlations.csv"})
    pulveriser_cost: str = field(default="pulverizer_towler_2010", metadata={
        "doc": "the pulveriser's cost correlation, a row of data/cost_correlations.csv"})
    naoh_dosing: str = field(default="whole_feed", metadata={
        "choices": ("whole_feed", "converting_pet"),
        "doc": "NaOH dosed on all PET entering the mill (what the yield data were measured with), or only on the PET "
               "that converts per pass (less NaOH, less acid: whether the conversion holds is not known)"})
    recycle_purge_fraction: float = rng(0.05, 0.0, 1.0, lo_open=True,
                                        doc="share of the unreacted PET purged (1: no recycle)")
    dissolution_water_kg_per_kg_na2tpa: float = rng(8.0, 5.0, 100.0, doc=(
        "water that dissolves the Na2TPA (it dissolves to roughly 12-14 wt %, 6-7 kg/kg: below 5 it would not)"))
    tank_residence_time_h: float = rng(1.0, 0.0, 48.0, lo_open=True,
                                       doc="residence time that sizes the dissolver and the acidifier (h)")
    pet_cake_moisture: float = rng(0.3, 0.0, 0.9, doc="water in the unreacted-PET cake (mass fraction)")
    h2so4_to_stoichiometric: float = rng(1.02, 1.0, 2.0,
                                         doc="H2SO4 dosed / the acid that neutralises the Na2TPA and the NaOH left")
    condensate_reuse: bool = field(default=False, metadata={
        "doc": "the evaporator's condensate (water with the EG it carries) dissolves the Na2TPA, fresh water topping "
               "it up, its surplus treated; the TPA cake's wash stays fresh water (the EG would stay in the rTPA)"})
    neutralisation_heat: bool = field(default=False, metadata={
        "doc": "the acidifier's heat of neutralisation (data/plant_chemicals.csv) warms the liquor it sends on (less "
               "steam in the evaporator), or is left out (the acidifier's outlet at its feeds' temperature)"})
    heat_integration: bool = field(default=False, metadata={
        "doc": "a heat-exchanger network (BioSTEAM's pinch synthesis over the units' heat exchangers, condensers "
               "and reboilers) matches hot streams with cold ones: less steam and cooling water, its exchangers' "
               "cost added; false: every heat exchanger buys its own steam or cooling water"})
    hxn_min_approach_k: float = rng(10.0, 1.0, 50.0, doc=(
        "the heat-exchanger network's minimum approach temperature (K), with heat_integration"))
    tpa_recovery: float = rng(0.98, 0.5, 1.0, doc="share of the TPA the filter keeps")
    tpa_cake_moisture: float = rng(0.2, 0.03, 0.6, doc="water in the washed TPA cake (mass fraction)")
    wash_water_kg_per_kg_tpa: float = rng(2.0, 0.0, 20.0, doc="wash water on the TPA cake")
    dry_moisture: float = rng(0.002, 0.0, 0.02, doc="water left in the dried rTPA and salt (mass fraction)")
    evaporated_water_fraction: float = rng(0.95, 0.5, 0.99,
                                           doc="share of the mother liquor's water the evaporator removes")
    evaporator_cost: str = field(default="forced_circulation_evaporator_seider_2017", metadata={
        "doc": "the evaporator bodies' cost correlation (per body), a row of data/cost_correlations.csv"})
    crystallizer: str = field(default="last_effect", metadata={
        "choices": ("last_effect", "separate"),
        "doc": "last_effect: the evaporator's last forced-circulation body, holding the slurry, is the crystallizer "
               "(priced once, as a body); separate: a crystallizer priced beside it"})
    brine_material: str = field(default="stainless_steel_316", metadata={
        "doc": "material of the units in acidic sulfate brine (TPA filter, evaporator, crystallizer, centrifuge), a row "
               "of data/material_factors.csv"})
    crystallizer_cost: str = field(default="forced_circulation_crystallizer_seider_2017", metadata={
        "doc": "the Na2SO4 crystallizer's cost correlation, a row of data/cost_correlations.csv"})
    salt_cake_moisture: float = rng(0.05, 0.01, 0.4, doc="water in the centrifuged salt (mass fraction)")
    eg_stripper_recovery: float = rng(0.95, 0.5, 0.999,
                                      doc="share of the liquor's EG the stripper sets out to vaporise")
    eg_stripper_pressure_pa: float = rng(101325.0, 5000.0, 500000.0, doc="EG stripper's pressure (Pa)")
    eg_column_water_recovery: float = rng(0.999, 0.95, 0.9999, doc="water to the EG column's top")
    eg_column_eg_recovery: float = rng(0.995, 0.9, 0.9999, doc="EG to the EG column's bottom")
    eg_column_reflux_to_minimum: float = rng(1.2, 1.0, 5.0, lo_open=True, doc="reflux / minimum reflux")
    eg_column_pressure_pa: float = rng(101325.0, 5000.0, 500000.0, doc="EG column's pressure (Pa)")
    eg_price_fraction: float = rng(0.7, 0.0, 1.0, doc="recovered EG's price / virgin MEG's (purity discount)")
    na2so4_usd_per_t: float = rng(0.0, -1000.0, 1000.0, doc="the salt's value: sale (> 0) or disposal (< 0)")
    landfill: str = field(default="landfill_low_organic", metadata={
        "choices": ("landfill_low_organic", "landfill"),
        "doc": "the greenhouse-gas factor of the landfilled plastics and salt (a row of data/ghg_factors.csv): "
               "low-organic-carbon waste, or organic waste"})
    cost_year: int = rng(2021, 1950, 2100, doc="dollar year of the plant: equipment by CEPCI, the prices' year")
    mill_bare_module_factor: float = rng(2.3, 1.0, 10.0, doc="installed / purchase cost of the ball mill")
    warehouse: float = rng(0.04, 0.0, 1.0, doc="of ISBL installed cost")
    site_development: float = rng(0.09, 0.0, 1.0, doc="of ISBL installed cost")
    additional_piping: float = rng(0.045, 0.0, 1.0, doc="of ISBL installed cost")
    prorateable: float = rng(0.10, 0.0, 1.0, doc="prorateable costs, of the direct cost")
    field_expenses: float = rng(0.10, 0.0, 1.0, doc="of the direct cost")
    construction: float = rng(0.20, 0.0, 1.0, doc="home office and construction fees, of the direct cost")
    contingency: float = rng(0.10, 0.0, 1.0, doc="project contingency, of the direct cost")
    other_indirect: float = rng(0.10, 0.0, 1.0, doc="start-up, permits and other indirect costs, of the direct cost")
    working_capital_fraction: float = rng(0.05, 0.0, 1.0, doc="of the fixed capital")
    staffing: str = field(default="per_unit", metadata={
        "choices": ("per_unit", "fixed"),
        "doc": "per_unit: operators per shift from each unit (data/staffing.csv); fixed: plant.staff"})
    staff: int = rng(20, 1, 1000, doc="operating staff with staffing=fixed")
    operators_per_position: float = rng(4.5, 1.0, 10.0, doc="staff per operator position around the clock")
    operator_wage_usd_per_yr: float = rng(65460.0, 0.0, 1e6, doc="operator's mean annual wage")
    supervision_fraction: float = rng(0.15, 0.0, 1.0, doc="supervisory and clerical labour, of operating labour")
    labour_burden: float = rng(0.9, 0.0, 3.0, doc="overhead on salaries")
    maintenance_fraction: float = rng(0.03, 0.0, 0.2, doc="of the maintenance basis per year")
    maintenance_basis: str = field(default="isbl_installed", metadata={
        "choices": ("isbl_installed", "fixed_capital"),
        "doc": "what maintenance_fraction is a share of: ISBL installed cost (NREL) or the fixed capital"})
    insurance_fraction: float = rng(0.007, 0.0, 0.1, doc="property insurance and tax, of the fixed capital per year")
    plant_life_yr: int = rng(30, 1, 100, doc="years of operation")
    construction_fractions: list[float] = field(default_factory=lambda: [0.08, 0.60, 0.32], metadata={
        "doc": "capital spent in each construction year (sums to 1)"})
    startup_months: float = rng(3.0, 0.0, 12.0, doc="start-up: half the sales, 75 % of variable costs")
    loan_fraction: float = rng(0.4, 0.0, 1.0, hi_open=True, doc="share of the capital financed by debt")
    loan_interest: float = rng(0.08, 0.0, 1.0, doc="the loan's yearly interest")
    loan_years: int = rng(10, 1, 100, doc="years to repay the loan")
    discount_rate: float = rng(0.10, 0.0, 1.0, lo_open=True, doc="internal rate of return (real, after tax)")
    tax_rate: float = rng(0.21, 0.0, 1.0, hi_open=True, doc="income tax rate")
    depreciation_file: str = field(default="macrs_7yr.csv", metadata={"doc": "depreciation schedule, a data/ table"})
    evaporation: EvaporationConfig = field(default_factory=EvaporationConfig, metadata={
        "doc": "the evaporator (plant/evaporation=...)"})
    heat: HeatConfig = field(default_factory=HeatConfig, metadata={"doc": "the steam's source (plant/heat=...)"})
    sodium: SodiumConfig = field(default_factory=SodiumConfig, metadata={"doc": "the salt's fate (plant/sodium=...)"})
    prices_usd_per_t: dict[str, float] = field(default_factory=dict, metadata={"range": (0.0, 1e5, False, False),
        "doc": "prices that replace the prices file's, by item ($/t; steam per t, electricity: economics), e.g. "
               "+plant.prices_usd_per_t.naoh=700"})
    ghg_kg_co2e: dict[str, float] = field(default_factory=dict, metadata={"range": (0.0, 100.0, False, False),
        "doc": "greenhouse-gas factors that replace data/ghg_factors.csv's, by item (its unit: kg, MJ or kWh), e.g. "
               "+plant.ghg_kg_co2e.electricity_us=0.1"})
    what_it_takes: list[str] = field(default_factory=lambda: [
        "price.naoh", "price.pet_bale", "price.steam_factor", "economics.electricity_usd_per_kwh",
        "plant.operator_wage_usd_per_yr", "plant.dissolution_water_kg_per_kg_na2tpa", "price.eg", "yield.conversion",
        "ghg.naoh", "ghg.steam", "ghg.electricity_us", "ghg.pet_bale"], metadata={
        "doc": "levers whose break-even values (MSP = virgin TPA's price, footprint = virgin PTA's) the plant study "
               "solves for (what_it_takes.csv): parameters of data/plant_uncertainty.csv (yield.conversion: a "
               "factor on the conversion per pass of the same mill, at most 1); [] for none"})
    what_it_takes_span: float = rng(10.0, 1.0, 100.0,
                                    doc="each lever is searched between its base over and times this (within its range)")
    regional: RegionalConfig = field(default_factory=RegionalConfig, metadata={
        "doc": "study=regional: the states that could share a plant (plant.regional.*)"})
    options_front: list[str] = field(default_factory=list, metadata={
        "doc": "option groups crossed around the same mill (any of evaporation, heat, sodium, naoh_dosing; each once): "
               "every combination's MSP and footprint and their Pareto front (options.csv); [] for none"})
    monte_carlo_draws: int = rng(2000, 0, 100_000, doc="draws of the Monte Carlo (0: none)")
    seed: int = rng(0, 0, None, doc="seed of the Monte Carlo draws")

    def __post_init__(self):
        unknown = [g for g in self.options_front if g not in OPTION_GROUPS]
        if unknown or len(set(self.options_front)) < len(self.options_front):
            raise ConfigError(f"plant.options_front={self.options_front}: give each of {list(OPTION_GROUPS)} at most "
                              "once")
        check_positive_lists(self, "plant", ("construction_fractions",))
        if abs(sum(self.construction_fractions) - 1.0) > 1e-9:
            raise ConfigError(f"plant.construction_fractions={self.construction_fractions} sum to "
                              f"{sum(self.construction_fractions):g}: they must sum to 1")
        for cake in ("tpa_cake_moisture", "salt_cake_moisture"):
            if self.dry_moisture >= getattr(self, cake):
                raise ConfigError(f"plant.dry_moisture={self.dry_moisture} must be below plant.{cake}="
                                  f"{getattr(self, cake)}: a dryer cannot add water")


def check_interval(name: str, values: list, lo: float | None = None, hi: float | None = None) -> None:
    """[low, high] with low < high, both within [lo, hi]."""
    if len(values) != 2 or not values[0] < values[1]:
        raise ConfigError(f"{name}={values}: give [low, high] with low < high")
    for i, v in enumerate(values):
        _check_field(f"{name}[{i}]", v, {"range": (lo, hi, False, False)})


@dataclass
class DemConfig:
    """Where a design's power and collision dose come from: the DEM of its mill (full) or the
    surrogate fitted to DEM runs (milliseconds; its predicted uncertainty is recorded)."""

    mode: str = field(default="full", metadata={
        "choices": ("full", "surrogate"),
        "doc": "full: the DEM of every mill; surrogate: the Gaussian processes fitted to DEM runs"})
    table: str = field(default="surrogate_training.csv", metadata={
        "doc": "the surrogate's training table: a data/ table or a path (from `ballmill surrogate`)"})
    allow_extrapolation: bool = field(default=False, metadata={
        "doc": "evaluate designs outside the hull of the training runs by the surrogate anyway"})
    outside: str = field(default="refuse", metadata={
        "choices": ("refuse", "full"),
        "doc": "dem=surrogate, a design outside the hull of the training runs (allow_extrapolation false): refuse it, "
               "or run the DEM for it (its record says dem_source=full, dem_outside_surrogate=true)"})


@dataclass
class SurrogateBounds:
    """The training box of the surrogate's dimensionless inputs, [low, high] each."""

    fraction_of_critical: list[float] = field(default_factory=lambda: [0.3, 0.9],
                                             metadata={"doc": "mill speed / critical speed"})
    fill_fraction: list[float] = field(default_factory=lambda: [0.2, 0.45],
                                      metadata={"doc": "ball bed volume / mill volume"})
    length_to_diameter: list[float] = field(default_factory=lambda: [0.75, 2.5],
                                           metadata={"doc": "mill length / diameter"})
    diameter_to_ball: list[float] = field(default_factory=lambda: [5.0, 22.0],
                                         metadata={"doc": "mill diameter / ball diameter"})
    restitution: list[float] = field(default_factory=lambda: [0.3, 0.8],
                                    metadata={"doc": "ball-ball and ball-wall restitution"})
    friction: list[float] = field(default_factory=lambda: [0.2, 0.8],
                                 metadata={"doc": "ball-ball and ball-wall sliding friction"})

    def __post_init__(self):
        hi = {"fraction_of_critical": 1.5, "fill_fraction": 0.6, "restitution": 1.0}
        for f in dataclasses.fields(self):
            check_interval(f"bounds.{f.name}", getattr(self, f.name), 0.0, hi.get(f.name))


@dataclass
class OptimiserConfig:
    """The cheapest mill (study=cheapest_mill): the knobs' ranges, the search and its seed.
    The ball is at least min_ball_to_feed x the feed's particle size (and within ball_radius_m)."""

    fraction_of_critical: list[float] = field(default_factory=lambda: [0.3, 0.9],
                                             metadata={"doc": "speed / critical speed (at most 0.9)"})
    fill_fraction: list[float] = field(default_factory=lambda: [0.2, 0.45],
                                      metadata={"doc": "ball bed volume / mill volume"})
    ball_radius_m: list[float] = field(default_factory=lambda: [0.04, 0.08],
                                      metadata={"doc": "ball radius (m)"})
    length_to_diameter: list[float] = field(default_factory=lambda: [0.75, 2.5],
                                           metadata={"doc": "mill length / diameter"})
    feed_particle_size_m: float = rng(0.012, 0.0, None, lo_open=True, doc="largest PET flake (m)")
    min_ball_to_feed: float = rng(5.0, 1.0, None, doc="smallest ball diameter / feed particle size")
    trials: int = rng(300, 10, None, doc="designs the search evaluates (surrogate)")
    seed: int = rng(0, 0, None, doc="sampler seed: the same seed gives the same optimum")
    confirm: bool = field(default=True, metadata={"doc": "run the full DEM of the optimum and of the paper's mill"})

    def __post_init__(self):
        check_interval("optimiser.fraction_of_critical", self.fraction_of_critical, 0.0, 0.9)
        check_interval("optimiser.fill_fraction", self.fill_fraction, 0.2, 0.45)
        check_interval("optimiser.ball_radius_m", self.ball_radius_m, 0.0)
        check_interval("optimiser.length_to_diameter", self.length_to_diameter, 0.0)


# The MM400 fields no source pins down (estimates): lab runs report them beside their results.
MM400_GEOMETRY = ("jar_volume_ml", "jar_inner_diameter_m", "amplitude_m", "pivot_radius_m")


@dataclass
class CalibrationConfig:
    """`ballmill calibrate`: the ball-wall (steel-PMMA) restitution and friction that best match
    the tracked videos of a folder (with its videos.csv manifest), by a grid search, a Bayesian
    search (Optuna), or both (then compared)."""

    videos: str = field(default="???", metadata={"doc": "folder of videos with a videos.csv manifest"})
    out: str = field(default="outputs/lab/calibration", metadata={"doc": "where tables, figures and best.json go"})
    method: str = field(default="grid", metadata={
        "choices": ("grid", "optuna", "both"), "doc": "grid search, Bayesian search (Optuna), or both, compared"})
    restitutions: list[float] = field(default_factory=lambda: [0.3, 0.45, 0.6, 0.75, 0.9], metadata={
        "doc": "grid: the ball-wall restitutions tried"})
    frictions: list[float] = field(default_factory=lambda: [0.1, 0.2, 0.3, 0.4, 0.5], metadata={
        "doc": "grid: the ball-wall friction coefficients tried"})
    collision_weight: float = rng(1.0, 0.0, None, doc="weight of the collision-rate error beside the speed error")
    repeats: int = rng(1, 1, None, doc="starts simulated per condition and pair, averaged (less noise)")
    restitution_range: list[float] = field(default_factory=lambda: [0.3, 0.9],
                                            metadata={"doc": "Optuna: [low, high] of the restitution"})
    friction_range: list[float] = field(default_factory=lambda: [0.1, 0.5],
                                         metadata={"doc": "Optuna: [low, high] of the friction"})
    trials: int = rng(25, 1, None, doc="Optuna: pairs tried (the default grid has 25)")
    batch: int = rng(5, 1, None, doc="Optuna: pairs simulated together in one launch")
    startup_trials: int = rng(5, 1, None, doc="Optuna: random pairs before the TPE model takes over")
    seed: int = rng(0, 0, None, doc="Optuna sampler seed (the search is reproducible)")

    def __post_init__(self):
        for name, values in (("restitution_range", self.restitution_range), ("friction_range", self.friction_range)):
            check_interval(name, values)
        for name, values, lo_open, hi in (("restitutions", self.restitutions, True, 1.0),
                                          ("frictions", self.frictions, False, None),
                                          ("restitution_range", self.restitution_range, True, 1.0),
                                          ("friction_range", self.friction_range, False, None)):
            check_list(name, values, hi, lo_open)


@dataclass
class StudyReport:
    """How `ballmill report` presents a sweep of this study: named parts, each a function of report.py."""

    figure: str | None = field(default=None, metadata={"doc": "a figure of plots.FIGURES drawn from the records"})
    sections: list[str] = field(default_factory=list, metadata={"doc": "report.SECTIONS, in order"})
    compare: str | None = field(default=None, metadata={
        "doc": "case column of data/paper2023_reported.csv: the paper's numbers to set beside ours"})


@dataclass
class StudyConfig:
    """What a run does (a pipeline of studies.STUDIES) and how its sweep is reported."""

    name: str = field(default="design", metadata={
        "doc": "the run's name: its folder under outputs/runs or outputs/sweeps"})
    kind: str = field(default="design", metadata={
        "choices": ("design", "drum", "lab", "yield_calibration", "yield_fit", "plant", "cheapest_mill", "regional"),
        "doc": "the pipeline the run executes (studies.STUDIES)"})
    observations: str | None = field(default=None, metadata={"doc": "observations.csv drawn beside a lab study"})
    experiment: str | None = field(default=None, metadata={
        "doc": "drum: the experiment of data/measured_mill_power.csv the mill group reproduces"})
    report: StudyReport = field(default_factory=StudyReport, metadata={
        "doc": "how `ballmill report` presents the sweep (study.report.*)"})


@dataclass
class TrackConfig:
    """`ballmill track`: ball positions and speeds from a video file or an image folder."""

    video: str = field(default="???", metadata={"doc": "video file or folder of images"})
    fps: float | None = rng(None, 0.0, None, lo_open=True,
                            doc="capture rate (frames/s); else the video's capture.json / .json sidecar")
    mm_per_px: float | None = rng(None, 0.0, None, lo_open=True, doc="image scale; else the sidecar's")
    balls: int = rng(2, 1, 2, doc="balls in the jar")
    ball_diameter_mm: float = rng(17.6, 0.0, None, lo_open=True, doc="ball size")
    polarity: str = field(default="auto", metadata={
        "choices": ("auto", "dark", "bright"),
        "doc": "dark balls on a bright background, bright on dark, or told from the frames"})
    out: str | None = field(default=None, metadata={"doc": "CSV path; default <video>.track.csv"})


@dataclass
class RenderConfig:
    """`ballmill render`: simulate the MM400 conditions (lab.*) and film them as synthetic videos."""

    out: str = field(default="outputs/lab/videos", metadata={"doc": "folder for the videos and videos.csv"})
    wall_restitution: float = rng(0.6, 0.0, 1.0, lo_open=True, doc="ball-wall restitution filmed")
    wall_friction: float = rng(0.3, 0.0, None, doc="ball-wall friction filmed")
    backlit: bool = field(default=True, metadata={"doc": "dark balls on a bright background"})
    mm_per_px: float = rng(0.2, 0.0, None, lo_open=True,
                           doc="image scale (mm per pixel); film at 0.2 or finer to count collisions")
    noise_grey: float = rng(2.0, 0.0, None, doc="camera noise, grey levels (1 sigma)")


@dataclass
class ReportConfig:
    """`ballmill report`: tables, figures and a Markdown report from sweep folders."""

    sweeps: list[str] = field(default_factory=list, metadata={"doc": "sweep folders of `ballmill run -m`"})
    out: str = field(default="outputs/report", metadata={"doc": "where the report goes"})


@dataclass
class BenchConfig:
    """`ballmill bench`: DEM throughput (particle-steps/s) on the reference drum."""

    cases: list[str] = field(default_factory=lambda: ["1000", "8640", "bpr19", "100000", "long100000"],
                              metadata={"doc": "ball counts N of the scaled reference drum, longN (its "
                                               "cross-section, longer), or bpr19"})
    scaling: list[str] = field(default_factory=lambda: ["8640"],
                               metadata={"doc": "cases also run on one thread (thread scaling)"})
    arch: str = field(default="cpu", metadata={"choices": ("cpu", "cuda"), "doc": "Taichi backend"})
    precision: str = field(default="f64", metadata={"choices": ("f64", "f32"), "doc": "floating point of the engine"})
    threads: int = rng(0, 0, None, doc="CPU threads (0: all cores)")
    skin: float = rng(0.5, 0.0, None, lo_open=True, doc="neighbour skin / largest ball radius")
    settle_s: float = rng(0.3, 0.0, None, doc="settling time before the timed rotation (s)")
    rotate_s: float = rng(1.0, 0.0, None, lo_open=True, doc="timed rotation (s)")
    large_from: int = rng(20_000, 2, None, doc="cases of at least this many balls use the large_* times")
    large_settle_s: float = rng(0.15, 0.0, None, doc="settling time of large cases (s)")
    large_rotate_s: float = rng(0.05, 0.0, None, lo_open=True, doc="timed rotation of large cases (s)")
    profile_steps: int = rng(50, 1, None, doc="steps each phase is launched alone to time it")
    mm400: bool = field(default=False, metadata={"doc": "the MM400 10 x 10 grid instead of the drum"})
    mm400_duration_s: float = rng(2.0, 0.0, None, lo_open=True, doc="simulated time per MM400 replica (s)")
    peer: str | None = field(default=None, metadata={"choices": (None, "liggghts", "lammps", "liggghts,lammps", "both"),
                                                     "doc": "run the same drums in LIGGGHTS, LAMMPS or both (1 and 2 "
                                                            "ranks; both = liggghts,lammps)"})
    rounds: int = rng(1, 1, None, doc="every run (ours, then the peers') repeated one after the other: medians "
                                      "of the rates and of the ratios taken within each round")
    json: str = field(default="outputs/bench/bench.json", metadata={"doc": "where the figures are written"})


@dataclass
class SurrogateConfig:
    """`ballmill surrogate`: DEM runs of drums on a space-filling design of the dimensionless
    groups (scrambled Sobol for training, a Latin hypercube inside its hull held out), each
    cached like any drum run and averaged over sim.window_revolutions after
    sim.startup_revolutions (sim=surrogate); the training table; the model's cross-validated and
    held-out error."""

    bounds: SurrogateBounds = field(default_factory=SurrogateBounds, metadata={"doc": "the training box (bounds.*)"})
    points: int = rng(64, 8, None, doc="training runs (a power of two: Sobol)")
    holdout: int = rng(16, 0, None, doc="runs held out of training to measure the error")
    seed: int = rng(0, 0, None, doc="seed of the Sobol and Latin hypercube designs")
    ball_radius_m: float = rng(0.08, 0.0, None, lo_open=True, doc="ball of every run (the diameter ratio sets D)")
    jobs: int = rng(2, 1, None, doc="runs in parallel (one Taichi thread each)")
    folds: int = rng(5, 2, None, doc="k of the k-fold cross-validation")
    out: str = field(default="outputs/surrogate", metadata={"doc": "training table, errors, figure"})

    def __post_init__(self):
        if self.points & (self.points - 1):
            raise ConfigError(f"points={self.points}: a Sobol design needs a power of two (32, 64, 128, ...)")
        hull = len(dataclasses.fields(SurrogateBounds)) + 1  # points of a simplex in the space of the inputs
        fitted = self.points - math.ceil(self.points / self.folds)
        if fitted < hull:
            raise ConfigError(f"points={self.points} in folds={self.folds}: each fold is fitted on {fitted} runs, fewer "
                              f"than the {hull} whose hull the surrogate needs; give more points or more folds")


@dataclass
class CompareConfig:
    """`ballmill compare`: the surrogate against the DEM on finished sweeps: every job whose power
    came from the DEM, its mill predicted by the surrogate; the errors per job and their summary."""

    sweeps: list[str] = field(default_factory=list, metadata={"doc": "sweep folders of `ballmill run -m`"})
    table: str = field(default="surrogate_training.csv", metadata={"doc": "the surrogate's training table"})
    out: str = field(default="outputs/surrogate/compare.csv", metadata={"doc": "the per-job table"})


def register() -> None:
    """Schemas for the config groups, so Hydra type-checks them when composing."""
    cs = ConfigStore.instance()
    cs.store(group="sim", name="base_sim", node=SimConfig)
    cs.store(group="mill", name="base_drum", node=DrumConfig)
    cs.store(group="scaleup", name="base_scaleup", node=ScaleupConfig)
    cs.store(group="economics", name="base_economics", node=EconomicsConfig)
    cs.store(group="lab", name="base_mm400", node=MM400Config)
    cs.store(group="study", name="base_study", node=StudyConfig)
    cs.store(group="yield_model", name="base_yield_model", node=YieldModelConfig)
    cs.store(group="plant", name="base_plant", node=PlantConfig)
    cs.store(group="plant/evaporation", name="base_evaporation", node=EvaporationConfig)
    cs.store(group="plant/heat", name="base_heat", node=HeatConfig)
    cs.store(group="plant/sodium", name="base_sodium", node=SodiumConfig)
    cs.store(group="dem", name="base_dem", node=DemConfig)
    cs.store(group="optimiser", name="base_optimiser", node=OptimiserConfig)
    for name, node in COMMANDS.items():
        cs.store(name=f"base_{name}", node=node)


# The options of each command other than `run` (its config is conf/<command>.yaml).
COMMANDS = {"track": TrackConfig, "render": RenderConfig, "calibrate": CalibrationConfig, "report": ReportConfig,
            "bench": BenchConfig, "surrogate": SurrogateConfig, "compare": CompareConfig}


def span(lo, hi, lo_open: bool, hi_open: bool) -> str:
    """A range as an interval, e.g. (0.0, inf]."""
    left, right = "(" if lo_open else "[", ")" if hi_open else "]"
    return f"{left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}"


def choices(meta) -> tuple:
    """A field's choices: a tuple, or a function giving one (a registry, read when it is asked)."""
    c = meta["choices"]
    return tuple(c()) if callable(c) else c


def allowed(meta) -> str:
    """What a field's metadata allows: 'one of a, b', an interval, or '' (anything of its type)."""
    if "choices" in meta:
        return "one of " + ", ".join(map(str, choices(meta)))
    return span(*meta["range"]) if "range" in meta else ""


def walk(schema: type, prefix: str = ""):
    """(path, field, default) of each field of a schema, a nested dataclass's fields in its place
    (a.b), and after a list of dataclasses (mill.charge) the fields of its items (a[].b)."""
    hints = typing.get_type_hints(schema)
    for f in dataclasses.fields(schema):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if dataclasses.is_dataclass(default):
            yield from walk(type(default), f"{prefix}{f.name}.")
            continue
        yield f"{prefix}{f.name}", f, default
        item = typing.get_args(hints[f.name])
        if item and dataclasses.is_dataclass(item[0]):
            yield from walk(item[0], f"{prefix}{f.name}[].")


def _check_field(path: str, value, meta) -> None:
    if isinstance(value, dict) and "range" in meta:  # a table of numbers: each entry in the range
        for k, v in value.items():
            _check_field(f"{path}.{k}", v, meta)
        return
    if "choices" in meta and value not in choices(meta):
        raise ConfigError(f"{path}={value!r} is not one of {list(choices(meta))}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{path}={value} is not a finite number")
    if "range" not in meta or value is None:
        return
    lo, hi, lo_open, hi_open = meta["range"]
    bad = (lo is not None and (value < lo or (lo_open and value == lo))) or (
        hi is not None and (value > hi or (hi_open and value == hi))
    )
    if bad:
        raise ConfigError(f"{path}={value} is outside the allowed range {span(*meta['range'])}")


def check(obj, path: str) -> None:
    """Range-check a dataclass instance (recursing into dataclasses, lists and dicts of them);
    `path` prefixes the field names in messages ("" for a command's own options)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            check(v, _join(path, k))
        return
    if isinstance(obj, list):
        for i, v in enumerate(obj):
            _check_field(f"{path}[{i}]", v, {})
            check(v, f"{path}[{i}]")
        return
    if not dataclasses.is_dataclass(obj):
        return
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        _check_field(_join(path, f.name), value, f.metadata)
        check(value, _join(path, f.name))


def _join(path: str, name) -> str:
    return f"{path}.{name}" if path else str(name)


def to_object(cfg: DictConfig, schema: type, path: str):
    """Turn a config node into the dataclass `schema`, refusing unknown keys, then range-check."""
    base = OmegaConf.structured(schema)
    try:
        values = OmegaConf.to_container(cfg, resolve=True) if isinstance(cfg, DictConfig) else cfg
        merged = OmegaConf.merge(base, values)
    except Exception as exc:  # omegaconf's message names the key and the expected type
        raise ConfigError(f"{path or 'options'}: {one_line(exc)}") from exc
    try:
        obj = OmegaConf.to_object(merged)
    except ConfigError:  # a schema's own check (__post_init__): its message names the fields
        raise
    except Exception as exc:  # a mandatory value (???) not given
        raise ConfigError(f"{path or 'options'}: {one_line(exc)}") from exc
    check(obj, path)
    return obj


def one_line(exc: Exception) -> str:
    """omegaconf's and Hydra's messages without their multi-line context blocks."""
    return " ".join(str(exc).split("\n")[0].split())


def material_tables(cfg: DictConfig) -> tuple[dict[str, MaterialConfig], dict[str, InteractionConfig]]:
    """The composed config's materials and pair table ('a-b' keys), each entry range-checked."""
    return ({k: to_object(v, MaterialConfig, f"materials.{k}") for k, v in cfg.materials.items()},
            {k: to_object(v, InteractionConfig, f"interactions.{k}") for k, v in cfg.interactions.items()})
