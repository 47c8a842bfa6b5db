"""``mocap-mj identify``: the subject's model (segment lengths, marker offsets) and motion.

Identify the subject's model from one or more marker trials: the segment lengths and joint
positions (kinematic parameters) and every marker's offset on its segment, together with the
joint motion of every frame, by one Levenberg-Marquardt fit over all frames (the --solver paper
alternative is Zou & Sugihara's Algorithm 1). Writes OUT/model.xml (the identified MJCF),
theta.json, motion.npz (first trial; motion_<i>.npz for the others), identifiability.json,
report.md, plots and summary.json; docs/outputs.md explains them. The folder appears
only when the fit is complete; a fit that cannot be determined by the data is refused.
Before the fit the marker data are checked for markers that do not move with their segment
(mislabels, label swaps, re-stuck markers, impossible distances): each finding is a warning
on stderr and in summary.json and report.md (--strict: refused); --exclude-markers drops
markers' data. The anatomical fit also checks T10's placement against the stature (a
``placement`` finding, a warning like the others; --strict refuses it too, before the fit).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import _numba_prewarm
from ..checks import check_markers
from ..cli import add_force_flag, add_json_flag, into_out_folder, output_folder
from ..errors import MocapError
from ..identify.api import AUTO_SELECT_ABOVE, AUTO_SELECT_COUNT, identify, select_count
from ..identify.output import frame_range, result_text, write_result
from ..identify.paper import DEFAULT_DELTA, DEFAULT_STEP
from ..identify.pipeline import t10_check
from ..identify.plausibility import plausibility_text
from ..identify.problem import TrialData
from ..identify.recipe import INITS, Recipe
from ..ik import IKSettings
from ..marker_quality import Finding
from ..parameters import ParameterSet
from ..subject import Subject
from ._markers import add_marker_options, load_trial, model_for
from ._quality import (
    add_quality_options,
    check_trials,
    drop_excluded,
    parse_marker_list,
    quality_text,
    without_ghosts,
)
from ._subject import (
    add_subject_options,
    set_landmarks,
    subject_from_args,
    with_measured_widths,
)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the subject's model from marker trials",
        description=__doc__,
    )
    add_marker_options(p, several=True)
    p.add_argument(
        "--out", required=True, metavar="FOLDER", help="output folder (must be new or empty)"
    )
    p.add_argument(
        "--model", metavar="MJCF", help="initial MJCF model (default: the bundled humanoid)"
    )
    _add_fit_options(p)
    add_quality_options(p)
    add_subject_options(p)
    _add_paper_options(p)
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=run)


def _add_fit_options(p: argparse.ArgumentParser) -> None:
    """The solver, initial model, frames, loss and LM options of ``identify``."""
    p.add_argument(
        "--recipe",
        metavar="FILE",
        help="YAML recipe: the identification's choices (every result folder holds the "
        "recipe.yaml it was made with, so --recipe DIR/recipe.yaml re-runs it); a flag below "
        "given a value other than its default overrides the recipe's (default: the flags)",
    )
    p.add_argument(
        "--solver",
        choices=["lm", "paper"],
        default="lm",
        help="lm: joint Levenberg-Marquardt over all frames; paper: Algorithm 1 of Zou & "
        "Sugihara (default: lm)",
    )
    p.add_argument(
        "--init",
        choices=list(INITS),
        default="placed",
        help="initial model and prior mean (lm solver): placed = the nominal model scaled to "
        "the subject from marker distances, marker offsets then placed by IK (default); "
        "scaled = scaled only; nominal = the bundled model as it is",
    )
    p.add_argument(
        "--frames",
        metavar="A:B",
        help="frames to fit, from A up to but excluding B, counted from 0 in every trial "
        "(default: all)",
    )
    p.add_argument(
        "--select",
        default="auto",
        metavar="N",
        help="N, auto or all: identify on N frames chosen for pose diversity (shared among the "
        "trials by their length), refine the model on every frame with the same loss and "
        "priors, then solve every frame's IK with it for motion.npz and joint_centres.csv; "
        f"auto: {AUTO_SELECT_COUNT} frames when the trials hold more than {AUTO_SELECT_ABOVE} "
        "in all, else every frame; all: every frame (default: auto)",
    )
    p.add_argument(
        "--loss",
        choices=["l2", "huber", "cauchy"],
        default="l2",
        help="loss on each marker distance; huber and cauchy down-weight outliers (default: l2)",
    )
    p.add_argument("--robust", action="store_true", help="same as --loss cauchy")
    p.add_argument(
        "--max-iterations",
        type=int,
        default=100,
        metavar="N",
        help="LM iterations at most (lm solver; default: 100)",
    )
    p.add_argument(
        "--prior-mm",
        type=float,
        default=50.0,
        metavar="MM",
        help="width of the weak prior that holds each parameter near its initial value, in "
        "mm; it only matters in directions the markers do not inform (default: 50)",
    )
    p.add_argument(
        "--observable-mm",
        type=float,
        default=5.0,
        metavar="MM",
        help="a parameter direction counts as observable when its standard deviation is "
        "below this, in mm (default: 5)",
    )


def _add_paper_options(p: argparse.ArgumentParser) -> None:
    """The options of the paper solver (Algorithm 1 of Zou & Sugihara), in their own group."""
    g = p.add_argument_group("paper solver (Algorithm 1 of Zou & Sugihara)")
    g.add_argument(
        "--sampling",
        choices=["batch", "even", "random", "stochastic"],
        help="which frames each iteration uses (required with --solver paper; default: none)",
    )
    g.add_argument(
        "--iterations", type=int, default=100, metavar="N", help="iterations (default: 100)"
    )
    g.add_argument(
        "--step",
        type=float,
        metavar="ALPHA",
        help=f"gradient step alpha (default: {DEFAULT_STEP:g})",
    )
    g.add_argument(
        "--delta",
        type=float,
        metavar="M",
        help=f"finite-difference perturbation in m (default: {DEFAULT_DELTA:g})",
    )
    g.add_argument(
        "--fraction",
        type=float,
        default=0.1,
        metavar="F",
        help="fraction of the frames per iteration for random/stochastic sampling (default: 0.1)",
    )
    g.add_argument(
        "--seed", type=int, default=0, metavar="N", help="seed of the frame sampling (default: 0)"
    )


def run(args: argparse.Namespace) -> int:
    # Long C3D recordings are read chunk by chunk into memory maps in a scratch folder that
    # lives as long as the command (load_trial).
    with tempfile.TemporaryDirectory(prefix="mocap-mj-identify-") as scratch:
        return _run(args, Path(scratch))


def _run(args: argparse.Namespace, scratch: Path) -> int:
    pset = ParameterSet(model_for(args))
    t0 = time.perf_counter()
    loaded = [load_trial(path, pset.marker_names, args, scratch) for path in args.markers]
    read_seconds = time.perf_counter() - t0
    excluded = parse_marker_list(args.exclude_markers, pset.marker_names)
    trials = []
    ranges = []
    for t in loaded:
        sl = frame_range(args.frames, len(t.markers), t.path)
        if sl.stop - sl.start < 1:
            raise MocapError(f"{t.path}: --frames {args.frames} selects no frame")
        ranges.append([sl.start, sl.stop])
        markers = drop_excluded(t.markers[sl], pset, excluded)
        trials.append(TrialData(t.path, markers, t.times[sl]))
        check_markers(t.path, pset.marker_names, trials[-1].markers, IKSettings().min_markers)
    to_check = [
        (t.path, d.markers, t.rate, r[0]) for t, d, r in zip(loaded, trials, ranges, strict=True)
    ]
    if args.solver == "paper":
        if args.select not in ("auto", "all"):
            raise MocapError("--select: the paper's solver samples its own frames (--sampling)")
        from .paper import run_paper

        found, _ = check_trials(args, pset, to_check, excluded)
        trials = _without_ghosts(pset, trials, ranges, found)
        with output_folder(args.out, force=args.force) as out:
            return run_paper(args, pset, trials, ranges, out)
    subject = subject_from_args(args, [t.path for t in loaded])  # bad input before any output
    subject = with_measured_widths(args, pset.marker_names, trials, subject)
    recipe = recipe_from_args(args)
    count = select_count(recipe.select, sum(len(t.markers) for t in trials), len(trials))
    found, quality = check_trials(args, pset, to_check, excluded)  # after every bad-input error
    trials = _without_ghosts(pset, trials, ranges, found)
    if args.strict and recipe.anatomy:
        _refuse_misplaced_t10(pset, trials, subject)
    return into_out_folder(
        args,
        lambda out: _identify(
            args, recipe, pset, loaded, trials, ranges, subject, out, count, read_seconds, quality
        ),
    )


def _without_ghosts(
    pset: ParameterSet, trials: list[TrialData], ranges: list[list[int]], found: list[Finding]
) -> list[TrialData]:
    """The trials with the samples their ``ghost`` and ``jump`` findings name missing (they
    are not the marker, and a least-squares fit would follow them)."""
    return [
        t._replace(markers=without_ghosts(t.markers, pset, found, t.name, r[0]))
        for t, r in zip(trials, ranges, strict=True)
    ]


def _refuse_misplaced_t10(pset: ParameterSet, trials: list[TrialData], subject: Subject) -> None:
    """``--strict``: refuse the trials when T10's placement finding (found in the fit, from
    the stature: :func:`mocap_mj.identify.pipeline.t10_check`) would be reported, as the
    marker-data findings are: --strict refuses whatever the run would warn about."""
    placement = t10_check(pset, trials, subject)
    if placement is not None and placement.finding is not None:
        raise MocapError(
            f"{placement.finding.message}; --strict refuses a placement finding (re-place "
            "the marker, drop it with --exclude-markers T10, or run without --strict)"
        )


def recipe_from_args(args: argparse.Namespace) -> Recipe:
    """The recipe of ``identify``'s flags, over ``--recipe``'s file when given: a flag whose
    value differs from its default overrides the file's choice."""
    flags: dict[str, Any] = {
        "init": args.init,
        "anatomy": not args.no_anatomy,
        "symmetric": None if args.symmetric is None else args.symmetric * 1e-3,
        "asymmetry_prior": not args.no_asymmetry_prior,
        "hip_centre": getattr(args, "hip_centre", "harrington"),
        "sliding_landmarks": not args.no_sliding_landmarks,
        "loss": "cauchy" if args.robust else args.loss,
        "select": _select_value(args.select),
        "max_iterations": args.max_iterations,
        "prior_sigma": args.prior_mm * 1e-3,
        "observable_std": args.observable_mm * 1e-3,
    }
    base = Recipe.load(args.recipe) if getattr(args, "recipe", None) else Recipe()
    default = Recipe()
    return replace(base, **{k: v for k, v in flags.items() if v != getattr(default, k)})


def _select_value(text: str) -> int | str:
    """``--select`` text: a number of frames, auto or all."""
    if text in ("auto", "all"):
        return text
    try:
        return int(text)
    except ValueError:
        raise MocapError(
            f"--select: expected a number of frames, auto or all, got {text!r}"
        ) from None


def _identify(
    args: argparse.Namespace,
    recipe: Recipe,
    pset: ParameterSet,
    loaded: list[Any],
    trials: list[TrialData],
    ranges: list[list[int]],
    subject: Subject,
    out: Path,
    count: int | None = None,
    read_seconds: float | None = None,
    quality: dict[str, Any] | None = None,
) -> tuple[dict[str, Any], str]:
    _numba_prewarm.start()  # the identification kernels compile on the other core meanwhile
    from .progress import frames_bar, progress_bar

    total = sum(len(t.markers) for t in trials) if count is not None else 0
    # Every frame's motion of a long recording is written chunk by chunk into a folder beside
    # the output (one file system: write_result moves the files in).
    with (
        tempfile.TemporaryDirectory(dir=out.parent, prefix=".mocap-mj-motion-") as sink,
        progress_bar("identify (LM)", enabled=not args.json) as progress,
        frames_bar(
            "IK of every frame", total, enabled=count is not None and not args.json
        ) as motion_progress,
    ):
        fit = identify(
            trials,
            recipe,
            subject,
            pset=pset,
            first_frames=[r[0] for r in ranges],
            quality=quality,
            progress=progress,
            motion_progress=motion_progress,
            motion_sink=Path(sink),
            landmarks=set_landmarks(args)[0],
        )
        inputs = {"markers_files": [t.path for t in loaded], "read_seconds": read_seconds}
        summary = write_result(fit, out, inputs=inputs, force=True)
    for f in (summary.get("marker_quality") or {}).get("findings", []):
        if f["kind"] == "placement":  # found in the identification, after the stature
            print(f"mocap-mj {args.command}: warning: {f['message']}", file=sys.stderr)
    if summary.get("shoulder_note"):
        print(f"mocap-mj {args.command}: warning: {summary['shoulder_note']}", file=sys.stderr)
    per_marker = np.array(
        [np.nan if v is None else v * 1e-3 for v in summary["marker_rmse_by_marker_mm"].values()]
    )
    outside = {n: [v * 1e-3 for v in b] for n, b in summary["kappa_outside_bounds_mm"].items()}
    reports = "\n".join(str(t.report) for t in loaded)
    text = f"{reports}\n{result_text(summary, pset, Path(args.out))}\n"
    if count is not None:
        text += (
            f"identified on {sum(map(len, summary['frames_selected']))} of {total} frames "
            "chosen for pose diversity (--select); motion.npz and joint_centres.csv: every "
            f"frame by IK with the identified model, marker RMSE "
            f"{summary['motion_marker_rmse_mm']:.3f} mm\n"
        )
    measured = "; ".join(
        f"{n} {m['value'] * (1 if m['unit'] == 'kg' else 1e3):g} "
        f"{'kg' if m['unit'] == 'kg' else 'mm'} ({m['source']})"
        for n, m in summary["measurements"].items()
    )
    text += f"measurements: {measured or 'none (regressions from the markers)'}\n"
    est = summary.get("stature_estimate")
    if est:
        text += (
            f"stature {est['value']:.2f} +- {est['sd']:.2f} m estimated from {est['source']} "
            "(no measured height)\n"
        )
    if quality is not None:
        text += quality_text(quality) + "\n"
    plaus = plausibility_text(
        pset,
        per_marker,
        outside,
        at_bound=summary["kappa_at_bound"],
        at_limit=summary["joints_at_limit"],
    )
    return summary, text + plaus
