"""Bad arguments to the Python API raise one MocapError subclass naming the argument.

The bad calls are generated: for each entry point of ``mocap_mj`` (``identify``,
``TrialData``, ``Recipe``, ``solve_motion``, ``Motion``, ``write_result``, ``ParameterSet``,
``Kinematics``, ``KinematicParameter``, ``load_model``, ``model_path``) and each argument, a
wrong type, a wrong shape, NaN, inf, decreasing or constant times, zero or negative rates,
mismatched lengths, a dict for a dataclass and markers in mm given as metres (or metres
divided by 1000 once more). Every call must raise :class:`~mocap_mj.errors.MocapError` (any
other exception fails the test) with a one-line message naming the argument; none may reach
a solver. Good calls are the other tests' (test_api.py, test_identify.py); here only the
conversions of array-likes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mocap_mj
from mocap_mj import Hooks, MocapError, ParameterSet, Recipe, TrialData, Tuning
from mocap_mj.errors import ArgumentError
from mocap_mj.pipeline.fit import Fit

#: Frames of the good trial: enough for times to increase, few for speed.
FRAMES = 6

Call = Callable[[], object]


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


@pytest.fixture(scope="module")
def trial(pset: ParameterSet) -> TrialData:
    """A good trial: the bundled model's markers (T, 39, 3) [m] at its initial pose, swaying."""
    kin = mocap_mj.Kinematics(pset)
    qpos = np.tile(pset.model.qpos0, (FRAMES, 1))
    qpos[:, 0] = np.linspace(0.0, 0.05, FRAMES)  # the pelvis moves 5 cm forward
    return TrialData("good", kin.marker_positions(qpos), np.arange(FRAMES) / 100.0)


def bad_arrays(good: np.ndarray, *, nan: bool = True) -> Iterator[tuple[str, object]]:
    """Bad versions of an array argument: wrong types, wrong shapes, inf (and NaN unless
    ``nan`` is allowed there)."""
    yield "text", "not an array"
    yield "dict", {"values": good.tolist()}
    yield "one axis fewer", good[0] if good.ndim > 1 else np.float64(good[0])
    yield "one axis more", good[None]
    yield "ragged list", [[0.0, 1.0], [2.0]]
    with_inf = good.astype(float).copy()
    with_inf.flat[-1] = np.inf
    yield "inf", with_inf
    if nan:
        with_nan = good.astype(float).copy()
        with_nan.flat[-1] = np.nan
        yield "NaN", with_nan


def bad_times(good: np.ndarray) -> Iterator[tuple[str, object]]:
    """Bad times (T,) [s]: bad arrays, decreasing, constant, one too few."""
    yield from bad_arrays(good)
    yield "decreasing", good[::-1].copy()
    yield "constant", np.zeros_like(good)
    yield "one too few", good[:-1]


def bad_rates(n: int) -> Iterator[tuple[str, object]]:
    """Bad per-trial rates [Hz] of ``n`` trials."""
    for label, rate in (("zero", 0.0), ("negative", -100.0), ("NaN", math.nan), ("inf", math.inf)):
        yield label, [rate] * n
    yield "text", ["100"] * n
    yield "a number, not a sequence", 100.0
    yield "one too many", [100.0] * (n + 1)


def trial_cases(trial: TrialData) -> Iterator[tuple[str, str, Call]]:
    """``TrialData(name, markers, times, weights)`` with one argument bad."""
    m, t = trial.markers, trial.times
    for label, value in (("int", 3), ("None", None), ("dict", {})):
        yield "name", label, lambda v=value: TrialData(v, m, t)  # type: ignore[arg-type]
    for label, value in bad_arrays(m, nan=False):
        yield "markers", label, lambda v=value: TrialData("t", v, t)  # type: ignore[arg-type]
    for label, value in bad_times(t):
        yield "times", label, lambda v=value: TrialData("t", m, v)  # type: ignore[arg-type]
    weights = np.ones(m.shape[:2])
    for label, value in [*bad_arrays(weights), ("negative", -weights)]:
        yield "weights", label, lambda v=value: TrialData("t", m, t, v)  # type: ignore[arg-type]


def recipe_cases() -> Iterator[tuple[str, str, Call]]:
    """``Recipe(field=...)``: for every field a value of another kind and out-of-range
    numbers (every field's range excludes them)."""
    for field in dataclasses.fields(Recipe):
        for label, value in (
            ("object", object()),
            ("unknown word", "nonsense"),
            ("NaN", math.nan),
            ("inf", math.inf),
            ("negative", -1.0),
            ("dict", {}),
        ):
            yield field.name, label, lambda f=field.name, v=value: Recipe(**{f: v})


def identify_cases(trial: TrialData, pset: ParameterSet) -> Iterator[tuple[str, str, Call]]:
    """``mocap_mj.identify(recordings, recipe, subject, **options)`` with one argument bad."""

    def call(**kw: Any) -> Call:
        args = {"recordings": [trial], "recipe": Recipe(max_iterations=1), **kw}
        return lambda: mocap_mj.identify(**args)

    scaled = {"mm as m": 1e3, "m divided by 1000": 1e-3}
    fewer = TrialData("fewer", trial.markers[:, :-1], trial.times)
    bad_trials: list[tuple[str, object]] = [
        ("one TrialData, not a list", trial),
        ("empty", []),
        ("text", "trial.c3d"),
        ("dict in the list", [trial._asdict()]),
        ("tuple in the list", [tuple(trial)]),
        ("no frames", [TrialData("empty", trial.markers[:0], trial.times[:0])]),
        ("38 markers", [fewer]),
        ("a list by _replace", [trial._replace(markers=trial.markers.tolist())]),
        ("NaN times by _replace", [trial._replace(times=trial.times * np.nan)]),
        *((k, [trial._replace(markers=trial.markers * f)]) for k, f in scaled.items()),
    ]
    for label, value in bad_trials:
        yield "recordings", label, call(recordings=value)
    yield "recordings", "missing", lambda: mocap_mj.identify(recipe=Recipe())  # type: ignore[call-arg]
    recipe_dict = dataclasses.asdict(Recipe())
    for label, value in (("dict", recipe_dict), ("text", "l2"), ("None", None)):
        yield "recipe", label, call(recipe=value)
    for name, kinds in (
        ("subject", ("dict", "text")),
        ("pset", ("dict", "text")),
        ("tuning", ("dict", "text")),
        ("hooks", ("dict", "text")),
        ("landmarks", ("text",)),
    ):
        for label in kinds:
            yield name, label, call(**{name: {"a": 1} if label == "dict" else "text"})
    yield "landmarks", "numbers", call(landmarks={1: 2})
    for field in ("tolerances", "performance"):
        for label, value in (("dict", {"a": 1}), ("text", "text")):
            yield f"tuning.{field}", label, call(tuning=Tuning(**{field: value}))
    for field in ("progress", "motion_progress"):
        yield f"hooks.{field}", "not callable", call(hooks=Hooks(**{field: 3}))
    yield "hooks.motion_sink", "dict", call(hooks=Hooks(motion_sink={"a": 1}))
    for label, value in bad_arrays(pset.nominal):
        yield "theta0", label, call(theta0=value)
    yield "theta0", "one too many", call(theta0=np.append(pset.nominal, 0.0))
    yield from recording_cases(trial, call)


def recording_cases(trial: TrialData, call: Callable[..., Call]) -> Iterator[tuple[str, str, Call]]:
    """``identify([Recording(name, markers, times, rate, first_frame)])`` with one field bad."""
    m, t = trial.markers, trial.times

    def one(**kw: Any) -> Call:
        fields = {"name": "r", "markers": m, "times": t, "rate": 100.0, **kw}
        return call(recordings=[mocap_mj.Recording(**fields)])

    for label, value in (("negative", -1), ("fraction", 1.5), ("text", "0")):
        yield "recordings[0].first_frame", label, one(first_frame=value)
    for label, rate in (("zero", 0.0), ("negative", -100.0), ("NaN", math.nan), ("inf", math.inf),
                        ("text", "100")):  # fmt: skip
        yield "recordings[0].rate", label, one(rate=rate)
    for label, value in bad_arrays(m, nan=False):
        yield "recordings[0]", f"markers {label}", one(markers=value)
    for label, value in bad_times(t):
        yield "recordings[0]", f"times {label}", one(times=value)
    yield "recordings[0]", "mm as m", one(markers=m * 1e3)
    yield "recordings[0]", "markers a nested list", one(markers=m.tolist())
    yield "recordings[0]", "times of ints", one(times=np.arange(len(t)))


def solve_motion_cases(trial: TrialData, pset: ParameterSet) -> Iterator[tuple[str, str, Call]]:
    """``mocap_mj.solve_motion(model, trial, loss=, settings=, sliding=, progress=)``."""

    def call(**kw: Any) -> Call:
        args = {"model": pset, "trial": trial, **kw}
        return lambda: mocap_mj.solve_motion(**args)

    for label, value in (("int", 3), ("dict", {})):
        yield "model", label, call(model=value)
    fewer = TrialData("fewer", trial.markers[:, :-1], trial.times)
    for label, value in (
        ("dict", trial._asdict()),
        ("a list of trials", [trial]),
        ("38 markers", fewer),
        ("mm as m", trial._replace(markers=trial.markers * 1e3)),
        ("no frames", TrialData("empty", trial.markers[:0], trial.times[:0])),
    ):
        yield "trial", label, call(trial=value)
    yield (
        "trial",
        "mm as m, model file",
        call(model=str(pset.path), trial=trial._replace(markers=trial.markers * 1e3)),
    )
    for label, value in (("unknown", "square"), ("int", 2)):
        yield "loss", label, call(loss=value)
    yield "settings", "dict", call(settings={"max_iterations": 3})
    yield "sliding", "text", call(sliding="yes")
    yield "progress", "not callable", call(progress=3)


def motion_cases(trial: TrialData, pset: ParameterSet) -> Iterator[tuple[str, str, Call]]:
    """``Motion(qpos, times, markers, marker_names, first_frame=)`` with one argument bad."""
    q = np.tile(pset.model.qpos0, (FRAMES, 1))
    m, t, names = trial.markers, trial.times, pset.marker_names
    for label, value in bad_arrays(q, nan=False):
        yield "qpos", label, lambda v=value: mocap_mj.Motion(v, t, m, names)  # type: ignore[arg-type]
    for label, value in bad_times(t):
        yield "times", label, lambda v=value: mocap_mj.Motion(q, v, m, names)  # type: ignore[arg-type]
    for label, value in bad_arrays(m, nan=False):
        yield "markers", label, lambda v=value: mocap_mj.Motion(q, t, v, names)  # type: ignore[arg-type]
    for label, value in (
        ("text", "LASI"),
        ("numbers", list(range(len(names)))),
        ("one fewer", names[:-1]),
    ):
        yield "marker_names", label, lambda v=value: mocap_mj.Motion(q, t, m, v)  # type: ignore[arg-type]
    for label, value in (("text", "0"), ("fraction", 1.5), ("negative", -1)):
        yield "first_frame", label, lambda v=value: mocap_mj.Motion(q, t, m, names, first_frame=v)  # type: ignore[arg-type]


def model_cases(tmp: Path, pset: ParameterSet) -> Iterator[tuple[str, str, Call]]:
    """The model's entry points: ``ParameterSet(path)``, ``Kinematics(pset)``,
    ``load_model(path)``, ``model_path(name)``, ``KinematicParameter(name, description,
    targets)``, ``write_result(fit, folder, ...)``, and the methods that take theta, poses or
    a path."""
    for label, value in (("int", 3), ("dict", {})):
        yield "path", label, lambda v=value: ParameterSet(v)  # type: ignore[arg-type]
        yield "pset", label, lambda v=value: mocap_mj.Kinematics(v)  # type: ignore[arg-type]
        yield "path", label, lambda v=value: mocap_mj.load_model(v)  # type: ignore[arg-type]
        yield "name", label, lambda v=value: mocap_mj.model_path(v)  # type: ignore[arg-type]
        yield "fit", label, lambda v=value: mocap_mj.write_result(v, tmp / "out")  # type: ignore[arg-type]
    kin = mocap_mj.Kinematics(pset)
    for label, value in bad_arrays(pset.nominal):
        yield "theta", label, lambda v=value: kin.set_theta(v)  # type: ignore[arg-type]
    for label, value in bad_arrays(np.tile(pset.model.qpos0, (2, 1)), nan=False):
        if label != "one axis fewer":  # one pose (nq,) is a frame
            yield "qpos", label, lambda v=value: kin.marker_positions(v)  # type: ignore[arg-type]
    for method in (pset.load_json, lambda path: pset.save_json(path, pset.nominal),
                   lambda path: pset.export_mjcf(path, pset.nominal)):  # fmt: skip
        yield "path", "int", lambda m=method: m(3)
    kp = mocap_mj.KinematicParameter
    for label, value in (("int", 3), ("dict", {})):
        yield "name", label, lambda v=value: kp(v, "d", (("pelvis", "x"),))  # type: ignore[arg-type]
        yield "description", label, lambda v=value: kp("n", v, (("pelvis", "x"),))  # type: ignore[arg-type]
    for label, value in (("text", "pelvis"), ("unknown axis", (("pelvis", "w"),)),
                         ("a single", (("pelvis",),)), ("int", 3)):  # fmt: skip
        yield "targets", label, lambda v=value: kp("n", "d", v)  # type: ignore[arg-type]
    fit = Fit.__new__(Fit)  # a Fit's type alone: the checks come before any field is read
    yield "folder", "int", lambda: mocap_mj.write_result(fit, 3)  # type: ignore[arg-type]
    yield "force", "text", lambda: mocap_mj.write_result(fit, tmp / "out", force="yes")  # type: ignore[arg-type]
    yield "inputs", "text", lambda: mocap_mj.write_result(fit, tmp / "out", inputs="a.c3d")  # type: ignore[arg-type]


def all_cases(tmp: Path, good: TrialData, pset: ParameterSet) -> list[tuple[str, str, str, Call]]:
    """Every bad call: (entry point, argument, what is wrong, the call)."""
    groups = {
        "TrialData": trial_cases(good),
        "Recipe": recipe_cases(),
        "identify": identify_cases(good, pset),
        "solve_motion": solve_motion_cases(good, pset),
        "Motion": motion_cases(good, pset),
        "model": model_cases(tmp, pset),
    }
    return [(entry, *case) for entry, cases in groups.items() for case in cases]


def test_every_bad_argument_raises_a_mocap_error_naming_it(
    tmp_path: Path, trial: TrialData, pset: ParameterSet
) -> None:
    """One test over all the generated calls (a few hundred, a second): each must raise a
    MocapError whose one-line message names its argument; the failures are listed together."""
    cases = all_cases(tmp_path, trial, pset)
    assert len(cases) > 200, len(cases)
    wrong = []
    for entry, argument, label, call in cases:
        try:
            call()
        except MocapError as exc:
            message = str(exc)
            if argument not in message or "\n" in message:
                wrong.append(f"{entry} {argument} ({label}): message {message!r}")
        except Exception as exc:  # any other exception is the failure sought
            wrong.append(f"{entry} {argument} ({label}): {type(exc).__name__}: {exc}")
        else:
            wrong.append(f"{entry} {argument} ({label}): accepted")
    assert not wrong, "\n".join(wrong)
    assert not (tmp_path / "out").exists()  # nothing written by a refused write_result


def test_mm_given_as_metres_is_named_as_such(trial: TrialData) -> None:
    with pytest.raises(ArgumentError, match="millimetres given as metres") as err:
        mocap_mj.identify([trial._replace(markers=trial.markers * 1e3)])
    assert "recordings[0]" in str(err.value)
    with pytest.raises(ArgumentError, match="multiply by 1000"):
        mocap_mj.identify([trial._replace(markers=trial.markers * 1e-3)])


def test_array_likes_convert_and_errors_are_value_and_type_errors(trial: TrialData) -> None:
    """A nested list is an array (the same values); a refused argument is also the Python
    exception a caller would catch (ValueError; TypeError for a wrong type)."""
    listed = TrialData("good", trial.markers.tolist(), trial.times.tolist())  # type: ignore[arg-type]
    assert isinstance(listed.markers, np.ndarray) and isinstance(listed.times, np.ndarray)
    assert np.array_equal(listed.markers, trial.markers)
    assert np.array_equal(listed.times, trial.times)
    assert listed.markers is not trial.markers
    assert TrialData("same", trial.markers, trial.times).markers is trial.markers  # no copy
    with pytest.raises(ValueError, match="times"):
        TrialData("t", trial.markers, trial.times[::-1])
    with pytest.raises(TypeError, match="recipe"):
        mocap_mj.identify([trial], {"loss": "l2"})  # type: ignore[arg-type]
