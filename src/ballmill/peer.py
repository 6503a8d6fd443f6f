"""The bench drum written for LIGGGHTS 3.8 (Debian package `liggghts`), run right after our
engine on the same machine, so that the speed ratio is measured, not remembered.

Same balls, positions, materials, contact model (Hertz, tangential history, EDEM type-A
rolling friction as `cdt`), time step, settling time and rotation; the drum is the faceted
STL of `drum_mesh` (LIGGGHTS turns walls only as meshes), with 128 facets.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from .config import ConfigError, DrumConfig, InteractionConfig, MaterialConfig
from .dem import SystemSpec
from .drum import drum_mesh, drum_speed_rpm

INPUT = """\
atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
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
fix drum all mesh/surface/stress file drum.stl type 1
fix walls all wall/gran model hertz tangential history rolling_friction cdt mesh n_meshes 1 meshes drum
fix integr all nve/sphere
thermo 100000
run {settle_steps}
fix spin all move/mesh mesh drum rotate origin 0. 0. 0. axis 0. 1. 0. period {period_s}
run {rotate_steps}
"""


def write_case(folder: Path, spec: SystemSpec, drum: DrumConfig, material: MaterialConfig, pair: InteractionConfig,
               dt_s: float, settle_s: float, rotate_s: float, skin_m: float) -> None:
    """balls.data, drum.stl and in.drum for LIGGGHTS in `folder`."""
    lo, hi = spec.domain_lo_m, spec.domain_hi_m
    rows = "\n".join(f"{k + 1} 1 {2 * r:.9g} {material.density_kg_per_m3:.9g} {x:.9g} {y:.9g} {z:.9g}"
                     for k, (r, (x, y, z)) in enumerate(zip(spec.radius_m, spec.position_m)))
    (folder / "balls.data").write_text(
        f"ballmill bench drum\n\n{spec.n_particles} atoms\n1 atom types\n\n"
        f"{lo[0]} {hi[0]} xlo xhi\n{lo[1]} {hi[1]} ylo yhi\n{lo[2]} {hi[2]} zlo zhi\n\nAtoms\n\n{rows}\n")
    import trimesh

    mesh = drum_mesh(drum)
    trimesh.Trimesh(mesh.vertices_m, mesh.faces).export(folder / "drum.stl", file_type="stl_ascii")
    youngs = 2 * material.shear_modulus_pa * (1 + material.poisson_ratio)
    (folder / "in.drum").write_text(INPUT.format(
        skin_m=skin_m, youngs_pa=youngs, poisson=material.poisson_ratio, restitution=pair.restitution,
        friction=pair.static_friction, rolling=pair.rolling_friction, dt_s=dt_s,
        settle_steps=round(settle_s / dt_s), rotate_steps=round(rotate_s / dt_s),
        period_s=60.0 / drum_speed_rpm(drum)))


def run_liggghts(folder: Path, ranks: int) -> float:
    """Particle-steps per second of the timed (rotation) run, from LIGGGHTS' own loop time."""
    cmd = ["liggghts", "-in", "in.drum", "-log", "none"]
    if ranks > 1:
        cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks), *cmd]
    proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, check=False)
    out = proc.stdout
    if proc.returncode:
        raise RuntimeError(f"LIGGGHTS failed ({' '.join(cmd)}):\n{(out + proc.stderr)[-2000:]}")
    loops = re.findall(r"Loop time of ([\d.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", out)
    if len(loops) < 2:
        raise RuntimeError(f"LIGGGHTS printed no timing for the rotation run:\n{out[-2000:]}")
    seconds, steps, atoms = loops[-1]
    return int(atoms) * int(steps) / float(seconds)


def require_liggghts() -> None:
    if shutil.which("liggghts") is None:
        raise ConfigError("peer=liggghts needs LIGGGHTS on the PATH (Debian: apt-get install liggghts)")


def liggghts_rates(spec: SystemSpec, drum: DrumConfig, material: MaterialConfig, pair: InteractionConfig,
                   dt_s: float, settle_s: float, rotate_s: float, skin_m: float, ranks=(1, 2)) -> dict:
    """{'liggghts_1_ranks': particle-steps/s, ...} for the same drum."""
    require_liggghts()
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        write_case(Path(tmp), spec, drum, material, pair, dt_s, settle_s, rotate_s, skin_m)
        for n in ranks:
            out[f"liggghts_{n}_ranks"] = run_liggghts(Path(tmp), n)
    return out

