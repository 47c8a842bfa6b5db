"""Real-data skeleton checks of identified models (issue #14 targets); prints figures.

    python benchmarks/anatomy.py OUT_DIR [OUT_DIR ...] [--pair A B ...]

For every ``mocap-mj identify`` result folder: marker RMSE, kinematic parameters at or
outside their anatomical range (:mod:`mocap_mj.identify.ranges`, with the measurements the
run used), left/right differences of the paired segment lengths, and, where the run had the
joint widths, the median over frames of the distance from the knee, ankle, elbow and wrist
centres to their lateral marker (KNE, ANK, ELB, WRA) against width/2 + marker radius. With
``--pair A B`` (folder names, repeatable as A B C for all pairs): the largest difference
of the joint-centre distances (:func:`mocap_mj.identify.consistency.joint_centre_lengths`)
between the models.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from mocap_mj.identify.consistency import joint_centre_lengths
from mocap_mj.identify.ranges import kappa_ranges
from mocap_mj.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories
from mocap_mj.parameters import ParameterSet
from mocap_mj.results import load_motion
from mocap_mj.subject import Measurement, Subject

PAIRED = ("thigh", "shank", "upperarm", "forearm", "clavicle", "foot")
#: (joint centre, lateral marker, width measurement), per side.
WIDTH_CHECKS = (("knee", "KNE", "knee_width"), ("ankle", "ANK", "ankle_width"),
                ("elbow", "ELB", "elbow_width"), ("wrist", "WRA", "wrist_width"))  # fmt: skip


def check(folder: Path, pset: ParameterSet) -> dict[str, object]:
    summary = json.loads((folder / "summary.json").read_text())
    theta = pset.load_json(folder / "theta.json")
    subject = Subject(
        {
            n: Measurement(v["value"], v["source"])
            for n, v in summary.get("measurements", {}).items()
        }
    )
    kappa = theta[: pset.n_kappa]
    lo, hi = kappa_ranges(pset, subject)
    out: dict[str, object] = {"rmse_mm": summary["marker_rmse_mm"]}
    out["outside"] = [n for n, k, a, b in zip(pset.kappa_names, kappa, lo, hi, strict=True)
                      if k < a - 1e-9 or k > b + 1e-9]  # fmt: skip
    out["at_bound"] = summary.get("kappa_at_bound", {})
    lr = {}
    for seg in PAIRED:
        name = f"{seg}_length"
        lr[seg] = abs(kappa[pset.index(name + "_l")] - kappa[pset.index(name + "_r")]) * 1e3
    out["lr_mm"] = lr
    widths = {}
    motion = load_motion(folder / "motion.npz")
    model = pset.model_for(theta)
    jc = joint_centre_trajectories(model, motion.qpos)
    for side, p in (("l", "L"), ("r", "R")):
        for joint, marker, width in WIDTH_CHECKS:
            w = subject.get(f"{width}_{side}")
            if w is None:
                continue
            j = JOINT_CENTRE_NAMES.index(f"{joint}_{side}")
            m = motion.markers[:, motion.marker_names.index(p + marker)]
            if marker == "WRA":  # Plug-in Gait: from the WRA-WRB midpoint
                m = 0.5 * (m + motion.markers[:, motion.marker_names.index(p + "WRB")])
            d = np.nanmedian(np.linalg.norm(jc[:, j] - m, axis=1))
            widths[f"{joint}_{side}"] = (d - (w / 2 + subject.marker_radius)) * 1e3
    out["width_error_mm"] = widths
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--pair", nargs="+", action="append", default=[], metavar="FOLDER")
    args = ap.parse_args()
    pset = ParameterSet()
    for f in args.folders:
        r = check(f, pset)
        lr = r["lr_mm"]
        assert isinstance(lr, dict)
        wid = r["width_error_mm"]
        assert isinstance(wid, dict)
        print(f"{f.name}: RMSE {r['rmse_mm']:.2f} mm; outside range: {r['outside'] or 'none'}; "
              f"at bound: {r['at_bound'] or 'none'}")  # fmt: skip
        print("  L/R |diff| mm: " + ", ".join(f"{k} {v:.1f}" for k, v in lr.items())
              + f"  (max {max(lr.values()):.1f})")  # fmt: skip
        if wid:
            print("  centre-to-lateral-marker minus (width/2 + r), median over frames, mm: "
                  + ", ".join(f"{k} {v:+.1f}" for k, v in wid.items())
                  + f"  (max |.| {max(abs(v) for v in wid.values()):.1f})")  # fmt: skip
    for group in args.pair:
        for a, b in itertools.combinations(group, 2):
            la = joint_centre_lengths(pset, pset.load_json(Path(a) / "theta.json"))
            lb = joint_centre_lengths(pset, pset.load_json(Path(b) / "theta.json"))
            diff = {n: abs(la[n] - lb[n]) * 1e3 for n in la}
            worst = sorted(diff.items(), key=lambda kv: -kv[1])[:4]
            print(f"{Path(a).name} vs {Path(b).name}: max joint-centre distance difference "
                  f"{worst[0][1]:.1f} mm; worst: "
                  + ", ".join(f"{n} {v:.1f}" for n, v in worst))  # fmt: skip


if __name__ == "__main__":
    main()
