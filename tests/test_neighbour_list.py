"""The Verlet list: complete (every touching pair found), skin-independent, and results that do
not depend on how steps are launched (a launch a step, whole steps serially, or a team of
threads) or on the number of threads."""

import numpy as np
import pytest

from ballmill.config import BallSizeConfig, DrumConfig, InteractionConfig, LinerConfig, MaterialConfig, SimConfig
from ballmill.dem import Engine, EngineOptions, Motion, init_taichi
from ballmill.dem.geometry import CAPSULE, CYLINDER, PLANE
from ballmill.dem.walls import still_under
from ballmill.drum import drum_spec
from ballmill.lab import Condition, mm400_spec
from ballmill.scenario import compose, load, time_step_s

DRUM = DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, ball_radius_m=0.01)  # 304 balls
SIM = SimConfig(shear_modulus_scale=1e-2, settle_s=0.15)  # dt 2.2e-5 s; the drum turns from 0.15 s


def simulate(threads=2, launches=1, drum=DRUM, kinds=None, every_wall=False, **options):
    """10,000 steps (0.22 s) of a settling, then turning, charge; what the test needs, as numpy
    (each call restarts Taichi, so no engine outlives it).  `kinds`: a team engine's launches
    run by these launches in turn (what its pacer may choose); `every_wall`: every wall is
    tested for contact at every step, none left out as out of reach."""
    spec = drum_spec(drum, {"steel": MaterialConfig()}, {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}, SIM)
    init_taichi("cpu", "f64", threads)
    engine = Engine(spec, EngineOptions(dt_s=time_step_s(spec, SIM), **options))
    if every_wall:
        engine.walls.w_still.fill(0)
        engine.nl.build_all()  # marks every wall within reach of every ball (a rebuild changes no result)
    for k in range(launches):
        if kinds:
            engine._run_steps(kinds[k % len(kinds)], 10_000 // launches)
        else:
            engine.advance(10_000 // launches)
    x, v, w = engine.kinematics()
    return {"x": x, "v": v, "w": w, "events": engine.drain_events(),
            "radius": spec.radius_m, "contact_pairs": engine.nl.contact_pairs(), "rebuilds": engine.rebuilds(),
            "walls_in_reach": engine.walls.reach.to_numpy()[:spec.n_particles],
            "wall_contacts": engine.walls.c_n.to_numpy()[engine.step_index % 2, :spec.n_particles]}


@pytest.fixture(scope="module")
def reference():
    return simulate(threads=2, launch="parallel")


def test_every_touching_pair_is_in_the_list_and_in_contact(reference):
    x, r = reference["x"], reference["radius"]
    d = np.linalg.norm(x[:, None] - x[None], axis=-1)
    touching = np.triu(d < r[:, None] + r[None], k=1).sum()  # brute force over all pairs
    assert touching > 100  # a settled bed: many contacts
    assert reference["contact_pairs"] == touching


def test_small_and_large_skin_give_identical_trajectories(reference):
    small = simulate(launch="team", skin_fraction=0.05)
    large = simulate(launch="parallel", skin_fraction=1.0)
    assert small["rebuilds"] > 3 * large["rebuilds"]  # the skin did change how often the list was built
    for other in (small, large):  # partners are summed in id order, so not even round-off differs
        for key in ("x", "v", "w"):
            assert np.array_equal(other[key], reference[key]), key


def test_every_launch_and_thread_count_gives_identical_bits(reference):
    for threads, launch in ((1, "parallel"), (1, "serial"), (2, "serial"), (1, "team"), (2, "team")):
        other = simulate(threads=threads, launches=4, launch=launch)  # serial, team: 2,500 steps per launch
        for key in ("x", "v", "w"):
            assert np.array_equal(other[key], reference[key]), (threads, launch, key)
        assert other["rebuilds"] == reference["rebuilds"], (threads, launch)


@pytest.mark.parametrize("kinds", [("team", "serial"), ("serial", "team")])
def test_a_team_engine_that_hands_its_steps_to_one_thread_and_back_gives_identical_bits(reference, kinds):
    """What a pacer does when another process takes a core: the same bits and the same rebuilds
    (a one-thread launch once left the team's flag set, and the team rebuilt needlessly: 44 and
    45 rebuilds against 40)."""
    handed = simulate(threads=2, launches=20, launch="team", kinds=kinds)
    for key in ("x", "v", "w"):
        assert np.array_equal(handed[key], reference[key]), key
    assert handed["rebuilds"] == reference["rebuilds"]


def test_every_launch_rebuilds_the_list_on_the_same_steps():
    """The rebuild decision is a function of the state: each launch rebuilds after the drift,
    from the positions it reached (a launch a step once rebuilt before it, from the step
    before's, and its rebuilds fell a step or more earlier from the sixth on: 2425 against 2426)."""
    spec = drum_spec(DRUM, {"steel": MaterialConfig()}, {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}, SIM)
    steps = {}
    for launch in ("parallel", "serial"):
        init_taichi("cpu", "f64", 1)
        engine = Engine(spec, EngineOptions(dt_s=time_step_s(spec, SIM), launch=launch))
        builds = []
        for k in range(3_000):
            engine.advance(1)
            builds.append(engine.rebuilds())
        steps[launch] = np.flatnonzero(np.diff(builds, prepend=builds[0])).tolist()
    assert len(steps["parallel"]) >= 6  # the sixth rebuild is the first the old order moved
    assert steps["parallel"] == steps["serial"]


def test_the_gpu_binning_path_gives_the_cpu_paths_contacts_and_bits(reference):
    """Parallel binning with a per-cell sort (what CUDA runs), here on the CPU backend."""
    gpu_path = simulate(launch="parallel", parallel_binning=True)
    assert gpu_path["contact_pairs"] == reference["contact_pairs"]
    assert gpu_path["rebuilds"] == reference["rebuilds"]
    for key in ("x", "v", "w"):
        assert np.array_equal(gpu_path[key], reference[key]), key


def test_walls_out_of_reach_are_left_out_without_changing_a_bit(reference):
    """At each list build a ball marks the analytic walls it may touch before the next build
    (walls.py): the drum's shell and ends keep their distances as it turns, so most balls leave
    them out.  Testing every wall at every step gives the same bits and the same collisions."""
    reach = reference["walls_in_reach"]
    assert (reach == 0).mean() > 0.3  # balls with no wall in reach (of the shell and two ends)
    assert reference["wall_contacts"].sum() > 30  # and balls in contact with a wall
    every = simulate(launch="parallel", every_wall=True)
    assert (every["walls_in_reach"] == 0b111).all()
    for key in ("x", "v", "w"):
        assert np.array_equal(every[key], reference[key]), key
    for ours, theirs in zip(every["events"], reference["events"]):
        assert np.array_equal(ours, theirs)


@pytest.mark.parametrize(("motion", "kind", "point", "axis", "still"), [
    (Motion(axis=(0, 1, 0), angular_velocity_rad_per_s=1.6), CYLINDER, (0, 0, 0), (0, 1, 0), True),  # drum shell
    (Motion(axis=(0, 1, 0), angular_velocity_rad_per_s=1.6), PLANE, (0, -0.1, 0), (0, 1, 0), True),  # drum end
    (Motion(axis=(0, 1, 0), angular_velocity_rad_per_s=1.6), PLANE, (0, 0, -0.1), (0, 0, 1), False),  # a flat
    (Motion(pivot_m=(0.05, 0, 0), axis=(0, 1, 0), angular_velocity_rad_per_s=1.6), CYLINDER, (0, 0, 0), (0, 1, 0),
     False),  # a shell turning off its axis
    (Motion(axis=(0, 0, 1), angle_amplitude_rad=0.1, frequency_hz=25), CAPSULE, (0, 0, 0), (1, 0, 0), False),
    (Motion(translation_amplitude_m=(0.01, 0, 0), frequency_hz=25), CAPSULE, (0, 0, 0), (1, 0, 0), False),  # MM400
    (Motion(), PLANE, (0, 0, 0), (0, 0, 1), True),  # at rest
])
def test_a_wall_is_left_out_only_under_a_motion_that_keeps_its_distances(motion, kind, point, axis, still):
    assert still_under(motion, kind, point, axis) is still


def test_a_bidisperse_lifter_drum_gives_identical_bits_for_any_threads_launches_and_skin():
    drum = DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, charge=[BallSizeConfig(0.024, 80),
                                                                        BallSizeConfig(0.016, 150)],
                      liner=LinerConfig(kind="bars", count=6, height_m=0.02, top_width_m=0.015, face_angle_deg=15))
    reference = simulate(launch="parallel", drum=drum)
    for options in ({"threads": 1, "launches": 4, "launch": "serial"}, {"launch": "team", "skin_fraction": 0.05}):
        other = simulate(drum=drum, **options)
        for key in ("x", "v", "w"):
            assert np.array_equal(other[key], reference[key]), (options, key)


def test_a_batch_of_replicas_shared_by_two_threads_gives_the_one_thread_bits():
    """Seven two-ball MM400 jars: one thread runs them in 4 runs of replicas, two threads in 7
    (Engine.batches); every jar moves, and each gives the same bits either way."""
    s = load(compose("config", ["sim=lab", "lab.balls_per_jar=2"]))
    conds = [Condition(f, d, e, 0.3) for f, d, e in zip((22.5, 25, 27.5, 30, 22.5, 25, 30), (0.0176, 0.0206) * 4,
                                                           (0.3, 0.45, 0.6, 0.75, 0.9, 0.6, 0.6))]
    spec = mm400_spec(s.lab, conds, s.materials, s.interactions, s.sim)
    runs = {}
    for threads in (1, 2):
        init_taichi("cpu", "f64", threads)
        engine = Engine(spec, EngineOptions(dt_s=time_step_s(spec, s.sim)))
        assert engine.launch == "serial" and engine.batches == min(7, 4 * threads)
        for _ in range(4):
            engine.advance(2_000)
        runs[threads] = engine.kinematics()
    moved = np.linalg.norm(runs[1][0] - spec.position_m, axis=1)
    assert (moved > 1e-3).all()  # 8,000 steps (15 ms) in swinging jars: every ball has moved
    for one, two in zip(runs[1], runs[2]):
        assert np.array_equal(one, two)


def test_a_rebuild_carries_each_open_contact_to_its_new_slot():
    """A rebuild renumbers slots in place (neighbours.build_particle): after one at the bed's
    positions 3,000 steps into its fall, every open contact is open in its pair's new slot, some
    moved up and some down, and its records (collision start, tangential spring, impact speed,
    dissipation, kept force), which stay where they were, are the same bits; every other pair of
    the new list is closed."""
    spec = drum_spec(DRUM, {"steel": MaterialConfig()}, {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}, SIM)
    init_taichi("cpu", "f64", 1)
    engine = Engine(spec, EngineOptions(dt_s=time_step_s(spec, SIM), skin_fraction=1.0))
    engine.advance(3_000)
    nl, n = engine.nl, engine.n

    def listed():
        """{(i, j): (slot, open, the open contact's records)} of every listed pair."""
        nb_n, nb_j, rec, open_ = nl.nb_n.to_numpy()[:n], nl.nb_j.to_numpy()[:n], nl.rec.to_numpy()[:n], nl.open_slots()
        fields = [getattr(nl, name).to_numpy()[:n] for name in ("start", "xi", "vn0", "ed", "f")]
        return {(i, nb_j[i, s]): (s, bool(open_[i, s]), *(np.concatenate([np.ravel(f[i, rec[i, s]]).astype(float)
                                                                           for f in fields]) if open_[i, s] else ()))
                for i in range(n) for s in range(nb_n[i])}

    before = listed()
    nl.build_all()
    after = listed()
    kept = before.keys() & after.keys()
    assert before.keys() - after.keys() and after.keys() - before.keys()  # pairs left the list, others joined
    contacts = [key for key in kept if before[key][1]]
    assert len(contacts) > 50  # open contacts among the kept pairs (86)
    moved = [after[key][0] - before[key][0] for key in contacts]
    assert min(moved) < 0 < max(moved)  # open contacts moved to lower and to higher slots
    for key in contacts:
        assert before[key][1:] == after[key][1:], key
    assert not any(after[key][1] for key in after.keys() - set(contacts))
    # each ball's open contacts hold records of their own, and its mask of records in use names them
    open_, rec, used = nl.open_slots(), nl.rec.to_numpy()[:n], nl.used.to_numpy()[:n]
    for i in range(n):
        mine = rec[i][open_[i]].astype(np.uint64)
        assert len(set(mine)) == len(mine) and int(np.bitwise_or.reduce(np.uint64(1) << mine, initial=0)) == used[i]
