"""Our joint centres against Vicon's own Plug-in Gait output stored in the same C3D file.

    python benchmarks/vicon_pig.py RESULTS [--shared ../shared/data] [--trials NAME ...]

RESULTS holds one ``mocap-mj identify`` folder per trial, named as the trial
(``benchmarks/real_data.py --out RESULTS`` writes them). For each trial whose file carries
Vicon's Plug-in Gait segment points (LFEP/LFEO hip and knee, LTIO ankle, LCLO shoulder,
LHUO elbow, LRAO wrist, and the right side's): the median over frames of the distance
between our centre (``joint_centres.csv``) and Vicon's, and its components in Vicon's
segment frame; our flexion axes (summary.json ``joint_axes``) with their varus-valgus /
flexion crosstalk beside Nexus's own (its KneeAngles); the distances from each shoulder
centre to CLAV and C7, ours and Vicon's; Vicon's own segment lengths (median over frames).
Prints mm; reads the files only.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import ezc3d
import numpy as np

#: Our joint centre -> Vicon's segment point at it (first found).
POINTS = {"hip": ("FEP",), "knee": ("FEO", "TIP"), "ankle": ("TIO", "FOP"),
          "shoulder": ("CLO", "HUP"), "elbow": ("HUO", "RAP"), "wrist": ("RAO", "HNP")}  # fmt: skip
#: Vicon's segment lengths: (name, proximal point, distal point), side letter prefixed.
LENGTHS = (("thigh", "FEP", "FEO"), ("shank", "FEO", "TIO"), ("upper arm", "HUP", "HUO"),
           ("forearm", "HUO", "RAO"))  # fmt: skip


def _points(path: Path) -> tuple[list[str], np.ndarray, int]:
    """The file's point labels, positions (T, N, 3) [mm] (NaN where a point is missing) and
    the number of its first frame (the C3D header's, counted from 1 as the tool writes it)."""
    c = ezc3d.c3d(str(path))
    labels = list(c["parameters"]["POINT"]["LABELS"]["value"])
    xyz = np.transpose(c["data"]["points"][:3], (2, 1, 0)).astype(float)
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan
    return labels, xyz, int(c["header"]["points"]["first_frame"]) + 1


def _median_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.nanmedian(np.linalg.norm(a - b, axis=1)))


def compare(c3d: Path, result: Path) -> list[str]:
    """The printed lines for one trial's file and its ``identify`` folder."""
    labels, xyz, first = _points(c3d)
    rows = list(csv.DictReader((result / "joint_centres.csv").open()))
    vicon = xyz[np.array([int(r["frame"]) - first for r in rows])]

    def at(name: str) -> np.ndarray:
        return vicon[:, labels.index(name)]

    def ours(joint: str, side: str) -> np.ndarray:
        return np.array([[float(r[f"{joint}_{side}_{a}_mm"]) for a in "xyz"] for r in rows])

    def frame_of(code: str) -> np.ndarray | None:
        """Vicon's segment axes (T, 3, 3) (columns anterior, lateral, proximal) at ``code``'s
        segment (its O, A, L, P points), None when absent."""
        seg = code[:-1]
        if not all(seg + k in labels for k in "OALP"):
            return None
        axes = [at(seg + k) - at(seg + "O") for k in "ALP"]
        return np.stack([a / np.linalg.norm(a, axis=1, keepdims=True) for a in axes], axis=2)

    gaps, shoulder, lengths, parts = [], [], [], []
    for p, side in (("L", "l"), ("R", "r")):
        for joint, codes in POINTS.items():
            code = next((p + k for k in codes if p + k in labels), None)
            if code is not None:
                d = _median_distance(ours(joint, side), at(code))
                gaps.append(f"{joint}_{side} {d:.1f}")
                axes = frame_of(code)
                if axes is not None:
                    local = np.einsum("tji,tj->ti", axes, ours(joint, side) - at(code))
                    a, lat, prox = np.nanmedian(local, axis=0)
                    parts.append(f"{joint}_{side} {a:+.0f}/{lat:+.0f}/{prox:+.0f}")
        if p + "CLO" in labels:
            for ref in ("CLAV", "C7"):
                us = _median_distance(ours("shoulder", side), at(ref))
                them = _median_distance(at(p + "CLO"), at(ref))
                shoulder.append(f"{side} to {ref} {us:.1f} / {them:.1f}")
        for name, a, b in LENGTHS:
            if p + a in labels and p + b in labels:
                lengths.append(f"{name}_{side} {_median_distance(at(p + a), at(p + b)):.1f}")
    lines = [f"{c3d.stem}: median |ours - Vicon's| mm: {', '.join(gaps) or 'no Vicon output'}"]
    lines += _axis_lines(result, labels, xyz)
    if parts:
        lines.append(f"  ours - Vicon's in Vicon's segment frame (anterior/lateral-y/"
                     f"proximal), mm: {', '.join(parts)}")  # fmt: skip
    if shoulder:
        lines.append(f"  shoulder centre, ours / Vicon's, mm: {'; '.join(shoulder)}")
    if lengths:
        lines.append(f"  Vicon's segment lengths, mm: {', '.join(lengths)}")
    return lines


def _axis_lines(result: Path, labels: list[str], xyz: np.ndarray) -> list[str]:
    """Our flexion axes (summary.json ``joint_axes``: source, angle to Plug-in Gait's axis,
    varus-valgus on flexion with ours and with the chord plane's) and Nexus's own knee
    crosstalk (its ``LKneeAngles`` varus on flexion over the file's frames)."""
    axes = json.loads((result / "summary.json").read_text()).get("joint_axes") or {}
    out = []
    for joint, d in axes.items():
        text = (
            f"  {joint}: axis from {d['source']}"
            f"{' (markers contradict the chord)' if d.get('conflict') else ''}, "
            f"{d['angle_to_pig_deg']:+.1f} deg to the chord's"
        )
        for key, who in (("crosstalk_model", "ours"), ("crosstalk_pig", "chord")):
            c = d.get(key)
            if c:
                text += f"; varus on flexion ({who}) r {c['corr']:+.2f} slope {c['slope']:+.2f}"
        code = f"{joint[-1].upper()}KneeAngles"
        if joint.startswith("knee") and code in labels:
            a = xyz[:, labels.index(code)]
            ok = np.all(np.isfinite(a[:, :2]), axis=1)
            if np.ptp(a[ok, 0]) > 20:
                r = np.corrcoef(a[ok, 0], a[ok, 1])[0, 1]
                slope = np.polyfit(a[ok, 0], a[ok, 1], 1)[0]
                text += f"; Nexus's {code} r {r:+.2f} slope {slope:+.2f}"
        out.append(text)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("results", type=Path)
    ap.add_argument("--shared", type=Path, default=Path("../shared/data"))
    ap.add_argument("--trials", nargs="+", default=["Movement_trial", "Static_trial"])
    args = ap.parse_args()
    for trial in args.trials:
        print("\n".join(compare(args.shared / "real" / f"{trial}.c3d", args.results / trial)))


if __name__ == "__main__":
    main()
