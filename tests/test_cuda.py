"""The CUDA backend against the CPU's: the same drum, settling then turning, on both, in double
precision.  Float sums run in another order on the GPU, so the two agree to round-off, not
bit for bit, and a granular bed amplifies round-off: the comparison is over the first 2,000
steps, where it is still far below a ball's size.  Runs where Taichi finds a CUDA device."""

import numpy as np
import pytest
import taichi as ti
from taichi.lang.misc import is_arch_supported

from ballmill.config import DrumConfig, InteractionConfig, MaterialConfig, SimConfig
from ballmill.dem import Engine, EngineOptions, init_taichi
from ballmill.drum import drum_spec
from ballmill.scenario import time_step_s

pytestmark = pytest.mark.skipif(not is_arch_supported(ti.cuda), reason="no CUDA device")

DRUM = DrumConfig(inner_diameter_m=0.3, inner_length_m=0.1, ball_radius_m=0.01)  # 304 balls
SIM = SimConfig(shear_modulus_scale=1e-2, settle_s=0.02)  # dt 2.2e-5 s: the drum turns after 900 steps


def kinematics(arch: str, steps: int) -> tuple[np.ndarray, np.ndarray, int]:
    spec = drum_spec(DRUM, {"steel": MaterialConfig()}, {"steel-steel": InteractionConfig(0.5, 0.5, 0.01)}, SIM)
    init_taichi(arch, "f64")
    engine = Engine(spec, EngineOptions(dt_s=time_step_s(spec, SIM)))
    engine.advance(steps)
    x, v, _ = engine.kinematics()
    return x, v, engine.nl.contact_pairs()


def test_cuda_and_cpu_agree_to_round_off_over_2000_steps():
    x_cpu, v_cpu, pairs_cpu = kinematics("cpu", 2000)
    x_gpu, v_gpu, pairs_gpu = kinematics("cuda", 2000)
    dx, dv = np.abs(x_gpu - x_cpu).max(), np.abs(v_gpu - v_cpu).max()
    print(f"CPU vs CUDA after 2000 steps: |dx| <= {dx:.3g} m, |dv| <= {dv:.3g} m/s")
    assert dx < 1e-9  # m: a ball is 1e-2 m
    assert dv < 1e-6  # m/s
    assert pairs_gpu == pairs_cpu
