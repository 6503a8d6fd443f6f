"""Bad input, case by case: each is refused with one line, `error: ...`, naming the field or file
and what is allowed, with exit status 2, before any simulation starts and without touching
what the output folder already holds.  Runs in-process (no Taichi kernel is launched: the
engine's constructor fails the test if anything reaches it)."""

import re

import cv2
import numpy as np
import pandas as pd
import pytest
import trimesh
from omegaconf import OmegaConf
from test_kinetics import table_with

from ballmill.cli import RUN_GROUPS, main
from ballmill.config import COMMANDS, ConfigError, SimConfig, to_object, walk
from ballmill.dem.engine import Engine
from ballmill.vision.frames import write_frames


@pytest.fixture
def inputs(tmp_path_factory):
    """Files for the cases: STL meshes, videos, manifests, sweep folders."""
    d = tmp_path_factory.mktemp("inputs")
    trimesh.creation.box((0.4, 0.2, 0.4)).export(d / "closed.stl")
    open_box = trimesh.creation.box((0.4, 0.2, 0.4))
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)  # one side missing
    open_box.export(d / "open.stl")
    (d / "notes.stl").write_text("not a mesh\n")
    (d / "garbage.avi").write_bytes(b"\x00\x01garbage" * 100)
    (d / "empty.avi").write_bytes(b"")
    grey = [np.full((120, 200), 200, np.uint8) for _ in range(20)]
    write_frames(grey, d / "grey.avi", 2134.0, 0.2)
    discs = []
    for k in range(20):  # one dark ball of 12 mm (30 px at 0.2 mm/px) crossing a bright frame
        frame = np.full((160, 240), 220, np.uint8)
        cv2.circle(frame, (80 + 2 * k, 80), 30, 40, -1, lineType=cv2.LINE_AA)
        discs.append(frame)
    write_frames(discs, d / "ball12mm.avi", 2134.0, 0.2)
    real = (d / "ball12mm.avi").read_bytes()
    (d / "truncated.avi").write_bytes(real[:400])
    for name, rows in {"no_columns": "file,balls\nball12mm.avi,1\n",
                       "balls_two": "file,frequency_hz,ball_diameter_mm,balls\nball12mm.avi,25,12,two\n",
                       "missing_video": "file,frequency_hz,ball_diameter_mm,balls\ngone.avi,25,12,1\n",
                       "empty_manifest": "file,frequency_hz,ball_diameter_mm,balls\n"}.items():
        (d / name).mkdir()
        (d / name / "videos.csv").write_text(rows)
    (d / "experiments").mkdir()
    for name, change in {"negative_mass": {"pet_mass_g": "-1.0"}, "yield_above_100": {"yield_percent": "104"},
                         "one_condition": {"time_min": "40"}, "three_balls": {"ball_count": "3"}}.items():
        (d / "experiments" / f"{name}.csv").write_text(table_with(change))
    (d / "experiments" / "missing_columns.csv").write_text("experiment,yield_percent\nx,50\n")
    (d / "no_manifest").mkdir()
    (d / "empty_sweep").mkdir()
    job = d / "corrupt_sweep" / "scaleup.bpr=19"
    job.mkdir(parents=True)
    (job / "record.json").write_text('{"study": "fig3b", "status": "o')  # truncated mid-write
    return d


@pytest.fixture
def cli(tmp_path, monkeypatch, capsys):
    """Run `ballmill ARGS` in a folder whose outputs/ already holds results; return (status, stderr)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(Engine, "__init__", lambda *a, **k: pytest.fail("a simulation started"))
    kept = tmp_path / "outputs" / "sweeps" / "fig3b" / "old" / "record.json"
    kept.parent.mkdir(parents=True)
    kept.write_text('{"status": "ok"}')

    def call(*args):
        before = sorted(p for p in tmp_path.rglob("*"))
        with pytest.raises(SystemExit) as exit_info:
            main(list(args))
        err = capsys.readouterr().err.strip().splitlines()
        assert sorted(p for p in tmp_path.rglob("*")) == before  # nothing written or removed
        assert kept.read_text() == '{"status": "ok"}'
        return exit_info.value.code, err[-1] if err else ""

    return call


RUN = [
    # (overrides, the message's pattern); every one of them names the field and what is allowed
    (["scaleup.fill_fraction=1.0"], r"scaleup.fill_fraction=1.0 is outside the allowed range \(0.0, 1.0\)"),
    (["scaleup.fill_fraction=0"], r"scaleup.fill_fraction=0.0 is outside the allowed range \(0.0, 1.0\)"),
    (["scaleup.bpr=nan"], r"scaleup.bpr=nan is not a finite number"),
    (["scaleup.bpr=inf"], r"scaleup.bpr=inf is not a finite number"),
    (["scaleup.bpr=-5"], r"scaleup.bpr=-5.0 is outside the allowed range \(0.0, inf\]"),
    (["scaleup.bpr=30"], r"scaleup.bpr=30.0 is outside the yield fit's range \[10.0, 23.0\]"),
    (["scaleup.bpr=abc"], r"scaleup.bpr=abc.*could not be converted to Float"),
    (["scaleup.bpr=[1,2]"], r"scaleup.bpr=\[1,2\].*"),
    (["scaleup.region=XX", "scaleup.pet_feed_kg_per_h=null"], r"scaleup.region='XX' is not one of \['DC', 'DE'"),
    (["scaleup.region=FL"], r"scaleup: give either pet_feed_kg_per_h \(now 1000.0\) or region \(now FL\), not both"),
    (["scaleup.napcor_quantity=sold"], r"scaleup.napcor_quantity='sold' is not one of \['bottles_collected'"),
    (["scaleup.ball_radius_m=10"], r"scaleup.ball_radius_m=10.0: balls of 20 m do not fit a mill"),
    (["scaleup.speed_rpm=0"], r"scaleup.speed_rpm=0.0 is outside the allowed range \(0.0, inf\]"),
    (["scaleup.operating_hours_per_year=9000"], r"scaleup.operating_hours_per_year=9000.0 is outside .*\(0.0, 8784.0\]"),
    (["yield_model.target_yield_percent=0"], r"yield_model.target_yield_percent=0.0 is outside .*\(0.0, 100.0\]"),
    (["yield_model.target_yield_percent=101"], r"yield_model.target_yield_percent=101.0 is outside .*\(0.0, 100.0\]"),
    (["yield_model.impact_threshold_j=0"], r"yield_model.impact_threshold_j=0.0 is outside .*\(0.0, inf\]"),
    (["yield_model.rule=dose"], r"yield_model.rule='dose' is not one of \['bpr_line', 'specific_energy'"),
    (["study=yield_calibration", "yield_model.lab.ball_diameters_m=[]"],
     r"yield_model.lab.ball_diameters_m=\[\] is empty: give at least one value"),
    (["study=yield_calibration", "yield_model.lab.jar_inner_diameters_m=[]"],
     r"yield_model.lab.jar_inner_diameters_m=\[\] is empty: give at least one value"),
    (["study=yield_calibration", "yield_model.lab.jar_inner_lengths_m=[0.02]"],
     r"a lab jar 0.02 m long is shorter than its bore 0.03 m \(yield_model.lab.jar_inner_lengths_m"),
    (["study=yield_fit", "yield_model.experiments=/no/such.csv"],
     r"yield_model.experiments=/no/such.csv: no such data/ table or file"),
    (["study=yield_fit", "yield_model.experiments={inputs}/experiments/missing_columns.csv"],
     r"yield_model.experiments=.*missing_columns.csv: missing columns \['mill', 'jar_inner_diameter_mm'"),
    (["study=yield_fit", "yield_model.experiments={inputs}/experiments/negative_mass.csv"],
     r"negative_mass.csv: row 2 \(b\): pet_mass_g=-1.0 is outside the allowed range \(0.0, inf\)"),
    (["study=yield_fit", "yield_model.experiments={inputs}/experiments/yield_above_100.csv"],
     r"yield_above_100.csv: row 2 \(b\): yield_percent=104.0 is outside the allowed range \[0.0, 100.0\]"),
    (["yield_model=fitted", "yield_model.experiments={inputs}/experiments/one_condition.csv"],
     r"one_condition.csv: rows 1-2 are all one condition .* needs experiments at two conditions or more"),
    (["yield_model=fitted", "yield_model.experiments={inputs}/experiments/three_balls.csv"],
     r"three_balls.csv: row 2 \(b\): ball_count=3 is outside the allowed range \[1, 2\]"),
    (["yield_model=fitted", "yield_model.fit.models=[quadratic]"],
     r"yield_model.fit.models\[0\]='quadratic' is not one of \['dose_linear', 'saturating', 'bpr_line'\]"),
    (["yield_model=fitted", "yield_model.fit.thresholds_j=[-0.01]"],
     r"yield_model.fit.thresholds_j\[0\]=-0.01 is outside the allowed range \(0.0, inf\]"),
    (["yield_model=fitted", "yield_model.rtd.kind=tanks", "yield_model.rtd.tanks=3"],
     r"yield_model.rtd.kind='tanks' is not one of \['plug', 'tanks_in_series', 'axial_dispersion'\]"),
    (["yield_model=fitted", "yield_model.rtd.kind=tanks_in_series", "yield_model.rtd.tanks=0.5"],
     r"yield_model.rtd.tanks=0.5 is outside the allowed range \[1.0, inf\]"),
    (["yield_model=fitted", "yield_model.rtd.sensitivity_tanks=[0.5,3]"],
     r"yield_model.rtd.sensitivity_tanks\[0\]=0.5 is outside the allowed range \[1.0, inf\]"),
    (["yield_model=fitted", "yield_model.rtd.kind=axial_dispersion", "yield_model.target_yield_percent=100"],
     r"yield_model.target_yield_percent=100 .* cannot be reached under yield_model.rtd.kind=axial_dispersion"),
    (["study=yield_calibration", "yield_model.lab.settle_s=5"],
     r"yield_model.lab.settle_s=5.0 leaves nothing of yield_model.lab.duration_s=3.0 to measure"),
    (["study=plant", "plant.bale_pet_fraction=0"], r"plant.bale_pet_fraction=0.0 is outside .*\[0.5, 1.0\]"),
    (["study=plant", "plant.feed_form=chips"], r"plant.feed_form='chips' is not one of \['flake', 'powder'\]"),
    (["study=plant", "plant.evaporated_water_fraction=1"], r"plant.evaporated_water_fraction=1.0 is outside .*\[0.5, 0.99\]"),
    (["study=plant", "plant.granulator_cost=hammer"], r"plant.granulator_cost='hammer' is not a row of data/cost_correlations.csv"),
    (["study=plant", "plant.cost_year=2030"], r"cepci.csv: no row with year=2030; have \["),
    (["study=plant", "plant.staffing=robots"], r"plant.staffing='robots' is not one of \['per_unit', 'fixed'\]"),
    (["study=plant", "plant.startup_months=13"], r"plant.startup_months=13.0 is outside the allowed range \[0.0, 12.0\]"),
    (["study=plant", "plant.loan_fraction=1"], r"plant.loan_fraction=1.0 is outside .*\[0.0, 1.0\)"),
    (["study=plant", "plant.eg_price_fraction=1.5"], r"plant.eg_price_fraction=1.5 is outside .*\[0.0, 1.0\]"),
    (["study=plant", "plant.hxn_min_approach_k=0"], r"plant.hxn_min_approach_k=0.0 is outside .*\[1.0, 50.0\]"),
    (["study=plant", "economics.prices_file=cepci.csv"], r"cepci.csv lacks the columns \['item', 'price_usd_per_t'\]"),
    (["study=plant", "plant.plant_life_yr=0"], r"plant.plant_life_yr=0 is outside the allowed range \[1, 100\]"),
    (["study=plant", "plant.recycle_purge_fraction=0"], r"plant.recycle_purge_fraction=0.0 is outside .*\(0.0, 1.0\]"),
    (["study=plant", "plant.recycle_purge_fraction=1.5"], r"plant.recycle_purge_fraction=1.5 is outside .*\(0.0, 1.0\]"),
    (["study=plant", "plant.construction_fractions=[0.5,0.4]"], r"plant.construction_fractions=\[0.5, 0.4\] sum to 0.9"),
    (["study=plant", "plant.dissolution_water_kg_per_kg_na2tpa=1e9"],
     r"plant.dissolution_water_kg_per_kg_na2tpa=1000000000.0 is outside the allowed range \[5.0, 100.0\]"),
    (["study=plant", "plant.eg_column_water_recovery=0.5"],
     r"plant.eg_column_water_recovery=0.5 is outside the allowed range \[0.95, 0.9999\]"),
    (["study=plant", "plant.salt_cake_moisture=0.9"], r"plant.salt_cake_moisture=0.9 is outside .*\[0.01, 0.4\]"),
    (["study=plant", "plant.tank_residence_time_h=1e6"], r"plant.tank_residence_time_h=1000000.0 is outside .*\(0.0, 48.0\]"),
    (["study=plant", "plant.operator_wage_usd_per_yr=1e12"], r"plant.operator_wage_usd_per_yr=1000000000000.0 is outside"),
    (["study=plant", "plant.dry_moisture=0.02", "plant.salt_cake_moisture=0.02"],
     r"plant.dry_moisture=0.02 must be below plant.salt_cake_moisture=0.02: a dryer cannot add water"),
    (["study=plant", "scaleup.naoh_to_stoichiometric=0.5"],
     r"scaleup.naoh_to_stoichiometric=0.5 is below 0.749 with plant.naoh_dosing=whole_feed: the mill would run out"),
    (["study=plant", "plant.naoh_dosing=converting_pet", "scaleup.naoh_to_stoichiometric=0.9"],
     r"scaleup.naoh_to_stoichiometric=0.9 is below 1 with plant.naoh_dosing=converting_pet"),
    (["study=plant", "plant.brine_material=titanium"], r"material_factors.csv: no row with material='titanium'; have \["),
    (["study=plant", "+plant.prices_usd_per_t.gold=1"], r"plant.prices_usd_per_t: no item \['gold'\] in data/prices.csv"),
    (["study=plant", "+plant.ghg_kg_co2e.steam=0.05", "+plant.ghg_kg_co2e.unobtainium=1"],
     r"plant.ghg_kg_co2e: no item \['unobtainium'\] in data/ghg_factors.csv"),
    (["study=plant", "plant/evaporation=solar"], r"Could not find 'plant/evaporation/solar'; available: multi_effect, mvr"),
    (["study=plant", "plant/evaporation=mvr", "plant.evaporation.kwh_per_t_water=500"],
     r"plant.evaporation.kwh_per_t_water=500.0 is outside the allowed range \[10.0, 100.0\]"),
    (["study=plant", "plant.evaporation.effect_pressures_pa=[25000,60000]"],
     r"plant.evaporation.effect_pressures_pa=\[25000.0, 60000.0\]: give one to six falling pressures"),
    (["study=plant", "plant/evaporation=mvr", "plant.evaporation.compressor_cost=fan"],
     r"plant.evaporation.compressor_cost='fan' is not a row of data/cost_correlations.csv"),
    (["study=plant", "plant/sodium=bpmed", "plant.sodium.current_efficiency=1.5"],
     r"plant.sodium.current_efficiency=1.5 is outside the allowed range \[0.1, 1.0\]"),
    (["study=plant", "+plant.prices_usd_per_t.naoh=-5"], r"plant.prices_usd_per_t.naoh=-5.0 is outside .*\[0.0, 100000.0\]"),
    (["study=plant", "plant.what_it_takes=[price.gold]"],
     r"plant.what_it_takes: \['price.gold'\] are not parameters of data/plant_uncertainty.csv"),
    (["study=plant", "plant/heat=nuclear"], r"Could not find 'plant/heat/nuclear'; available: bought_steam, electric_boiler"),
    (["study=plant", "plant.landfill=sea"], r"plant.landfill='sea' is not one of \['landfill_low_organic', 'landfill'\]"),
    (["study=plant", "scaleup.naoh_feed_kg_per_h=400"], r"study=plant: give the NaOH as scaleup.naoh_to_stoichiometric"),
    (["scaleup.pet_feed_kg_per_h=1e12"], r"mill: .* balls need about .* GiB for the DEM \(2\.8 kB per ball\), more .*"),
    (["economics.cost_exponent=3"], r"economics.cost_exponent=3.0 is outside the allowed range \(0.0, 2.0\]"),
    (["economics.cepci_target_year=2030"], r"cepci.csv: no row with year=2030; have \["),
    (["economics.prices_file=missing.csv"], r"data table 'missing.csv' not found in .*; available: \["),
    (["sim.dt_fraction=1.0"], r"sim: the time step is 1.00 x the Rayleigh step .* set sim.allow_unstable_time_step"),
    (["sim.dt_fraction=0"], r"sim.dt_fraction=0.0 is outside the allowed range \(0.0, 1.0\]"),
    (["sim.dt_s=0.01"], r"sim: the time step is \d+\.\d\d x the Rayleigh step"),
    (["sim=test", "sim.steady_after_s=0.6", "sim.duration_s=0.6"], r"sim.steady_after_s=0.6 leaves no samples to average"),
    (["sim.window_revolutions=0"], r"sim.window_revolutions=0.0 is outside the allowed range \(0.0, inf\]"),
    (["sim.startup_revolutions=-1"], r"sim.startup_revolutions=-1.0 is outside the allowed range \[0.0, inf\]"),
    (["sim.window_revolutions=nan"], r"sim.window_revolutions=nan is not a finite number"),
    (["sim.window_revolutions=0.001"], r"sim.sample_every_s=0.01 gives fewer than 2 samples in the averaging window"),
    (["sim.duration_s=5"], r"sim: the start-up and the averaging window are given in revolutions .* give one pair"),
    (["sim=test", "sim.window_revolutions=2"], r"sim: the start-up and the averaging window are given in revolutions"),
    (["sim.window_revolutions=null"], r"sim: the start-up and the averaging window are given in revolutions"),
    (["yield_model.run_lab_calibration=true"],
     r"Could not override 'yield_model.run_lab_calibration': Key 'run_lab_calibration' not in 'YieldModelConfig'"),
    (["sim=test", "sim.sample_every_s=1.0"], r"sim.sample_every_s=1.0 gives fewer than 2 samples"),
    (["sim.threads=999"], r"sim.threads=999 is more than this machine's \d+ cores"),
    (["sim.threads=-1"], r"sim.threads=-1 is outside the allowed range \[0, inf\]"),
    (["sim.arch=gpu"], r"sim.arch='gpu' is not one of \['cpu', 'cuda'\]"),
    (["sim.precision=f16"], r"sim.precision='f16' is not one of \['f64', 'f32'\]"),
    (["sim.max_contacts_per_particle=4"], r"sim.max_contacts_per_particle=4 is too few for a bed of \d+ balls .* use at least 12"),
    (["sim.dt_fractoin=0.1"], r"Could not override 'sim.dt_fractoin': Key 'dt_fractoin' not in 'SimConfig'"),
    (["sim=huge"], r"Could not find 'sim/huge'; available: lab, paper, steady, surrogate, test"),
    (["study=foo"], r"Could not find 'study/foo'; available: cheapest_mill, design, drum, lab"),
    (["+sweep=fig99"], r"Could not find 'sweep/fig99'; available: .*fig3b, fig4, lab_validation"),
    (["materials.steel.density_kg_per_m3=-1"], r"materials.steel.density_kg_per_m3=-1.0 is outside .*\(0.0, inf\]"),
    (["interactions.steel-steel.restitution=1.5"], r"interactions.steel-steel.restitution=1.5 is outside .*\(0.0, 1.0\]"),
    (["interactions.steel-steel.restitution=nan"], r"interactions.steel-steel.restitution=nan is not a finite number"),
    (["mill.ball_material=unobtainium"], r"unknown material 'unobtainium'; known: \['pmma', 'steel'\]"),
    (["study=drum", "mill.ball_radius_m=0.1"], r"mill.ball_radius_m=0.1: balls of 0.2 m do not fit a drum"),
    (["study=drum", "mill.speed_rpm=0"], r"mill.speed_rpm=0.0 is outside the allowed range \(0.0, inf\]"),
    (["study=drum", "mill.fill_fraction=0.9", "mill.bed_porosity=0.0"], r"mill: \d+ balls of radius .* do not fit"),
    (["study=drum", "mill.geometry=stl", "mill.stl_path=/no/such.stl"], r"mill.stl_path=/no/such.stl: no such file"),
    (["study=drum", "mill.geometry=stl", "mill.stl_path={inputs}/notes.stl"], r"mill.stl_path=.*notes.stl: (not a readable STL|holds no triangles)"),
    (["study=drum", "mill.geometry=stl", "mill.stl_path={inputs}/open.stl"], (r"mill.stl_path=.*open.stl: the mesh is "
                                                                              r"not closed")),
    (["study=drum", "mill.geometry=cad"], r"mill.geometry='cad' is not one of \['analytic', 'stl'\]"),
    (["study=lab", "sim=lab", "lab.frequencies_hz=[]"], r"lab.frequencies_hz=\[\] is empty"),
    (["study=lab", "sim=lab", "lab.frequencies_hz=[25,-1]"], r"lab.frequencies_hz\[1\]=-1.0 is outside .*\(0.0, inf\]"),
    (["study=lab", "sim=lab", "lab.ball_diameters_m=[0.05]"], r"lab.ball_diameters_m: 0.05 m balls do not fit"),
    (["study=lab", "sim=lab", "lab.settle_s=2.0"], r"lab.settle_s=2.0 leaves nothing of lab.duration_s=2.0"),
    (["study=lab", "sim=lab", "lab.balls_per_jar=3"], r"lab.balls_per_jar=3 is outside the allowed range \[1, 2\]"),
    (["dem=surrogate", "scaleup.pet_feed_kg_per_h=20000"],
     r"dem=surrogate: diameter_to_ball=\S+ is outside the training runs' range \[\S+, \S+\]; use dem=full"),
    (["dem=surrogate", "yield_model=impact_threshold"],
     r"dem=surrogate: yield_model.rule=impact_threshold needs the impact spectrum"),
    (["dem=surrogate", "dem.table=/no/such.csv"], r"dem.table=/no/such.csv: no such data/ table or file"),
    (["dem=fast"], r"dem.*fast.*available: full, surrogate"),
    (["study=plant", "plant.options_front=[heat,colour]"],
     r"plant.options_front=\['heat', 'colour'\]: give each of \['evaporation', 'heat', 'sodium', 'naoh_dosing'\] at most once"),
    (["study=regional", "plant.regional.scale_fresh_pet_kg_per_h=[5000,100]"],
     r"plant.regional.scale_fresh_pet_kg_per_h=\[5000.0, 100.0\]: give \[low, high\] with low < high"),
    (["study=regional", "plant.regional.scale_fresh_pet_kg_per_h=[1,100]"],
     r"plant.regional.scale_fresh_pet_kg_per_h\[0\]=1.0 is outside the allowed range \[10.0, 1000000.0\]"),
    (["study=regional", "plant.regional.states=[FL]"],
     r"plant.regional.states=\['FL'\]: give two or more different state codes"),
    (["study=regional", "scaleup.pet_feed_kg_per_h=null", "scaleup.region=FL", "plant.regional.states=[FL,TX]"],
     r"plant.regional.states: \['TX'\] have no centre in data/population_centres.csv"),
    (["dem=surrogate", "dem.outside=maybe"], r"dem.outside='maybe' is not one of \['refuse', 'full'\]"),
    (["study=drum", "dem=surrogate"], r"dem=surrogate: study=drum is the DEM of the mill group's drum"),
    (["study=cheapest_mill", "optimiser.fill_fraction=[0.1,0.4]"],
     r"optimiser.fill_fraction\[0\]=0.1 is outside the allowed range \[0.2, 0.45\]"),
    (["study=cheapest_mill", "optimiser.fraction_of_critical=[0.3,0.95]"],
     r"optimiser.fraction_of_critical\[1\]=0.95 is outside the allowed range \[0.0, 0.9\]"),
    (["study=cheapest_mill", "optimiser.ball_radius_m=[0.08,0.04]"],
     r"optimiser.ball_radius_m=\[0.08, 0.04\]: give \[low, high\] with low < high"),
    (["study=cheapest_mill", "optimiser.min_ball_to_feed=20"],
     r"optimiser.ball_radius_m=\[0.04, 0.08\]: the feed's 0.012 m particles need balls of radius >= 0.12 m"),
    (["study=cheapest_mill", "yield_model=specific_energy", "yield_model.mode=fixed_time"],
     r"study=cheapest_mill: yield_model.mode=fixed_time gives no target to reach"),
    (["-m", "scaleup.bpr=19,99"], r"scaleup.bpr=99.0 is outside the yield fit's range .*\(job scaleup.bpr=99\)"),
    (["scaleup.bpr=19,20"], r"scaleup.bpr: several values need a sweep: add -m"),
    (["bpr19"], r"Error parsing override 'bpr19'"),
    (["mill.liner.kind=bars", "mill.liner.count=8"],
     r"liner: give one of height_m \(None\) and height_to_diameter \(None\), the other null"),
    (["mill.liner.kind=bars", "mill.liner.count=0", "mill.liner.height_m=0.02", "mill.liner.top_width_m=0.02"],
     r"liner.count=0: a bars liner needs at least 1 bar or wave"),
    (["mill.liner.kind=bars", "mill.liner.count=8", "mill.liner.height_m=0.02"],
     r"liner: bars need one of top_width_m \(None\) and top_width_to_height \(None\)"),
    (["mill.liner.kind=lifters"], r"mill.liner.kind='lifters' is not one of \['smooth', 'bars', 'wave'\]"),
    (["mill.liner.kind=bars", "mill.liner.count=8", "mill.liner.height_m=0.02", "mill.liner.top_width_m=0.02",
      "mill.liner.face_angle_deg=75"], r"mill.liner.face_angle_deg=75.0 is outside the allowed range \[0.0, 60.0\]"),
    (["study=drum", "mill.liner.kind=bars", "mill.liner.count=60", "mill.liner.height_m=0.02",
      "mill.liner.top_width_m=0.03"], r"mill.liner: 60 bars 0.03 m wide .* overlap on a shell of radius 0.2 m"),
    (["study=drum", "mill.liner.kind=wave", "mill.liner.count=8", "mill.liner.height_m=0.15"],
     r"mill.liner: lifters of height 0.15 m reach beyond half the shell's radius"),
    (["study=drum", "mill.geometry=stl", "mill.liner.kind=wave", "mill.liner.count=8", "mill.liner.height_m=0.01"],
     r"mill.liner.kind=wave builds the shell's mesh itself: use geometry=analytic"),
    (["study=drum", "mill.charge=[{{diameter_m:0.02,count:10}},{{diameter_m:0.01,mass_fraction:0.5}}]"],
     r"mill.charge: give every size a count, or every size a mass_fraction"),
    (["study=drum", "mill.charge=[{{diameter_m:0.02,mass_fraction:0.4}},{{diameter_m:0.01,mass_fraction:0.5}}]"],
     r"mill.charge: the mass fractions sum to 0.9, not 1"),
    (["study=drum", "mill.charge=[{{diameter_m:-0.02,count:10}}]"],
     r"mill.charge\[0\].diameter_m=-0.02 is outside the allowed range \(0.0, inf\]"),
    (["study=drum", "mill.charge=[{{diameter_m:0.2,count:10}}]"], r"mill.charge: balls of 0.2 m do not fit a drum"),
    (["scaleup.charge=[{{diameter_m:0.1,count:10}}]"], r"scaleup.charge: give each size a mass_fraction"),
    (["dem=surrogate", "mill.liner.kind=wave", "mill.liner.count=8", "mill.liner.height_to_diameter=0.02"],
     r"dem=surrogate knows smooth drums with balls of one size, not mill.liner.kind=wave: use dem=full"),
]


@pytest.mark.parametrize("overrides, message", RUN, ids=[" ".join(o) for o, _ in RUN])
def test_run_refuses(cli, inputs, overrides, message):
    status, line = cli("run", *[o.format(inputs=inputs) for o in overrides])
    assert status == 2
    assert line.startswith("error: ") and re.search(message, line), line


OTHERS = [
    (["report"], r"sweeps=\[\] is empty: give sweeps=\[outputs/sweeps/NAME,...\]"),
    (["report", "outputs/sweeps/fig3b"], r"'outputs/sweeps/fig3b' is not key=value: .* sweeps=\[outputs/sweeps/fig3b\]"),
    (["report", "sweeps=[/no/such/sweep]"], r"sweeps: /no/such/sweep is not a folder"),
    (["report", "sweeps=[{inputs}/empty_sweep]"], r"sweeps: no \*/record.json under .*empty_sweep"),
    (["report", "sweeps=[a]", "colour=red"], r"Could not override 'colour': Key 'colour' not in 'ReportConfig'"),
    (["track"], r"missing mandatory value: video"),
    (["track", "video=/no/such.avi"], r"video=/no/such.avi does not exist"),
    (["track", "video={inputs}/empty.avi", "fps=2134", "mm_per_px=0.2"], r"video=.*empty.avi: OpenCV cannot open it"),
    (["track", "video={inputs}/garbage.avi", "fps=2134", "mm_per_px=0.2"], r"video=.*garbage.avi: OpenCV cannot open"),
    (["track", "video={inputs}/truncated.avi", "fps=2134", "mm_per_px=0.2"], (r"video=.*truncated.avi: (OpenCV cannot "
                                                                              r"open it|holds no frames)")),
    (["track", "video={inputs}/grey.avi", "balls=1"], r"video=.*grey.avi: no ball found in any of its 20 frames"),
    (["track", "video={inputs}/ball12mm.avi", "balls=1", "ball_diameter_mm=17.6"],
     r"the balls measure 1[12].\d\d mm across, not ball_diameter_mm=17.6 \(at mm_per_px=0.2\); give ball_diameter_mm="),
    (["track", "video={inputs}/ball12mm.avi", "mm_per_px=-1"], r"mm_per_px=-1.0 is outside the allowed range \(0.0, inf\]"),
    (["track", "video={inputs}/ball12mm.avi", "fps=0"], r"fps=0.0 is outside the allowed range \(0.0, inf\]"),
    (["track", "video={inputs}/ball12mm.avi", "balls=3"], r"balls=3 is outside the allowed range \[1, 2\]"),
    (["track", "video={inputs}/ball12mm.avi", "polarity=grey"], r"polarity='grey' is not one of \['auto', 'dark'"),
    (["render", "mm_per_px=0"], r"mm_per_px=0.0 is outside the allowed range \(0.0, inf\]"),
    (["render", "wall_restitution=2"], r"wall_restitution=2.0 is outside the allowed range \(0.0, 1.0\]"),
    (["calibrate"], r"missing mandatory value: videos"),
    (["calibrate", "videos=/no/such/folder"], r"videos=/no/such/folder: no videos.csv"),
    (["calibrate", "videos={inputs}/no_manifest"], r"videos=.*no_manifest: no videos.csv \(columns file"),
    (["calibrate", "videos={inputs}/no_columns"], r"videos.csv: missing columns \['ball_diameter_mm', 'frequency_hz'\]"),
    (["calibrate", "videos={inputs}/balls_two"], r"videos.csv: column balls holds 'two'; give positive numbers"),
    (["calibrate", "videos={inputs}/missing_video"], r"videos.csv: names videos that are not in .*: \['gone.avi'\]"),
    (["calibrate", "videos={inputs}/empty_manifest"], r"videos.csv: lists no videos"),
    (["calibrate", "videos=x", "restitutions=[]"], r"restitutions=\[\] is empty"),
    (["calibrate", "videos=x", "restitutions=[0.5,1.5]"], r"restitutions\[1\]=1.5 is outside .*\(0.0, 1.0\]"),
    (["bench", "cases=[0]"], r"cases: '0' is neither a ball count \(an integer >= 2\), longN nor bpr19"),
    (["bench", "cases=[big]"], r"cases: 'big' is neither a ball count"),
    (["bench", "cases=[long700]"], r"cases: 'long700': .*balls of 0.01 m do not fit a drum of D 0.4 m x L 0.0162"),
    (["bench", "peer=gromacs"], r"peer='gromacs' is not one of \[None, 'liggghts', 'lammps', 'liggghts,lammps', 'both'\]"),
    (["bench", "mm400=true", "mm400_duration_s=0"], r"mm400_duration_s=0.0 is outside the allowed range \(0.0, inf\]"),
    (["surrogate", "points=60"], r"points=60: a Sobol design needs a power of two"),
    (["surrogate", "points=8", "folds=2"], r"points=8 in folds=2: each fold is fitted on 4 runs, fewer than the 7"),
    (["surrogate", "bounds.fill_fraction=[0.5,0.3]"], r"bounds.fill_fraction=\[0.5, 0.3\]: give \[low, high\]"),
    (["surrogate", "bounds.restitution=[0.3,1.2]"], r"bounds.restitution\[1\]=1.2 is outside the allowed range"),
    (["compare"], r"sweeps=\[\] is empty: give sweeps=\[outputs/sweeps/NAME,...\]"),
    (["compare", "sweeps=[/no/such/sweep]"], r"sweeps: /no/such/sweep is not a folder"),
    (["frobnicate"], r"unknown command 'frobnicate'; one of run, report, track"),
]


@pytest.mark.parametrize("args, message", OTHERS, ids=[" ".join(a) for a, _ in OTHERS])
def test_other_commands_refuse(cli, inputs, args, message):
    status, line = cli(*[a.format(inputs=inputs) for a in args])
    assert status == 2
    assert line.startswith("error: ") and re.search(message, line), line


def test_a_corrupted_record_is_listed_as_failed_not_reused(inputs, tmp_path, capsys):
    main(["report", f"sweeps=[{inputs / 'corrupt_sweep'}]", f"out={tmp_path}"])
    md = (tmp_path / "fig3b.md").read_text() if (tmp_path / "fig3b.md").exists() else (tmp_path / "?.md").read_text()
    assert "0 finished, 1 failed" in md and "record.json unreadable: rerun the sweep" in md
    assert pd.read_csv(next(tmp_path.glob("*.csv"))).status.tolist() == ["failed"]


def test_a_time_step_above_40_percent_of_rayleigh_is_accepted_with_a_warning(caplog):
    from ballmill.jobs import check_jobs

    with caplog.at_level("WARNING"):
        assert check_jobs(["sim.dt_fraction=0.5"], multirun=False) is None
    assert "the time step is 50 % of the Rayleigh step (above 40 %)" in caplog.text


# The campaign as the configs grow: every field with a range or choices, of every config group and
# command, refused with its name and value outside them.  A field comes with what its schema needs
# besides (a run's length in seconds replaces its revolutions; a command's required input).
SECONDS = {"startup_revolutions": None, "window_revolutions": None, "steady_after_s": 0.1, "duration_s": 1.0}
COMPANIONS = {(SimConfig, "steady_after_s"): SECONDS, (SimConfig, "duration_s"): SECONDS,
              (COMMANDS["track"], None): {"video": "run1.avi"}, (COMMANDS["calibrate"], None): {"videos": "videos"}}


def outside(path: str, f):
    """A value of the field outside what it allows (None: a field of any value)."""
    meta = f.metadata
    if "choices" in meta:
        return "not_a_choice"
    lo, hi, lo_open, hi_open = meta["range"]
    integer = "int" in str(f.type) and "float" not in str(f.type)
    if lo is not None:
        return lo if lo_open else lo - 1
    if hi is not None:
        return hi if hi_open else hi + 1
    return None if integer else float("nan")


def ranged_fields():
    """(prefix of the field's name in messages, schema, path, field): the run's groups, then each
    command's own options (named bare)."""
    schemas = [*((f"{group}.", schema) for group, schema in RUN_GROUPS), *(("", schema) for schema in COMMANDS.values())]
    for group, schema in schemas:
        for path, f, _ in walk(schema):
            if ("range" in f.metadata or "choices" in f.metadata) and "[]" not in path and outside(path, f) is not None:
                yield group, schema, path, f


@pytest.mark.parametrize("prefix, schema, path, f", list(ranged_fields()),
                         ids=[f"{g or s.__name__ + ': '}{p}" for g, s, p, _ in ranged_fields()])
def test_every_ranged_field_refuses_a_value_outside_its_range(prefix, schema, path, f):
    bad = outside(path, f)
    values = {**COMPANIONS.get((schema, None), {}), **COMPANIONS.get((schema, path), {})}
    node = values
    *parents, name = path.split(".")
    for parent in parents:
        node = node.setdefault(parent, {})
    table = "dict" in str(f.type)  # a table of numbers: one entry outside
    node[name] = {"naoh": bad} if table else bad
    path = f"{path}.naoh" if table else path
    shown = "'not_a_choice'" if bad == "not_a_choice" else re.escape(str(float(bad)) if not isinstance(bad, int)
                                                                     or "float" in str(f.type) else str(bad))
    with pytest.raises(ConfigError, match=rf"(^|\W){re.escape(prefix + path)}={shown}(?![\w.])"):  # a check of its own may
        to_object(OmegaConf.create(values), schema, prefix.rstrip("."))  # come first, naming it all the same


# Numbers any value of which is meaningful (finite): the BPR line's coefficients and the range of
# its experiments.
ANY_VALUE = {"yield_model.bpr_slope_percent", "yield_model.bpr_intercept_percent", "yield_model.bpr_min",
             "yield_model.bpr_max"}


def test_every_number_field_has_a_range_unless_any_value_is_meaningful():
    """So that a new field cannot leave the campaign above unseen: without a range it is not in it."""
    unranged = {f"{group}.{path}" for group, schema in [*RUN_GROUPS, *COMMANDS.items()] for path, f, _ in walk(schema)
                if re.search(r"\b(float|int)\b", str(f.type)) and "list" not in str(f.type)
                and "range" not in f.metadata}
    assert unranged == ANY_VALUE
    assert {f"{prefix}{path}" for prefix, _, path, _ in ranged_fields()} >= {"sim.window_revolutions",
                                                                             "sim.startup_revolutions"}
