"""The `ballmill` command: `ballmill run|report|bench|track|render|calibrate ...`.

track, render and calibrate take Hydra-style `key=value` arguments: their own options (the
fields of the dataclasses below) bare, anything of the composed config (lab.*, sim.*,
interactions.*, calibrate.*) as a Hydra override.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

USAGE = """usage: ballmill COMMAND [ARGS]
  run [hydra overrides]      one scenario, or a sweep with -m / +sweep=NAME (files in sweep/)
  report SWEEP_DIR [...]     tables, figures and a Markdown report from sweep folders
  bench [options]            DEM throughput on the reference drum (see --help)
  track video=PATH [fps=2134 mm_per_px=0.2 balls=2 ball_diameter_mm=17.6 polarity=auto out=CSV]
                             ball positions and speeds from a video file or image folder
  render out=DIR [wall_restitution=0.6 wall_friction=0.3 backlit=true mm_per_px=0.2 lab.*=...]
                             simulate the MM400 conditions and film them: videos + videos.csv
  calibrate videos=DIR [out=DIR calibrate.*=... lab.*=...]
                             grid search of the ball-wall pair against tracked videos
"""


@dataclass
class TrackArgs:
    video: str = "???"
    fps: float | None = None  # capture rate; else the video's capture.json / .json sidecar
    mm_per_px: float | None = None
    balls: int = 2
    ball_diameter_mm: float = 17.6
    polarity: str = "auto"
    out: str | None = None  # default: <video>.track.csv


@dataclass
class RenderArgs:
    out: str = "outputs/lab/videos"
    wall_restitution: float = 0.6
    wall_friction: float = 0.3
    backlit: bool = True
    mm_per_px: float = 0.2
    noise_grey: float = 2.0


@dataclass
class CalibrateArgs:
    videos: str = "???"
    out: str = "outputs/lab/calibration"


def parse(schema, args: list[str]):
    """(the schema's options, the remaining Hydra overrides) from key=value arguments."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    names = {f.name for f in dataclasses.fields(schema)}
    own = [a for a in args if a.split("=", 1)[0] in names]
    try:
        opts = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(schema), OmegaConf.from_dotlist(own)))
    except OmegaConfBaseException as exc:  # names the key and the expected type
        sys.exit(f"ballmill: {exc}")
    return opts, [a for a in args if a not in own]


def compose(overrides: list[str]):
    """The project's config with Hydra overrides (sim=lab unless given), validated:
    (lab, sim, materials, interactions, calibrate)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    from .config import CalibrationConfig, MM400Config, SimConfig, material_tables, register, to_object
    from .run import ROOT

    register()
    with initialize_config_dir(str(ROOT / "conf"), version_base="1.3"):
        cfg = hydra_compose("config", ["sim=lab", *overrides])  # a later sim=... wins
    return (to_object(cfg.lab, MM400Config, "lab"), to_object(cfg.sim, SimConfig, "sim"), *material_tables(cfg),
            to_object(cfg.calibrate, CalibrationConfig, "calibrate"))


def track_cmd(args: list[str]) -> None:
    from .vision.track import TrackerSettings, track

    opts, rest = parse(TrackArgs, args)
    if rest or opts.video == "???":
        sys.exit(f"ballmill track: give video=PATH; unknown arguments {rest}" if rest else "ballmill track: give video=PATH")
    table = track(opts.video, TrackerSettings(opts.balls, opts.ball_diameter_mm, opts.polarity), opts.fps, opts.mm_per_px)
    out = Path(opts.out or f"{opts.video.rstrip('/')}.track.csv")
    table.to_csv(out, index=False)
    table.to_parquet(out.with_suffix(".parquet"), index=False)
    lost = table.groupby("ball").lost.sum().to_dict()
    print(f"{out}: {table.frame.nunique()} frames, frames with a ball lost {lost}, "
          f"mean speed {table.speed_mm_per_s.mean() / 1e3:.3f} m/s ({table.attrs['polarity']} balls)")


def render_cmd(args: list[str]) -> None:
    from .lab import conditions, simulate_mm400
    from .vision.render import Camera, render_lab_videos

    opts, rest = parse(RenderArgs, args)
    lab, sim, materials, interactions, _ = compose(rest)
    conds = conditions(lab, [opts.wall_restitution], [opts.wall_friction])
    traj, _ = simulate_mm400(lab, conds, materials, interactions, sim)
    cam = Camera(mm_per_px=opts.mm_per_px, backlit=opts.backlit, noise_grey=opts.noise_grey, seed=sim.seed)
    manifest = render_lab_videos(opts.out, lab, conds, traj, cam)
    print(f"{opts.out}: {len(manifest)} videos, manifest videos.csv")


def calibrate_cmd(args: list[str]) -> None:
    from .calibrate import calibrate, observations
    from .plots import plot_lab_validation, plot_score_surface, save_figure

    opts, rest = parse(CalibrateArgs, args)
    if opts.videos == "???":
        sys.exit("ballmill calibrate: give videos=DIR (a folder with videos.csv)")
    lab, sim, materials, interactions, grid = compose(rest)
    out = Path(opts.out)
    out.mkdir(parents=True, exist_ok=True)
    obs = observations(opts.videos, lab)
    obs.to_csv(out / "observations.csv", index=False)
    surface, simulated, best = calibrate(obs, lab, grid, materials, interactions, sim)
    surface.to_csv(out / "score_surface.csv", index=False)
    simulated.to_csv(out / "simulated.csv", index=False)
    (out / "best.json").write_text(json.dumps({**best, "overrides": rest}, indent=2))
    save_figure(plot_score_surface(surface, best), out / "score_surface")
    at_best = simulated[(simulated.wall_restitution == best["wall_restitution"])
                        & (simulated.wall_friction == best["wall_friction"])]
    save_figure(plot_lab_validation(at_best, obs), out / "validation")
    print(json.dumps(best, indent=2))


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(USAGE)
        return
    cmd, rest = sys.argv[1], sys.argv[2:]
    if cmd == "run":
        from .run import ROOT
        from .run import main as run_main

        sys.argv = [f"{sys.argv[0]} run", *rest, f"hydra.searchpath=[file://{ROOT}]"]
        run_main()
    elif cmd == "report":
        from .report import main as report_main

        report_main(rest)
    elif cmd == "bench":
        from .bench import main as bench_main

        bench_main(rest)
    elif cmd in COMMANDS:
        logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
        COMMANDS[cmd](rest)
    else:
        sys.exit(f"ballmill: unknown command {cmd!r}\n{USAGE}")


COMMANDS = {"track": track_cmd, "render": render_cmd, "calibrate": calibrate_cmd}
