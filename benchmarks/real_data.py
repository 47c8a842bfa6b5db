"""The real-data skeleton check of docs/validation.md#real-recordings: identify and export on
the shared Plug-in Gait trials, then the agreement figures.

    python benchmarks/real_data.py --out DIR [--shared ../shared/data]

Runs, as a user would (``mocap-mj`` in this Python): ``identify`` and ``ik --model`` (the
exported model on its own trial) on each of the five trials of ``real/``; ``identify`` on
Movement+Static and on the three biobuddy trials together; ``identify`` and ``ik --model``
on ``vendors/Qualisys.c3d``. Then prints :mod:`benchmarks.anatomy`'s lines for every
folder (ranges, bounds, left/right, widths), the cross-trial joint-centre distances of one
subject's single-trial models, the ``ik --model`` / ``identify`` RMSE ratios and the joints
held at a limit. Everything is written under ``--out``; the shared files are only read.
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import time
from pathlib import Path

from anatomy import pair_line, report, result_pset

from mocap_mj.anatomy.plausibility import limits_text

TRIALS = ["Test_func_rknee", "anatomical_posture", "Test_func_rhip", "Movement_trial",
          "Static_trial"]  # fmt: skip
GROUPS = {"move+static": ["Movement_trial", "Static_trial"],
          "bio3": ["Test_func_rknee", "Test_func_rhip", "anatomical_posture"]}  # fmt: skip


def _run(*argv: str) -> dict:
    """``mocap-mj ARGV --json --force`` in this Python; its JSON summary (exit on failure)."""
    cmd = [sys.executable, "-m", "mocap_mj", *argv, "--json", "--force"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv[:3])}...: {done.stderr.strip().splitlines()[-1]}")
    return json.loads(done.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="scratch folder for the results")
    ap.add_argument("--shared", type=Path, default=Path("../shared/data"),
                    help="the shared data folder (default ../shared/data)")  # fmt: skip
    args = ap.parse_args()
    real, out = args.shared / "real", args.out
    missing = [t for t in TRIALS if not (real / f"{t}.c3d").is_file()]
    if missing:
        raise SystemExit(f"{real}: missing {', '.join(missing)} (.c3d)")
    t0 = time.perf_counter()
    runs: dict[str, tuple[dict, dict | None]] = {}
    files = {t: str(real / f"{t}.c3d") for t in TRIALS}
    files["qualisys"] = str(args.shared / "vendors" / "Qualisys.c3d")
    for name, path in files.items():
        ident = _run("identify", "--markers", path, "--out", str(out / name))
        ik = _run("ik", "--markers", path, "--model", str(out / name / "model.xml"),
                  "--out", str(out / f"{name}-ik"))  # fmt: skip
        runs[name] = (ident, ik)
    for name, group in GROUPS.items():
        ident = _run("identify", "--markers", *[files[t] for t in group], "--out", str(out / name))
        runs[name] = (ident, None)
    for name in runs:
        print(report(out / name, result_pset(out / name, out)))
    for group in GROUPS.values():
        for a, b in itertools.combinations(group, 2):
            print(pair_line(out / a, out / b, result_pset(out / a, out)))
    for name, (ident, tracked) in runs.items():
        ratio = "" if tracked is None else (
            f", ik --model {tracked['marker_rmse_mm']:.4f} mm, ratio "
            f"{tracked['marker_rmse_mm'] / ident['marker_rmse_mm']:.4f}")  # fmt: skip
        held = limits_text(ident.get("joints_at_limit") or {}) or "none"
        print(f"{name}: identify {ident['marker_rmse_mm']:.4f} mm{ratio}; joints held at a "
              f"limit: {held}")  # fmt: skip
    print(f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
