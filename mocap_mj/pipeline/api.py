""":func:`identify`: the whole identification of ``mocap-mj identify``, in memory.

From the recordings' markers to a :class:`~mocap_mj.pipeline.fit.Fit`: the trials as the recipe
makes them (:mod:`~mocap_mj.pipeline.prepare`: marker set, frames, exclusions, widths, the
quality check and the labels' correction, ghost and jump samples dropped), the frames to
identify on (all, or a pose-diverse selection of a long recording), the initial model, the joint
LM with the anatomical priors and ranges and the trials' weights
(:func:`~mocap_mj.pipeline.steps.solve_anatomical`), the refinement on every frame of a selected
recording and the motion of every frame. Nothing is written:
:func:`mocap_mj.outputs.write_fit.write_result` writes a fit as a result folder.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.axes import knee_crosstalk, widths
from mocap_mj.anatomy.hinge_centres import hinge_report
from mocap_mj.capture.subject import Subject
from mocap_mj.io.strict_json import jsonable
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.long.chunks import FrameWeights
from mocap_mj.long.motion_out import (
    MotionOptions,
    every_frame_motion,
    write_every_frame_motion,
)
from mocap_mj.pipeline.anatomical import anatomical_priors, prior_information
from mocap_mj.pipeline.arguments import IDENTIFY, identify_call
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.marker_model import set_path
from mocap_mj.pipeline.motion import Motion
from mocap_mj.pipeline.prepare import (
    ModelChoice,
    Prepared,
    Source,
    choose_model,
    prepare,
    recording,
)
from mocap_mj.pipeline.recipe import Recipe, check_select
from mocap_mj.pipeline.report import Checks, Report, Timings
from mocap_mj.pipeline.results import joint_axes
from mocap_mj.pipeline.run_options import Hooks, Tuning
from mocap_mj.pipeline.steps import (
    Solved,
    robust_for,
    sliding_weigh,
    solve_trials,
)
from mocap_mj.pipeline.summary import (
    centre_fields,
    check_fit,
    checks_fields,
    fit_report,
    hinge_fields,
    judge,
    motion_fields,
    quality_fields,
    refinement_fields,
    regression_centres,
)
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.selection import select_in_trials

from ..arguments import validated

#: ``select="auto"``: above this many frames in all the trials, identify on a pose-diverse
#: subset. The cost of an LM iteration grows with the frames while an hour of motion repeats
#: a few thousand poses (docs/method.md#long-recordings).
AUTO_SELECT_ABOVE = 20_000
#: ``select="auto"``: the subset's size (the long-recording benchmark's, 1000 frames).
AUTO_SELECT_COUNT = 1000
#: The recipe of ``mocap-mj identify`` with no option (frozen, shared).
DEFAULT_RECIPE = Recipe()


@single_blas_thread  # the command's arithmetic, bit for bit, whatever the caller's BLAS pool
@validated(identify_call, **IDENTIFY)
def identify(
    recordings: Sequence[Source],
    recipe: Recipe = DEFAULT_RECIPE,
    subject: Subject | None = None,
    *,
    pset: ParameterSet | None = None,
    theta0: np.ndarray | None = None,
    landmarks: Mapping[str, str] | None = None,
    tuning: Tuning | None = None,
    hooks: Hooks | None = None,
) -> Fit:
    """Identify the subject's model and motion from ``recordings`` as ``recipe`` says: the
    whole pipeline of ``mocap-mj identify`` (:func:`~mocap_mj.pipeline.prepare.prepare`, then
    :func:`identify_prepared`), the same theta to the last bit on the same markers.

    Parameters
    ----------
    recordings : what :func:`mocap_mj.io.load_markers` returns (a trajectory, its labels
        matched to the model's markers by name), or TrialData with markers (T_i, M, 3) [m]
        in ``pset``'s marker order (NaN where missing) and times (T_i,) [s] (first frame 0,
        the rate from the times), or :class:`~mocap_mj.pipeline.prepare.Recording` (the
        same with its rate [Hz] and first frame given); one model for all of them. The
        caller's arrays are never changed.
    recipe : the choices (default: those of ``mocap-mj identify``).
    subject : the subject's measurements (default: none; the stature is then estimated).
    pset : the parameters to identify (default: the recipe's model and marker set, the set
        detected from the labels when the recipe names none).
    theta0 : (P,) [m] the initial model (default: from ``recipe.init``).
    landmarks : marker -> the anatomical landmark it sits on, for a ``pset`` of the caller's
        (default: the recipe's marker set's ``landmark:`` entries).
    tuning : :class:`~mocap_mj.pipeline.run_options.Tuning`, the solver's tolerances and
        performance options (default: theirs); they do not change the problem.
    hooks : :class:`~mocap_mj.pipeline.run_options.Hooks`: ``progress`` called with every
        LM iteration's trace entry; ``motion_progress`` with the frames done of the motion
        of every frame; ``motion_sink`` a folder: when the recipe selects frames (a long
        recording), every frame's motion is solved chunk by chunk and written there as it
        comes (motion*.npz, joint_centres*.csv; the memory then does not grow with the
        recording) and ``Fit.motion`` is None (``Fit.motion_files`` names the files).
        Default: none; the motion is held in memory (poses (T, nq) per trial).

    Notices (each label corrected, each quality warning) go to the logger
    ``mocap_mj.notices`` as they are found (:mod:`mocap_mj.pipeline.quality`); the fit's
    ``report`` records them.

    Returns
    -------
    Fit : theta (P,) [m], every frame's motion, identifiability, segment table, checks.
    """
    model = (
        choose_model(recipe, recordings)
        if pset is None
        else ModelChoice(pset, set_path(recipe.marker_set))
    )
    prepared = prepare(
        [recording(r, model.pset) for r in recordings],
        recipe,
        subject,
        model,
    )
    if landmarks is not None:
        prepared = replace(prepared, landmarks=landmarks)
    tuning = tuning or Tuning()
    settings = recipe.settings(tuning.tolerances, tuning.performance)
    return identify_prepared(prepared, theta0, settings, hooks)


@single_blas_thread
def identify_prepared(
    prepared: Prepared,
    theta0: np.ndarray | None = None,
    settings: LMSettings | None = None,
    hooks: Hooks | None = None,
) -> Fit:
    """The fit of :func:`~mocap_mj.pipeline.prepare.prepare`'s trials: the frames to identify
    on (all, or a pose-diverse selection of a long recording), the solve
    (:func:`~mocap_mj.pipeline.steps.solve_trials`), the refinement on every frame of a
    selected recording and the motion of every frame."""
    recipe, pset, trials = prepared.recipe, prepared.pset, prepared.trials
    firsts = list(prepared.first_frames)
    settings = settings or recipe.settings()
    hooks = hooks or Hooks()
    report: dict[str, Any] = {
        "frames_fitted_range": [
            [f, f + len(t.markers)] for f, t in zip(firsts, trials, strict=True)
        ],
        "marker_quality": None,
    }
    count = select_count(recipe.select, sum(len(t.markers) for t in trials), len(trials))
    fitted, whole, select_seconds = trials, None, None
    if count is not None:
        t0 = time.perf_counter()
        fitted, kept = selected(trials, pset.marker_names, count)
        select_seconds = report["select_seconds"] = time.perf_counter() - t0
        report["frames_selected"] = kept
        whole = trials
    solved = solve_trials(
        prepared, fitted, settings, theta0=theta0, progress=hooks.progress,
        selected=whole is not None,
    )  # fmt: skip
    partial = Report(prepared.quality, EMPTY_CHECKS, Timings(solved.seconds, None, select_seconds))
    fit = _described(solved, fitted, settings, recipe, (report, partial), firsts)
    if whole is None:
        return fit
    return _with_every_frame(fit, solved, whole, hooks.motion_sink, hooks.motion_progress)


#: The checks of a fit not yet checked (the start of :func:`_described`'s).
EMPTY_CHECKS = Checks({}, {}, {})


def _described(
    solved: Solved,
    trials: list[TrialData],
    settings: LMSettings,
    recipe: Recipe,
    reported: tuple[dict[str, Any], Report],
    firsts: list[int],
) -> Fit:
    """The fit of ``solved`` on ``trials`` (the frames identified on): its identifiability,
    checks, segment table and report (``reported``: summary.json's fields and the typed
    report so far, its quality and selection time); the motion the fitted frames' poses."""
    pset, result = solved.pset, solved.result
    summary, report = reported
    idf = Identifiability(
        pset,
        result.reduced_information,
        result.sigma,
        observable_std=settings.observable_std,
        theta=result.theta,
    )
    knee_crosstalk(pset, result.theta, result.qpos, [t.markers for t in trials],
                   joint_axes(solved.weighting))  # fmt: skip
    quality = report.quality
    if solved.t10_prior is not None and solved.t10_prior.finding is not None:
        quality = quality.with_finding(solved.t10_prior.finding)
    w = solved.weighting
    priors = (
        anatomical_priors(pset, replace(solved.anatomy, held=w.held_joints),
                          axes=widths(pset, joint_axes(w) or None), centres=w.centre_widths)
        if solved.anatomy is not None and w is not None
        else []
    )  # fmt: skip
    info = prior_information(priors, settings, pset.size)
    judged = judge(solved, trials)
    checked = check_fit(solved, trials, settings, judged, info)
    summary["marker_quality"] = quality_fields(quality)
    summary.update(fit_report(solved, trials, settings, recipe, idf, judged))
    summary.update(checks_fields(checked))
    report = replace(
        report,
        quality=quality,
        checks=checked.checks,
        timings=replace(report.timings, init_seconds=result.init_seconds),
        centres_vs_regression=regression_centres(solved, settings, recipe),
        centres_vs_construction=hinge_report(
            pset, result, info, checked.table.tau_frames, solved.construction or {}
        ),
    )
    summary["joint_centres_vs_regression"] = centre_fields(report.centres_vs_regression)
    summary["joint_centres_vs_construction"] = hinge_fields(report.centres_vs_construction)
    motion = tuple(
        Motion(np.asarray(q), t.times, t.markers, pset.marker_names, first_frame=f)
        for t, q, f in zip(trials, result.qpos, firsts, strict=True)
    )
    return Fit(
        pset=pset,
        recipe=recipe,
        settings=settings,
        result=result,
        identifiability=idf,
        trials=tuple(trials),
        motion=motion,
        first_frames=tuple(firsts),
        segments=tuple(checked.table.rows),
        sliding=solved.sliding,
        subject=solved.subject,
        report=report,
        summary_fields=jsonable(summary),
        ranges=solved.ranges,
    )


def _with_every_frame(
    fit: Fit,
    solved: Solved,
    whole: list[TrialData],
    sink: Path | None,
    progress: Callable[[int], None] | None,
) -> Fit:
    """``fit`` with the motion of every frame of ``whole`` (the recordings the fitted frames
    were selected from), by IK with the identified model: written into ``sink`` chunk by
    chunk, or held in memory without one."""
    summary = dict(fit.summary_fields)
    summary["motion_frames"] = [len(t.markers) for t in whole]
    refined, pset = solved.refined, fit.pset
    if refined is not None:
        summary["refinement"] = refinement_fields(pset, refined)
    options = MotionOptions(
        start=None if refined is None else refined.qpos,
        weighing=FrameWeights(
            sliding_weigh(pset, solved.weighting, solved.slides),
            (None if refined is None else refined.robust)
            or robust_for(pset, fit.result, fit.trials, fit.settings),
        ),
        progress=progress,
    )
    motion: tuple[Motion, ...] | None = None
    files: tuple[Path, ...] = ()
    if sink is not None:
        done = write_every_frame_motion(
            sink,
            pset,
            fit.theta,
            fit.settings,
            whole,
            first_frames=fit.first_frames,
            options=options,
        )
        files = tuple(
            sorted(sink.glob("motion*.npz"))
            + sorted(sink.glob("joint_centres*.csv"))
            + sorted(sink.glob("angles.csv"))
        )
    else:
        poses, done = every_frame_motion(pset, fit.theta, fit.settings, whole, options=options)
        motion = tuple(
            Motion(q, np.asarray(t.times, dtype=float), np.asarray(t.markers, dtype=float),
                   pset.marker_names, first_frame=f)
            for t, q, f in zip(whole, poses, fit.first_frames, strict=True)
        )  # fmt: skip
    summary.update(motion_fields(done.rmse, done.ik_seconds, done.seconds))
    timings = replace(fit.report.timings, motion_ik_seconds=done.ik_seconds,
                      motion_seconds=done.seconds)  # fmt: skip
    report = replace(fit.report, timings=timings, refinement=refined,
                     motion_marker_rmse=done.rmse)  # fmt: skip
    return replace(fit, report=report, summary_fields=jsonable(summary), motion=motion,
                   motion_files=files)  # fmt: skip


def select_count(select: int | str, frames: int, n_trials: int) -> int | None:
    """Frames to identify on for ``Recipe.select`` (None: every frame) over ``frames``
    frames in ``n_trials`` trials."""
    if select == "all":
        return None
    if select == "auto":
        return AUTO_SELECT_COUNT if frames > AUTO_SELECT_ABOVE else None
    check_select(select, n_trials)
    count = int(select)
    return count if count < frames else None


def selected(
    trials: list[TrialData], names: tuple[str, ...], count: int
) -> tuple[list[TrialData], list[list[int]]]:
    """The trials' pose-diverse frames (:func:`select_in_trials`) and their indices."""
    kept = select_in_trials([t.markers for t in trials], names, count)
    subsets = [
        TrialData(t.name, t.markers[k], t.times[k]) for t, k in zip(trials, kept, strict=True)
    ]
    return subsets, [k.tolist() for k in kept]
