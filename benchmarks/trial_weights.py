"""A static trial with soft tissue plus a movement, identified together: accuracy against the
synthetic truth with and without the per-trial weights
(docs/method.md#weighing-priors-trials-and-sliding-markers).

For each seed: one subject (``mocap_synth``: segment lengths +-10 %, offsets +-20 mm,
landmarks placed anatomically), a range-of-motion or walking trial (1 mm white noise, and
``--sta-mm`` soft-tissue artefact per radian) and a quiet-standing trial of the same subject
(1 mm white noise) whose every marker carries one constant soft-tissue offset (``--static-mm``
RMS per axis, random per marker, the same in every frame). Both are identified together by
:func:`mocap_mj.identify` with the default priors and ``init="nominal"``, once with the
per-trial weights (:func:`mocap_mj.solve.noise.trial_weights`) and once with every weight 1
(``Recipe(trial_weights=False)``); printed: the weights, the kinematic parameters' and joint
centres' RMS errors against the truth (:func:`mocap_mj.outputs.score.score`, on the movement trial)
for
both, and the movement alone for reference. With ``--static-mm 0 --sta-mm 0`` (white noise only) the
weights must all be 1.

Run: python benchmarks/trial_weights.py [--seeds 0 3] [--motion rom|walk] [--static-mm 5]
[--sta-mm 0] [--frames 300 500]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.outputs.score import score
from mocap_mj.outputs.write_fit import write_result
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize, write_experiment


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 3), metavar=("FIRST", "END"))
    parser.add_argument("--motion", choices=("rom", "walk"), default="rom")
    parser.add_argument("--static-mm", type=float, default=5.0)
    parser.add_argument("--sta-mm", type=float, default=0.0)
    parser.add_argument("--frames", type=int, nargs=2, default=(300, 500),
                        metavar=("MOVEMENT", "STATIC"))  # fmt: skip
    args = parser.parse_args()
    pset = ParameterSet()
    settings = LMSettings()
    errors: list[tuple[float, ...]] = []
    for seed in range(*args.seeds):
        move = synthesize(SynthConfig(frames=args.frames[0], motion=args.motion, seed=seed,
                                      sta_mm=args.sta_mm), pset)  # fmt: skip
        still = synthesize(SynthConfig(frames=args.frames[1], motion="static", seed=seed), pset)
        if not np.allclose(move.theta_true, still.theta_true):
            raise SystemExit("the two presets of one seed drew different subjects")
        rng = np.random.default_rng(1000 + seed)
        offset = rng.normal(0.0, args.static_mm * 1e-3, (1, still.markers.shape[1], 3))
        trials = [
            TrialData("movement", np.asarray(move.markers), np.asarray(move.times)),
            TrialData("static", np.asarray(still.markers) + offset, np.asarray(still.times)),
        ]
        row: list[float] = []
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            write_experiment(move, d / "synth")
            runs = (("weighed", trials, True), ("unweighed", trials, False),
                    ("movement alone", trials[:1], True))  # fmt: skip
            text = []
            for name, data, weigh in runs:
                out = d / name.replace(" ", "_")
                out.mkdir()
                recipe = Recipe.of_settings(
                    settings, init="nominal", sliding_landmarks=False, select="all",
                    trial_weights=weigh,
                )  # fmt: skip
                fit = identify(data, recipe, pset=pset)
                summary = write_result(fit, out, force=True)
                s = score(d / "synth", out, pset=pset, plot=False)
                w = summary["prior_weighting"]
                weights = w.get("trial_weights", [1.0] * len(data))
                taus = w.get("trial_tau_frames", [float("nan")] * len(data))
                text.append(
                    f"{name}: weights {', '.join(f'{x:.2f}' for x in weights)} (tau "
                    f"{', '.join(f'{x:.0f}' for x in taus)} frames), kappa "
                    f"{s['kappa_rmse_mm']:.2f} mm, joint centres {s['joint_centre_rmse_mm']:.2f} "
                    f"mm, fit {summary['marker_rmse_mm']:.2f} mm"
                )
                row += [s["kappa_rmse_mm"], s["joint_centre_rmse_mm"]]
        errors.append(tuple(row))
        print(f"seed {seed}: " + "; ".join(text), flush=True)
    rms = np.sqrt(np.mean(np.square(errors), axis=0))
    print(
        f"RMS over {len(errors)} seeds: kappa {rms[0]:.2f} mm weighed, {rms[2]:.2f} unweighed, "
        f"{rms[4]:.2f} movement alone; joint centres {rms[1]:.2f} / {rms[3]:.2f} / {rms[5]:.2f} mm"
    )


if __name__ == "__main__":
    main()
