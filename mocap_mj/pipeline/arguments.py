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
from mocap_mj.pipeline.recipe import Recipe
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


def loss_name(name: str, value: Any) -> None:
    """One of :data:`~mocap_mj.solve.losses.LOSS_NAMES`."""
    if not isinstance(value, str) or value not in LOSS_NAMES:
        raise ArgumentError(
            f"{name}: expected one of {', '.join(LOSS_NAMES)}, got {excerpt(value)}"
        )


def markers_of(trials: list[TrialData], names: tuple[str, ...], argument: str) -> None:
    """Each trial's markers (T, M, 3) in the model's marker order (M = ``len(names)``), in
    metres (:func:`~mocap_mj.arguments.marker_spacing`)."""
    for i, trial in enumerate(trials):
        index = f"[{i}]" if argument == "trials" else ""
        where = f"{argument}{index} {excerpt(trial.name)}: markers"
        if trial.markers.shape[1] != len(names):
            raise ShapeError(
                f"{where}: expected shape (*, {len(names)}, 3), the model's markers in its "
                f"order, got {trial.markers.shape}"
            )
        marker_spacing(where, trial.markers)


def identify_call(given: Mapping[str, Any]) -> None:
    """The checks of :func:`~mocap_mj.pipeline.api.identify`'s arguments together: the
    markers against the model's, one first frame and one rate per trial, theta0's size."""
    trials = list(given["trials"])
    pset = given.get("pset")
    names = MARKER_NAMES if pset is None else pset.marker_names
    markers_of(trials, names, "trials")
    for name in ("first_frames", "rates"):
        if given.get(name) is not None:
            sequence(name, given[name], "values", length=len(trials))
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
    "trials": trials_list,
    "recipe": instance(Recipe, "a Recipe"),
    "subject": optional(instance(Subject, "a Subject or None")),
    "pset": optional(instance(ParameterSet, "a ParameterSet or None")),
    "theta0": optional(lambda name, value: array(name, value, (None,))),
    "first_frames": optional(per_trial(lambda name, value: whole(name, value))),
    "rates": optional(per_trial(positive)),
    "quality": optional(instance(Mapping, "summary.json's marker_quality entry or None")),
    "tolerances": optional(instance(Tolerances, "a Tolerances or None")),
    "performance": optional(instance(Performance, "a Performance or None")),
    "progress": optional_callable,
    "motion_progress": optional_callable,
    "motion_sink": optional(path_like),
    "landmarks": optional(landmark_map),
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
