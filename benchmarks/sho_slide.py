"""The acromion marker's slide with arm elevation on synthetic trials; prints figures.

    python benchmarks/sho_slide.py [--seeds 0 4] [--rate 0.010] [--frames 300]

For each seed: the demo's synthetic range-of-motion trial (``mocap_synth``), each SHO moved
towards its sternoclavicular joint by ``rate`` [m/rad] x humerothoracic elevation (the
upper arm's tilt from the thorax, :func:`mocap_mj.anatomy.tissue.slide_angles`; the
direction of the slide on the shared Movement/Static trials), then ``solve_anatomical``
without a sliding model and with
:data:`~mocap_mj.anatomy.tissue.SHOULDER_SLIDE`. Prints the clavicle lengths' errors (SC
joint to glenohumeral centre) and the glenohumeral centres' RMS error over frames [mm].
"""

from __future__ import annotations

import argparse

import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.tissue import SHOULDER_SLIDE, slide_angles
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.anatomical import AnatomyPriors, Weighing
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize


def gh_error(pset: ParameterSet, result, kin_true: Kinematics, qpos: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """RMS over frames and sides [m] of the glenohumeral centres' 3-D error in the world,
    the identified model in its own poses against the truth."""
    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    used = result.used[0]
    est = kin.forward(result.qpos[0][used])
    true = kin_true.forward(qpos[used])
    ids = [pset.model.body(f"upperarm_{s}").id for s in "lr"]
    return float(np.sqrt(np.mean(np.sum((est.xpos[:, ids] - true.xpos[:, ids]) ** 2, axis=-1))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 4), metavar=("FIRST", "STOP"))
    ap.add_argument("--rate", type=float, default=0.010, help="slide [m/rad] (default 0.010)")
    ap.add_argument("--frames", type=int, default=300)
    args = ap.parse_args()
    pset = ParameterSet()
    slides = {"SHO": SHOULDER_SLIDE}
    idx = [pset.index(f"clavicle_length_{s}") for s in "lr"]
    for seed in range(*args.seeds):
        exp = synthesize(SynthConfig(frames=args.frames, seed=seed), pset)
        qpos = np.asarray(exp.qpos)
        kin = Kinematics(pset)
        kin.set_theta(exp.theta_true)
        true = kin.forward(qpos)
        markers = np.array(exp.markers)
        angles = slide_angles(pset, qpos, slides)
        for side in "lr":
            m = pset.marker_names.index(f"{side.upper()}SHO")
            inward = true.xpos[:, pset.model.body(f"clavicle_{side}").id] - markers[:, m]
            inward /= np.linalg.norm(inward, axis=1)[:, None]
            markers[:, m] += inward * (args.rate * angles[:, m])[:, None]
        trial = TrialData("slide", markers, np.asarray(exp.times))
        line = [f"seed {seed}: elevation max {np.degrees(np.nanmax(angles)):.0f} deg"]
        for label, s in (("without", None), ("with SHOULDER_SLIDE", slides)):
            res, wt = solve_anatomical(
                [trial], pset=pset, theta0=None, settings=LMSettings(),
                anatomy=AnatomyPriors(Subject()), weighing=Weighing(slides=s),
            )  # fmt: skip
            err = (res.theta[idx] - exp.theta_true[idx]) * 1e3
            gh = gh_error(pset, res, kin, qpos) * 1e3
            w = wt.slide_weight_min
            line.append(
                f"{label}: clavicle error l/r {err[0]:+.1f} / {err[1]:+.1f} mm, GH RMS {gh:.1f} mm"
                + (f" (smallest weight {w:.2f})" if w is not None else "")
            )
        print("; ".join(line), flush=True)


if __name__ == "__main__":
    main()
