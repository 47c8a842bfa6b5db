"""The kinetics of ``mocap-mj ik`` on recordings with force plates: plates per foot, the root's
residual force RMS over stance (per cent of body weight and of the peak ground reaction), the
residual moment RMS and the time of the inverse dynamics.

    python benchmarks/kinetics.py [--model MJCF] [--qualisys-mass KG] [--fit]

Runs ``mocap-mj ik --markers FILE --out TMP`` (the bundled humanoid unless --model) on the
shared Movement_trial.c3d (its PROCESSING:Bodymass, 85 kg) and Qualisys.c3d, which records no
mass: ``--qualisys-mass`` gives it, written into a copy's PROCESSING:Bodymass (default 75
kg, an assumption: the residual in per cent of body weight scales with it, the one in per
cent of the peak ground reaction does not), and prints summary.json's ``kinetics`` figures.
``--fit`` also runs ``mocap-mj identify --markers FILE [STATIC] --recipe R`` with
``inertia: fit`` in R (STATIC: the Static_trial.c3d beside the file, when there is one) and
prints summary.json's ``inertia`` residuals: the identified model's root residual over the
stance frames with de Leva's masses (before) and with the fitted ones (after).
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


def fitted(name: str, path: Path, tmp: Path) -> None:
    """identify ``path`` with ``inertia: fit`` into ``tmp``; its residuals before and after."""
    recipe = tmp / "fit.yaml"
    recipe.write_text("inertia: fit\n")
    static = path.with_name("Static_trial.c3d")
    cmd = [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(path)]
    cmd += [str(static)] if static.is_file() else []
    out = tmp / "id"
    proc = subprocess.run([*cmd, "--recipe", str(recipe), "--out", str(out)],
                          capture_output=True, text=True)  # fmt: skip
    if proc.returncode != 0:
        print(f"{name}: identify failed: {proc.stderr.strip().splitlines()[-1:]}")
        return
    summary = json.loads((out / "summary.json").read_text())
    section = summary["inertia"]
    if section["source"] != "fit":
        print(f"{name}: identify, no fit: {section['note']}")
        return
    figures = [section["residuals"]["pooled"][k] for k in ("before", "after")]
    print(
        f"{name} identify (marker RMSE {summary['marker_rmse_mm']:.1f} mm), "
        f"{section['stance_frames']} stance frames: residual force RMS "
        + "; ".join(
            f"{label} the fit {r['force_rms_pct_bw']:.1f} % BW, {r['force_rms_pct_peak_grf']:.1f}"
            f" % peak GRF, moment {r['moment_rms_nm']:.1f} N m"
            for label, r in zip(("before", "after"), figures, strict=True)
        )
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="MJCF model for ik (default: the bundled humanoid)")
    parser.add_argument("--qualisys-mass", type=float, default=75.0, metavar="KG")
    parser.add_argument("--fit", action="store_true", help="also identify with inertia: fit")
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
            if args.fit:
                fitted(name, Path(cmd[cmd.index("--markers") + 1]), Path(tmp))
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
