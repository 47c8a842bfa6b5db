"""How long ``mocap-mj COMMAND --help`` takes, for every command, in a fresh process each time.

The command line's flags live apart from the commands' work (mocap_mj/commands/parsers.py), so
that ``--help`` (and a refused flag) answers before NumPy, MuJoCo or numba would load; the
target is 0.3 s. Each command's help runs ``--runs`` times as ``PYTHON -m mocap_mj COMMAND
--help``; the script prints, per command, the median wall time and the median CPU time (user +
system) of the process, and the same for ``PYTHON -c pass`` (the interpreter's own start). On
a shared machine the CPU time is the steadier figure: the wall time grows with the other load.

Run: python benchmarks/cli_help.py [--runs 5] [--python PATH]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time

#: Every command of a full install (the add-ons' included), and the top-level help ("").
COMMANDS = ("", "info", "ik", "identify", "score", "export", "batch", "plug-in-gait", "gait-report",
            "marker-sets", "demo", "experiment", "synth", "view", "render")  # fmt: skip
TARGET_S = 0.3


def _timed(argv: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of one run of ``argv`` (its output discarded)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _median(argv: list[str], runs: int) -> tuple[float, float]:
    times = [_timed(argv) for _ in range(runs)]
    return statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="runs per command (default: 5)")
    ap.add_argument("--python", default=sys.executable, help="interpreter (default: this one)")
    args = ap.parse_args()
    wall, cpu = _median([args.python, "-c", "pass"], args.runs)
    print(f"{'python -c pass':<24} wall {wall:6.3f} s   cpu {cpu:6.3f} s")
    worst = 0.0
    for command in COMMANDS:
        argv = [args.python, "-m", "mocap_mj", *([command] if command else []), "--help"]
        wall, cpu = _median(argv, args.runs)
        worst = max(worst, cpu)
        label = f"mocap-mj {command} --help".replace("  ", " ")
        print(f"{label:<24} wall {wall:6.3f} s   cpu {cpu:6.3f} s")
    print(f"slowest --help: {worst:.3f} s of CPU (target {TARGET_S} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
