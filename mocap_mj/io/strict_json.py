"""Strict JSON for every file and line mocap-mj writes: ``NaN`` and infinities become ``null``.

Python's :mod:`json` writes ``NaN``/``Infinity`` by default, which is not JSON (``jq``,
JavaScript and most readers reject the file). A quantity that could not be computed (e.g. the
marker RMSE of a trial without a solved frame) is written as ``null`` instead.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["dumps", "jsonable", "read_object"]


def jsonable(obj: Any) -> Any:
    """``obj`` with non-finite floats as None, numpy scalars/arrays as Python numbers/lists,
    tuples as lists and mapping keys as strings."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def dumps(obj: Any, *, indent: int | None = None) -> str:
    """``json.dumps`` of :func:`jsonable` (``obj``), refusing anything that is not strict JSON."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False)


def read_object(path: str | Path, what: str) -> dict[str, Any]:
    """The JSON object in the file ``path`` (``what`` it should hold, for the message).

    Raises
    ------
    InputFileError
        One line naming the file and what was expected: it cannot be read, is not JSON
        (truncated, garbage, not UTF-8) or holds another JSON value than an object.
    """
    from mocap_mj.errors import InputFileError

    try:
        data = json.loads(Path(path).read_bytes())
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError
        raise InputFileError(f"{path}: not JSON, expected {what} ({exc})") from None
    if not isinstance(data, dict):
        raise InputFileError(f"{path}: expected {what}, got a JSON {type(data).__name__}")
    return data
