"""What :func:`mocap_mj.identify` and :func:`mocap_mj.solve_motion` take, checked on entry.

Each entry point's arguments by name, with the validator of each
(:mod:`mocap_mj.arguments`), and the checks of arguments that depend on one another (the
markers' count against the model's, one first frame and one rate per trial, a marker cloud
of a human's size in metres). Used as ``@validated(identify_call, **IDENTIFY)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mocap_mj.capture.subject import Subject
from mocap_mj.io.marker_names import MARKER_NAMES
from mocap_mj.io.trajectory import MarkerTrajectory
from mocap_mj.pipeline.prepare import Recording
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.run_options import Hooks, Tuning
from mocap_mj.skeleton.parameters import KINEMATIC_PARAMETERS, ParameterSet
from mocap_mj.solve.ik import IKSettings
from mocap_mj.solve.losses import LOSS_NAMES
from mocap_mj.solve.problem import TrialData, trial_arrays
from mocap_mj.solve.settings import Performance, Tolerances

from ..arguments import (
    Check,
    array,
    instance,
    kind,
    marker_spacing,
    optional,
    optional_callable,
    path_like,
    positive,
    received,
    sequence,
    whole,
)
from ..errors import ArgumentError, ArgumentTypeError, ShapeError, excerpt


def trials_list(name: str, value: Any) -> None:
    """A non-empty sequence of :class:`TrialData`, each with a frame at least."""
    if isinstance(value, TrialData):
        raise ArgumentError(
            f"{name}: expected a sequence of TrialData, got one TrialData: pass [trial]"
        )
    items = sequence(name, value, "TrialData")
    if not items:
        raise ArgumentError(f"{name}: expected at least one trial, got none")
    for i, trial in enumerate(items):
        one_trial(f"{name}[{i}]", trial)


def recordings_list(name: str, value: Any) -> None:
    """A non-empty sequence of recordings: trajectories (:func:`~mocap_mj.io.load_markers`'s,
    checked when made), :class:`~mocap_mj.pipeline.prepare.Recording` or :class:`TrialData`
    (:func:`one_trial`)."""
    if isinstance(value, TrialData | MarkerTrajectory):
        raise ArgumentError(
            f"{name}: expected a sequence of recordings, got one {type(value).__name__}: "
            "pass [recording]"
        )
    items = sequence(name, value, "recordings")
    if not items:
        raise ArgumentError(f"{name}: expected at least one recording, got none")
    for i, item in enumerate(items):
        if isinstance(item, Recording):
            one_recording(f"{name}[{i}]", item)
        elif not isinstance(item, MarkerTrajectory):
            one_trial(f"{name}[{i}]", item)


def one_trial(name: str, value: Any) -> None:
    """A :class:`TrialData` with a frame at least, its fields as :func:`trial_arrays` takes
    them (checked again: ``_replace`` builds a trial without the checks)."""
    kind(name, value, TrialData, "a TrialData(name, markers (T, M, 3) [m], times (T,) [s])")
    try:
        fields = trial_arrays(*value)
    except ArgumentError as exc:
        raise type(exc)(f"{name}: {exc}") from None
    for field, checked in zip(value._fields[1:], fields[1:], strict=True):
        if checked is not getattr(value, field):
            raise ArgumentTypeError(
                f"{name}: {field}: expected a float array, got "
                f"{received(getattr(value, field))} (TrialData(...) converts it)"
            )
    if len(value.markers) == 0:
        raise ArgumentError(f"{name} {excerpt(value.name)}: expected at least one frame, got none")


def per_trial(check: Check) -> Check:
    """A check of a sequence with ``check`` on each entry (lengths: :func:`identify_call`)."""

    def run(name: str, value: Any) -> None:
        for i, item in enumerate(sequence(name, value, "values, one per trial")):
            check(f"{name}[{i}]", item)

    return run


def landmark_map(name: str, value: Any) -> None:
    """A mapping of marker names to landmark names."""
    kind(name, value, Mapping, "a mapping of marker names to landmark names")
    for marker, landmark in value.items():
        if not isinstance(marker, str) or not isinstance(landmark, str):
            raise ArgumentError(
                f"{name}: expected marker name -> landmark name (texts), got "
                f"{excerpt(marker)}: {excerpt(landmark)}"
            )


def tuning_fields(name: str, value: Any) -> None:
    """A :class:`~mocap_mj.pipeline.run_options.Tuning` with fields of their types."""
    kind(name, value, Tuning, "a Tuning(tolerances, performance) or None")
    optional(instance(Tolerances, "a Tolerances or None"))(f"{name}.tolerances", value.tolerances)
    optional(instance(Performance, "a Performance or None"))(
        f"{name}.performance", value.performance
    )


def hooks_fields(name: str, value: Any) -> None:
    """A :class:`~mocap_mj.pipeline.run_options.Hooks` with fields of their types."""
    kind(name, value, Hooks, "a Hooks(progress, motion_progress, motion_sink) or None")
    optional_callable(f"{name}.progress", value.progress)
    optional_callable(f"{name}.motion_progress", value.motion_progress)
    optional(path_like)(f"{name}.motion_sink", value.motion_sink)


def one_recording(name: str, value: Recording) -> None:
    """A :class:`~mocap_mj.pipeline.prepare.Recording`: its markers and times as a trial's
    (:func:`~mocap_mj.solve.problem.trial_arrays`) and float arrays already (a Recording
    keeps what it is given), a frame at least, a positive rate [Hz] and a whole first frame."""
    try:
        _, markers, times, _ = trial_arrays(value.name, value.markers, value.times)
    except ArgumentError as exc:
        raise type(exc)(f"{name}: {exc}") from None
    for field, checked in (("markers", markers), ("times", times)):
        if checked is not getattr(value, field):
            raise ArgumentTypeError(
                f"{name}: {field}: expected a float array, got {received(getattr(value, field))} "
                "(np.asarray(..., dtype=float) converts it)"
            )
    if len(value.markers) == 0:
        raise ArgumentError(f"{name} {excerpt(value.name)}: expected at least one frame, got none")
    positive(f"{name}.rate", value.rate)
    whole(f"{name}.first_frame", value.first_frame)


def loss_name(name: str, value: Any) -> None:
    """One of :data:`~mocap_mj.solve.losses.LOSS_NAMES`."""
    if not isinstance(value, str) or value not in LOSS_NAMES:
        raise ArgumentError(
            f"{name}: expected one of {', '.join(LOSS_NAMES)}, got {excerpt(value)}"
        )


def markers_of(trials: list[TrialData | Recording], names: tuple[str, ...], argument: str) -> None:
    """Each trial's markers (T, M, 3) in the model's marker order (M = ``len(names)``), in
    metres (:func:`~mocap_mj.arguments.marker_spacing`)."""
    for i, trial in enumerate(trials):
        index = f"[{i}]" if argument in ("trials", "recordings") else ""
        where = f"{argument}{index} {excerpt(trial.name)}: markers"
        if trial.markers.shape[1] != len(names):
            raise ShapeError(
                f"{where}: expected shape (*, {len(names)}, 3), the model's markers in its "
                f"order, got {trial.markers.shape}"
            )
        marker_spacing(where, trial.markers)


def identify_call(given: Mapping[str, Any]) -> None:
    """The checks of :func:`~mocap_mj.pipeline.api.identify`'s arguments together: the
    markers against the model's (in metres), theta0's size."""
    recordings = list(given["recordings"])
    pset = given.get("pset")
    names = MARKER_NAMES if pset is None else pset.marker_names
    markers_of([r for r in recordings if isinstance(r, TrialData | Recording)], names, "recordings")
    for i, r in enumerate(recordings):
        if isinstance(r, MarkerTrajectory):
            marker_spacing(f"recordings[{i}] {excerpt(r.source.get('path', ''))}", r.positions)
    if given.get("theta0") is not None:
        size = len(KINEMATIC_PARAMETERS) + 3 * len(names) if pset is None else pset.size
        array("theta0", given["theta0"], (size,))


def solve_motion_call(given: Mapping[str, Any]) -> None:
    """The checks of :func:`~mocap_mj.pipeline.robust_ik.solve_motion`'s arguments together:
    a parameter set's markers against the trial's (a model file's are checked by the IK)."""
    model = given["model"]
    names = model.marker_names if isinstance(model, ParameterSet) else None
    if names is not None:
        markers_of([given["trial"]], names, "trial")
    else:
        marker_spacing(f"trial {excerpt(given['trial'].name)}: markers", given["trial"].markers)


#: :func:`~mocap_mj.pipeline.api.identify`'s arguments and their checks.
IDENTIFY: dict[str, Check] = {
    "recordings": recordings_list,
    "recipe": instance(Recipe, "a Recipe"),
    "subject": optional(instance(Subject, "a Subject or None")),
    "pset": optional(instance(ParameterSet, "a ParameterSet or None")),
    "theta0": optional(lambda name, value: array(name, value, (None,))),
    "landmarks": optional(landmark_map),
    "tuning": optional(tuning_fields),
    "hooks": optional(hooks_fields),
}
#: :func:`~mocap_mj.pipeline.robust_ik.solve_motion`'s arguments and their checks.
SOLVE_MOTION: dict[str, Check] = {
    "model": instance((ParameterSet, str, Path), "a ParameterSet or an MJCF file's path"),
    "trial": one_trial,
    "loss": loss_name,
    "settings": optional(instance(IKSettings, "an IKSettings or None")),
    "sliding": instance(bool, "True or False"),
    "progress": optional_callable,
}
