"""The bench drum written for the peers, LIGGGHTS 3.8 (Debian `liggghts`) and LAMMPS (Debian
`lammps`, GRANULAR package), run right after our engine on the same machine, so that the speed
ratio is measured, not remembered.

Same balls, positions, materials, time step, settling time and rotation, and the same skin as
ours; each peer set up as its users set up a drum: the domain split along the drum's axis
(`processors 1 * 1`: every rank holds a slice of the bed), `neigh_modify delay 0`, bins,
ghost velocities communicated, and the timing of the rotation run alone (its "Loop time").
LIGGGHTS: Hertz, tangential history, EDEM type-A rolling friction (`cdt`); the drum is the
faceted STL of `drum_mesh` (LIGGGHTS turns walls only as meshes), with 128 facets, a long
drum's cut along its axis (`LIGGGHTS_MAX_ASPECT`).
LAMMPS: `pair_style granular` hertz/material, damping tsuji (the restitution coefficient given;
Debian's 2021 LAMMPS predates `coeff_restitution`), tangential mindlin,
rolling sds (a spring-dashpot-slider, its slider at the same coefficient: the nearest to type A
that LAMMPS has); the drum is an analytic cylinder region turned by `fix wall/gran/region`.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from .config import ConfigError, DrumConfig, InteractionConfig, MaterialConfig
from .dem import SystemSpec
from .drum import drum_mesh, drum_speed_rpm
from .liner import liner_mesh

INPUT = """\
atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
processors 1 * 1
units si
hard_particles yes
read_data balls.data
neighbor {skin_m} bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype {youngs_pa}
fix m2 all property/global poissonsRatio peratomtype {poisson}
fix m3 all property/global coefficientRestitution peratomtypepair 1 {restitution}
fix m4 all property/global coefficientFriction peratomtypepair 1 {friction}
fix m5 all property/global coefficientRollingFriction peratomtypepair 1 {rolling}
pair_style gran model hertz tangential history rolling_friction cdt
pair_coeff * *
timestep {dt_s}
fix gravi all gravity 9.81 vector 0.0 0.0 -1.0
fix drum all mesh/surface/stress file drum.stl type 1 reference_point 0. 0. 0.
fix walls all wall/gran model hertz tangential history rolling_friction cdt mesh n_meshes 1 meshes drum
fix integr all nve/sphere
thermo 100000
run {settle_steps}
fix spin all move/mesh mesh drum rotate origin 0. 0. 0. axis 0. 1. 0. period {period_s}
{torque_output}run {rotate_steps}
"""
# LIGGGHTS refuses a mesh facet whose smallest angle is under its `curvature` (0.256 deg: a
# facet 224 times longer than wide, a long drum's) and warns under 0.5 deg (115 times) that a
# moving mesh will not parallelize well: a long drum's shell is cut along its axis
LIGGGHTS_MAX_ASPECT = 100.0
# the drum's torque about its axis (N m) every `every` steps into torque.txt
TORQUE_OUTPUT = """variable ty equal f_drum[5]
fix tq all ave/time 1 {every} {every} v_ty file torque.txt
"""


def write_data(folder: Path, spec: SystemSpec, material: MaterialConfig) -> None:
    """balls.data: id, type, diameter, density, position (both peers read this format)."""
    lo, hi = spec.domain_lo_m, spec.domain_hi_m
    rows = "\n".join(f"{k + 1} 1 {2 * r:.9g} {material.density_kg_per_m3:.9g} {x:.9g} {y:.9g} {z:.9g}"
                     for k, (r, (x, y, z)) in enumerate(zip(spec.radius_m, spec.position_m)))
    (folder / "balls.data").write_text(
        f"ballmill bench drum\n\n{spec.n_particles} atoms\n1 atom types\n\n"
        f"{lo[0]} {hi[0]} xlo xhi\n{lo[1]} {hi[1]} ylo yhi\n{lo[2]} {hi[2]} zlo zhi\n\nAtoms\n\n{rows}\n")


def write_case(folder: Path, spec: SystemSpec, drum: DrumConfig, material: MaterialConfig, pair: InteractionConfig,
               dt_s: float, settle_s: float, rotate_s: float, skin_m: float, torque_every: int = 0) -> None:
    """balls.data, drum.stl (the whole drum, lifters and ends, as one mesh) and in.drum for
    LIGGGHTS in `folder`; with torque_every, the drum's torque every that many steps."""
    write_data(folder, spec, material)
    import trimesh

    mesh = drum_mesh(drum, LIGGGHTS_MAX_ASPECT) if drum.liner.kind == "smooth" else liner_mesh(drum, closed=True)
    trimesh.Trimesh(mesh.vertices_m, mesh.faces).export(folder / "drum.stl", file_type="stl_ascii")
    youngs = 2 * material.shear_modulus_pa * (1 + material.poisson_ratio)
    (folder / "in.drum").write_text(INPUT.format(
        skin_m=skin_m, youngs_pa=youngs, poisson=material.poisson_ratio, restitution=pair.restitution,
        friction=pair.static_friction, rolling=pair.rolling_friction, dt_s=dt_s,
        settle_steps=round(settle_s / dt_s), rotate_steps=round(rotate_s / dt_s),
        period_s=60.0 / drum_speed_rpm(drum),
        torque_output=TORQUE_OUTPUT.format(every=torque_every) if torque_every else ""))


def liggghts_torque(spec: SystemSpec, drum: DrumConfig, material: MaterialConfig, pair: InteractionConfig,
                    dt_s: float, settle_s: float, rotate_s: float, skin_m: float, every: int, ranks: int = 2):
    """The same drum run by LIGGGHTS: its torque about the axis (t_s, torque_axis_nm) while turning."""
    import numpy as np
    import pandas as pd

    require_peers(("liggghts",))
    with tempfile.TemporaryDirectory() as tmp:
        write_case(Path(tmp), spec, drum, material, pair, dt_s, settle_s, rotate_s, skin_m, every)
        run_peer("liggghts", Path(tmp), ranks)
        steps, torque = np.loadtxt(Path(tmp) / "torque.txt", comments="#", unpack=True)
    return pd.DataFrame({"t_s": steps * dt_s, "torque_axis_nm": torque})


LAMMPS_INPUT = """\
units si
atom_style sphere
atom_modify map array
boundary f f f
newton off
comm_modify vel yes
processors 1 * 1
read_data balls.data
neighbor {skin_m} bin
neigh_modify delay 0
variable contact string "hertz/material {youngs_pa} {restitution} {poisson} damping tsuji &
  tangential mindlin NULL 1.0 {friction} rolling sds {rolling_stiffness} 0.0 {rolling} twisting none"
pair_style granular
pair_coeff * * ${{contact}}
timestep {dt_s}
fix gravi all gravity 9.81 vector 0.0 0.0 -1.0
variable theta equal {omega}*(time>{settle_s})*(time-{settle_s})
region drum cylinder y 0.0 0.0 {radius_m} {y_lo} {y_hi} side in rotate v_theta 0 0 0 0 1 0
fix walls all wall/gran/region granular ${{contact}} region drum
fix integr all nve/sphere
thermo 100000
run {settle_steps}
run {rotate_steps}
"""


def write_lammps_case(folder: Path, spec: SystemSpec, drum: DrumConfig, material: MaterialConfig,
                      pair: InteractionConfig, dt_s: float, settle_s: float, rotate_s: float, skin_m: float) -> None:
    """balls.data and in.drum for LAMMPS in `folder` (the drum an analytic rotating cylinder)."""
    write_data(folder, spec, material)
    youngs = 2 * material.shear_modulus_pa * (1 + material.poisson_ratio)
    half = drum.inner_length_m / 2
    (folder / "in.drum").write_text(LAMMPS_INPUT.format(
        skin_m=skin_m, youngs_pa=youngs, poisson=material.poisson_ratio, restitution=pair.restitution,
        friction=pair.static_friction, rolling=pair.rolling_friction,
        rolling_stiffness=youngs * float(spec.radius_m.max()), dt_s=dt_s, settle_s=settle_s,
        omega=drum_speed_rpm(drum) * 2 * math.pi / 60, radius_m=drum.inner_diameter_m / 2, y_lo=-half, y_hi=half,
        settle_steps=round(settle_s / dt_s), rotate_steps=round(rotate_s / dt_s)))


PEERS = {"liggghts": ("liggghts", write_case), "lammps": ("lmp", write_lammps_case)}


def run_peer(binary: str, folder: Path, ranks: int) -> float:
    """Particle-steps per second of the timed (rotation) run, from the peer's own loop time."""
    cmd = ["stdbuf", "-oL", binary, "-in", "in.drum", "-log", "none"]  # an error's line is not lost at MPI_Abort
    if ranks > 1:
        cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks), *cmd]
    proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, check=False)
    out = proc.stdout
    if proc.returncode:
        raise RuntimeError(f"{binary} failed ({' '.join(cmd)}):\n{(out + proc.stderr)[-2000:]}")
    loops = re.findall(r"Loop time of ([\d.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", out)
    if len(loops) < 2:
        raise RuntimeError(f"{binary} printed no timing for the rotation run:\n{out[-2000:]}")
    seconds, steps, atoms = loops[-1]
    return int(atoms) * int(steps) / float(seconds)


def require_peers(peers: tuple[str, ...]) -> None:
    for name in peers:
        if shutil.which(PEERS[name][0]) is None:
            raise ConfigError(f"peer={name} needs `{PEERS[name][0]}` on the PATH (Debian: apt-get install {name})")


def peer_rates(peers: tuple[str, ...], spec: SystemSpec, drum: DrumConfig, material: MaterialConfig,
               pair: InteractionConfig, dt_s: float, settle_s: float, rotate_s: float, skin_m: float,
               ranks=(1, 2)) -> dict:
    """{'<peer>_<n>_ranks': particle-steps/s, ...} for the same drum."""
    require_peers(peers)
    out = {}
    for name in peers:
        binary, write = PEERS[name]
        with tempfile.TemporaryDirectory() as tmp:
            write(Path(tmp), spec, drum, material, pair, dt_s, settle_s, rotate_s, skin_m)
            for n in ranks:
                out[f"{name}_{n}_ranks"] = run_peer(binary, Path(tmp), n)
    return out

