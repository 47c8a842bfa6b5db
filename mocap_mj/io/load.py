"""``load_markers``: any supported marker file -> a :class:`MarkerTrajectory` in metres, Z up.

One missing-data rule holds in every format: a sample is missing when any coordinate is NaN
or an empty cell, when all three coordinates are exactly 0 (how many tools write a gap; a real
marker is never exactly at the lab origin to every decimal), or when its C3D residual is
negative. ``source["missing_samples"]`` counts them per marker (all causes),
``source["zero_samples"]`` those written as zeros.

The units check: the median per-frame extent of the marker cloud must lie within 0.05..10 m
once converted; otherwise the error names the unit that would fit and the ``--units`` flag (a
wrong unit would otherwise give a "fit" of a 1,700 m person).
"""

from __future__ import annotations

import logging
import os
import stat
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mocap_mj.errors import InputFileError
from mocap_mj.io.formats import RawMarkers, read_raw
from mocap_mj.io.handedness import HANDEDNESS_MARKERS, check_handedness
from mocap_mj.io.marker_names import MARKER_NAMES
from mocap_mj.io.names import builtin_alias, is_non_marker, load_marker_map, split_prefix
from mocap_mj.io.orientation import (
    FOOT_MARKERS,
    HEAD_MARKERS,
    TRUNK_MARKERS,
    detect_up,
    normalize_up,
    rotation_to_z_up,
)
from mocap_mj.io.trajectory import MarkerTrajectory, first_frame
from mocap_mj.io.units import (
    check_extent,
    frame_extents,
    likely_unit,
    median_extent,
    metres_per_unit,
)

__all__ = ["COORDINATE_LIMIT", "load_markers"]

_log = logging.getLogger(__name__)

#: The largest distance from the lab origin a marker coordinate may state [m], after unit
#: conversion. The largest motion-capture volumes (outdoor and stadium systems) span some
#: 100 m, so a coordinate beyond 1 km is a corrupt or placeholder number (1e30, a float's
#: maximum), not a position; read on, it would overflow the fit's sums of squares. A file
#: whose every number is 1,000 times too large (metres stated for millimetres) is the units
#: check's to name, with the unit that fits (``check_extent``).
COORDINATE_LIMIT = 1000.0


def load_markers(
    path: str | os.PathLike[str],
    *,
    subject: str | None = None,
    marker_map: Mapping[str, str] | str | os.PathLike[str] | None = None,
    up: str | None = None,
    units: str | None = None,
    model_names: Collection[str] = MARKER_NAMES,
) -> MarkerTrajectory:
    """Read a marker file into metres, in the model's Z-up world, with model marker names.

    The format (C3D, OpenSim TRC, mocap-mj CSV, Vicon Nexus CSV, OptiTrack Motive CSV) is
    detected from the content. The file is only read, never modified.

    Steps, in order: subject prefixes ("Derrick:LASI", matched case-insensitively) are
    removed, keeping one subject; non-marker points are dropped (model outputs the file's
    metadata lists, and by name: Plug-in Gait outputs such as PELO or LKneeAngles,
    CentreOfMass, unlabelled points such as ``*115``), never a model marker name nor a name
    ``marker_map`` lists; ``marker_map`` renames; other names that spell a Plug-in Gait marker
    (``lasi``, ``L_IAS``, ``LFRA``: :func:`~mocap_mj.io.names.builtin_alias`) take its name
    when that is unambiguous; units become metres; missing samples become NaN; the marker
    cloud's size is checked against the unit; a coordinate beyond :data:`COORDINATE_LIMIT`
    (1 km) from the origin is refused, naming the marker and frame; the vertical axis is
    rotated onto +Z; a mirrored recording (left markers on the subject's right: a
    left-handed export or every left/right label swapped) is refused
    (:mod:`mocap_mj.io.handedness`).

    Missing samples and the units check: the module docstring.

    Parameters
    ----------
    path : str or PathLike
        The marker file.
    subject : str, optional
        The subject to keep when labels carry several subject prefixes (required then).
    marker_map : mapping or path, optional
        Lab name -> model name (e.g. ``{"LFRA": "LFRM"}``), or a YAML/JSON file holding one.
        Applied after prefixes are removed. Names it lists are never dropped as non-markers.
    up : {"x", "y", "z", "-x", "-y", "-z"}, optional
        The file's vertical axis. None detects it: the axis along which head markers (LFHD,
        RFHD, LBHD, RBHD; else C7, CLAV) sit highest above foot markers (LANK, RANK, LHEE,
        RHEE, LTOE, RTOE); without those markers, what the file states (mocap-mj CSV ``up=``,
        Motive: y, C3D POINT:Y_SCREEN), else z. See :mod:`mocap_mj.io.orientation`.

    model_names : collection of str
        The marker names of the caller's model or marker set (default: Plug-in Gait). A file
        name that is one of them is never aliased, and aliases only produce names among them.
    units : {"mm", "cm", "m"}, optional
        The coordinates' length unit, overriding what the file states (or its silence, which
        otherwise means mm).

    Returns
    -------
    MarkerTrajectory
        ``positions`` (T, M, 3) [m], NaN for missing samples; ``source`` records the path,
        format, units, up axis and how it was chosen, the subject, dropped points, extras
        (markers the model does not use: kept, ignored by fitting), the names mapped and
        aliased, missing samples per marker, and ``warnings`` (each also logged once).

    Raises
    ------
    InputFileError
        Unreadable, truncated or malformed file (the message names the file and the line,
        byte or C3D group), unknown units, a marker cloud whose size does not fit the unit,
        several subjects without ``subject``, duplicate marker names, no markers at all, or
        a mirrored recording.
    UnknownNameError
        ``up`` is not an axis name.
    """
    file, wanted_up, rename = _arguments(path, marker_map, up, units)
    raw = read_raw(file)
    sel = _selection(file, raw, subject, rename, model_names)
    reading = Reading(file, raw, sel, units, wanted_up, rename, lambda: iter([raw.positions]))
    return MarkerTrajectory(
        times=raw.times,
        positions=reading.convert(raw.positions),
        names=tuple(sel.names),
        rate=raw.rate,
        source=reading.source,
    )


def require_file(file: Path) -> None:
    """Raise :class:`InputFileError` unless ``file`` is a regular file (after symlinks),
    naming what it is instead: absent, a folder, or a FIFO, socket or device (which a reader
    would block on or read forever)."""
    try:
        mode = file.stat().st_mode
    except FileNotFoundError:
        raise InputFileError(f"{file}: no such file") from None
    except OSError as exc:
        raise InputFileError(f"{file}: cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise InputFileError(f"{file}: is a folder, expected a marker file")
    if not stat.S_ISREG(mode):
        raise InputFileError(
            f"{file}: is not a regular file (a pipe, socket or device), expected a marker file"
        )


def _arguments(
    path: str | os.PathLike[str],
    marker_map: Mapping[str, str] | str | os.PathLike[str] | None,
    up: str | None,
    units: str | None,
) -> tuple[Path, str | None, Mapping[str, str]]:
    """:func:`load_markers`'s arguments checked: the file, the normalised ``up`` (None to
    detect) and the marker map (empty without one)."""
    file = Path(path)
    wanted_up = normalize_up(up) if up is not None else None
    rename = load_marker_map(marker_map) if marker_map is not None else {}
    require_file(file)
    if units is not None and metres_per_unit(units) is None:
        raise InputFileError(f"{file}: --units: expected mm, cm or m, got {units!r}")
    return file, wanted_up, rename


class _Selection(NamedTuple):
    """The markers :func:`load_markers` keeps and how they were chosen and named."""

    keep: list[tuple[int, str]]  # (column, name without prefix)
    names: list[str]  # model names, in ``keep``'s order
    subject: str | None
    subjects: list[str]
    dropped: list[str]
    others: list[str]  # other subjects' markers
    aliased: dict[str, str]


def _selection(
    file: Path,
    raw: RawMarkers,
    subject: str | None,
    rename: Mapping[str, str],
    model_names: Collection[str],
) -> _Selection:
    """Keep one subject's markers, rename and alias them; refuse duplicates and no markers."""
    keep, chosen_subject, subjects, dropped, others = _select_markers(file, raw, subject, rename)
    names = [rename.get(name, name) for _, name in keep]
    aliased = _apply_aliases(names, rename, set(model_names))
    _check_unique(file, raw, keep, names)
    if not names:
        raise InputFileError(
            f"{file}: {raw.labels_where}: expected at least one marker, got none "
            f"(dropped: {', '.join(dropped) or 'nothing'})"
        )
    return _Selection(keep, names, chosen_subject, subjects, dropped, others, aliased)


class Reading:
    """How :func:`load_markers` turns a file's points into the trajectory, learnt from every
    frame once: the unit, the vertical axis and the ``source`` record; :meth:`convert` then
    applies it to any frames. One code path for a file read whole and one read chunk by
    chunk (:mod:`mocap_mj.io.stream`), so that the two cannot drift.

    ``chunks`` yields the file's positions (n, M_file, 3) [file units] in frame order, all
    frames once.
    """

    def __init__(
        self,
        file: Path,
        raw: RawMarkers,
        sel: _Selection,
        units: str | None,
        wanted_up: str | None,
        rename: Mapping[str, str],
        chunks: Callable[[], Iterator[np.ndarray]],
    ) -> None:
        self.file, self.raw, self.columns = file, raw, [i for i, _ in sel.keep]
        names = sel.names
        self.scale, unit, units_note = _metres(file, raw, units)
        if not np.all(np.isfinite(raw.times)):
            raise self._infinite()
        survey = _Survey(names)
        for chunk in chunks():
            survey.add(*self._metres(chunk))
        extent = median_extent(np.concatenate(survey.extents))
        if survey.beyond is not None and (extent is None or likely_unit(extent, unit) is None):
            raise self._beyond(survey.beyond, names, unit)
        check_extent(file, extent, unit, units_note)
        if survey.beyond is not None:
            raise self._beyond(survey.beyond, names, unit)
        surveyed = survey.up_positions()
        up_axis, up_how, detected = _vertical(raw, surveyed, survey.up_names, wanted_up)
        self.rotation = rotation_to_z_up(up_axis)
        check_handedness(file, surveyed, survey.up_names)  # in any axes
        del surveyed
        self.source: dict[str, Any] = {
            "path": str(file.resolve()),
            "format": raw.format,
            "units": unit,
            "units_note": units_note,
            "up": up_axis,
            "up_detected": detected,
            "up_how": up_how,
            "rotation": self.rotation.tolist(),
            "subject": sel.subject,
            "subjects": sel.subjects,
            "dropped": raw.dropped + sel.dropped,
            "other_subjects_markers": sel.others,
            "extras": [n for n in names if n not in MARKER_NAMES],
            "renamed": {k: v for k, v in rename.items() if k in {n for _, n in sel.keep}},
            "aliased": sel.aliased,
            "missing_samples": {n: int(c) for n, c in zip(names, survey.missing, strict=True) if c},
            "zero_samples": {n: int(c) for n, c in zip(names, survey.zeros, strict=True) if c},
            **raw.info,
        }
        self.source["warnings"] = list(raw.info.get("warnings", []))
        for message in self.source["warnings"]:
            _log.warning(message)

    def _infinite(self) -> InputFileError:
        return InputFileError(
            f"{self.file}: {self.raw.labels_where}: expected finite times and coordinates, got "
            "infinity"
        )

    def _beyond(self, where: tuple[int, int, float], names: list[str], unit: str) -> InputFileError:
        row, marker, value = where
        frame = first_frame(self.raw.info) + row  # the recording's own number
        return InputFileError(
            f"{self.file}: {names[marker]}: frame {frame} (t = {self.raw.times[row]:.3f} s): "
            f"expected coordinates within {COORDINATE_LIMIT:g} m of the origin (no lab is "
            f"larger), got {value:.4g} m ({value / self.scale:.4g} {unit})"
        )

    def _metres(self, chunk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The selected markers of ``chunk`` (n, M_file, 3) in metres, missing samples NaN
        (all-zero samples included), unrotated; and which samples were zeros (n, M)."""
        positions = chunk[:, self.columns] * self.scale
        if np.isinf(positions).any():
            raise self._infinite()
        zeros = np.all(positions == 0.0, axis=2)  # (n, M)
        positions[zeros] = np.nan
        return positions, zeros

    def convert(self, chunk: np.ndarray) -> np.ndarray:
        """The selected markers of ``chunk`` (n, M_file, 3) [file units] (n, M, 3) [m],
        NaN where missing, rotated Z up."""
        positions, _ = self._metres(chunk)
        return np.asarray(positions @ self.rotation.T)


class _Survey:
    """What the loader needs from every frame before it converts any: missing and zero
    samples per marker, the cloud's extent per frame, and the markers the vertical axis is
    detected from (:func:`mocap_mj.io.orientation.detect_up`: head, trunk and foot) and
    the handedness checked from (:mod:`mocap_mj.io.handedness`: pelvis and head)."""

    def __init__(self, names: list[str]) -> None:
        n = len(names)
        self.missing, self.zeros = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
        self.extents: list[np.ndarray] = [np.zeros(0)]
        wanted = {*HEAD_MARKERS, *TRUNK_MARKERS, *FOOT_MARKERS, *HANDEDNESS_MARKERS}
        # a marker set's own names (L_HDF, a Plug-in Gait LFHD) tell by their Plug-in Gait alias
        known = [n if n in wanted else builtin_alias(n, MARKER_NAMES) or n for n in names]
        self.up_columns = [i for i, name in enumerate(known) if name in wanted]
        self.up_names = [known[i] for i in self.up_columns]
        self._up: list[np.ndarray] = []
        self._frames = 0
        #: The first sample beyond :data:`COORDINATE_LIMIT`: (frame, marker, coordinate [m]).
        self.beyond: tuple[int, int, float] | None = None

    def add(self, positions: np.ndarray, zeros: np.ndarray) -> None:
        """Count a chunk's positions (n, M, 3) [m] (NaN missing) and zero samples (n, M)."""
        if self.beyond is None:
            far = np.abs(positions) > COORDINATE_LIMIT  # NaN compares False
            if far.any():
                t, m, axis = (int(i) for i in np.argwhere(far)[0])
                self.beyond = (self._frames + t, m, float(positions[t, m, axis]))
        self._frames += len(positions)
        self.missing += np.isnan(positions).any(axis=2).sum(axis=0)
        self.zeros += zeros.sum(axis=0)
        self.extents.append(frame_extents(positions))
        self._up.append(positions[:, self.up_columns])

    def up_positions(self) -> np.ndarray:
        """The vertical-axis markers of every frame (T, K, 3) [m]."""
        return np.concatenate(self._up) if self._up else np.zeros((0, len(self.up_columns), 3))


def _select_markers(
    file: Path, raw: RawMarkers, subject: str | None, rename: Mapping[str, str]
) -> tuple[list[tuple[int, str]], str | None, list[str], list[str], list[str]]:
    """Columns to keep as (index, name), the subject, all subjects, dropped, other subjects'."""
    split = [split_prefix(label) for label in raw.labels]
    prefixes = sorted({p for p, _ in split if p is not None})
    subjects = prefixes or list(raw.subjects)
    if subject is not None:
        wanted = subject.strip()
        matches = [s for s in subjects if s == wanted] or [
            s for s in subjects if s.casefold() == wanted.casefold()
        ]
        if len(matches) == 1:
            subject = matches[0]
        elif prefixes or raw.subjects:
            raise InputFileError(
                f"{file}: --subject: expected one of the file's subjects "
                f"({', '.join(subjects)}), got {wanted!r}"
            )
        else:
            subject = wanted
    elif len(prefixes) > 1:
        raise InputFileError(
            f"{file}: expected one subject, got {len(prefixes)} ({', '.join(prefixes)}): "
            f"pass --subject NAME to choose one"
        )
    chosen = subject if subject is not None else (prefixes[0] if prefixes else None)
    keep: list[tuple[int, str]] = []
    dropped: list[str] = []
    others: list[str] = []
    for i, (prefix, name) in enumerate(split):
        if prefix is not None and prefix != chosen:
            others.append(raw.labels[i])
            continue
        listed = raw.labels[i] in raw.non_markers or name in raw.non_markers
        if name not in rename and name not in MARKER_NAMES and (listed or is_non_marker(name)):
            dropped.append(raw.labels[i])
            continue
        keep.append((i, name))
    return keep, chosen, subjects, dropped, others


def _apply_aliases(names: list[str], rename: Mapping[str, str], model: set[str]) -> dict[str, str]:
    """Give built-in Plug-in Gait names to the columns that spell one; {file name: model name}.

    ``names`` is edited in place. A column keeps its name when the caller's map named it, when
    the target name is already a column, or when several columns would take the same name.
    """
    present = set(names)
    wanted: dict[str, list[int]] = {}
    for k, name in enumerate(names):
        protected = name in rename.values() or name in model
        target = None if protected else builtin_alias(name, MARKER_NAMES)
        target = target if target in model else None
        if target is not None and target not in present:
            wanted.setdefault(target, []).append(k)
    done: dict[str, str] = {}
    for target, columns in wanted.items():
        if len(columns) == 1:
            done[names[columns[0]]] = target
            names[columns[0]] = target
    return done


def _check_unique(
    file: Path, raw: RawMarkers, keep: list[tuple[int, str]], names: list[str]
) -> None:
    seen: dict[str, int] = {}
    for (i, _), name in zip(keep, names, strict=True):
        if name in seen:
            first = raw.labels[seen[name]]
            raise InputFileError(
                f"{file}: {raw.labels_where}: expected unique marker names, got "
                f"{name!r} twice (from {first!r} and {raw.labels[i]!r})"
            )
        seen[name] = i


def _metres(file: Path, raw: RawMarkers, given: str | None) -> tuple[float, str, str]:
    """(metres per file unit, the unit, where it came from)."""
    if given is not None:
        return float(metres_per_unit(given) or 0.0), given.strip(), "given by --units"
    if raw.units is None:
        return 1e-3, "mm", "the file states no units: assumed mm"
    scale = metres_per_unit(raw.units)
    if scale is None:
        raise InputFileError(
            f"{file}: {raw.units_where}: expected length units mm, cm or m, got {raw.units!r} "
            f"(pass --units to say which)"
        )
    return scale, raw.units, f"{raw.units} from {raw.units_where}"


def _vertical(
    raw: RawMarkers, positions: np.ndarray, names: Sequence[str], wanted: str | None
) -> tuple[str, str, bool]:
    """(up axis, how it was chosen, whether it was detected from markers)."""
    if wanted is not None:
        return wanted, "given by the caller (up=)", False
    if raw.info.get("up_stated") and raw.up_hint is not None:
        return normalize_up(raw.up_hint), "stated in the file header (up=)", False
    found, how = detect_up(positions, names)
    if found is not None:
        return found, how, True
    if raw.up_hint is not None:
        return raw.up_hint, f"{how}; used the {raw.format} metadata/default", False
    return "z", f"{how}; assumed z", False
