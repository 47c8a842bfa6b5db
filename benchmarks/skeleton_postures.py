"""A skeleton that is right in any posture and heading: identify on synthetic truths.

For every posture of ``mocap-mj synth --pose`` and the headings 0, 90, 180 and 270 degrees: a
static trial in the posture (``--frames``, 200) and, unless ``--no-dynamic``, a short
range-of-motion trial starting in it (``--dynamic-frames``, 300 at 100 Hz: 1 s blending out of
the posture, then the whole ROM), each identified alone with ``mocap_mj.identify`` and
``identify``'s default recipe (what ``mocap-mj identify`` runs), written as a result folder and
scored against the truth (``mocap_mj.outputs.score``, ``mocap_synth.truth_checks``). Printed
per case:

* ``z rms`` and ``z max``: the joint-centre errors over their Cramer-Rao bounds (the score's
  per-body RMS error over its bound; the bodies some marker follows), their RMS over bodies and
  the largest, with its body;
* ``axis``: the largest RMS angle [deg] between an identified and a true flexion axis (knees,
  ankles, elbows), with its joint;
* ``flips``: joint centres on the wrong side of their landmark marker (hip/ASIS, knee/KNE,
  ankle/ANK, elbow/ELB), and the fit's own implausibility lines (the ones that exit 3);
* ``ok``: whether the case meets the targets: z rms <= 1.3, z max <= 4, axis <= 10 deg, no
  flip.

Run: python benchmarks/skeleton_postures.py [--quick] [--poses NAME ...] [--headings DEG ...]
[--seed N] [--frames N] [--dynamic-frames N] [--no-dynamic]
(--quick: headings 0 and 180, 120-frame statics, 200-frame dynamics.)
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.pipeline.recipe import Recipe
from mocap_synth import POSES, SynthConfig
from mocap_synth.truth_checks import AXIS_DEG, Z_MAX, Z_RMS, identify_and_check


def _line(label: str, r: dict[str, Any]) -> str:
    flips = "; ".join(r["flips"] + r["implausible"]) or "none"
    return (
        f"{label:<26} z rms {r['z_rms']:5.2f}  z max {r['z_max']:5.2f} ({r['z_worst']:<10}) "
        f"axis {r['axis_max_deg']:5.1f} deg ({r['axis_worst']:<11}) "
        f"jc {r['score']['joint_centre_rmse_mm']:5.1f} mm  fit {r['marker_rmse_mm']:.2f} mm  "
        f"{r['seconds']:4.1f} s  {'ok ' if r['ok'] else 'FAIL'}  flips: {flips}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="headings 0 and 180, fewer frames")
    ap.add_argument("--poses", nargs="*", choices=POSES, default=list(POSES))
    ap.add_argument("--headings", nargs="*", type=float, default=None)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--frames", type=int, default=None, help="static frames (200)")
    ap.add_argument("--dynamic-frames", type=int, default=None, help="rom frames (300)")
    ap.add_argument("--no-dynamic", action="store_true")
    args = ap.parse_args()
    headings = args.headings or ([0.0, 180.0] if args.quick else [0.0, 90.0, 180.0, 270.0])
    frames = args.frames or (120 if args.quick else 200)
    dynamic = args.dynamic_frames or (200 if args.quick else 300)
    movements = [("static", frames)] + ([] if args.no_dynamic else [("rom", dynamic)])
    pset, recipe = ParameterSet(), Recipe()
    print(
        f"identify (default recipe) on synthetic truths, seed {args.seed}, 1 mm noise; "
        f"targets: z rms <= {Z_RMS}, z max <= {Z_MAX}, axis <= {AXIS_DEG:g} deg, no flip"
    )
    results = []
    for pose in args.poses:
        for heading in headings:
            for movement, n in movements:
                cfg = SynthConfig(frames=n, motion=movement, pose=pose, heading_deg=heading,
                                  seed=args.seed)  # fmt: skip
                r = identify_and_check(cfg, pset, recipe)
                results.append(r)
                print(_line(f"{pose} {heading:g} deg {movement} {n}", r), flush=True)
    bad = sum(not r["ok"] for r in results)
    print(
        f"{len(results) - bad} of {len(results)} cases meet the targets; over all cases z rms "
        f"{np.sqrt(np.mean([r['z_rms'] ** 2 for r in results])):.2f}, largest z "
        f"{max(r['z_max'] for r in results):.2f}, largest axis error "
        f"{max(r['axis_max_deg'] for r in results):.1f} deg, "
        f"{sum(bool(r['flips']) for r in results)} cases with a flipped joint"
    )


if __name__ == "__main__":
    main()
