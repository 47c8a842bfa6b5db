"""Our joint centres against Vicon's own Plug-in Gait output stored in the same C3D file.

    python benchmarks/vicon_pig.py RESULTS [--shared ../shared/data] [--trials NAME ...]

RESULTS holds one ``mocap-mj identify`` folder per trial, named as the trial
(``benchmarks/real_data.py --out RESULTS`` writes them). For each trial whose file carries
Vicon's Plug-in Gait segment points (LFEP/LFEO hip and knee, LTIO ankle, LCLO shoulder,
LHUO elbow, LRAO wrist, and the right side's): per centre the median over frames of the
distance between ours (``joint_centres.csv``) and Vicon's, its anterior / lateral /
proximal components in Vicon's segment frame and the explanation report.md gives
(summary.json's, else computed here without the other hip regression;
:mod:`mocap_mj.clinical.nexus_centres`, :mod:`mocap_mj.clinical.centre_causes`: one
implementation); our flexion axes (summary.json ``joint_axes``) with their varus-valgus /
flexion crosstalk beside Nexus's own (its KneeAngles); the distances from each shoulder
centre to CLAV and C7, ours and Vicon's; Vicon's own segment lengths (median over frames).
Prints mm; reads the files only.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from mocap_mj.clinical.centre_causes import explanation
from mocap_mj.clinical.nexus_centres import (
    NexusOutput,
    centre_gaps,
    nexus_crosstalk,
    read_nexus,
    rows_for,
)

#: Vicon's segment lengths: (name, proximal point, distal point), side letter prefixed.
LENGTHS = (("thigh", "FEP", "FEO"), ("shank", "FEO", "TIO"), ("upper arm", "HUP", "HUO"),
           ("forearm", "HUO", "RAO"))  # fmt: skip


def _median_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.nanmedian(np.linalg.norm(a - b, axis=1))) * 1e3


def _ours(result: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Frame numbers (T,) and our centres by name (T, 3) [m] of a result's joint_centres.csv."""
    rows = list(csv.DictReader((result / "joint_centres.csv").open()))
    names = [c[:-5] for c in rows[0] if c.endswith("_x_mm")]
    cell = {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}
    ours = {n: np.stack([cell[f"{n}_{a}_mm"] for a in "xyz"], axis=1) * 1e-3 for n in names}
    return cell["frame"].astype(int), ours


def compare(c3d: Path, result: Path) -> list[str]:
    """The printed lines for one trial's file and its ``identify`` folder."""
    nexus = read_nexus(c3d)
    if nexus is None:
        return [f"{c3d.stem}: no Vicon output"]
    frames, ours = _ours(result)
    rows = rows_for(frames, nexus)
    summary = json.loads((result / "summary.json").read_text())
    axes = summary.get("joint_axes") or {}
    written = (summary.get("joint_centres_vs_plug_in_gait") or {}).get("centres") or {}
    gaps = centre_gaps(nexus, rows, ours)
    lines = [f"{c3d.stem}: median |ours - Vicon's| mm: "
             + ", ".join(f"{g.joint} {g.distance * 1e3:.1f}" for g in gaps)]  # fmt: skip
    lines += _axis_lines(axes, nexus, rows)
    parts = [f"{g.joint} " + "/".join(f"{v * 1e3:+.0f}" for v in g.components) for g in gaps]
    lines.append(f"  ours - Vicon's in Vicon's segment frame (anterior/lateral/proximal), mm: "
                 f"{', '.join(parts)}")  # fmt: skip
    for g in gaps:
        talk = nexus_crosstalk(nexus, rows, g.joint[-1]) if g.joint.startswith("knee") else None
        # identify's own (it also measures the other hip regression on our pelvis)
        text = (written.get(g.joint) or {}).get("explanation") or explanation(
            g, axes.get(g.joint), talk
        )
        if text:
            lines.append(f"  {g.joint}: {text}")
    lines += _trunk_lines(nexus, rows, ours)
    return lines


def _trunk_lines(nexus: NexusOutput, rows: np.ndarray, ours: dict[str, np.ndarray]) -> list[str]:
    """The shoulder centres' distances to CLAV and C7 (ours / Vicon's) and Vicon's lengths."""
    ok = rows >= 0
    shoulder, lengths = [], []
    for p, side in (("L", "l"), ("R", "r")):
        if p + "CLO" in nexus.points:
            for ref in ("CLAV", "C7"):
                if ref in nexus.points:
                    at = nexus.points[ref][rows[ok]]
                    us = _median_distance(ours[f"shoulder_{side}"][ok], at)
                    them = _median_distance(nexus.points[p + "CLO"][rows[ok]], at)
                    shoulder.append(f"{side} to {ref} {us:.1f} / {them:.1f}")
        for name, a, b in LENGTHS:
            if nexus.has(p + a, p + b):
                d = _median_distance(nexus.points[p + a][rows[ok]], nexus.points[p + b][rows[ok]])
                lengths.append(f"{name}_{side} {d:.1f}")
    out = []
    if shoulder:
        out.append(f"  shoulder centre, ours / Vicon's, mm: {'; '.join(shoulder)}")
    if lengths:
        out.append(f"  Vicon's segment lengths, mm: {', '.join(lengths)}")
    return out


def _axis_lines(axes: dict, nexus: NexusOutput, rows: np.ndarray) -> list[str]:  # type: ignore[type-arg]
    """Our flexion axes (summary.json ``joint_axes``: source, angle to Plug-in Gait's axis,
    varus-valgus on flexion with ours and with the chord plane's) and Nexus's own knee
    crosstalk (its ``LKneeAngles`` varus on flexion over the common frames)."""
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
        talk = nexus_crosstalk(nexus, rows, joint[-1]) if joint.startswith("knee") else None
        if talk is not None:
            text += f"; Nexus's {joint[-1].upper()}KneeAngles r {talk[0]:+.2f} slope {talk[1]:+.2f}"
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
