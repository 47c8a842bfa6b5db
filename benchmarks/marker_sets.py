"""The bundled vendor marker sets on the shared recordings; prints a table of figures.

See docs/model.md#landmarks.

    python benchmarks/marker_sets.py [--out DIR] [--only NAME ...]

Runs ``mocap-mj identify --markers FILE --marker-set SET`` (no other flag) on each shared
recording with its set (:data:`CASES`), then prints per run: marker RMSE, kinematic
parameters outside their anatomical range, the largest left/right length difference, the
widths measured from landmark pairs, and for the knee, ankle and elbow of each side whose
two landmark markers (lateral and medial) the recording holds, the median over frames of
the distance from the joint centre to the midpoint of the two markers' fitted positions
(the identified model's markers in its identified poses). Last, for the three trials of
one subject (the biobuddy trials), the largest difference of any joint-centre distance
between every two of their models (:func:`mocap_mj.solve.consistency.joint_centre_lengths`).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import json
import tempfile
from pathlib import Path

import numpy as np

from mocap_mj.anatomy.plausibility import (
    PAIR_JOINTS,
    kappa_outside_bounds,
    left_right_differences,
    pair_centre_gaps,
)
from mocap_mj.anatomy.ranges import kappa_ranges
from mocap_mj.capture.landmarks import WIDTH_PAIRS
from mocap_mj.capture.marker_set import MarkerSet, load_marker_set, model_with_marker_set
from mocap_mj.capture.subject import Subject
from mocap_mj.cli import main as cli
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import joint_centre_lengths

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
SETS = ROOT / "models" / "marker_sets"
#: name -> (recording, marker set, the group its models are compared in or "").
CASES: dict[str, tuple[Path, Path, str]] = {
    "Qualisys": (DATA / "vendors/Qualisys.c3d", SETS / "qualisys_isb.yaml", ""),
    "FP_Type3": (DATA / "vendors/FP_Type3.c3d", SETS / "qualisys_clusters.yaml", ""),
    "BTS": (DATA / "vendors/BTS.c3d", SETS / "davis_bts.yaml", ""),
    "FP_Type1": (DATA / "vendors/FP_Type1.c3d", SETS / "davis.yaml", ""),
    "rknee": (DATA / "real/Test_func_rknee.c3d", SETS / "plug_in_gait_medial.yaml", "bb"),
    "rhip": (DATA / "real/Test_func_rhip.c3d", SETS / "plug_in_gait_medial.yaml", "bb"),
    "posture": (
        DATA / "real/anatomical_posture.c3d",
        SETS / "plug_in_gait_medial.yaml",
        "bb",
    ),
}


def set_pset(marker_set: Path, folder: Path) -> tuple[ParameterSet, MarkerSet]:
    """The parameter set of the bundled humanoid with ``marker_set``'s markers."""
    ms = load_marker_set(marker_set)
    path = folder / f"model_{marker_set.stem}.xml"
    path.write_text(model_with_marker_set(ms).to_xml())
    return ParameterSet(str(path)), ms


def centre_to_midpoint(
    pset: ParameterSet, ms: MarkerSet, theta: np.ndarray, qpos: np.ndarray, seen: set[str]
) -> dict[str, tuple[float, float]]:
    """Per joint and side (``knee_l``...) with both landmark markers in ``seen``: |joint
    centre - midpoint of the two markers' fitted positions| [m] in the model's reference
    pose (:func:`~mocap_mj.anatomy.plausibility.pair_centre_gaps`: the knee extended) and
    its median over the frames ``qpos`` (T, nq). They differ only at the knee, whose centre
    rolls back with flexion (:mod:`mocap_mj.skeleton.rolling`)."""
    landmarks = {m.name: m.landmark for m in ms.markers if m.landmark}
    ref = pair_centre_gaps(pset, theta, landmarks, seen)
    model = pset.model_for(theta)
    found = {}
    for key in ref:
        joint, side = key.rsplit("_", 1)
        width, child = PAIR_JOINTS[joint]
        a, b = (model.site(str(_marker_on(ms, lm, side, seen))).id for lm in WIDTH_PAIRS[width])
        found[key] = (model.body(f"{child}_{side}").id, a, b)
    dist: dict[str, list[float]] = {k: [] for k in found}
    for _, data in rolling.posed(model, qpos):
        for key, (body, a, b) in found.items():
            mid = 0.5 * (data.site_xpos[a] + data.site_xpos[b])
            dist[key].append(float(np.linalg.norm(data.xpos[body] - mid)))
    return {k: (ref[k], float(np.median(v))) for k, v in dist.items() if v}


def run(name: str, out: Path) -> tuple[ParameterSet, np.ndarray] | None:
    """Identify case ``name`` into ``out / name`` and print its row; None without its file."""
    path, marker_set, _ = CASES[name]
    if not (path.is_file() and marker_set.is_file()):
        print(f"| {name} | {path} or {marker_set} not present: skipped |")
        return None
    folder = out / name
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        status = cli(["identify", "--markers", str(path), "--marker-set", str(marker_set),
                      "--out", str(folder), "--force", "--json"])  # fmt: skip
    summary = json.loads((folder / "summary.json").read_text())
    pset, ms = set_pset(marker_set, out)
    theta = pset.load_json(folder / "theta.json")
    motion = load_motion(folder / "motion.npz", pset.model)
    seen = {n for i, n in enumerate(pset.marker_names) if np.isfinite(motion.markers[:, i]).any()}
    subject = Subject.from_summary(summary)
    outside = kappa_outside_bounds(pset, theta, *kappa_ranges(pset, subject))
    lr = left_right_differences(pset, theta)
    worst = max(lr, key=lambda k: lr[k])
    widths = {
        n: v["value"] * 1e3 for n, v in summary["measurements"].items()
        if v["source"].startswith("markers ")
    }  # fmt: skip
    centres = centre_to_midpoint(pset, ms, theta, motion.qpos, seen)
    print(
        f"| {name} | {status} | {summary['marker_rmse_mm']:.2f} | {list(outside) or 'none'} "
        f"| {worst} {lr[worst] * 1e3:.1f} | "
        + (", ".join(f"{k} {v:.0f}" for k, v in sorted(widths.items())) or "-")
        + " | "
        + (", ".join(_centre_text(k, *v) for k, v in centres.items()) or "-")
        + (f" (max {max(v[0] for v in centres.values()) * 1e3:.1f})" if centres else "")
        + " |"
    )
    return pset, theta


def _marker_on(ms: MarkerSet, landmark: str, side: str, seen: set[str]) -> str | None:
    """The marker of ``ms`` in ``seen`` on ``landmark`` of ``side`` ("l" / "r"), or None."""
    for m in ms.markers:
        if m.landmark == landmark and m.name in seen and m.body.endswith(f"_{side}"):
            return m.name
    return None


def _centre_text(joint: str, ref: float, frames: float) -> str:
    rolled = f" (frames {frames * 1e3:.1f})" if abs(frames - ref) > 5e-4 else ""
    return f"{joint} {ref * 1e3:.1f}{rolled}"


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="result folders (default: temporary)")
    ap.add_argument("--only", nargs="+", choices=list(CASES), default=list(CASES))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        print(
            "| run | exit | RMSE mm | outside range | largest L/R diff mm | widths from "
            "landmark pairs mm | centre to landmark midpoint mm (median over frames) |"
        )
        print("|---|---|---|---|---|---|---|")
        fits = {name: run(name, out) for name in args.only}
        groups = {CASES[n][2] for n in fits if CASES[n][2]}
        for group in sorted(groups):
            done = {n: f for n, f in fits.items() if CASES[n][2] == group and f is not None}
            for a, b in itertools.combinations(done, 2):
                (pa, ta), (pb, tb) = done[a], done[b]
                la, lb = joint_centre_lengths(pa, ta), joint_centre_lengths(pb, tb)
                diff = sorted(((abs(la[k] - lb[k]) * 1e3, k) for k in la), reverse=True)
                print(f"{a} vs {b}: largest joint-centre distance difference "
                      f"{diff[0][0]:.1f} mm ({diff[0][1]}); next "
                      + ", ".join(f"{k} {v:.1f}" for v, k in diff[1:4]))  # fmt: skip


if __name__ == "__main__":
    main()
