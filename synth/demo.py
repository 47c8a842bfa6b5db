"""``mocap-mj demo``: synthesize a trial, identify the model, score it against the truth.

The README's main job: a range-of-motion trial (``--frame-count``, 100 Hz) of a perturbed copy of
the bundled humanoid (kinematic parameters within +-10 %, landmark markers placed on the
perturbed skeleton as the marker set defines them, the others within +-20 mm of their
nominal offsets; 1 mm noise), identified with the joint Levenberg-Marquardt solver
(anatomical priors and ranges on) and scored against the truth; a walking trial of the same
subject (``--holdout`` frames), never seen by the identification, tests the identified model
by IK. Writes ``synth/`` (the truth), ``walk/`` (the held-out trial), ``result/`` (a folder
``view`` and ``render`` open) and ``summary.json``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.capture.subject import Subject
from mocap_mj.commands.common import into_out_folder, prepare_out
from mocap_mj.commands.progress import progress_bar
from mocap_mj.outputs.score import score
from mocap_mj.outputs.write_fit import expected_rmse, write_result
from mocap_mj.pipeline.anatomical import AnatomyPriors, anatomical_priors, prior_information
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.run_options import Hooks
from mocap_mj.skeleton import prewarm
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.problem import TrialData

from .config import SynthConfig
from .experiment import synthesize, write_experiment


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def run(args: argparse.Namespace) -> int:
    return into_out_folder(args, lambda staging: _demo(args, staging, Path(args.out)))


def _identify(exp: Any, pset: ParameterSet, staging: Path, out: Path, quiet: bool) -> Fit:
    """The range-of-motion trial of ``exp`` identified, written into ``staging``/result."""
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    # The synthetic truth perturbs left and right lengths independently (by up to 20 % apart):
    # not a subject of the population the asymmetry prior describes; the nominal model is its
    # best prior mean, and its white noise shows no soft tissue to slide.
    recipe = Recipe(init="nominal", asymmetry_prior=False, sliding_landmarks=False, select="all")
    with progress_bar("identify (LM)", enabled=not quiet) as progress:
        fit = identify([trial], recipe, pset=pset, hooks=Hooks(progress))
    write_result(
        fit,
        prepare_out(staging / "result", force=True),
        inputs={"markers_files": [str(out / "synth" / "markers.csv")]},
        force=True,
    )
    return fit


def _held_out(pset: ParameterSet, theta: np.ndarray, walk: Any) -> dict[str, Any]:
    """The held-out walk tracked by IK with the identified model theta (P,) [m]: its marker
    RMSE, what the noise alone leaves (mm) and its frames."""
    kin = Kinematics(pset)
    kin.set_theta(theta)
    held = IKSolver(kin).solve_trial(np.asarray(walk.markers))
    nv, m = kin.nv, pset.n_markers
    return {
        "heldout_marker_rmse_mm": held.rmse() * 1e3,
        "heldout_expected_rmse_mm": float(
            np.sqrt(3) * walk.sigma * np.sqrt(1 - nv / (3 * m)) * 1e3
        ),
        "frames_held_out": len(walk.markers),
    }


def _demo(args: argparse.Namespace, staging: Path, out: Path) -> tuple[dict[str, Any], str]:
    """Run the demo writing into ``staging``; messages and paths name ``out``."""
    t0 = time.perf_counter()
    prewarm.start()  # the identification kernels compile on the other core meanwhile
    cfg = SynthConfig(frames=args.frames, noise_mm=args.noise_mm, seed=args.seed)
    pset = ParameterSet()
    exp = synthesize(cfg, pset)
    write_experiment(exp, staging / "synth", force=True)
    # The same subject (same seed: same truth model) walking: held out from the fit.
    walk = synthesize(replace(cfg, frames=max(args.holdout, 2), motion="walk"), pset)
    write_experiment(walk, staging / "walk", force=True)
    n = args.frames
    fit = _identify(exp, pset, staging, out, quiet=args.json)
    ident, settings, idf = fit.summary(), fit.settings, fit.identifiability
    s = score(staging / "synth", staging / "result", pset=pset)
    # The bound with the landmark priors' information added (the score's is the data's own).
    info = prior_information(anatomical_priors(pset, AnatomyPriors(Subject())), settings, pset.size)
    pk, po = (b * 1e3 for b in idf.bound_rms_with_prior(info))
    s.update(_held_out(pset, fit.theta, walk))
    seconds = time.perf_counter() - t0
    k = pset.n_kappa
    # What the noise alone leaves after the fit: sqrt(3) sigma sqrt(1 - p / n).
    expected = expected_rmse(exp.sigma, ident["n_unknowns"], ident["n_residuals"]) * 1e3
    before = exp.theta_nominal - exp.theta_true
    summary = {
        "seconds": seconds,
        "identify_seconds": ident["seconds"],
        "frames": n,
        "frames_held_out": s["frames_held_out"],
        "iterations": ident["iterations"],
        "implausible": ident["implausible"],  # the fit's own checks: non-empty exits 3
        "marker_rmse_mm": ident["marker_rmse_mm"],
        "expected_rmse_mm": expected,
        "heldout_marker_rmse_mm": s.get("heldout_marker_rmse_mm"),
        "kappa_rmse_mm": s["kappa_rmse_mm"],
        "offset_rmse_mm": s["offset_rmse_mm"],
        "kappa_crlb_mm": s["kappa_crlb_mm"],
        "offset_crlb_mm": s["offset_crlb_mm"],
        "kappa_crlb_ratio": s["kappa_crlb_ratio"],
        "offset_crlb_ratio": s["offset_crlb_ratio"],
        "kappa_crlb_with_priors_mm": pk,
        "offset_crlb_with_priors_mm": po,
        "kappa_crlb_with_priors_ratio": s["kappa_rmse_mm"] / pk,
        "offset_crlb_with_priors_ratio": s["offset_rmse_mm"] / po,
        "joint_centre_rmse_mm": s["joint_centre_rmse_mm"],
        "joint_centre_crlb_mm": s["joint_centre_crlb_mm"],
        "joint_centre_crlb_ratio": s["joint_centre_crlb_ratio"],
        "kappa_rmse_before_mm": _rms(before[:k]) * 1e3,
        "offset_rmse_before_mm": _rms(before[k:]) * 1e3,
        "observable_directions": s["observable_directions"],
        "exclusion": s["exclusion"],
        "result": str(out / "result"),
        "truth": str(out / "synth"),
    }
    return summary, _text(args, summary, s, out)


def _text(args: argparse.Namespace, summary: dict[str, Any], s: dict[str, Any], out: Path) -> str:
    """The demo's stdout: the before/after table of the score ``s`` and its figures."""
    pk, po = summary["kappa_crlb_with_priors_mm"], summary["offset_crlb_with_priors_mm"]
    return "\n".join(
        [
            f"mocap-mj demo: {summary['frames']} frames of a synthetic range-of-motion trial, "
            "noise "
            f"{args.noise_mm:g} mm, truth = nominal humanoid perturbed, landmark markers "
            f"placed on it (seed {args.seed}); a {args.holdout}-frame walk of the same subject "
            "held out",
            "",
            f"{'':<26}{'before':>9}{'after':>9}{'CRLB':>9}{'ratio':>8}",
            f"{'kinematic params (mm)':<26}{summary['kappa_rmse_before_mm']:>9.2f}"
            f"{s['kappa_rmse_mm']:>9.3f}{s['kappa_crlb_mm']:>9.3f}{s['kappa_crlb_ratio']:>8.2f}",
            f"{'marker offsets (mm)':<26}{summary['offset_rmse_before_mm']:>9.2f}"
            f"{s['offset_rmse_mm']:>9.3f}{s['offset_crlb_mm']:>9.3f}"
            f"{s['offset_crlb_ratio']:>8.2f}",
            f"{'joint centres (mm)':<26}{'':>9}{s['joint_centre_rmse_mm']:>9.3f}"
            f"{s['joint_centre_crlb_mm']:>9.3f}{s['joint_centre_crlb_ratio']:>8.2f}",
            f"{'marker RMSE fit (mm)':<26}{'':>9}{summary['marker_rmse_mm']:>9.3f}"
            f"   (noise alone: {summary['expected_rmse_mm']:.3f})",
            f"{'marker RMSE walk (mm)':<26}{'':>9}"
            f"{s.get('heldout_marker_rmse_mm', float('nan')):>9.3f}"
            f"   (noise alone: {s.get('heldout_expected_rmse_mm', float('nan')):.3f})",
            "",
            f"CRLB above: the data's alone; with the landmark priors' information added: "
            f"kinematic {pk:.3f} mm (ratio {s['kappa_rmse_mm'] / pk:.2f}), offsets "
            f"{po:.3f} mm (ratio {s['offset_rmse_mm'] / po:.2f})",
            f"identification: {summary['identify_seconds']:.2f} s, "
            f"{summary['iterations']} iterations; "
            f"whole demo {summary['seconds']:.1f} s",
            s["exclusion"] + ".",
            f"wrote {out}/synth (truth), {out}/result (open with: mocap-mj view {out}/result)",
        ]
    )
