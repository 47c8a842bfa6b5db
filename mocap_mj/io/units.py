"""Length units as marker files state them, their size in metres, and a size sanity check;
the columns of a written table named and scaled by their unit."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocap_mj.errors import InputFileError

_METRES_PER_UNIT = {
    "mm": 1e-3, "millimeter": 1e-3, "millimeters": 1e-3, "millimetre": 1e-3, "millimetres": 1e-3,
    "cm": 1e-2, "centimeter": 1e-2, "centimeters": 1e-2, "centimetre": 1e-2, "centimetres": 1e-2,
    "m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0,
}  # fmt: skip

#: Plausible median per-frame extent of a marker cloud [m]: from a foot or hand marker set
#: (a few cm) to a full body with arms raised in a large volume. A unit error moves the
#: extent by 10x (cm/mm), 100x (m/cm) or 1000x (m/mm): a 1.7 m person measures 1,700 m when
#: millimetres are read as metres, 1.7 mm the other way round.
CLOUD_EXTENT = (0.05, 10.0)


def metres_per_unit(unit: str) -> float | None:
    """Metres in one ``unit`` (case-insensitive: mm, cm, m and their spelt-out names), or None."""
    return _METRES_PER_UNIT.get(unit.strip().lower())


def per_metre(unit: str) -> float:
    """How many ``unit`` (:func:`metres_per_unit`'s names) one metre holds: a written
    table's factor from metres; an unknown unit raises ``KeyError``."""
    metres = metres_per_unit(unit)
    if metres is None:
        raise KeyError(unit)
    return 1.0 / metres


def unit_column(name: str, unit: str) -> str:
    """The column of a written table holding quantity ``name`` in ``unit``, as every table
    of the tool names its columns: ``knee_l_x``, ``mm`` -> ``knee_l_x_mm``."""
    return f"{name}_{unit}"


def cloud_extent(positions: np.ndarray) -> float | None:
    """Median over frames of the diagonal of the markers' bounding box [same unit as input].

    ``positions`` (T, M, 3); NaN samples are ignored; frames with fewer than 2 markers seen
    do not count. None when no frame has 2 markers.
    """
    return median_extent(frame_extents(positions))


def frame_extents(positions: np.ndarray) -> np.ndarray:
    """The diagonal of the markers' bounding box (T',) [same unit as input] of every frame
    of ``positions`` (T, M, 3) with 2 markers seen or more (NaN samples ignored): the
    per-frame part of :func:`cloud_extent`, for a file read in chunks."""
    seen = np.isfinite(positions).all(axis=2)  # (T, M)
    pos = positions[seen.sum(axis=1) >= 2]
    # fmax/fmin skip NaN as nanmax/nanmin do (every row has a marker seen), without a copy
    span = np.fmax.reduce(pos, axis=1) - np.fmin.reduce(pos, axis=1)  # (T', 3)
    return np.asarray(np.linalg.norm(span, axis=1))


def median_extent(extents: np.ndarray) -> float | None:
    """The median of per-frame extents (:func:`frame_extents`), None without any."""
    return float(np.median(extents)) if len(extents) else None


def check_cloud_size(path: Path, positions: np.ndarray, unit: str, where: str) -> None:
    """Error unless the marker cloud ``positions`` (T, M, 3) [m] has a human-sized extent.

    The extent (:func:`cloud_extent`) must lie within :data:`CLOUD_EXTENT`; the error names
    the measured size, the unit used and where it came from, the unit that would make the
    size plausible, and the ``--units`` flag.
    """
    check_extent(path, cloud_extent(positions), unit, where)


def check_extent(path: Path, extent: float | None, unit: str, where: str) -> None:
    """:func:`check_cloud_size` for the cloud's extent [m] (None: no frame with 2 markers)."""
    low, high = CLOUD_EXTENT
    if extent is None or low <= extent <= high or extent == 0.0:
        return
    likely = likely_unit(extent, unit)
    hint = f"the file is likely in {likely}: pass --units {likely}" if likely else "pass --units"
    raise InputFileError(
        f"{path}: units: expected a marker cloud {low:g}..{high:g} m across in {unit} "
        f"({where}), got {extent:.4g} m; {hint}"
    )


def likely_unit(extent: float, unit: str) -> str | None:
    """The unit (mm, cm or m) that gives a cloud measuring ``extent`` [m] in ``unit`` a size
    within :data:`CLOUD_EXTENT`, the one nearest 1 m (a person's typical cloud) when several
    do; None when none does."""
    low, high = CLOUD_EXTENT
    used = metres_per_unit(unit) or 1e-3
    sizes = {name: extent / used * _METRES_PER_UNIT[name] for name in ("mm", "cm", "m")}
    fits = sorted(
        (name for name, size in sizes.items() if low <= size <= high),
        key=lambda name: abs(math.log(sizes[name])),
    )
    return fits[0] if fits else None
