"""The trials as :func:`mocap_mj.identify` fits them, from the recordings: :func:`prepare`.

From each recording (what :func:`mocap_mj.io.load_markers` returns, a
:class:`~mocap_mj.solve.problem.TrialData` in the model's marker order, or a :class:`Recording`)
to the trials of the fit, as ``mocap-mj identify`` does it: the model of the recipe's marker set
(:mod:`~mocap_mj.pipeline.marker_model`; detected from the labels when none is named), the
recipe's frames and excluded markers, the bad-input checks (:func:`selected`), then
(:func:`checked`) the joint widths the set's landmark pairs measure and its markers' radius,
then the quality check with the correction of exchanged labels
(:mod:`~mocap_mj.pipeline.quality`), the ghost and jump samples dropped, and under
``recipe.strict`` the refusal of a misplaced T10. Notices (each correction, each warning) go to
the logger ``mocap_mj.notices`` as they are found.

A recording's markers are copied before they are corrected, unless a :class:`Recording` says
they are the pipeline's own (the command line's scratch copy of a long recording).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.anatomy.initial import with_stature
from mocap_mj.anatomy.trunk import t10_placement
from mocap_mj.capture.checks import check_markers, recorded_floor
from mocap_mj.capture.landmarks import disagreements, measured_widths
from mocap_mj.capture.marker_quality import exclude_markers, parse_marker_list
from mocap_mj.capture.subject import Subject
from mocap_mj.io.trajectory import MarkerTrajectory
from mocap_mj.pipeline.marker_model import (
    detected_set,
    model_file,
    set_landmarks,
    set_path,
    with_set_radius,
)
from mocap_mj.pipeline.quality import Checked, Policy, check_trials, notice, without_ghosts
from mocap_mj.pipeline.recipe import Recipe, check_select, frame_range
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData

from ..errors import MocapError


@dataclass(frozen=True, eq=False)
class Recording:
    """One recording in the model's marker order.

    Attributes
    ----------
    name : str
        Its file (or a name): messages, the summary.
    markers : (T, M, 3) float [m]
        Positions in the model's marker order, NaN where missing.
    times : (T,) float [s]
    rate : float [Hz]
    first_frame : int
        The recording's own number of row 0.
    own : bool
        The markers are the pipeline's to correct in place (a scratch copy); default False:
        they are copied first.
    """

    name: str
    markers: np.ndarray
    times: np.ndarray
    rate: float
    first_frame: int = 0
    own: bool = False


class ModelChoice(NamedTuple):
    """The parameters to identify and the marker-set file they come from (None: the model's
    own sites)."""

    pset: ParameterSet
    set_file: Path | None


@dataclass(frozen=True, eq=False)
class Prepared:
    """The trials of a fit, as :func:`prepare` makes them.

    Attributes
    ----------
    recipe : Recipe
    pset : ParameterSet
    trials : list of TrialData
        The frames fitted: markers (T_i, M, 3) [m], corrected, ghosts missing; times [s].
    first_frames : list of int
        Each trial's first fitted frame in its recording's numbering.
    subject : Subject
        The measurements, with the widths the set's landmarks measure.
    quality : MarkerQuality
        The quality check's findings, the labels' corrections and the excluded markers.
    landmarks : dict
        marker -> the landmark it sits on (the set's; empty for the bundled sites).
    """

    recipe: Recipe
    pset: ParameterSet
    trials: list[TrialData]
    first_frames: list[int]
    subject: Subject
    quality: MarkerQuality
    landmarks: Mapping[str, str]


Source = MarkerTrajectory | TrialData | Recording


def choose_model(recipe: Recipe, recordings: Sequence[Source]) -> ModelChoice:
    """:func:`model_of` the trajectories' labels (markers already in a model's order,
    TrialData or :class:`Recording`, are the bundled humanoid's)."""
    labels: list[str] | None = []
    for r in recordings:
        if not isinstance(r, MarkerTrajectory):
            labels = None
            break
        labels += [n for n in r.names if n not in labels]  # type: ignore[operator]
    return model_of(recipe, labels)


def model_of(recipe: Recipe, labels: Sequence[str] | None) -> ModelChoice:
    """The parameters of ``recipe.model`` with ``recipe.marker_set``'s sites; with neither,
    the bundled humanoid with the bundled set the ``labels`` fit (None: its own sites)."""
    name = recipe.marker_set
    if name is None and recipe.model is None:
        if labels is None:
            return ModelChoice(ParameterSet(), None)
        name = detected_set(labels)
    path = set_path(name)
    return ModelChoice(ParameterSet(model_file(path, recipe.model)), path)


def recording(
    r: Source, pset: ParameterSet, first_frame: int = 0, rate: float | None = None
) -> Recording:
    """``r`` as a :class:`Recording` in ``pset``'s marker order (a trajectory's markers
    selected by name, a copy; a TrialData's copied when corrected)."""
    if isinstance(r, Recording):
        return r
    if isinstance(r, MarkerTrajectory):
        name = str(r.source.get("path", "recording"))
        return Recording(name, r.select(pset.marker_names), r.times, r.rate, r.first_frame, True)
    times = np.asarray(r.times, dtype=float)
    return Recording(r.name, r.markers, times, rate or _rate(times), first_frame)


def _rate(times: np.ndarray) -> float:
    """Frame rate [Hz] of times (T,) [s] (their median step); 100 Hz for a single frame."""
    steps = np.diff(np.asarray(times, dtype=float))
    return float(1.0 / np.median(steps)) if len(steps) and np.median(steps) > 0 else 100.0


class Selected(NamedTuple):
    """The recipe's frames of each recording, its excluded markers' data dropped
    (:func:`selected`): the trials, each one's first frame in its recording's numbering,
    the recordings' rates [Hz] and the markers excluded."""

    trials: list[TrialData]
    first_frames: list[int]
    rates: list[float]
    excluded: tuple[str, ...]


def prepare(
    recordings: Sequence[Recording],
    recipe: Recipe,
    subject: Subject | None,
    model: ModelChoice,
) -> Prepared:
    """The trials of the fit of ``recordings`` as ``recipe`` says (the module's text):
    :func:`selected`, then :func:`checked`. Bad input raises
    :class:`~mocap_mj.errors.MocapError` before the quality check notices anything."""
    return checked(selected(recordings, recipe, model.pset), recipe, subject, model)


def selected(recordings: Sequence[Recording], recipe: Recipe, pset: ParameterSet) -> Selected:
    """The recipe's frames and excluded markers of ``recordings`` (markers copied unless the
    pipeline's own), each trial refused unless some frame is usable
    (:func:`~mocap_mj.capture.checks.check_markers`)."""
    excluded = parse_marker_list(",".join(recipe.exclude_markers), pset.marker_names)
    trials, firsts = [], []
    for r in recordings:
        sl = frame_range(recipe.frames, len(r.markers), r.name)
        if sl.stop - sl.start < 1:
            raise MocapError(f"{r.name}: --frames {recipe.frames} selects no frame")
        firsts.append(r.first_frame + sl.start)  # the recording's own numbering
        markers = r.markers[sl] if r.own else np.array(r.markers[sl], dtype=float)
        trials.append(TrialData(r.name, exclude_markers(markers, pset.marker_names, excluded),
                                np.asarray(r.times[sl], dtype=float)))  # fmt: skip
        check_markers(r.name, pset.marker_names, trials[-1].markers,
                      recorded_floor(trials[-1].markers))  # fmt: skip
    return Selected(trials, firsts, [r.rate for r in recordings], excluded)


def checked(
    chosen: Selected, recipe: Recipe, subject: Subject | None, model: ModelChoice
) -> Prepared:
    """``chosen``'s trials with the subject's widths the set's landmarks measure, then the
    quality check and the labels' correction, the ghost and jump samples dropped, and under
    ``recipe.strict`` a misplaced T10 refused."""
    pset, trials, firsts = model.pset, chosen.trials, chosen.first_frames
    landmarks, bodies = set_landmarks(model.set_file, recipe.model)
    subject = with_set_radius(model.set_file, subject or Subject())
    subject = with_measured_widths(landmarks, bodies, pset.marker_names, trials, subject)
    check_select(recipe.select, len(trials))  # before any notice
    checks = [
        Checked(t.name, t.markers, rate, f)
        for t, rate, f in zip(trials, chosen.rates, firsts, strict=True)
    ]
    policy = Policy(strict=recipe.strict, relabel=recipe.relabel, one_model=True)
    found, quality = check_trials(pset, checks, chosen.excluded, policy)
    trials = [
        t._replace(markers=without_ghosts(t.markers, pset, found, t.name, f))
        for t, f in zip(trials, firsts, strict=True)
    ]
    if recipe.strict and recipe.anatomy:
        _refuse_misplaced_t10(pset, trials, subject)
    return Prepared(recipe, pset, trials, firsts, subject, quality, landmarks)


def with_measured_widths(
    landmarks: Mapping[str, str],
    bodies: Mapping[str, str],
    names: Sequence[str],
    trials: Sequence[TrialData],
    subject: Subject,
) -> Subject:
    """``subject`` with the joint widths that the set's landmark pairs measure in ``trials``
    (markers (T, M, 3) [m] in the order ``names``) where none is given
    (:func:`mocap_mj.capture.landmarks.measured_widths`); a given width that differs by more
    than 10 mm is kept, with a notice."""
    if not landmarks:
        return subject
    found = measured_widths(
        dict(landmarks), dict(bodies), list(names), [t.markers for t in trials],
        2 * subject.marker_radius,
    )  # fmt: skip
    given = {m.name: v for m in found if (v := subject.get(m.name)) is not None}
    for line in disagreements(found, given):
        notice(f"warning: {line}")
    for m in found:
        if m.name not in given:
            subject.set(m.name, m.value, m.source)
    return subject


def _refuse_misplaced_t10(pset: ParameterSet, trials: list[TrialData], subject: Subject) -> None:
    """``strict``: refuse the trials when T10's placement finding (found in the fit, from the
    stature, estimated from the markers when not measured:
    :func:`~mocap_mj.anatomy.trunk.t10_placement`) would be reported, as the marker-data
    findings are: strict refuses whatever the run would warn about."""
    placement = t10_placement(
        pset, trials, with_stature(subject, pset, [t.markers for t in trials])
    )
    if placement is not None and placement.finding is not None:
        raise MocapError(
            f"{placement.finding.message}; --strict refuses a placement finding (re-place "
            "the marker, drop it with --exclude-markers T10, or run without --strict)"
        )
