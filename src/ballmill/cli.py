"""The `ballmill` command: `ballmill run|report|bench ...`."""

from __future__ import annotations

import sys

USAGE = """usage: ballmill COMMAND [ARGS]
  run [hydra overrides]      one scenario, or a sweep with -m / +sweep=NAME (files in sweep/)
  report SWEEP_DIR [...]     tables, figures and a Markdown report from sweep folders
  bench [options]            DEM throughput on the reference drum (see --help)
"""


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(USAGE)
        return
    cmd, rest = sys.argv[1], sys.argv[2:]
    if cmd == "run":
        from .run import ROOT, main as run_main

        sys.argv = [f"{sys.argv[0]} run", *rest, f"hydra.searchpath=[file://{ROOT}]"]
        run_main()
    elif cmd == "report":
        from .report import main as report_main

        report_main(rest)
    elif cmd == "bench":
        from .bench import main as bench_main

        bench_main(rest)
    else:
        sys.exit(f"ballmill: unknown command {cmd!r}\n{USAGE}")
