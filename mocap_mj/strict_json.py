"""Strict JSON for every file and line mocap-mj writes: ``NaN`` and infinities become ``null``.

Python's :mod:`json` writes ``NaN``/``Infinity`` by default, which is not JSON (``jq``,
JavaScript and most readers reject the file). A quantity that could not be computed (e.g. the
marker RMSE of a trial without a solved frame) is written as ``null`` instead.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["dumps", "jsonable"]


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
