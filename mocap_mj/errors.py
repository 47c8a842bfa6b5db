"""One exception base class and its specific subclasses.

Every error the library raises on bad input derives from :class:`MocapError`, so a caller
(and the CLI, which turns it into a one-line message and a non-zero exit) can catch them all.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterable

#: Longest excerpt of a value or message quoted in an error [characters].
EXCERPT = 80


class MocapError(Exception):
    """Base class of every error mocap-mj raises on bad input or an impossible request."""


class ArgumentError(MocapError, ValueError):
    """An argument of the Python API that is not what the function takes (its value, range,
    units or length against another argument); the message names the argument."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of the wrong type (a dict for a dataclass, a string for an array...)."""


class ShapeError(ArgumentError):
    """An array argument has the wrong shape or dtype."""


class UnknownNameError(MocapError, KeyError):
    """A name (marker, parameter, joint, body) that the model does not have."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]) -> None:
        self.kind = kind
        self.name = name
        self.valid = list(valid)
        super().__init__(f"unknown {kind} {name!r}; the model has: {', '.join(self.valid)}")

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


class InputFileError(MocapError):
    """A file that cannot be read as what it claims to be (names file, row/group, expectation)."""


class SolverError(MocapError):
    """A solver could not run on the data it was given (too few markers, all-NaN frames...)."""


def check_shape(name: str, array: object, shape: tuple[int | None, ...]) -> None:
    """Raise :class:`ShapeError` naming ``name`` unless ``array.shape`` matches ``shape``.

    ``None`` in ``shape`` matches any length on that axis.
    """
    got = getattr(array, "shape", None)
    if (
        got is None
        or len(got) != len(shape)
        or any(want is not None and want != have for want, have in zip(shape, got, strict=True))
    ):
        want_txt = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ShapeError(f"{name}: expected shape {want_txt}, got {got}")


class OutputFolderError(MocapError):
    """An output folder that cannot be written (a file, not empty, read-only, no permission)."""


def excerpt(value: object, limit: int = EXCERPT) -> str:
    """``repr(value)`` on one line, cut to ``limit`` characters with "..." when longer.

    A container is shown by its type and length alone when its repr would be long, so that a
    document of shared (aliased) values is never expanded into a message."""
    if isinstance(value, dict | list | tuple | set) and len(value) > 8:
        return f"a {type(value).__name__} of {len(value)} entries"
    try:
        text = " ".join(_short_repr(value).split())
    except RecursionError:
        return f"a {type(value).__name__}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _short_repr(value: object) -> str:
    """A bounded repr: at most a few entries per container and levels deep."""
    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict, short.maxstring = 3, 6, 6, 60
    short.maxother = 60
    return short.repr(value)
