"""What Nexus' ``CentreOfMass`` is made of: the limbs as Plug-in Gait's kinetics place them, the
trunk as fixed points of the pelvis, thorax and head.

    python benchmarks/pig_centre_of_mass.py [--trial PATH]

Takes the trial's Plug-in Gait segments (``mocap_mj.clinical.plug_in_gait``) and the limbs'
centres of mass of ``mocap_mj.clinical.centre_of_mass`` (Dempster's masses and fractions, 0.422
of the body), subtracts them from Nexus' ``CentreOfMass``, and fits what remains with the pelvis
(0.142), thorax (0.355) and head (0.081) each holding its centre of mass at a fixed point of its
own frame (nine unknowns, linear least squares over every frame). Prints the residual [mm], the
fitted points beside the published ones (``mocap_mj.clinical.centre_of_mass``, their mean in
the segment's frame), the singular values of the fit, and the published model's difference
from Nexus [mm]: the residual says whether that structure is Plug-in Gait's; the singular
values say whether this trial tells the three points apart. The trial is only read.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.centre_of_mass import centre_of_mass, segment_centres
from mocap_mj.io.load import load_markers

SHARED = Path(__file__).resolve().parents[2] / "shared"
TRUNK = (("pelvis", 0.142), ("thorax", 0.355), ("head", 0.081))


def limbs(parts: dict[str, tuple[float, np.ndarray]]) -> tuple[np.ndarray, float]:
    """The limbs' mass-weighted centre of mass sum (T, 3) [m] and their mass fraction
    (``parts``: :func:`~mocap_mj.clinical.centre_of_mass.segment_centres`)."""
    own = [v for k, v in parts.items() if k not in dict(TRUNK)]
    return np.asarray(sum(m * c for m, c in own)), sum(m for m, _ in own)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", type=Path, default=SHARED / "data/real/Movement_trial.c3d")
    args = ap.parse_args()
    c3d = ezc3d.c3d(str(args.trial))
    labels = [s.strip().split(":")[-1] for s in c3d["parameters"]["POINT"]["LABELS"]["value"]]
    if "CentreOfMass" not in labels:
        raise SystemExit(f"{args.trial}: no CentreOfMass point")
    nexus = c3d["data"]["points"][:3, labels.index("CentreOfMass"), :].T / 1000.0  # mm -> m
    traj = load_markers(args.trial)
    result = plug_in_gait(traj, pig_from_c3d(args.trial))
    segs = result.segments
    markers = {n: traj.positions[:, i] for i, n in enumerate(traj.names)}
    parts = segment_centres(segs, result.centres, markers, result.subject.marker_radius)
    part, share = limbs(parts)
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
        seg, com = segs[name], parts[name][1]
        published = np.nanmean(np.einsum("tji,tj->ti", seg.axes, com - seg.origin), axis=0)
        fitted = np.round(points[3 * k : 3 * k + 3], 4)
        print(f"{name:7s} centre of mass in its frame [m]: fitted {fitted}, published "
              f"{np.round(published, 4)}")  # fmt: skip
    print("singular values:", np.round(np.linalg.svd(design.reshape(-1, 9), compute_uv=False), 3))
    diff = 1e3 * (centre_of_mass(parts) - nexus)
    dist = np.linalg.norm(diff, axis=1)
    print(f"published model - Nexus [mm]: RMS {np.sqrt(np.nanmean(dist**2)):.2f}, max "
          f"{np.nanmax(dist):.2f}, mean {np.round(np.nanmean(diff, axis=0), 2)}")  # fmt: skip


if __name__ == "__main__":
    main()
