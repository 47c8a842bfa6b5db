"""Partial Plug-in Gait marker sets on the shared real trials.

See docs/recordings.md#partial-marker-sets.

For each trial: ``mocap-mj identify`` with every marker, then with the lower-body set only
(16 markers), the upper-body set only (head, trunk, arms: 23) and the trunk and lower body
without the arms (25), each a run of the CLI with ``--exclude-markers`` (the file's subject
measurements kept, so that only the markers differ). Prints per run the marker RMSE, LM
iterations, time, parameters measured, kinematic parameters outside their range, the largest
left/right difference of the measured lengths, the IK ratio of the exported model
(``mocap-mj ik --model``), and the largest difference of the measured joint-centre distances
from the full-marker model's (lower limbs and pelvis for the sets with legs, arms for the
upper-body set), with the worst distance named.

Run: python benchmarks/partial_markers.py [--data ../shared/data/real] [--trials A B ...]
[--out FOLDER]
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

LOWER = "LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB RANK RHEE RTOE".split()
HEAD_TRUNK = "LFHD RFHD LBHD RBHD C7 T10 CLAV STRN RBAK".split()
ARMS = [f"{s}{m}" for s in "LR" for m in ("SHO", "UPA", "ELB", "FRM", "WRA", "WRB", "FIN")]
#: Variant -> the markers it excludes.
VARIANTS = {
    "full": [],
    "lower": HEAD_TRUNK + ARMS,
    "upper": LOWER,
    "no_arms": ARMS,
}
LEG_LENGTHS = [
    *(f"pelvis:thigh_{s}" for s in "lr"),
    *(f"thigh_{s}:shank_{s}" for s in "lr"),
    *(f"shank_{s}:foot_{s}" for s in "lr"),
    "thigh_l:thigh_r",
]
ARM_LENGTHS = [
    f"{a}:{b}"
    for s in "lr"
    for a, b in (
        ("thorax", f"clavicle_{s}"),
        (f"clavicle_{s}", f"upperarm_{s}"),
        (f"upperarm_{s}", f"ulna_{s}"),
        (f"radius_{s}", f"hand_{s}"),
    )
]
PAIRS = ("thigh_length", "shank_length", "upperarm_length", "forearm_length", "clavicle_length",
         "foot_length")  # fmt: skip
TRIALS = ("Movement_trial", "Static_trial", "Test_func_rknee")


def run(args: list[str]) -> None:
    done = subprocess.run([sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"mocap-mj {' '.join(args)} failed: {done.stderr.strip()}")


def segments(folder: Path) -> dict[str, dict[str, str]]:
    with open(folder / "segments.csv", newline="") as f:
        return {r["name"]: r for r in csv.DictReader(f)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(Path(__file__).parents[2] / "shared/data/real"))
    parser.add_argument("--trials", nargs="+", default=list(TRIALS))
    parser.add_argument("--out", default=None, help="keep the result folders here")
    args = parser.parse_args()
    root = Path(args.out or tempfile.mkdtemp(prefix="partial_markers_"))
    print(
        "trial variant | RMSE mm | iters | s | measured | outside | max L/R mm | IK ratio | "
        "max |d| vs full mm (worst) | n"
    )
    for trial in args.trials:
        c3d = Path(args.data) / f"{trial}.c3d"
        full: dict[str, dict[str, str]] = {}
        for variant, excluded in VARIANTS.items():
            out = root / f"{trial}_{variant}"
            cmd = ["identify", "--markers", str(c3d), "--out", str(out), "--force"]
            if excluded:
                cmd += ["--exclude-markers", ",".join(excluded)]
            run(cmd)
            ik_cmd = ["ik", "--model", str(out / "model.xml"), "--markers", str(c3d)]
            ik_cmd += ["--out", str(out / "ik"), "--force"]
            if excluded:
                ik_cmd += ["--exclude-markers", ",".join(excluded)]
            run(ik_cmd)
            s = json.loads((out / "summary.json").read_text())
            ik_rmse = json.loads((out / "ik" / "summary.json").read_text())["marker_rmse_mm"]
            rows = segments(out)
            if variant == "full":
                full = rows
            lr = [
                abs(float(rows[f"{p}_l"]["value_mm"]) - float(rows[f"{p}_r"]["value_mm"]))
                for p in PAIRS
                if rows[f"{p}_l"]["flag"] != "not_measured"
            ]
            compared = ARM_LENGTHS if variant == "upper" else LEG_LENGTHS
            diffs = {
                n: float(rows[n]["value_mm"]) - float(full[n]["value_mm"])
                for n in compared
                if rows[n]["flag"] != "not_measured"
            }
            worst = max(diffs, key=lambda n: abs(diffs[n])) if diffs else "-"
            worst_text = f"{diffs[worst]:+.1f} ({worst})" if diffs else "-"
            print(
                f"{trial} {variant} | {s['marker_rmse_mm']:.2f} | {s['iterations']} | "
                f"{s['seconds']:.1f} | {s['parameters_measured']} | "
                f"{len(s['kappa_outside_bounds_mm'])} | {max(lr, default=0.0):.1f} | "
                f"{ik_rmse / s['marker_rmse_mm']:.3f} | {worst_text} | {len(diffs)}",
                flush=True,
            )
    print(f"results in {root}")


if __name__ == "__main__":
    main()
