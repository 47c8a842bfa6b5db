"""Checks of the Python API's arguments where they enter, as reusable validators.

A public function or class checks each argument on entry (its type, an array's shape and
values, times that increase, rates above zero, lengths that agree, a marker cloud of a
human's size) with the validators here, and a bad one raises one
:class:`~mocap_mj.errors.ArgumentError` (or its subclasses :class:`ArgumentTypeError`,
:class:`ShapeError`) naming the argument, what it received and what was expected, rather
than an ``IndexError`` or ``ZeroDivisionError`` deep inside a solver. :func:`validated` runs a
function's checks on its bound arguments before its body. They are vectorised and cost about
a millisecond per call against a solve of seconds (``benchmarks/arguments.py``).
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from os import PathLike
from typing import Any, ParamSpec, TypeVar

import numpy as np

from mocap_mj.io.units import CLOUD_EXTENT, frame_extents, median_extent

from .errors import ArgumentError, ArgumentTypeError, ShapeError, excerpt

P = ParamSpec("P")
R = TypeVar("R")
#: A check of one argument: it receives the argument's name and value.
Check = Callable[[str, Any], object]
#: A whole-call check: it receives the call's arguments by name (those given only).
CallCheck = Callable[[Mapping[str, Any]], None]
#: Frames of a recording whose marker cloud is measured by :func:`marker_spacing`: evenly
#: spaced, enough for a median that a few bad frames do not move, cheap on an hour's trial.
SPACING_FRAMES = 200


def received(value: object) -> str:
    """What a message says was received: the type, and a short excerpt of the value."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = excerpt(value)
    return text if text.startswith("a ") else f"{type(value).__name__} {text}"


def kind(name: str, value: object, kinds: type | tuple[type, ...], what: str) -> None:
    """Raise :class:`ArgumentTypeError` unless ``value`` is an instance of ``kinds``."""
    if not isinstance(value, kinds):
        hint = ""
        fields = hasattr(kinds, "__dataclass_fields__") or hasattr(kinds, "_fields")
        if isinstance(value, Mapping) and isinstance(kinds, type) and fields:
            hint = f" (build it with {kinds.__name__}(**fields))"
        raise ArgumentTypeError(f"{name}: expected {what}, got {received(value)}{hint}")


def instance(kinds: type | tuple[type, ...], what: str) -> Check:
    """The check that a value is one of ``kinds`` (``what`` names them in the message)."""
    return lambda name, value: kind(name, value, kinds, what)


def optional(check: Check) -> Check:
    """``check``, with None accepted (the argument's default)."""

    def run(name: str, value: Any) -> None:
        if value is not None:
            check(name, value)

    return run


def array(
    name: str,
    value: object,
    shape: tuple[int | None, ...],
    *,
    missing: bool = False,
    keep: bool = False,
) -> np.ndarray:
    """``value`` as a float array of ``shape`` (None: any length on that axis) whose entries
    are finite, NaN allowed where ``missing`` (a marker not seen). A nested list converts; a
    text, a mapping or a ragged list does not. ``keep``: a numeric array is returned as it
    is (its dtype kept, as a file stored it)."""
    if isinstance(value, str | bytes | Mapping) or value is None:
        raise ArgumentTypeError(
            f"{name}: expected an array {_shape_text(shape)}, got {received(value)}"
        )
    try:
        numeric = isinstance(value, np.ndarray) and np.issubdtype(value.dtype, np.number)
        out = np.asarray(value) if keep and numeric else np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentTypeError(
            f"{name}: expected an array {_shape_text(shape)} of numbers, got {received(value)}"
        ) from None
    if out.ndim != len(shape) or any(
        want is not None and want != have for want, have in zip(shape, out.shape, strict=False)
    ):
        raise ShapeError(f"{name}: expected shape {_shape_text(shape)}, got {out.shape}")
    if np.issubdtype(out.dtype, np.inexact):
        finite(name, out, missing=missing)
    return out


def finite(name: str, values: np.ndarray, *, missing: bool = False) -> None:
    """Raise :class:`ArgumentError` at the first entry of ``values`` that is inf (or NaN,
    unless ``missing`` allows it), naming its index."""
    bad = np.isinf(values) if missing else ~np.isfinite(values)
    if bad.any():
        where = tuple(int(i) for i in np.unravel_index(int(np.argmax(bad)), values.shape))
        allowed = "finite numbers, NaN where missing" if missing else "finite numbers"
        raise ArgumentError(f"{name}: expected {allowed}, got {values[where]} at index {where}")


def increasing(name: str, times: np.ndarray) -> None:
    """Raise :class:`ArgumentError` unless ``times`` (T,) increase strictly."""
    steps = np.diff(times)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise ArgumentError(
            f"{name}: expected strictly increasing times [s], got {times[i]:g} then "
            f"{times[i + 1]:g} at index {i + 1}"
        )


def number(name: str, value: object, *, low: float = -math.inf, low_open: bool = False) -> float:
    """``value`` as a finite float at least ``low`` (above it when ``low_open``); a bool is
    not a number here."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{name}: expected a number, got {received(value)}")
    out = float(value)
    if not math.isfinite(out) or out < low or (low_open and out == low):
        bound = f"above {low:g}" if low_open else f"at least {low:g}"
        raise ArgumentError(f"{name}: expected a finite number {bound}, got {out!r}")
    return out


def positive(name: str, value: object) -> float:
    """``value`` as a finite float above zero (a rate [Hz], a width [m])."""
    return number(name, value, low=0.0, low_open=True)


def whole(name: str, value: object, *, low: int = 0) -> int:
    """``value`` as an int at least ``low`` (an integer float or NumPy integer converts)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{name}: expected a whole number, got {received(value)}")
    if not float(value).is_integer() or value < low:
        raise ArgumentError(f"{name}: expected a whole number at least {low}, got {value!r}")
    return int(float(value))


def sequence(name: str, value: object, what: str, length: int | None = None) -> list[Any]:
    """``value`` as a list (a list, tuple or other sequence; not a text or a mapping), of
    ``length`` entries when given."""
    if isinstance(value, str | bytes | Mapping | np.ndarray) or not isinstance(value, Sequence):
        raise ArgumentTypeError(f"{name}: expected a sequence of {what}, got {received(value)}")
    if length is not None and len(value) != length:
        raise ArgumentError(f"{name}: expected {length} entries (one per trial), got {len(value)}")
    return list(value)


def optional_callable(name: str, value: object) -> None:
    """Raise :class:`ArgumentTypeError` unless ``value`` is None or callable."""
    if value is not None and not callable(value):
        raise ArgumentTypeError(f"{name}: expected a function or None, got {received(value)}")


def path_like(name: str, value: object) -> None:
    """Raise :class:`ArgumentTypeError` unless ``value`` is a path (a str or os.PathLike)."""
    if isinstance(value, bool) or not isinstance(value, str | PathLike):
        raise ArgumentTypeError(f"{name}: expected a file or folder path, got {received(value)}")


def marker_spacing(name: str, markers: np.ndarray) -> None:
    """Raise :class:`ArgumentError` unless markers (T, M, 3) [m] span a human: the median
    extent of a frame's marker cloud (:func:`mocap_mj.io.units.cloud_extent`, on up to
    :data:`SPACING_FRAMES` frames) within :data:`~mocap_mj.io.units.CLOUD_EXTENT`. Millimetres
    given as metres measure a thousand times too large, metres given as millimetres a
    thousand times too small; the message says so. No frame with 2 markers: not checked."""
    rows = np.unique(
        np.linspace(0, len(markers) - 1, min(len(markers), SPACING_FRAMES)).astype(int)
    )
    size = median_extent(frame_extents(markers[rows])) if len(markers) else None
    low, high = CLOUD_EXTENT
    if size is None or low <= size <= high:
        return
    if size > high:
        guess = f"millimetres given as metres? ({size * 1e-3:.4g} m if so: divide by 1000)"
    else:
        guess = f"metres divided by 1000 twice? ({size * 1e3:.4g} m if so: multiply by 1000)"
    raise ArgumentError(
        f"{name}: the marker cloud measures {size:.4g} m across (median over frames), a human's "
        f"measures {low:g}..{high:g} m: {guess} (lengths are in metres)"
    )


def validated(
    *whole_call: CallCheck, **checks: Callable[[str, Any], object]
) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """A decorator that runs ``checks`` (argument name -> validator(name, value)) on the
    arguments a call gives, then each ``whole_call`` check (arguments that depend on each
    other) on all of them, before the function's body. An argument left at its default is
    not checked (the defaults are valid). A call that does not bind (a missing or unknown
    argument) raises :class:`ArgumentTypeError` naming the function."""

    def wrap(func: Callable[P, R]) -> Callable[P, R]:
        signature = inspect.signature(func)
        unknown = set(checks) - set(signature.parameters)
        if unknown:
            raise TypeError(f"{func.__qualname__} has no argument {', '.join(sorted(unknown))}")

        @functools.wraps(func)
        def run(*args: P.args, **kwargs: P.kwargs) -> R:
            try:
                given = signature.bind(*args, **kwargs).arguments
            except TypeError as exc:
                raise ArgumentTypeError(f"{func.__name__}: {exc}") from None
            for name, check in checks.items():
                if name in given:
                    check(name, given[name])
            for check_call in whole_call:
                check_call(given)
            return func(*args, **kwargs)

        return run

    return wrap


def _shape_text(shape: tuple[int | None, ...]) -> str:
    return (
        "("
        + ", ".join("*" if s is None else str(s) for s in shape)
        + ("," if len(shape) == 1 else "")
        + ")"
    )
