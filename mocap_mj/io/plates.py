"""Force platforms: a C3D file's plates (through ezc3d) and OpenSim ground-reaction ``.mot``
files, per marker frame, in the markers' frame and SI units.

A :class:`PlateRecord` holds, per marker frame (T of them), the force the plate exerts on the
subject, the centre of pressure on the plate's surface and the free moment about the
vertical there, all in the frame :func:`~mocap_mj.io.load.load_markers` returns for the same
file (metres, +Z up) and in N, m and N m.

The rules, in the order they apply to a C3D plate:

- **What ezc3d reads.** ezc3d (``extract_forceplat_data=True``) gives each sample's force and
  moment about the centre of the plate's surface (the mean of its corners) in the file's
  axes, for plate types 1-4; any other type is refused naming the plate.
- **Offsets.** The analog offset of a plate is the median force and moment of its quietest
  unloaded stretch: of the 0.1 s windows of analog samples, the one whose median force is
  smallest, when that force is below :data:`OFFSET_LIMIT` (100 N: an amplifier's offset
  is smaller, a foot's load larger); a plate loaded throughout (no such window) keeps its
  samples as they are.
- **Sign.** A plate pushes and never pulls: vendors write either the force on the plate or
  the force on the subject, so when a plate's largest vertical sample points down, its force
  and moment are negated (a plate that is never loaded takes the sign of the file's loaded
  plates).
- **Resampling.** The analog samples of each marker frame are averaged (frame k holds the
  samples j with ``floor(j * marker_rate / analog_rate) = k``); force and moment are averaged,
  then the centre of pressure follows from the averaged wrench.
- **Centre of pressure and free moment.** From the force F and the moment M about the
  surface centre c, on the surface plane (unit normal n, up): ``cop = c + n x M / (n . F)``,
  free moment ``(n . (M - (cop - c) x F)) n``. A frame is loaded while ``n . F`` exceeds
  ``threshold_n``; elsewhere the centre of pressure is NaN and the free moment 0. Kistler's
  polynomial correction of a type-3 centre of pressure (FORCE_PLATFORM:FPCOPPOLY) is not
  applied: it moves FP_Type3.c3d's by under a millimetre.

Lengths are read in POINT:UNITS (millimetres when the file is silent, as the marker loader
reads them), forces in FORCE_PLATFORM:UNITS (N when silent), moments in their channels'
ANALOG:UNITS (else force times length). The vertical axis is the loader's for the same file
(``up``), so plates and markers share one frame.
"""

from __future__ import annotations

import logging
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import ezc3d
import numpy as np

from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.io.formats.c3d import _point_labels, read_parameters
from mocap_mj.io.orientation import normalize_up, rotation_to_z_up
from mocap_mj.io.units import metres_per_unit

__all__ = [
    "OFFSET_LIMIT",
    "OFFSET_WINDOW",
    "SUPPORTED_TYPES",
    "PlateRecord",
    "read_grf_mot",
    "read_plates",
    "recorded_ground_reactions",
]

#: Plate types ezc3d extracts (C3D user guide: 1 force + COP, 2 six channels, 3 Kistler's
#: eight channels, 4 six channels with a calibration matrix).
SUPPORTED_TYPES = (1, 2, 3, 4)
#: Length of the windows the offset is taken from [s].
OFFSET_WINDOW = 0.1
#: The largest median force [N] of a window taken for the unloaded plate's offset.
OFFSET_LIMIT = 100.0
#: A plate's sides must measure within this range [m] (the smallest commercial plates are
#: 0.1 m wide, treadmill belts some 3 m long).
SIDE_RANGE = (0.05, 5.0)

_log = logging.getLogger(__name__)

_MOMENT_UNITS = {"nmm": 1e-3, "n.mm": 1e-3, "n*mm": 1e-3, "n mm": 1e-3, "nm": 1.0, "n.m": 1.0,
                 "n*m": 1.0, "n m": 1.0}  # fmt: skip
_FORCE_UNITS = {"n": 1.0, "kn": 1e3}


@dataclass(frozen=True)
class PlateRecord:
    """One force plate's ground reaction per marker frame, in the markers' frame (+Z up).

    Fields: ``name`` ("plate 1", ... in the file's order); ``plate_type`` (the C3D type,
    1-4; 0 for a ground-reaction table without plate geometry); ``corners`` (4, 3) [m] (NaN
    when the file gives none); ``force`` (T, 3) [N], the force the plate exerts on the
    subject; ``cop`` (T, 3) [m], the centre of pressure on the plate's surface, NaN where
    unloaded; ``free_moment`` (T, 3) [N m], the free moment about the vertical at the centre
    of pressure, 0 where unloaded; ``rate`` [Hz], the marker rate of the frames.
    """

    name: str
    plate_type: int
    corners: np.ndarray
    force: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    rate: float

    @property
    def loaded(self) -> np.ndarray:
        """(T,) bool: the frames with a centre of pressure (vertical force over the
        threshold the record was read with)."""
        return np.asarray(np.isfinite(self.cop).all(axis=1))


def read_plates(
    path: str | os.PathLike[str],
    *,
    marker_rate: float | None = None,
    threshold_n: float = 20.0,
    up: str | None = None,
    window: str = "frame",
    offsets: str = "quiet",
) -> list[PlateRecord]:
    """Every force plate a C3D file declares, per marker frame, in SI units and the frame
    :func:`~mocap_mj.io.load.load_markers` gives the file's markers.

    The rules (ezc3d's extraction, offsets, sign, resampling by averaging the analog samples
    of each marker frame, centre of pressure): the module docstring. The file is only read.

    Parameters
    ----------
    path : str or PathLike
        The C3D file.
    marker_rate : float, optional
        The rate [Hz] to resample to. Default: POINT:RATE; for a file without marker points
        (rate 0), the analog rate divided by the analog samples per frame.
    threshold_n : float
        Vertical force [N] above which a frame is loaded (default 20 N, the usual
        force-plate threshold: above the noise of an unloaded plate, below any foot's load).
    up : {"x", "y", "z", "-x", "-y", "-z"}, optional
        The file's vertical axis, as ``load_markers``' ``up``. None: the axis
        ``load_markers`` chooses for this file; for a file whose markers cannot tell (none,
        or several subjects), the plates' own (their surface normal: a C3D plate's z axis
        points into the plate).
    window : {"frame", "centred"}
        A frame's analog samples: its own (default) or those within half a frame of it.
    offsets : {"quiet", "none"}
        Each channel's offset removed (default: its quietest unloaded window) or not.
    Returns
    -------
    list of PlateRecord
        One per readable plate of FORCE_PLATFORM:USED, named "plate k" by its place in the
        file; a plate with bad corners or samples is skipped with one warning naming it.

    Raises
    ------
    InputFileError
        The file is not a C3D ezc3d reads, or a plate is of a type ezc3d does not extract,
        names analog channels the file does not hold or lacks its calibration matrix (type
        4), or none of its plates can be read (the message names the file and the plate).
    """
    file = Path(path)
    _check_options(file, threshold_n, window, offsets)
    try:  # the parameters first (a copy of the file's start): what ezc3d would refuse
        header = read_parameters(file)
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        raise InputFileError(f"{file}: ezc3d could not read it: {_one_line(exc)}") from exc
    n_plates = _plates_used(header)
    if n_plates == 0:
        return []
    _check_declared(file, header, n_plates)
    whole = _extracted(file)
    params = whole["parameters"]
    scale_pos = _length_scale(file, params)
    scale_force = _force_scale(file, params)
    analog_rate = _analog_rate(file, params)
    rate = _marker_rate(file, params, marker_rate, analog_rate, whole)
    raw = _readable(file, whole, params, scale_pos, scale_force, zero=offsets == "quiet")
    rotation = rotation_to_z_up(_up_axis(file, up, list(raw.values())))
    vertical = rotation[2]  # the up direction in the file's axes
    signs = {k: _sign(p, vertical, threshold_n) for k, p in raw.items()}
    loaded_signs = {s for s in signs.values() if s != 0}
    default = loaded_signs.pop() if len(loaded_signs) == 1 else 1
    records = []
    for k, plate in raw.items():
        sign = signs[k] or default
        force = _frames(plate.force * sign, analog_rate, rate, window) @ rotation.T
        moment = _frames(plate.moment * sign, analog_rate, rate, window) @ rotation.T
        corners = plate.corners @ rotation.T
        cop, free = _cop(force, moment, corners, threshold_n)
        records.append(PlateRecord(f"plate {k + 1}", plate.type, corners, force, cop, free, rate))
    return records


def recorded_ground_reactions(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The ground reaction under each foot a C3D already holds from the software that
    processed it (Vicon Nexus' Plug-in Gait outputs ``LGroundReactionForce`` and
    ``RGroundReactionForce``, with or without a ``Subject:`` prefix): side ("left",
    "right") -> (T, 3) as stored (Nexus writes N/kg in the file's axes), NaN in the frames
    it left empty (a negative residual or all three zero: no plate counted for that foot).
    Empty when the file holds neither; the file is only read."""
    file = Path(path)
    try:
        header = read_parameters(file)
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        raise InputFileError(f"{file}: ezc3d could not read it: {_one_line(exc)}") from exc
    labels = [lab.split(":")[-1] for lab in _point_labels(header.get("POINT", {}))]
    wanted = {"left": "LGroundReactionForce", "right": "RGroundReactionForce"}
    if not set(wanted.values()) & set(labels):
        return {}
    try:
        c3d = ezc3d.c3d(str(file))
    except Exception as exc:
        raise InputFileError(f"{file}: ezc3d could not read it: {_one_line(exc)}") from exc
    points = np.asarray(c3d["data"]["points"][:3], dtype=float)  # (3, N, T)
    residuals = c3d["data"]["meta_points"]["residuals"]
    out = {}
    for side, name in wanted.items():
        if name not in labels:
            continue
        i = labels.index(name)
        if i >= points.shape[1]:
            continue
        values = points[:, i, :].T.copy()
        empty = (np.asarray(residuals)[0, i, :] < 0) | np.all(values == 0.0, axis=1)
        values[empty] = np.nan
        out[side] = values
    return out


def _check_options(file: Path, threshold_n: float, window: str, offsets: str) -> None:
    """:func:`read_plates`' arguments, each refused in one line."""
    if not file.is_file():
        raise InputFileError(f"{file}: no such file")
    if threshold_n <= 0 or not math.isfinite(threshold_n):
        raise InputFileError(f"{file}: threshold_n: expected a positive force, got {threshold_n}")
    if window not in ("frame", "centred"):
        raise MocapError(f"plate window {window!r}: expected frame or centred")
    if offsets not in ("quiet", "none"):
        raise MocapError(f"plate offsets {offsets!r}: expected quiet or none")


def _extracted(file: Path) -> Any:
    """The file as ezc3d reads it with its plates extracted."""
    try:
        return ezc3d.c3d(str(file), extract_forceplat_data=True)
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        raise InputFileError(
            f"{file}: group FORCE_PLATFORM: ezc3d could not extract the plates: {_one_line(exc)}"
        ) from exc


def _readable(
    file: Path,
    whole: Any,
    params: dict[str, Any],
    scale_pos: float,
    scale_force: float,
    *,
    zero: bool = True,
) -> dict[int, _RawPlate]:
    """Plate index -> its :class:`_RawPlate`, of the plates that can be read; one warning
    per plate skipped (naming the file, the plate and why); the first refusal raised when
    none can be read. ``zero``: the analog offsets removed (the quiet window's)."""
    raw: dict[int, _RawPlate] = {}
    refused: list[InputFileError] = []
    for k, pf in enumerate(whole["data"]["platform"]):
        try:
            raw[k] = _RawPlate.of(file, k, pf, params, scale_pos, scale_force, zero=zero)
        except InputFileError as exc:
            refused.append(exc)
    if not raw:
        raise refused[0]
    for why in refused:  # one plate's bad geometry or samples leave the others readable
        _log.warning("%s; that plate is skipped, the file's other plates are read", why)
    return raw


def read_grf_mot(
    path: str | os.PathLike[str],
    *,
    marker_rate: float | None = None,
    threshold_n: float = 20.0,
    up: str = "y",
) -> list[PlateRecord]:
    """The ground reactions of an OpenSim ``.mot`` (or ``.sto``) file, one record per force.

    The file holds a header ending in ``endheader``, a line of column names and rows of
    numbers; each force is a set of nine columns ``<prefix>force_v{x,y,z}`` [N] (the force on
    the subject), ``<prefix>force_p{x,y,z}`` [m] (its point) and ``<prefix>torque_{x,y,z}``
    [N m] (the torque at that point), e.g. ``ground_force_vx`` or ``1_ground_force_vx``.
    The forces are rotated from the file's ``up`` axis (default y: OpenSim's ground is Y
    up) onto +Z as the marker loader does, and resampled to ``marker_rate`` by averaging the
    rows of each marker frame (frame k from the first row's time), force and moment about
    the floor point below the origin, as :func:`read_plates` does (module docstring). The
    floor's height is the median height of the loaded rows' points. No corners: NaN.

    Raises
    ------
    InputFileError
        No ``endheader`` or time column, a force without its nine columns, a row that is
        not numbers, or times that do not increase (the message names the file and the row).
    """
    file = Path(path)
    if not file.is_file():
        raise InputFileError(f"{file}: no such file")
    columns, table = _mot_table(file)
    times = table[:, columns.index("time")]
    if len(times) > 1 and np.any(np.diff(times) <= 0):
        row = int(np.argmax(np.diff(times) <= 0)) + 2
        raise InputFileError(
            f"{file}: data row {row}: expected increasing times, got {times[row - 1]}"
        )
    file_rate = 1.0 / float(np.median(np.diff(times))) if len(times) > 1 else 1.0
    rate = float(marker_rate) if marker_rate is not None else file_rate
    rotation = rotation_to_z_up(normalize_up(up))
    records = []
    for k, prefix in enumerate(_mot_prefixes(file, columns)):

        def cols(stem: str, *, p: str = prefix) -> np.ndarray:
            return table[:, [columns.index(f"{p}{stem}{a}") for a in "xyz"]]

        force = cols("force_v") @ rotation.T
        point = cols("force_p") @ rotation.T
        torque = cols("torque_") @ rotation.T
        loaded = force[:, 2] > threshold_n
        height = float(np.median(point[loaded, 2])) if loaded.any() else 0.0
        centre = np.array([0.0, 0.0, height])
        arm = np.where(loaded[:, None], point - centre, 0.0)
        moment = np.cross(arm, force) + torque
        bins = np.floor((times - times[0]) * rate + 1e-6).astype(int)
        force_f, moment_f = _average(force, bins), _average(moment, bins)
        corners = np.full((4, 3), np.nan)
        cop, free = _cop_about(force_f, moment_f, centre, np.array([0.0, 0.0, 1.0]), threshold_n)
        records.append(PlateRecord(f"plate {k + 1}", 0, corners, force_f, cop, free, rate))
    return records


# --- C3D ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _RawPlate:
    """A plate as ezc3d extracts it, in SI units and the file's axes, offsets removed: force
    (N, 3) [N] and moment (N, 3) [N m] about the surface centre per analog sample, corners
    (4, 3) [m]."""

    type: int
    corners: np.ndarray
    force: np.ndarray
    moment: np.ndarray

    @classmethod
    def of(
        cls,
        file: Path,
        k: int,
        pf: dict[str, Any],
        params: dict[str, Any],
        scale_pos: float,
        scale_force: float,
        *,
        zero: bool = True,
    ) -> _RawPlate:
        kind = int(_values(params, "FORCE_PLATFORM", "TYPE")[k])
        corners = np.asarray(pf["corners"], dtype=float).T * scale_pos  # (4, 3)
        _check_corners(file, k, corners)
        force = np.asarray(pf["force"], dtype=float).T * scale_force  # (N, 3)
        if kind == 1:
            cop = np.asarray(pf["center_of_pressure"], dtype=float).T * scale_pos
            turn = np.asarray(pf["Tz"], dtype=float).T * _moment_scale(file, k, params, 5)
        else:
            # type 3's moments are its forces times ORIGIN's lever arms (length units)
            scale = scale_force * scale_pos if kind == 3 else _moment_scale(file, k, params, 3)
            turn = np.asarray(pf["moment"], dtype=float).T * scale
        bad = ~np.isfinite(np.concatenate([force, turn], axis=1)).all(axis=1)
        if bad.any():
            raise InputFileError(
                f"{file}: plate {k + 1}: analog sample {int(np.argmax(bad)) + 1}: expected "
                f"finite forces and moments, got NaN or infinity"
            )
        quiet = _quiet(force, _analog_rate(file, params)) if zero else None
        force = force - _offset(force, quiet)
        turn = turn - _offset(turn, quiet)
        if kind == 1:
            # ezc3d's type 1 moment is not about the centre: build it from its COP and Tz
            cop = np.where(np.isfinite(cop), cop, corners.mean(axis=0))
            return cls(kind, corners, force, np.cross(cop - corners.mean(axis=0), force) + turn)
        return cls(kind, corners, force, turn)


def _quiet(force: np.ndarray, analog_rate: float) -> slice | None:
    """The analog samples the offsets are taken from: of the ``OFFSET_WINDOW`` windows of
    ``force`` (N, 3) [N], the one with the smallest median force, when that force is below
    ``OFFSET_LIMIT``; None for a plate loaded throughout."""
    width = max(1, round(OFFSET_WINDOW * analog_rate))
    n_windows = len(force) // width
    if n_windows == 0:
        return None
    medians = np.median(force[: n_windows * width].reshape(n_windows, width, 3), axis=1)
    best = int(np.argmin(np.linalg.norm(medians, axis=1)))
    if np.linalg.norm(medians[best]) >= OFFSET_LIMIT:
        return None
    return slice(best * width, (best + 1) * width)


def _offset(samples: np.ndarray, quiet: slice | None) -> np.ndarray:
    """(3,): the median of ``samples`` (N, 3) over ``quiet``; zeros without one."""
    return np.zeros(3) if quiet is None else np.asarray(np.median(samples[quiet], axis=0))


def _sign(plate: _RawPlate, vertical: np.ndarray, threshold_n: float) -> int:
    """+1 when the plate's largest vertical sample points up (the force on the subject), -1
    when down (the force on the plate), 0 for a plate never loaded."""
    fz = plate.force @ vertical
    if len(fz) == 0:
        return 0
    peak = float(fz[int(np.argmax(np.abs(fz)))])
    if abs(peak) <= threshold_n:
        return 0
    return 1 if peak > 0 else -1


def _frames(
    samples: np.ndarray, analog_rate: float, rate: float, window: str = "frame"
) -> np.ndarray:
    """(T, 3): ``samples`` (N, 3) averaged per marker frame (module docstring); ``window``
    "centred": the samples within half a frame of each frame's instant instead."""
    at = np.arange(len(samples)) * rate / analog_rate
    bins = np.floor(at + 1e-6).astype(int)
    if window == "centred" and len(bins):
        n = int(bins.max()) + 1
        centred = np.floor(at + 0.5 + 1e-6).astype(int)
        keep = centred < n
        out = np.full((n, 3), np.nan)
        out[: int(centred[keep].max()) + 1] = _average(samples[keep], centred[keep])
        return out
    return _average(samples, bins)


def _average(samples: np.ndarray, bins: np.ndarray) -> np.ndarray:
    """(T, 3): the mean of ``samples`` (N, 3) over each bin 0..T-1 of ``bins`` (N,)."""
    n = int(bins.max()) + 1 if len(bins) else 0
    counts = np.bincount(bins, minlength=n).astype(float)
    out = np.stack([np.bincount(bins, weights=samples[:, a], minlength=n) for a in range(3)], 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(out / counts[:, None])


def _cop(
    force: np.ndarray, moment: np.ndarray, corners: np.ndarray, threshold_n: float
) -> tuple[np.ndarray, np.ndarray]:
    """Centre of pressure (T, 3) [m] and free moment (T, 3) [N m] of a plate with
    ``corners`` (4, 3) [m] (z up), from force (T, 3) [N] and moment (T, 3) [N m] about the
    surface centre."""
    normal = np.cross(corners[0] - corners[1], corners[0] - corners[3])  # into the plate
    normal = -normal / np.linalg.norm(normal)
    if normal[2] < 0:  # a floor plate faces up whatever the corners' order
        normal = -normal
    return _cop_about(force, moment, corners.mean(axis=0), normal, threshold_n)


def _cop_about(
    force: np.ndarray,
    moment: np.ndarray,
    centre: np.ndarray,
    normal: np.ndarray,
    threshold_n: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Centre of pressure (T, 3) [m] on the plane through ``centre`` (3,) [m] with unit
    ``normal`` (3,) and the free moment (T, 3) [N m] about ``normal`` there, from force
    (T, 3) [N] and moment (T, 3) [N m] about ``centre`` (module docstring)."""
    fn = force @ normal
    loaded = fn > threshold_n
    arm = np.full_like(force, np.nan)
    arm[loaded] = np.cross(normal, moment[loaded]) / fn[loaded, None]
    free = np.zeros_like(force)
    tau = np.einsum("ij,j->i", moment[loaded] - np.cross(arm[loaded], force[loaded]), normal)
    free[loaded] = tau[:, None] * normal
    return centre + arm, free


def _plates_used(params: dict[str, Any]) -> int:
    used = _values(params, "FORCE_PLATFORM", "USED")
    return int(used[0]) if used else 0


def _check_declared(file: Path, params: dict[str, Any], n_plates: int) -> None:
    """Refuse, naming the plate, what ezc3d would not extract or would extract wrongly."""
    types = _values(params, "FORCE_PLATFORM", "TYPE")
    channel = params["FORCE_PLATFORM"].get("CHANNEL", {}).get("value")
    channels = np.asarray(channel if channel is not None else [], dtype=int)
    n_analog = int(np.asarray(params.get("ANALOG", {}).get("USED", {}).get("value", [0]))[0])
    for k in range(n_plates):
        name = f"plate {k + 1}"
        if k >= len(types):
            raise InputFileError(
                f"{file}: group FORCE_PLATFORM:TYPE: {name}: expected a type, the group "
                f"declares {n_plates} plates and {len(types)} types"
            )
        kind = int(types[k])
        if kind not in SUPPORTED_TYPES:
            raise InputFileError(
                f"{file}: group FORCE_PLATFORM:TYPE: {name}: expected type 1, 2, 3 or 4 "
                f"(the types ezc3d extracts), got type {kind}"
            )
        need = 8 if kind == 3 else 6
        if channels.ndim != 2 or channels.shape[1] <= k or channels.shape[0] < need:
            raise InputFileError(
                f"{file}: group FORCE_PLATFORM:CHANNEL: {name}: expected {need} analog "
                f"channels for type {kind}, got CHANNEL of shape {channels.shape}"
            )
        listed = channels[:need, k]
        if listed.min() < 1 or listed.max() > n_analog:
            raise InputFileError(
                f"{file}: group FORCE_PLATFORM:CHANNEL: {name}: expected channels 1..{n_analog}"
                f" (ANALOG:USED), got {listed.tolist()}"
            )
        if kind == 4:
            cal = params["FORCE_PLATFORM"].get("CAL_MATRIX", {}).get("value")
            shape: tuple[int, ...] = np.shape(cal) if cal is not None else ()
            if len(shape) < 3 or shape[2] <= k:
                raise InputFileError(
                    f"{file}: group FORCE_PLATFORM:CAL_MATRIX: {name}: expected a 6 x 6 "
                    f"calibration matrix for type 4, got shape {shape}"
                )


def _check_corners(file: Path, k: int, corners: np.ndarray) -> None:
    """Refuse corners (4, 3) [m] that are not a plate's rectangle: sides within
    ``SIDE_RANGE``, equal diagonals (within 5 %) and in one plane (within 1 cm)."""
    lo, hi = SIDE_RANGE
    ok = bool(np.isfinite(corners).all())
    if ok:
        sides = np.linalg.norm(corners - np.roll(corners, -1, axis=0), axis=1)
        d1, d2 = (float(np.linalg.norm(corners[i] - corners[i + 2])) for i in (0, 1))
        normal = np.cross(corners[0] - corners[1], corners[0] - corners[3])
        norm = float(np.linalg.norm(normal))
        off_plane = abs(float((corners[2] - corners[0]) @ normal)) / norm if norm else math.inf
        ok = bool(
            np.all((sides >= lo) & (sides <= hi))
            and abs(d1 - d2) <= 0.05 * max(d1, d2)
            and off_plane <= 0.01
        )
    if not ok:
        shown = np.array2string(corners, precision=3, separator=", ").replace("\n", "")
        raise InputFileError(
            f"{file}: group FORCE_PLATFORM:CORNERS: plate {k + 1}: expected the corners of a "
            f"plate (a flat rectangle with sides of {lo:g} to {hi:g} m), got {shown} m"
        )


def _length_scale(file: Path, params: dict[str, Any]) -> float:
    units = [str(v).strip() for v in _values(params, "POINT", "UNITS")]
    unit = units[0] if units and units[0] else "mm"  # the marker loader's default
    scale = metres_per_unit(unit)
    if scale is None:
        raise InputFileError(f"{file}: group POINT:UNITS: expected mm, cm or m, got {unit!r}")
    return scale


def _force_scale(file: Path, params: dict[str, Any]) -> float:
    units = [str(v).strip() for v in _values(params, "FORCE_PLATFORM", "UNITS")]
    unit = units[0] if units and units[0] else "N"
    scale = _FORCE_UNITS.get(unit.lower())
    if scale is None:
        raise InputFileError(f"{file}: group FORCE_PLATFORM:UNITS: expected N or kN, got {unit!r}")
    return scale


def _moment_scale(file: Path, k: int, params: dict[str, Any], row: int) -> float:
    """N m per moment unit of plate ``k``: its channel's ANALOG:UNITS (CHANNEL's ``row``,
    0-based: the first moment channel) when it is a moment unit, else force times length."""
    channels = np.asarray(params["FORCE_PLATFORM"]["CHANNEL"]["value"], dtype=int)
    units = [str(v).strip() for v in _values(params, "ANALOG", "UNITS")]
    index = int(channels[row, k]) - 1
    stated = units[index].lower() if index < len(units) else ""
    if stated in _MOMENT_UNITS:
        return _MOMENT_UNITS[stated]
    return _force_scale(file, params) * _length_scale(file, params)


def _analog_rate(file: Path, params: dict[str, Any]) -> float:
    values = _values(params, "ANALOG", "RATE")
    rate = float(values[0]) if values else 0.0
    if not (math.isfinite(rate) and rate > 0):
        raise InputFileError(f"{file}: group ANALOG:RATE: expected a positive rate, got {values}")
    return rate


def _marker_rate(
    file: Path,
    params: dict[str, Any],
    marker_rate: float | None,
    analog_rate: float,
    c3d: Any,
) -> float:
    """``marker_rate`` checked; default POINT:RATE, else (no marker points) the analog rate
    over the analog samples per frame of ``c3d`` (ezc3d's reading)."""
    if marker_rate is not None:
        if not (math.isfinite(marker_rate) and 0 < marker_rate <= analog_rate):
            raise InputFileError(
                f"{file}: marker_rate: expected a rate in (0, {analog_rate:g}] Hz (the analog "
                f"rate), got {marker_rate}"
            )
        return float(marker_rate)
    values = _values(params, "POINT", "RATE")
    rate = float(values[0]) if values else 0.0
    if math.isfinite(rate) and rate > 0:
        return rate
    n_point_frames = int(np.asarray(c3d["data"]["points"]).shape[2])
    n_analog = int(np.asarray(c3d["data"]["analogs"]).shape[2])
    if n_point_frames > 0 and n_analog >= n_point_frames:
        return analog_rate * n_point_frames / n_analog
    return analog_rate


def _up_axis(file: Path, up: str | None, plates: Sequence[_RawPlate]) -> str:
    """``up`` normalised; None: the marker loader's axis for ``file``, else the plates'."""
    if up is not None:
        return normalize_up(up)
    from mocap_mj.io.load import load_markers  # the loader reads the markers' own axis

    try:
        return str(load_markers(file).source["up"])
    except MocapError:
        pass
    corners = plates[0].corners
    down = np.cross(corners[0] - corners[1], corners[0] - corners[3])  # into the plate
    axis = int(np.argmax(np.abs(down)))
    return ("-" if down[axis] > 0 else "") + "xyz"[axis]


def _values(params: dict[str, Any], group: str, name: str) -> list[Any]:
    entry = params.get(group, {}).get(name)
    if not isinstance(entry, dict) or entry.get("value") is None:
        return []
    value = entry["value"]
    return list(np.ravel(value)) if not isinstance(value, list) else value


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())[:200]


# --- OpenSim .mot ---------------------------------------------------------------------------

_FORCE_COLUMN = re.compile(r"^(?P<prefix>.*)force_vx$")


def _mot_table(file: Path) -> tuple[list[str], np.ndarray]:
    """The column names and the rows (R, C) of a ``.mot`` file."""
    try:
        lines = file.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise InputFileError(f"{file}: cannot read: {exc.strerror or exc}") from None
    end = next((i for i, line in enumerate(lines) if line.strip().lower() == "endheader"), None)
    if end is None or end + 1 >= len(lines):
        raise InputFileError(f"{file}: header: expected a line 'endheader' and column names")
    columns = lines[end + 1].split()
    if "time" not in columns:
        raise InputFileError(f"{file}: line {end + 2}: expected a column 'time', got {columns[:4]}")
    rows = []
    for i, line in enumerate(lines[end + 2 :], start=end + 3):
        if not line.strip():
            continue
        cells = line.split()
        try:
            values = [float(c) for c in cells]
        except ValueError:
            values = []
        if len(values) != len(columns) or not all(math.isfinite(v) for v in values):
            raise InputFileError(
                f"{file}: line {i}: expected {len(columns)} finite numbers, "
                f"got {line.strip()[:60]!r}"
            )
        rows.append(values)
    if not rows:
        raise InputFileError(f"{file}: expected data rows after the column names, got none")
    return columns, np.array(rows, dtype=float)


def _mot_prefixes(file: Path, columns: list[str]) -> list[str]:
    """The prefixes of the forces ``columns`` holds, each with its nine columns."""
    prefixes = [m["prefix"] for c in columns if (m := _FORCE_COLUMN.match(c))]
    if not prefixes:
        raise InputFileError(
            f"{file}: column names: expected ground-reaction columns such as ground_force_vx, "
            f"got {', '.join(columns[:6])}"
        )
    for prefix in prefixes:
        need = [f"{prefix}{stem}{a}" for stem in ("force_v", "force_p", "torque_") for a in "xyz"]
        missing = [n for n in need if n not in columns]
        if missing:
            raise InputFileError(
                f"{file}: column names: expected the nine columns of force {prefix!r}, "
                f"missing {', '.join(missing)}"
            )
    return prefixes
