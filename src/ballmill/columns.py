"""The column vocabulary of every output table, and the one place that converts camera <-> world.

Units are in the names (`_m`, `_s`, `_w_per_kg`, ...; a name without one is dimensionless or
text).  `TABLES` says what each column of a table means; a record's columns are grouped by the
study part that writes them, and `<x>` stands for a part of a name (a wall body, a category).
`describe(table, name)` finds a column's meaning, also under the record's prefixes (`dem_`,
`paper_`, `optimum_`, ...); the docs' reference is generated from here, and the tests check
that what the runs write is described.

The particle tables (simulated trajectories, the tracker's output, calibration observations)
share their names.  The camera's world origin is the image centre (where the renderer puts the
jar's rest centre); z is up and the camera looks along +y, so it sees (x, z).
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

PARTICLES = {
    "t_s": "time since the run's start (s)",
    "frame": "camera frame",
    "replica": "replica: one jar or mill of a batch run in one launch",
    "particle": "particle (ball) id within its replica",
    "x_m": "position, x (m)", "y_m": "position, y: along the drum axis, or the camera's line of sight (m)",
    "z_m": "position, z: up (m)",
    "vx_m_per_s": "velocity, x (simulation only)", "vy_m_per_s": "velocity, y (simulation only)",
    "vz_m_per_s": "velocity, z (simulation only)",
    "wx_rad_per_s": "angular velocity, x (simulation only)", "wy_rad_per_s": "angular velocity, y (simulation only)",
    "wz_rad_per_s": "angular velocity, z (simulation only)",
    "u_px": "image column of the ball's centre (tracker)", "v_px": "image row, downwards (tracker)",
    "radius_px": "fitted radius in the image (tracker)", "radius_m": "fitted radius (tracker)",
    "lost": "True where the tracker did not find the ball in this frame",
    "frame_vx_m_per_s": "displacement to the previous frame x capture rate, x: the speed as the paper measured it",
    "frame_vz_m_per_s": "displacement to the previous frame x capture rate, z",
    "frame_speed_m_per_s": "magnitude of the frame-to-frame velocity (camera plane)",
    "frame_jump_m_per_s": "change of the frame-to-frame velocity to the next frame (a collision when above "
                          "lab.collision_speed_jump_m_per_s)",
}

# A record (record.json / record.parquet, one row per run) in parts: part -> (what writes it, columns).
RECORD = {
    "every run": ("run.py: the study, its status and where the numbers come from", {
        "study": "the study's name (study.name): the folder its runs go to",
        "kind": "the pipeline it ran (study.kind)",
        "status": "ok, or failed (then FAILED.json holds the same record)",
        "error": "a failed run's exception and message; empty when ok",
        "ballmill_version": "the package version that wrote the record",
        "git_commit": "the checkout's commit (empty outside a git checkout)",
        "taichi_version": "Taichi's version", "numpy_version": "NumPy's version", "python": "Python's version",
        "machine": "the CPU architecture", "cpu_count": "the machine's logical CPUs",
        "arch": "Taichi backend of the run (sim.arch)", "threads": "sim.threads as configured (0: all cores)",
        "precision": "the engine's floating point (sim.precision)",
        "wall_time_s": "wall-clock time of the run, checks and writing included",
        "overrides": "the job's command-line overrides",
    }),
    "design": ("study=design (also plant, cheapest_mill): the scale-up's mill, its dose and costs", {
        "bpr": "ball-to-powder mass ratio (scaleup.bpr)",
        "region": "the state whose PET share is the feed (scaleup.region), or empty",
        "shape_rule": "how the mill's proportions were chosen (scaleup.shape_rule)",
        "yield_rule": "the yield rule (yield_model.rule)",
        "impact_threshold_j": "E*: impacts of at least this normal energy count in the impact_* measures",
        "bpr_line_yield_percent": "the BPR line's yield at this BPR, capped to 0-100",
        "yield_extrapolated": "True when the BPR lies outside the line's experiments (allowed by "
                              "yield_model.allow_extrapolation)",
        "pet_feed_kg_per_h": "PET fed to the mill", "naoh_feed_kg_per_h": "NaOH fed to the mill",
        "residence_time_min": "the charge's time in the mill",
        "holdup_kg": "powder (PET + NaOH) held in the mill: feed x residence time",
        "ball_mass_kg": "mass of the ball charge: BPR x hold-up (drum study: of the configured charge)",
        "ball_count": "balls in the mill", "ball_radius_m": "ball radius (the largest of a graded charge)",
        "charge_<d>mm_balls": "balls of diameter <d> mm in a graded charge",
        "mill_volume_m3": "inner volume of the mill", "diameter_m": "inner diameter of the mill",
        "length_m": "inner length of the mill", "speed_rpm": "mill speed",
        "critical_speed_rpm": "critical speed N_c = 42.3 / sqrt(D - d)",
        "fraction_of_critical": "speed / critical speed",
        "largest_impact_j": "the largest normal impact energy in the DEM's collision log",
        "collision_power_w_per_kg_pet": "power dissipated in all collisions per kg of PET held up (the dose rate "
                                        "of the specific-energy rule)",
        "collision_power_w_per_kg_pet_se": "its standard error (batch means of the averaging window)",
        "collision_frequency_per_s_per_kg_pet": "collisions per second per kg of PET held up",
        "collision_frequency_per_s_per_kg_pet_se": "its standard error",
        "impact_power_w_per_kg_pet": "power dissipated in collisions of at least impact_threshold_j per kg of PET "
                                     "(the dose rate of the impact-threshold rule)",
        "impact_power_w_per_kg_pet_se": "its standard error",
        "impact_frequency_per_s_per_kg_pet": "collisions of at least impact_threshold_j per second per kg of PET",
        "impact_frequency_per_s_per_kg_pet_se": "its standard error",
        "collision_log_share": ("energy the collision log books in the averaging window / the energy balance's "
                                "dissipation there: below 1 by contacts still open at the run's end"),
        "collision_dose_kj_per_kg_pet": "energy dissipated in all collisions per kg of PET over the residence time",
        "impact_dose_kj_per_kg_pet": "the same for collisions of at least impact_threshold_j",
        "electricity_usd_per_yr": "the mill's electricity per year (DEM power x hours x price)",
        "electricity_usd_per_t_pet": "the mill's electricity per tonne of PET fed",
        "purchase_cost_usd": "purchase cost of the mill (the paper's Eq. 1, brought to cepci_target_year)",
        "purchase_cost_usd_per_kg_per_h": "purchase cost per kg/h of PET fed",
        "yield_percent": "TPA yield of the mill (the yield rule's)",
        "yield_capped": "True where the BPR line gives more than 100 % and the yield is capped",
        "margin_usd_per_t_tpa": "raw-material margin per tonne of TPA at full conversion (the paper's Eq. 3)",
        "pet_t_per_t_tpa": "PET per tonne of TPA", "naoh_t_per_t_tpa": "NaOH per tonne of TPA",
        "h2so4_t_per_t_tpa": "H2SO4 per tonne of TPA", "eg_t_per_t_tpa": "EG per tonne of TPA",
        "cepci_base": "CEPCI of the cost correlation's year", "cepci_target": "CEPCI of the target year",
        "bond_rowland_power_w": "the Bond/Rowland correlation's power for the same mill, beside the DEM's",
        "annualised_cost_usd_per_yr": "cheapest mill: capital recovery x installed mill + electricity, per year",
        "sim_duration_s": "cheapest mill: the confirming DEM's simulated time after settling",
    }),
    "dem": (("the mill's DEM (dem_summary.json in its cache folder, prefixed dem_), or under dem=surrogate the "
             "surrogate's prediction"), {
        "dem_key": "hash of what determines the DEM run: its folder under outputs/cache/dem/",
        "dem_dir": "the DEM's cache folder (loads, energy, collisions, trajectories)",
        "dem_source": "full (the DEM) or surrogate",
        "dem_outside_surrogate": "dem=surrogate: the design lay outside the surrogate's training runs and "
                                 "dem.outside=full ran the DEM for it",
        "dem_table": "the surrogate's training table (dem=surrogate)",
        "dem_balls": "balls simulated", "dem_ball_mass_kg": "mass of the balls (surrogate)",
        "dem_speed_rpm": "drum speed", "dem_critical_speed_rpm": "critical speed of the drum",
        "dem_dt_s": "time step", "dem_rayleigh_dt_s": "Rayleigh time step of the smallest ball",
        "dem_torque_axis_nm": "mean torque of the charge on the drum about its axis (negative: opposes the "
                              "rotation), rolling friction left out",
        "dem_torque_axis_with_rolling_nm": "the same with the rolling-friction torque",
        "dem_power_w": "mean power drawn by the drum, P = T w, over the averaging window",
        "dem_power_se_w": "its standard error (10 batch means; surrogate: its predicted standard deviation)",
        "dem_power_with_rolling_w": "mean power with the rolling-friction torque",
        "dem_simulated_s": "simulated time, settling included",
        "dem_averaging_from_s": "start of the averaging window",
        "dem_averaging_ended_by": "why the run ended: the configured window, or sim.power_se_target reached",
        "dem_startup_revolutions": "revolutions of the drum from its start to the averaging window",
        "dem_window_revolutions": "the averaging window in revolutions of the drum",
        "dem_power_trend_t": "t statistic of the power's straight-line trend over the window (10 batch means)",
        "dem_power_drift_fraction": "that trend's change of the power over the window, as a fraction of its mean",
        "dem_steady": ("True when the window gives the steady power: it starts a quarter revolution or more after "
                       "the drum, spans a revolution or more, and the power has no trend (1 %, 2 %) over it"),
        "dem_unsteady_reason": "why the power is not the steady one (empty when dem_steady)",
        "dem_collisions_per_s": "finished contacts per second in the averaging window",
        "dem_dissipated_power_from_log_w": "energy dissipated by those contacts per second (the collision log)",
        "dem_specific_dissipated_power_w_per_kg": "dem_dissipated_power_from_log_w per kg of balls: how hard the "
                                                  "charge works its contents",
        "dem_<pair>_collisions_per_s": "collisions per second of a pair type: ball_ball, or ball_wall_<body> per "
                                       "wall body (drum: the shell and ends)",
        "dem_<pair>_impact_energy_mean_j": "mean normal impact energy 1/2 m* v_n^2 at first touch",
        "dem_<pair>_impact_energy_p90_j": "90th percentile of the normal impact energy",
        "dem_<pair>_dissipated_mean_j": "mean energy dissipated per collision over its whole contact",
        "dem_<pair>_dissipated_p90_j": "90th percentile of the energy dissipated per collision",
        "dem_charge_toe_deg": "toe of the charge, degrees anticlockwise from 3 o'clock (Morrell's convention)",
        "dem_charge_shoulder_deg": "shoulder of the charge, same convention",
        "dem_charge_shell_arc_deg": "arc of the shell the charge covers",
        "dem_charge_airborne_fraction": "share of the balls in flight (no ball or shell within a quarter radius)",
        "dem_charge_regime": "cascading, cataracting (5 % or more airborne) or centrifuging (arc of 340 deg or more)",
        "dem_torque_arm_power_w": "torque-arm power of the charge, P = w g |sum m x| (Hogg & Fuerstenau 1972)",
        "dem_morrell_toe_deg": "Morrell's (1996) empirical toe angle for this mill",
        "dem_morrell_shoulder_deg": "Morrell's empirical shoulder angle",
        "dem_morrell_net_power_w": "Morrell's C-model net power with those angles (x 1.26)",
        "dem_collision_power_w": "surrogate: power dissipated in collisions",
        "dem_collision_power_se_w": "surrogate: its predicted standard deviation",
        "dem_inside_hull": "surrogate: True when the mill's groups lie inside the hull of the training runs",
        **{f"dem_{group}": f"surrogate: the mill's {doc}, an input of the surrogate" for group, doc in (
            ("fraction_of_critical", "speed / critical speed"), ("fill_fraction", "ball bed volume / mill volume"),
            ("length_to_diameter", "length / diameter"), ("diameter_to_ball", "diameter / ball diameter"),
            ("restitution", "ball-ball and ball-wall restitution"), ("friction", "ball-ball and ball-wall friction"))},
    }),
    "yield rules": (("a dose rule's yield curve (an energy rule's dose line, or the fitted model), the mill's "
                     "residence-time distribution and the residence time's fixed point (yield_model)"), {
        "yield_mode": "target_yield (residence time solved) or fixed_time (yield reported)",
        "calibration_dir": "the lab calibration's cache folder",
        "target_yield_percent": "the yield the residence time is solved for",
        "target_dose_kj_per_kg_pet": "the mean dose per kg of PET whose yield, averaged over the RTD, is the target",
        "rtd_kind": "the mill's residence-time distribution (yield_model.rtd.kind)",
        "rtd_tanks": "its n of tanks in series", "rtd_peclet": "its Peclet number (axial dispersion)",
        "rtd_dose_factor": "the mean dose the target needs under the RTD / the dose it needs in plug flow",
        "fit_model": "the fitted model chosen (dose_linear, saturating or bpr_line)",
        "fit_measure": "its dose rate (collision_power_w_per_kg or impact_power_w_per_kg); empty for bpr_line",
        "fit_threshold_j": "its E* (impact measure; empty for all collisions)",
        "fit_cv_rmse_percent": "its leave-one-condition-out cross-validated RMS error",
        "fit_skipped": "steps of study=yield_fit skipped, each with why (a flat or falling fit reaches no target)",
        "fit_dir": "the fit's cache folder (rows, candidates, predictions, fit.json)",
        "fit_<param>": "a parameter of the chosen model (a_percent, b_percent_per_kj_per_kg; ymax_percent, "
                       "k_per_kj_per_kg, d0_kj_per_kg; slope_percent, intercept_percent)",
        "fit_<param>_se": "its standard error (the fit's covariance)",
        "yield_measure": "the dose rate the line uses (collision_power_w_per_kg or impact_power_w_per_kg)",
        "yield_a_percent": "intercept a of Y = a + b D",
        "yield_b_percent_per_kj_per_kg": "slope b of Y = a + b D (D in kJ per kg of PET)",
        "yield_b_se_percent_per_kj_per_kg": "its standard error, from the lab rate's",
        "lab_rate_w_per_kg_balls": "the lab DEM's dose rate per kg of balls at the nominal condition",
        "lab_rate_se_w_per_kg_balls": "its standard error",
        "residence_time_se_min": ("standard error of the solved residence time: the mill's dose rate's and the "
                                  "target dose's (the yield model's, which holds the lab rates') relative errors "
                                  "/ (1 + fixed_point_rate_exponent)"),
        "fixed_point_iterations": ("DEM runs the fixed point took (besides them: the two mills around the root that "
                                   "measure its error, and the root's own mill when interpolated)"),
        "fixed_point_root": "how the residence time was found: interpolated inside a bracket, or simulated",
        "fixed_point_rate_exponent": ("alpha of the mill's dose rate ~ tau^alpha at the root (the mill-size "
                                      "feedback), measured on the mills at tau (1 + yield_model.sensitivity_step)^+-1"),
        "fixed_point_rate_exponent_se": "its standard error, from those two mills' rates'",
        "fixed_point_dose_miss": "relative miss of the final mill's dose against the target dose",
        "fixed_point_history_min": "the residence times tried, in order (space-separated)",
    }),
    "drum": ("study=drum: the mill group's drum as configured, per kg of balls", {
        "experiment": "the row of data/measured_mill_power.csv the drum reproduces (study.experiment)",
        "wall_restitution": "ball-wall restitution of the run", "wall_friction": "ball-wall sliding friction",
        "liner": "the shell's profile (mill.liner.kind)",
        "collision_power_w_per_kg_balls": "power dissipated in collisions per kg of balls",
        "collision_power_w_per_kg_balls_se": "its standard error",
        "collision_frequency_per_s_per_kg_balls": "collisions per second per kg of balls",
        "collision_frequency_per_s_per_kg_balls_se": "its standard error",
        "impact_power_w_per_kg_balls": "power dissipated in collisions of at least impact_threshold_j per kg of "
                                       "balls",
        "impact_power_w_per_kg_balls_se": "its standard error",
        "impact_frequency_per_s_per_kg_balls": "collisions of at least impact_threshold_j per second per kg of balls",
        "impact_frequency_per_s_per_kg_balls_se": "its standard error",
    }),
    "lab": ("study=lab: the MM400 conditions (the per-condition table is lab_summary.csv)", {
        "balls": "balls per jar", "conditions": "conditions simulated (frequencies x ball sizes)",
        "observations": "tracked observations drawn beside the simulation (study.observations)",
    }),
    "yield calibration": (("study=yield_calibration: the lab DEM behind the energy rules; each rule's dose line "
                           "as <rule>_<yield rules column>"), {
        "lab_frequency_hz": "the kinetics experiments' shaking frequency", "lab_balls": "balls in their jar",
        "lab_ball_diameter_m": "their ball diameter", "lab_jar_material": "their jar material",
        "bpr_basis": "the BPR's powder: PET + NaOH, or PET alone",
        "calibration_key": "hash of the lab conditions: the calibration's cache folder",
    }),
    "yield fit": (("study=yield_fit: the experiments table and the fit's choice (its model in the yield rules' fit_ "
                  "columns)"), {
        "experiments": "the experiments table (yield_model.experiments)",
        "experiments_digest": "hash of its content", "experiments_rows": "its rows",
        "experiments_conditions": "its experimental conditions (all but the milling time)",
        "lab_conditions": "the lab DEM runs they need (jar, balls, frequency)",
        "fit_key": "hash of the table and what sets its doses: the fit's cache folder",
        "fit_candidate": "the candidate chosen: model and dose measure",
        "fit_candidates_within_one_se": "candidates whose CV error is within one standard error of the lowest",
    }),
    "plant": ("study=plant: the plant around the mill on BioSTEAM (the mill itself in the design columns)", {
        "plant_fresh_pet_kg_per_h": "clean PET the mill needs from outside", "plant_mill_pet_kg_per_h": "PET through "
                                                                                                 "the mill, recycle included",
        "recycle_purge_fraction": "share of the unreacted PET purged",
        "plant_bales_kg_per_h": "bales bought (PET and non-PET)", "plant_rtpa_t_per_yr": "rTPA produced per year",
        "plant_eg_kg_per_h": "EG product", "plant_na2so4_kg_per_h": "Na2SO4 product",
        "plant_staff": "operating staff (the staffing rule)",
        "plant_purchase_cost_usd": "purchase cost of all units", "plant_installed_cost_usd": "installed cost of all units",
        "plant_fixed_capital_usd": "fixed capital investment", "plant_working_capital_usd": "working capital",
        "plant_total_capital_usd": "fixed and working capital",
        "plant_voc_usd_per_yr": "variable operating cost per year (BioSTEAM's VOC)",
        "plant_foc_usd_per_yr": "fixed operating cost per year: labour, maintenance, insurance",
        "plant_labour_usd_per_yr": "labour with supervision and burden per year",
        "plant_electricity_kw": "the plant's electricity", "plant_mill_power_kw": "the mill's (from its DEM)",
        "plant_steam_kw": "steam heat bought", "plant_design_warnings": "BioSTEAM's out-of-range notes "
                                                                      "(design_warnings.txt)",
        "plant_s": "wall time of the plant, its variants, tornado and Monte Carlo",
        "monte_carlo_s": "wall time of the Monte Carlo",
        "plant_options_s": "wall time of the options crossed for the front (plant.options_front, options.csv)",
        "msp_usd_per_kg": "minimum selling price of rTPA (net present value zero at the internal rate of return)",
        "msp_capital_usd_per_kg": "what of the MSP pays for capital, its return and taxes",
        "msp_<item>_usd_per_kg": "one stream's or utility's part of the MSP per kg rTPA (a feed, a waste, a "
                                 "co-product negative, steam, electricity, fixed_operating)",
        "msp_mill_section_usd_per_kg": "the mill's part: its share of capital and maintenance, its electricity",
        "msp_mill_share": "the mill section's share of the MSP",
        "msp_p<q>_usd_per_kg": "the q-th percentile (5, 50, 95) of the MSP's Monte Carlo",
        "gwp_total_kg_per_kg": "cradle-to-gate footprint, kg CO2e per kg rTPA",
        "gwp_<item>_kg_per_kg": "one input's, utility's or waste's part of it (co-product credits negative)",
        "gwp_p<q>_kg_per_kg": "the q-th percentile (5, 50, 95) of the footprint's Monte Carlo",
        "gwp_mass_allocation_kg_per_kg": "the footprint with the burdens shared by mass among rTPA, EG and Na2SO4 "
                                         "instead of crediting the co-products",
        "gwp_economic_allocation_kg_per_kg": "the same shared by value (rTPA at virgin TPA's price, the co-products at "
                                             "theirs)",
        "virgin_tpa_usd_per_kg": "virgin TPA's price (data/prices.csv)",
        "virgin_tpa_gwp_kg_per_kg": "virgin TPA's footprint (data/ghg_factors.csv)",
    }),
    "regional": (("study=regional: one plant for a group of states against a plant each (states.csv, sites.csv, "
                  "scale.csv)"), {
        "regional_states": "the states (plant.regional.states)",
        "regional_fresh_pet_kg_per_h": "their PET together",
        "regional_site": "the cheapest site of the plant for all (a state's centre of population)",
        "regional_haul_km": "the bales' feed-weighted road distance to it",
        "regional_haul_usd_per_t_bales": "their haulage per t of bales", "regional_haul_kg_co2e_per_t_bales":
            "its greenhouse gas per t of bales", "regional_msp_usd_per_kg": "the plant for all's MSP, haulage in",
        "regional_gwp_kg_per_kg": "its footprint, haulage in",
        "apart_msp_usd_per_kg": "a plant each: their rTPA-weighted MSP", "apart_gwp_kg_per_kg": "their footprint",
        "break_even_fresh_pet_kg_per_h": "the fresh PET feed at which one plant (US grid, no haul) meets virgin "
                                         "TPA's price (scale.csv; NaN: no feed in plant.regional.scale_fresh_pet_kg_per_h)",
        "break_even_gwp_fresh_pet_kg_per_h": "the one at which it meets virgin PTA's footprint",
        "regional_sharing_states": "the states whose plant shared with the nearest larger neighbour is cheaper "
                                   "than the two apart",
        "haul_usd_per_t_km": "a truck's cost per tonne-km (data/haulage.csv)",
        "haul_kg_co2e_per_t_km": "its greenhouse gas per tonne-km", "regional_s": "wall time of the study's plants",
    }),
    "cheapest mill": (("study=cheapest_mill: the paper's mill and the optimum (design columns prefixed paper_ and "
                       "optimum_ by the surrogate, paper_dem_ and optimum_dem_ as the DEM confirms them)"), {
        "optimiser_trials": "designs the search evaluated", "optimiser_seed": "the search's seed",
        "surrogate_design_s": "median time of one design by the surrogate",
        "cost_saved_fraction": "1 - optimum / paper annualised cost, by the surrogate",
        "cost_saved_fraction_dem": "the same by the DEM",
        "knob_<knob>_cost_increase_fraction": "the optimum's cost rise with that knob back at the paper's value",
        "<mill>_dem_design_s": "wall time of the DEM confirming the paper's (or the optimum's) mill",
        "<mill>_surrogate_power_error": "surrogate power / DEM power - 1 for that mill",
        "<mill>_surrogate_cost_error": "surrogate annualised cost / DEM's - 1",
    }),
}
# Record columns nested under a prefix: the prefix's meaning, then the column's.
PREFIXES = {
    "paper_dem_": "the paper's mill as the DEM confirms it: ", "optimum_dem_": "the optimum as the DEM confirms it: ",
    "paper_": "the paper's mill, by the surrogate: ", "optimum_": "the cheapest mill, by the surrogate: ",
}


def rule_prefixes() -> dict[str, str]:
    """study=yield_calibration's columns of each dose-line rule: <rule>_<yield rules column>."""
    from . import yield_rules  # the registry's modules import the engine: read when a record is described

    return {f"{r.name}_": f"the {r.name} rule's line: " for r in yield_rules.dose_lines()}

TABLES = {
    "record": {name: doc for _, columns in RECORD.values() for name, doc in columns.items()},
    "loads": {  # loads.parquet: per sample and wall body
        "t_s": "sample time", "replica": "replica", "body": "wall body (drum: the shell and ends turning together)",
        "torque_axis_nm": "torque of the balls on the body about its motion's axis, rolling friction left out",
        "torque_rolling_axis_nm": "the rolling-friction part of that torque",
        "power_w": "power the body delivers to the balls", "power_rolling_w": "the rolling-friction part of it",
        "force_x_n": "force of the balls on the body, x", "force_y_n": "force, y", "force_z_n": "force, z",
    },
    "energy": {  # energy.parquet: per sample, cumulative from the start
        "t_s": "sample time", "replica": "replica",
        "kinetic_j": "translational kinetic energy of the balls", "rotational_j": "rotational kinetic energy",
        "potential_j": "gravitational potential energy", "elastic_j": "elastic energy stored in open contacts",
        "wall_work_j": "work the moving walls have done on the balls",
        "dissipated_normal_j": "energy dissipated by normal damping",
        "dissipated_tangential_j": "energy dissipated tangentially (damping and sliding)",
        "dissipated_rolling_j": "energy dissipated by rolling friction",
        "residual_j": "wall work - change of stored energy - dissipation: the balance's error",
    },
    "collisions": {  # collisions.parquet: one row per finished contact
        "t_start_s": "first touch", "t_end_s": "separation", "replica": "replica", "particle": "the ball",
        "partner": "the other ball (-1 for a wall)", "kind": "ball-ball or ball-wall",
        "body": "the wall body of a ball-wall contact (empty for ball-ball)",
        "impact_speed_m_per_s": "normal relative speed at first touch",
        "impact_energy_j": "normal impact energy 1/2 m* v_n^2 at first touch",
        "dissipated_j": "energy the contact dissipated over its whole duration",
    },
    "trajectories": PARTICLES,
    "lab_summary": {  # lab_summary.csv of study=lab: one row per condition
        "frequency_hz": "shaking frequency", "ball_diameter_m": "ball diameter",
        "wall_restitution": "ball-wall restitution", "wall_friction": "ball-wall friction",
        "replicate": "another start of the same condition", "replica": "the condition's replica in the batch",
        "mean_speed_m_per_s": "mean frame-to-frame speed, as the paper measured it",
        "speed_p<q>_m_per_s": "the q-th percentile of the frame-to-frame speed (q = 10, 50, 90)",
        "mean_true_speed_m_per_s": "mean instantaneous 3-D speed at the same frames",
        "video_collisions_per_s": "collisions a video would show: frame-velocity jumps above "
                                  "lab.collision_speed_jump_m_per_s",
        "ball_wall_collisions_per_s": "ball-wall contacts per second (engine)",
        "ball_ball_collisions_per_s": "ball-ball contacts per second (engine)",
        "mean_impact_speed_m_per_s": "mean normal impact speed", "mean_impact_energy_j": "mean normal impact energy",
        "impact_energy_p90_j": "90th percentile of the impact energy",
        "balls": "balls per jar", **{k: v for k, v in RECORD["drum"][1].items() if k.endswith(("balls", "balls_se"))},
        "jar_volume_ml": "jar volume (lab.jar_volume_ml)", "jar_inner_diameter_m": "jar bore",
        "amplitude_m": "half stroke", "pivot_radius_m": "arm length",
        "impact_threshold_j": "E* of the impact_* columns",
    },
}


def pattern(name: str) -> re.Pattern:
    """A vocabulary name as a regular expression: <x> matches any part of a name."""
    return re.compile("^" + re.sub(r"<[a-z]+>", "[a-z0-9_.]+", re.escape(name).replace(r"\<", "<").replace(r"\>", ">"))
                      + "$")


def describe(table: str, name: str) -> str | None:
    """What column `name` of `table` means (None: not in the vocabulary)."""
    vocabulary = TABLES[table]
    if name in vocabulary:
        return vocabulary[name]
    for key, doc in vocabulary.items():
        if "<" in key and pattern(key).match(name):
            return doc
    for prefix, meaning in (PREFIXES | rule_prefixes()).items() if table == "record" else ():
        inner = describe(table, name[len(prefix):]) if name.startswith(prefix) else None
        if inner:
            return meaning + inner
    return None


def undescribed(table: str, names) -> list[str]:
    """The names the vocabulary does not describe."""
    return [n for n in names if describe(table, n) is None]


def world_to_image(x_m, z_m, width_px: int, height_px: int, mm_per_px: float):
    """World (x, z) in m to image (column, row) in px."""
    return (width_px / 2 + np.asarray(x_m) * 1e3 / mm_per_px, height_px / 2 - np.asarray(z_m) * 1e3 / mm_per_px)


def image_to_world(u_px, v_px, width_px: int, height_px: int, mm_per_px: float):
    """Image (column, row) in px to world (x, z) in m; the inverse of world_to_image."""
    return ((np.asarray(u_px) - width_px / 2) * mm_per_px / 1e3, (height_px / 2 - np.asarray(v_px)) * mm_per_px / 1e3)


def add_frame_velocities(table: pd.DataFrame, fps: float) -> pd.DataFrame:
    """The frame_* columns per particle (and replica, where there is one), from x_m, z_m at
    consecutive frames; NaN on a particle's first frame and next to a frame where it was lost."""
    keys = [k for k in ("replica", "particle") if k in table]
    table = table.sort_values([*keys, "t_s"]).reset_index(drop=True)
    g = table.groupby(keys, sort=False)
    vx, vz = g.x_m.diff() * fps, g.z_m.diff() * fps
    step = pd.DataFrame({"vx": vx, "vz": vz, **{k: table[k] for k in keys}}).groupby(keys, sort=False)
    jump = np.hypot(step.vx.shift(-1) - vx, step.vz.shift(-1) - vz)
    return table.assign(frame_vx_m_per_s=vx, frame_vz_m_per_s=vz, frame_speed_m_per_s=np.hypot(vx, vz),
                        frame_jump_m_per_s=jump)
