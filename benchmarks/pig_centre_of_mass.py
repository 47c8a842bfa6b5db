"""What Nexus' ``CentreOfMass`` is made of: the limbs as Plug-in Gait's kinetics place them, the
trunk as fixed points of the pelvis, thorax and head.

    python benchmarks/pig_centre_of_mass.py [--trial PATH]

Takes the trial's Plug-in Gait segments (``mocap_mj.clinical.plug_in_gait``) and the limbs'
centres of mass of ``mocap_mj.clinical.kinetics`` (Dempster's masses and fractions, 0.422 of the
body), subtracts them from Nexus' ``CentreOfMass``, and fits what remains with the pelvis (0.142),
thorax (0.355) and head (0.081) each holding its centre of mass at a fixed point of its own frame
(nine unknowns, linear least squares over every frame). Prints the residual [mm], the fitted
points and the singular values of the fit: the residual says whether that structure is Plug-in
Gait's; the singular values say whether this trial tells the three points apart (those
Plug-in Gait's footnotes give, which the tool does not have). The trial is only read.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.kinetics import DEMPSTER
from mocap_mj.io.load import load_markers

SHARED = Path(__file__).resolve().parents[2] / "shared"
TRUNK = (("pelvis", 0.142), ("thorax", 0.355), ("head", 0.081))


def limbs(segs: dict, centres: dict) -> tuple[np.ndarray, float]:
    """The limbs' mass-weighted centre of mass sum (T, 3) [m] and their mass fraction."""
    total, share = 0.0, 0.0
    for s in "lr":
        toe, ankle = segs[f"foot_{s}"].origin, centres[f"ankle_{s}"]
        length = np.nanmedian(np.linalg.norm(ankle - toe, axis=1))
        tip = ankle - length * segs[f"foot_{s}"].axes[:, :, 2]
        wrist, hand = centres[f"wrist_{s}"], centres[f"hand_{s}"]
        for name, distal, proximal in (
            ("foot", tip, ankle),
            ("tibia", ankle, centres[f"knee_{s}"]),
            ("femur", centres[f"knee_{s}"], centres[f"hip_{s}"]),
            ("hand", wrist + 2 * (hand - wrist), wrist),
            ("radius", wrist, centres[f"elbow_{s}"]),
            ("humerus", centres[f"elbow_{s}"], centres[f"shoulder_{s}"]),
        ):
            body = DEMPSTER[name]
            total = total + body.mass * (distal + body.com * (proximal - distal))
            share += body.mass
    return np.asarray(total), share


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", type=Path, default=SHARED / "data/real/Movement_trial.c3d")
    args = ap.parse_args()
    c3d = ezc3d.c3d(str(args.trial))
    labels = [s.strip().split(":")[-1] for s in c3d["parameters"]["POINT"]["LABELS"]["value"]]
    if "CentreOfMass" not in labels:
        raise SystemExit(f"{args.trial}: no CentreOfMass point")
    nexus = c3d["data"]["points"][:3, labels.index("CentreOfMass"), :].T / 1000.0  # mm -> m
    result = plug_in_gait(load_markers(args.trial), pig_from_c3d(args.trial))
    segs = result.segments
    part, share = limbs(segs, result.centres)
    rest = nexus - part - sum(m * segs[n].origin for n, m in TRUNK)
    rows = np.isfinite(rest).all(axis=1)
    design = np.concatenate([m * segs[n].axes[rows] for n, m in TRUNK], axis=2)  # (T, 3, 9)
    points, *_ = np.linalg.lstsq(design.reshape(-1, 9), rest[rows].reshape(-1), rcond=None)
    fit = np.einsum("tij,j->ti", design, points)
    print(f"{args.trial.name}: {rows.sum()} frames, limbs {share:.3f} of the body mass")
    print("residual RMS [mm] X Y Z:", np.round(1e3 * np.sqrt(np.mean((fit - rest[rows]) ** 2,
                                                                      axis=0)), 3))  # fmt: skip
    print("Nexus' trunk part alone, spread [mm]:", np.round(1e3 * rest[rows].std(axis=0), 2))
    for k, (name, _) in enumerate(TRUNK):
        print(
            f"{name:7s} centre of mass in its frame [m]: {np.round(points[3 * k : 3 * k + 3], 4)}"
        )
    print("singular values:", np.round(np.linalg.svd(design.reshape(-1, 9), compute_uv=False), 3))


if __name__ == "__main__":
    main()
