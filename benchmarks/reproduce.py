"""Does the exported model reproduce the fit? ``identify``, then ``ik --model`` on the same trial.

For every trial: ``mocap-mj identify --markers T --out DIR/T [flags]`` and
``mocap-mj ik --markers T --model DIR/T/model.xml --out DIR/T-ik [--loss]``, each as a fresh
process, exactly as a user runs them; prints the identify RMSE, its LM iterations and seconds,
the IK RMSE and their ratio (target: within 2 %).

Run: python benchmarks/reproduce.py [TRIAL.c3d ...] [--robust] [--ik-loss l2|huber|cauchy]
     [--out DIR] [--json F]
(default trials: the five of ../shared/data/real). ``--robust`` passes ``--loss cauchy`` to
identify; the IK uses ``--ik-loss`` (default: the identification's loss).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
TRIALS = ("Movement_trial", "Static_trial", "Test_func_rknee", "Test_func_rhip",
          "anatomical_posture")  # fmt: skip


def cli(*args: str) -> dict[str, Any]:
    out = subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args, "--json", "--force"],
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        raise SystemExit(f"mocap-mj {args[0]} failed: {out.stderr.strip()}")
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trials", nargs="*", help="marker files (default: the shared real trials)")
    p.add_argument("--robust", action="store_true", help="identify with --loss cauchy")
    p.add_argument("--ik-loss", choices=["l2", "huber", "cauchy"], help="loss of the IK")
    p.add_argument("--out", help="result folders (default: a temporary folder)")
    p.add_argument("--json", help="write the rows as JSON here")
    args = p.parse_args()
    paths = [Path(t) for t in args.trials] or [REAL / f"{t}.c3d" for t in TRIALS]
    loss = args.ik_loss or ("cauchy" if args.robust else "l2")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.out or tmp)
        print("| trial | identify RMSE (mm) | LM iterations | LM s | ik RMSE (mm) | ratio |")
        print("|---|---:|---:|---:|---:|---:|")
        for path in paths:
            res = root / path.stem
            flags = ["--loss", "cauchy"] if args.robust else []
            fit = cli("identify", "--markers", str(path), "--out", str(res), *flags)
            ik = cli("ik", "--markers", str(path), "--model", str(res / "model.xml"),
                     "--out", str(root / f"{path.stem}-ik"), "--loss", loss)  # fmt: skip
            row = {
                "trial": path.stem,
                "identify_rmse_mm": fit["marker_rmse_mm"],
                "iterations": fit["iterations"],
                "seconds": fit["seconds"],
                "ik_rmse_mm": ik["marker_rmse_mm"],
                "ratio": ik["marker_rmse_mm"] / fit["marker_rmse_mm"],
            }
            rows.append(row)
            print(f"| {row['trial']} | {row['identify_rmse_mm']:.4f} | {row['iterations']} | "
                  f"{row['seconds']:.1f} | {row['ik_rmse_mm']:.4f} | {row['ratio']:.4f} |",
                  flush=True)  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
