"""Checkpoint and restart: a drum run killed part-way and started again ends with the tables of
an uninterrupted run, bit for bit (a smooth drum of one ball size, and a lifter drum with a
bidisperse charge).  The run is killed (SIGKILL, as a crash or an out-of-memory kill would end
it) by itself, right after the checkpoint of a given sample: where it dies does not depend on
how fast the machine is.  BALLMILL_TEST_ARCH=cuda runs the drums on a GPU."""

import json
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from ballmill.files import read_parquet

RUN = """
import logging
import os
import signal
import sys
logging.basicConfig(level=logging.INFO)
from ballmill.config import BallSizeConfig, DrumConfig, InteractionConfig, LinerConfig, MaterialConfig, SimConfig
from ballmill.dem import Checkpoint
from ballmill.drum import simulate_drum
if len(sys.argv) > 2:  # killed right after the checkpoint before this sample
    die_at, save = int(sys.argv[2]), Checkpoint.save
    def save_then_die(self, engine, recorder, next_sample, label):
        save(self, engine, recorder, next_sample, label)
        if next_sample >= die_at:
            os.kill(os.getpid(), signal.SIGKILL)
    Checkpoint.save = save_then_die
# a checkpoint at every sample (the first after 1 ms of wall-clock time) of 60
sim = SimConfig(arch=os.environ.get("BALLMILL_TEST_ARCH", "cpu"), shear_modulus_scale=1e-2, settle_s=0.1,
                startup_revolutions=None, window_revolutions=None,
                steady_after_s=0.1, duration_s=0.5, sample_every_s=0.01, checkpoint_every_wall_s=1e-3)
drum = {drum}
simulate_drum(drum, {"steel": MaterialConfig()}, {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}, sim, sys.argv[1])
"""


SMOOTH = "DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, ball_radius_m=0.01)"
LIFTERS_BIDISPERSE = ("DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, liner=LinerConfig(kind='bars', count=6, "
                      "height_m=0.02, top_width_m=0.015, face_angle_deg=15), "
                      "charge=[BallSizeConfig(0.024, 80), BallSizeConfig(0.016, 150)])")


def run(folder: Path, drum: str, *die_at: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", RUN.replace("{drum}", drum), str(folder), *die_at],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, timeout=300, check=False)


@pytest.mark.parametrize("drum", [SMOOTH, LIFTERS_BIDISPERSE], ids=["smooth", "lifters_bidisperse"])
def test_a_killed_run_resumes_from_its_checkpoint_and_ends_with_identical_tables(tmp_path, drum):
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    assert run(whole, drum).returncode == 0
    assert run(killed, drum, "30").returncode == -signal.SIGKILL  # half-way: 30 samples of 60
    assert (killed / "checkpoint.npz").exists() and not (killed / "dem_summary.json").exists()
    resumed = run(killed, drum)
    assert resumed.returncode == 0, resumed.stderr
    assert "resumed from" in resumed.stderr and "at t=0.3" in resumed.stderr  # 30 samples of 0.01 s
    assert not (killed / "checkpoint.npz").exists()  # a finished run leaves none behind
    assert json.loads((killed / "dem_summary.json").read_text()) == json.loads((whole / "dem_summary.json").read_text())
    for table in ("loads", "energy", "collisions"):
        pd.testing.assert_frame_equal(read_parquet(killed / f"{table}.parquet"),
                                      read_parquet(whole / f"{table}.parquet"), check_exact=True)


class Planted:
    """Unpickling this would create a file: a checkpoint must never be unpickled."""

    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (open, (self.path, "w"))


def test_a_pickle_planted_as_checkpoint_runs_no_code(tmp_path):
    import pickle

    from ballmill.dem import Checkpoint

    planted = tmp_path / "checkpoint.npz"
    planted.write_bytes(pickle.dumps(Planted(str(tmp_path / "pwned"))))
    assert Checkpoint(planted, 0.1, "key").resume(None, None, "drum") == 0
    assert not (tmp_path / "pwned").exists()


def test_a_field_set_moves_every_kind_of_field_as_to_numpy_and_from_numpy_would():
    import numpy as np
    import taichi as ti

    from ballmill.dem import init_taichi
    from ballmill.dem.transfer import FieldSet

    init_taichi("cpu", "f64", 1)
    fields = {"vector": ti.Vector.field(3, float, (4, 2)), "matrix": ti.Matrix.field(2, 3, float, 5),
              "mask": ti.field(ti.u64, ()), "ids": ti.field(ti.i32, 7), "point": ti.Vector.field(3, float, ()),
              "grid": ti.field(float, (2, 3, 4))}
    rng = np.random.default_rng(1)
    values = {}
    for name, field in fields.items():
        like = field.to_numpy()
        values[name] = (rng.integers(0, 2**63, like.shape, dtype=np.uint64) if like.dtype == np.uint64 else
                        rng.integers(-9, 9, like.shape).astype(like.dtype) if like.dtype == np.int32 else
                        rng.normal(size=like.shape))
    moved = FieldSet(fields)
    moved.write(values)
    read = moved.read()
    for name, field in fields.items():
        assert np.array_equal(field.to_numpy(), values[name]), name
        assert read[name].dtype == values[name].dtype and np.array_equal(read[name], values[name]), name
