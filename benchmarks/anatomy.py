"""Real-data skeleton checks of identified models; prints figures.

See docs/validation.md#real-recordings.

    python benchmarks/anatomy.py OUT_DIR [OUT_DIR ...] [--pair A B [C ...]]

For every ``mocap-mj identify`` result folder: marker RMSE, kinematic parameters outside
their anatomical range (:mod:`mocap_mj.anatomy.ranges`, with the measurements the run used)
or held at a bound, left/right differences of the paired segment lengths and, where the run
had the joint widths, the median over frames of the distance from the knee, ankle, elbow and
wrist centres to their lateral marker minus width/2 + marker radius
(:mod:`mocap_mj.anatomy.plausibility`). With ``--pair A B ...``: the largest difference
of the joint-centre distances (:func:`mocap_mj.solve.consistency.joint_centre_lengths`)
between every two of the models.
"""

from __future__ import annotations

import argparse
import itertools
import json
import tempfile
from pathlib import Path

from mocap_mj.anatomy.plausibility import kappa_outside_bounds, left_right_differences, width_errors
from mocap_mj.anatomy.ranges import kappa_ranges
from mocap_mj.capture.marker_set import model_with_marker_set
from mocap_mj.capture.marker_sets import bundled
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import joint_centre_lengths


def result_pset(folder: Path, scratch: Path) -> ParameterSet:
    """The parameter set of an ``identify`` folder: the bundled humanoid with the marker set
    its summary.json records (Plug-in Gait when it records none); a model file for another
    set is written into ``scratch``."""
    summary = json.loads((folder / "summary.json").read_text())
    name = (summary.get("marker_set") or {}).get("name") or "plug_in_gait"
    if name == "plug_in_gait":
        return ParameterSet()
    path = scratch / f"model_{name}.xml"
    if not path.exists():
        path.write_text(model_with_marker_set(bundled(name)).to_xml())
    return ParameterSet(str(path))


def report(folder: Path, pset: ParameterSet) -> str:
    summary = json.loads((folder / "summary.json").read_text())
    theta = pset.load_json(folder / "theta.json")
    subject = Subject.from_summary(summary)
    outside = kappa_outside_bounds(pset, theta, *kappa_ranges(pset, subject))
    lr = {k: v * 1e3 for k, v in left_right_differences(pset, theta).items()}
    motion = load_motion(folder / "motion.npz", pset.model)
    wid = {
        k: v * 1e3
        for k, v in width_errors(pset, theta, motion.qpos, motion.markers, subject).items()
    }
    lines = [
        f"{folder.name}: RMSE {summary['marker_rmse_mm']:.2f} mm; outside range: "
        f"{list(outside) or 'none'}; at bound: {summary.get('kappa_at_bound') or 'none'}",
        "  L/R |diff| mm: " + ", ".join(f"{k} {v:.1f}" for k, v in lr.items())
        + f"  (max {max(lr.values()):.1f})",
    ]  # fmt: skip
    if wid:
        lines.append(
            "  centre-to-lateral-marker minus (width/2 + r), median over frames, mm: "
            + ", ".join(f"{k} {v:+.1f}" for k, v in wid.items())
            + f"  (max |.| {max(abs(v) for v in wid.values()):.1f})"
        )
    return "\n".join(lines)


def pair_line(a: Path, b: Path, pset: ParameterSet) -> str:
    """The largest joint-centre distance differences of two ``identify`` folders' models."""
    la = joint_centre_lengths(pset, pset.load_json(a / "theta.json"))
    lb = joint_centre_lengths(pset, pset.load_json(b / "theta.json"))
    diff = sorted(((abs(la[n] - lb[n]) * 1e3, n) for n in la), reverse=True)
    return (f"{a.name} vs {b.name}: max joint-centre distance difference {diff[0][0]:.1f} mm; "
            "worst: " + ", ".join(f"{n} {v:.1f}" for v, n in diff[:4])
            + f"; median {sorted(v for v, _ in diff)[len(diff) // 2]:.1f}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--pair", nargs="+", action="append", default=[], metavar="FOLDER")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        for f in args.folders:
            print(report(f, result_pset(f, Path(scratch))))
        for group in args.pair:
            for a, b in itertools.combinations(group, 2):
                print(pair_line(Path(a), Path(b), result_pset(Path(a), Path(scratch))))


if __name__ == "__main__":
    main()
