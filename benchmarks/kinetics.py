"""The kinetics of ``mocap-mj ik`` on recordings with force plates: plates per foot, the root's
residual force RMS over stance (per cent of body weight and of the peak ground reaction), the
residual moment RMS and the time of the inverse dynamics.

    python benchmarks/kinetics.py [--model MJCF] [--qualisys-mass KG]

Runs ``mocap-mj ik --markers FILE --out TMP`` (the bundled humanoid unless --model) on the
shared Movement_trial.c3d (its PROCESSING:Bodymass, 85 kg) and Qualisys.c3d, which records no
mass: ``--qualisys-mass`` gives it, written into a copy's PROCESSING:Bodymass (default 75
kg, an assumption: the residual in per cent of body weight scales with it, the one in per
cent of the peak ground reaction does not), and prints summary.json's ``kinetics`` figures.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import ezc3d

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
FILES = {
    "Movement_trial": DATA / "real" / "Movement_trial.c3d",
    "Qualisys": DATA / "vendors" / "Qualisys.c3d",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="MJCF model for ik (default: the bundled humanoid)")
    parser.add_argument("--qualisys-mass", type=float, default=75.0, metavar="KG")
    args = parser.parse_args()
    for name, path in FILES.items():
        if not path.is_file():
            print(f"{name}: {path} absent, skipped")
            continue
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "r"
            cmd = [
                sys.executable,
                "-m",
                "mocap_mj",
                "ik",
                "--markers",
                str(path),
                "--out",
                str(out),
            ]
            if args.model:
                cmd += ["--model", args.model]
            if name == "Qualisys":  # a copy with the assumed mass as PROCESSING:Bodymass
                c3d = ezc3d.c3d(str(path))
                c3d.add_parameter("PROCESSING", "Bodymass", [args.qualisys_mass])
                copy = Path(tmp) / path.name
                c3d.write(str(copy))
                cmd[cmd.index(str(path))] = str(copy)
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                print(f"{name}: ik failed: {proc.stderr.strip().splitlines()[-1:]}")
                continue
            summary = json.loads((out / "summary.json").read_text())
        trials = summary["kinetics"]["trials"]
        if not trials:
            print(f"{name}: no kinetics ({summary['kinetics']['refused']})")
            continue
        e = trials[0]
        feet = "; ".join(f"{s}: {', '.join(p) or 'none'}" for s, p in e["plates_per_foot"].items())
        print(
            f"{name} ({e['body_mass_kg']:g} kg, marker RMSE {summary['marker_rmse_mm']:.1f} mm): "
            f"plates {feet}; residual force RMS over {e['stance_frames']} stance frames "
            f"{e['residual_force_rms_pct_bw']:.1f} % BW, {e['residual_force_rms_pct_peak_grf']:.1f}"
            f" % peak GRF; residual moment RMS {e['residual_moment_rms_nm']:.1f} N m; inverse "
            f"dynamics {e['inverse_dynamics_seconds'] * 1e3:.0f} ms for {summary['frames']} frames"
        )
        for reason in e["excluded_contacts"]:
            print(f"  excluded contact: {reason}")


if __name__ == "__main__":
    main()
