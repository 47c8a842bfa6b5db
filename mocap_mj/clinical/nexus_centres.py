"""Our joint centres against Vicon Nexus's, stored in the same C3D: what differs and why.

Nexus writes its Plug-in Gait bone points into the recording (:mod:`.bones`: per segment an
origin O and the points A, L, P along its axes): the hip centre is LFEP, the knee LFEO, the
ankle LTIO, the shoulder LCLO, the elbow LHUO, the wrist LRAO (R for the right). Per joint
and side, :func:`centre_gaps` measures, over the frames both hold:

* the median distance [m] between our centre and Nexus's, and its anterior, lateral and
  proximal components in Nexus's segment frame (medians and standard deviations over the
  frames: a constant offset is a convention, a varying one follows the motion);
* seen from the joint's marker (KNE, ANK, SHO, ELB, the wrist bar's mid-point): both
  centres' distances from it and the angle between them (equal distances and an angle mean
  the centres differ by a direction about the marker, not by a depth);
* how the distance follows the joint's bend (the angle at our centre between its
  neighbours' centres): correlation and slope;
* Plug-in Gait's own construction (the chord of the knee, ankle and elbow, widths from the
  file's PROCESSING group) hung from our proximal centre: its distance from Nexus's centre
  (what our proximal centre moves) and from ours (what our axis moves);
* an alternative centre a caller supplies (the hips: Davis's regression on our pelvis).

:mod:`.centre_causes` turns these figures into report.md's sentences.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import ezc3d
import numpy as np

from mocap_mj.capture.subject import Subject

from ..errors import InputFileError, MocapError
from ..io.formats.c3d import _point_labels, read_parameters, recording_first_frame
from ..io.units import metres_per_unit
from ..skeleton.rigid import rigid_fit
from . import centres
from .compare import crosstalk
from .geometry import chord, unit
from .subject import pig_from_c3d

#: Nexus's segment axes (its A, L, P points, indices 0, 1, 2) as anatomical directions:
#: per direction (anterior, lateral, proximal) the axis index and its sign on the left and
#: on the right. Plug-in Gait's pelvis, femur and tibia y points left on both sides; the
#: clavicle's z points from the shoulder to the thorax origin (medially) and its y up on
#: the left, down on the right; the humerus's and radius's x point posteriorly and their y
#: to the subject's right (checked against the trunk markers on the shared Vicon trials).
LEG_AXES = ((0, 1, 1), (1, 1, -1), (2, 1, 1))
CLAVICLE_AXES = ((0, 1, 1), (2, -1, -1), (1, 1, -1))
ARM_AXES = ((0, -1, -1), (1, -1, 1), (2, 1, 1))


@dataclass(frozen=True)
class JointSpec:
    """One joint of the comparison: Nexus's point at its centre and the segment whose frame
    the components are given in (codes without the side letter; "PEL" has none), the
    markers it is seen from (their mid-point), our neighbouring centres (the bend's, and
    the proximal one Plug-in Gait's construction hangs from) and the axes' anatomy."""

    point: str
    segment: str
    markers: tuple[str, ...]
    proximal: str | None
    distal: str | None
    axes: tuple[tuple[int, int, int], ...]


#: The joints compared, by our name (``joint_centres.csv``'s, without the side).
JOINTS: dict[str, JointSpec] = {
    "hip": JointSpec("FEP", "PEL", (), "lumbosacral", "knee", LEG_AXES),
    "knee": JointSpec("FEO", "FE", ("KNE",), "hip", "ankle", LEG_AXES),
    "ankle": JointSpec("TIO", "TI", ("ANK",), "knee", "mtp", LEG_AXES),
    "shoulder": JointSpec("CLO", "CL", ("SHO",), "cervicothoracic", "elbow", CLAVICLE_AXES),
    "elbow": JointSpec("HUO", "HU", ("ELB",), "shoulder", "wrist", ARM_AXES),
    "wrist": JointSpec("RAO", "RA", ("WRA", "WRB"), "elbow", None, ARM_AXES),
}
#: The components' names, in order.
COMPONENTS = ("anterior", "lateral", "proximal")
#: A distance above this [m] asks for an explanation.
EXPLAIN_ABOVE = 0.010


@dataclass(frozen=True)
class NexusOutput:
    """What a C3D holds of Nexus's Plug-in Gait: frame numbers (T,), points by name
    (markers and bone points, (T, 3) [m] in the file's lab frame, NaN where missing; a
    ``Subject:`` prefix removed), angle points by name ((T, 3) [deg]), the subject values
    of its PROCESSING group (None when they are incomplete) and the file read."""

    frames: np.ndarray
    points: dict[str, np.ndarray]
    angles: dict[str, np.ndarray]
    subject: Subject | None
    source: str

    def has(self, *names: str) -> bool:
        return all(n in self.points for n in names)


def _labels(point: dict[str, Any]) -> list[str]:
    return [lab.split(":")[-1] for lab in _point_labels(point)]


def has_bone_points(path: str | Path) -> bool:
    """Whether the C3D ``path`` holds any joint-centre bone point of :data:`JOINTS` (its
    parameters only are read, :func:`~mocap_mj.io.formats.c3d.read_parameters`)."""
    try:
        point = read_parameters(Path(path)).get("POINT", {})
    except (RuntimeError, OSError) as exc:
        raise InputFileError(f"{path}: cannot read as C3D ({exc})") from None
    codes = {p + s.point for s in JOINTS.values() for p in "LR"}
    return bool(codes & set(_labels(point)))


def read_nexus(path: str | Path) -> NexusOutput | None:
    """Nexus's output in the C3D ``path``; None when it holds none of the joint-centre bone
    points of :data:`JOINTS`."""
    if not has_bone_points(path):
        return None
    try:
        c = ezc3d.c3d(str(path))
    except (RuntimeError, OSError) as exc:
        raise InputFileError(f"{path}: cannot read as C3D ({exc})") from None
    point = c["parameters"]["POINT"]
    labels = _labels(point)
    xyz = np.transpose(c["data"]["points"][:3], (2, 1, 0)).astype(float)
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan
    unit_name = str((point.get("UNITS", {}).get("value") or ["mm"])[0]).strip() or "mm"
    scale = metres_per_unit(unit_name)
    if scale is None:
        raise InputFileError(f"{path}: POINT:UNITS {unit_name!r} is not a length unit")
    points: dict[str, np.ndarray] = {}
    angles: dict[str, np.ndarray] = {}
    for i, name in enumerate(labels[: xyz.shape[1]]):
        if name.endswith(("Angles", "AbsAnkleAngle")):
            angles.setdefault(name, xyz[:, i])
        else:
            points.setdefault(name, xyz[:, i] * scale)
    try:
        subject: Subject | None = pig_from_c3d(path)
    except MocapError:
        subject = None
    first = recording_first_frame(int(c["header"]["points"]["first_frame"]))
    return NexusOutput(first + np.arange(xyz.shape[0]), points, angles, subject, str(path))


def rows_for(frames: np.ndarray, nexus: NexusOutput) -> np.ndarray:
    """Rows of ``nexus`` (T,) for our frame numbers (T,), -1 where it has none: by number
    when most of ours are among its frames, else by position (frames counted from 0)."""
    frames = np.asarray(frames, dtype=int)
    numbered = np.mean(np.isin(frames, nexus.frames)) >= 0.5
    rows = frames - (int(nexus.frames[0]) if numbered else 0)
    return np.where((rows >= 0) & (rows < len(nexus.frames)), rows, -1)


def lab_from_ours(nexus: NexusOutput, rows: np.ndarray, names: tuple[str, ...],
                  markers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The rigid map (R (3, 3), t (3,) [m]) from our frame to the file's lab frame (a
    reader turns a Y-up recording to Z up), fitted to the markers both hold: ours (T, M, 3)
    [m] named ``names``, at the file's ``rows`` (T,). Refused when fewer than three markers
    are shared or they disagree by more than 1 mm (other data than the file's)."""
    shared = [i for i, n in enumerate(names) if n in nexus.points]
    ok = rows >= 0
    few = MocapError(f"{nexus.source}: fewer than three of our markers in its points")
    if len(shared) < 3 or not ok.any():
        raise few
    a = np.asarray(markers, dtype=float)[ok][:, shared].reshape(-1, 3)
    b = np.stack([nexus.points[names[i]][rows[ok]] for i in shared], axis=1).reshape(-1, 3)
    good = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    if good.sum() < 3:
        raise few
    a, b = a[good], b[good]
    rots, shifts = rigid_fit(b[None], a)  # one rigid map for all the pooled samples
    rot, t = rots[0], shifts[0]
    err = float(np.median(np.linalg.norm(a @ rot.T + t - b, axis=1)))
    if err > 1e-3:
        raise MocapError(
            f"{nexus.source}: its markers are {err * 1e3:.1f} mm from the trial's (median): "
            "not the recording fitted"
        )
    return rot, t


@dataclass(frozen=True)
class CentreGap:
    """One centre against Nexus's over ``frames`` common frames. Distances [m], angles
    [rad]; None where the figure cannot be measured (no marker, no neighbour, no widths).

    ``components``, ``components_sd`` (3,) [m]: ours minus Nexus's, anterior, lateral,
    proximal in Nexus's segment frame (median, standard deviation over the frames).
    ``marker``: the marker(s) it is seen from; ``from_marker`` (ours, Nexus's) [m];
    ``marker_angle``: between the two seen from the marker; ``marker_anterior`` (ours,
    Nexus's) [m]: each centre's anterior distance from the marker. ``bend``: the joint's bend
    range (5th, 95th percentile) [rad], ``bend_corr`` and ``bend_slope`` [m/rad] of the
    distance on it. ``construction`` (to Nexus's, to ours) [m]: Plug-in Gait's construction
    on our ``proximal`` centre. ``alternative``: (name, to Nexus's, to ours) [m].
    ``arm_plane`` (elbows): the median angle [rad] between Plug-in Gait's arm plane (its
    shoulder centre, ELB, the wrist bar's mid-point) and the plane of Nexus's own shoulder,
    elbow and wrist centres, and its correlation with Nexus's elbow flexion."""

    joint: str
    point: str
    frames: int
    distance: float
    components: np.ndarray
    components_sd: np.ndarray
    marker: str | None = None
    from_marker: tuple[float, float] | None = None
    marker_angle: float | None = None
    marker_anterior: tuple[float, float] | None = None
    proximal: str | None = None
    bend: tuple[float, float] | None = None
    bend_corr: float | None = None
    bend_slope: float | None = None
    construction: tuple[float, float] | None = None
    alternative: tuple[str, float, float] | None = None
    arm_plane: tuple[float, float] | None = None


def _median_norm(v: np.ndarray) -> float:
    return float(np.nanmedian(np.linalg.norm(v, axis=-1)))


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(np.sum(unit(a) * unit(b), axis=-1), -1.0, 1.0))


def segment_axes(nexus: NexusOutput, code: str, rows: np.ndarray) -> np.ndarray | None:
    """Nexus's segment axes (T, 3, 3) (columns A, L, P) of ``code`` (e.g. "LFE", "PEL") at
    ``rows``; None without its O, A, L, P points."""
    if not nexus.has(*(code + k for k in "OALP")):
        return None
    o = nexus.points[code + "O"][rows]
    return np.stack([unit(nexus.points[code + k][rows] - o) for k in "ALP"], axis=2)


def anatomical(local: np.ndarray, axes: tuple[tuple[int, int, int], ...], side: str) -> np.ndarray:
    """Components (..., 3) along Nexus's A, L, P as anterior, lateral, proximal."""
    k = 1 if side == "l" else 2
    return np.stack([a[k] * local[..., a[0]] for a in axes], axis=-1)


def construction(
    joint: str, side: str, nexus: NexusOutput, rows: np.ndarray, proximal: np.ndarray
) -> np.ndarray | None:
    """Plug-in Gait's centre (T, 3) [m] of ``joint`` (knee, ankle, elbow) by its own
    construction from the file's markers and widths, hung from the ``proximal`` centre
    (T, 3) [m] given (ours); None for the other joints or without the markers or widths."""
    p, sub = side.upper(), nexus.subject
    names = {"knee": ("THI", "KNE"), "ankle": ("TIB", "ANK"), "elbow": ("ELB", "WRA", "WRB")}
    width = sub.get(f"{joint}_width_{side}") if sub is not None and joint in names else None
    if sub is None or width is None or not nexus.has(*(p + n for n in names[joint])):
        return None
    m = {n: nexus.points[p + n][rows] for n in names[joint]}
    r = sub.marker_radius
    if joint == "elbow":
        return centres.elbow(proximal, m["ELB"], 0.5 * (m["WRA"] + m["WRB"]), width, r, side)
    wand, marker = (m[n] for n in names[joint])
    return chord(wand, proximal, marker, 0.5 * width + r)


def centre_gaps(
    nexus: NexusOutput,
    rows: np.ndarray,
    ours: Mapping[str, np.ndarray],
    alternatives: Mapping[str, tuple[str, np.ndarray]] | None = None,
) -> list[CentreGap]:
    """Every centre of :data:`JOINTS` that Nexus's file and ``ours`` hold, left then right.

    ``rows`` (T,): the file's row of each of our frames (-1: none, :func:`rows_for`);
    ``ours``: our centres by ``joint_centres.csv`` name (``knee_l``, ``lumbosacral``)
    (T, 3) [m] in the file's lab frame; ``alternatives``: centre name -> (name, (T, 3) [m])
    another centre to measure against Nexus's (e.g. Davis's hip on our pelvis)."""
    ok = rows >= 0
    out = []
    for side in ("l", "r"):
        for joint, spec in JOINTS.items():
            name, code = f"{joint}_{side}", side.upper() + spec.point
            if code not in nexus.points or name not in ours or ok.sum() == 0:
                continue
            alt = (alternatives or {}).get(name)
            out.append(_gap(nexus, rows[ok], {k: v[ok] for k, v in ours.items()}, side,
                            joint, None if alt is None else (alt[0], alt[1][ok])))  # fmt: skip
    return out


def _neighbour(ours: Mapping[str, np.ndarray], name: str | None, side: str) -> np.ndarray | None:
    if name is None:
        return None
    return ours.get(f"{name}_{side}", ours.get(name))


def _gap(
    nexus: NexusOutput,
    rows: np.ndarray,
    ours: Mapping[str, np.ndarray],
    side: str,
    joint: str,
    alternative: tuple[str, np.ndarray] | None,
) -> CentreGap:
    spec = JOINTS[joint]
    p = side.upper()
    code = p + spec.point
    us, them = ours[f"{joint}_{side}"], nexus.points[code][rows]
    diff = us - them
    seg = spec.segment if spec.segment == "PEL" else p + spec.segment
    axes = segment_axes(nexus, seg, rows)
    if axes is None:
        comps = np.full((len(rows), 3), np.nan)
    else:
        comps = anatomical(np.einsum("tji,tj->ti", axes, diff), spec.axes, side)
    figures: dict[str, object] = {}
    if spec.markers and nexus.has(*(p + m for m in spec.markers)):
        m = np.mean([nexus.points[p + k][rows] for k in spec.markers], axis=0)
        figures["marker"] = "/".join(p + k for k in spec.markers)
        figures["from_marker"] = (_median_norm(us - m), _median_norm(them - m))
        figures["marker_angle"] = float(np.nanmedian(_angle(us - m, them - m)))
        if axes is not None:
            ant = [np.nanmedian(anatomical(np.einsum("tji,tj->ti", axes, c - m), spec.axes,
                                           side)[:, 0]) for c in (us, them)]  # fmt: skip
            figures["marker_anterior"] = (float(ant[0]), float(ant[1]))
    prox, dist = (_neighbour(ours, n, side) for n in (spec.proximal, spec.distal))
    if prox is not None and dist is not None:
        figures |= _bend_figures(np.pi - _angle(prox - us, dist - us), diff)
    if prox is not None:
        built = construction(joint, side, nexus, rows, prox)
        if built is not None:
            figures["proximal"] = spec.proximal
            figures["construction"] = (_median_norm(built - them), _median_norm(built - us))
    if joint == "elbow":
        figures |= _arm_plane(nexus, rows, p)
    if alternative is not None:
        figures["alternative"] = (alternative[0], _median_norm(alternative[1] - them),
                                  _median_norm(alternative[1] - us))  # fmt: skip
    return CentreGap(
        joint=f"{joint}_{side}", point=code, frames=int(np.sum(np.all(np.isfinite(diff), axis=1))),
        distance=_median_norm(diff), components=np.nanmedian(comps, axis=0),
        components_sd=np.nanstd(comps, axis=0), **figures,  # type: ignore[arg-type]
    )  # fmt: skip


def _arm_plane(nexus: NexusOutput, rows: np.ndarray, p: str) -> dict[str, object]:
    """The tilt of Plug-in Gait's arm plane against Nexus's own centres' (side letter ``p``),
    and its correlation with the elbow's flexion; empty without the points."""
    names = [p + n for n in ("CLO", "HUO", "RAO", "ELB", "WRA", "WRB")]
    if not nexus.has(*names):
        return {}
    sjc, ejc, wjc, elb, wra, wrb = (nexus.points[n][rows] for n in names)
    marker_plane = unit(np.cross(sjc - elb, 0.5 * (wra + wrb) - elb))
    centre_plane = unit(np.cross(sjc - ejc, wjc - ejc))
    tilt = np.arccos(np.clip(np.abs(np.sum(marker_plane * centre_plane, axis=1)), 0.0, 1.0))
    flexion = np.pi - _angle(sjc - ejc, wjc - ejc)
    ok = np.isfinite(tilt) & np.isfinite(flexion)
    if ok.sum() < 3 or np.std(tilt[ok]) == 0 or np.std(flexion[ok]) == 0:
        return {}
    return {"arm_plane": (float(np.median(tilt[ok])),
                          float(np.corrcoef(tilt[ok], flexion[ok])[0, 1]))}  # fmt: skip


def _bend_figures(bend: np.ndarray, diff: np.ndarray) -> dict[str, object]:
    """The bend's range and the distance's correlation and slope on it (None when the bend
    spans less than 5 degrees: nothing to correlate)."""
    d = np.linalg.norm(diff, axis=1)
    ok = np.isfinite(bend) & np.isfinite(d)
    if ok.sum() < 3:
        return {}
    lo, hi = np.percentile(bend[ok], [5, 95])
    out: dict[str, object] = {"bend": (float(lo), float(hi))}
    if hi - lo >= np.radians(5.0) and np.std(d[ok]) > 0:
        out["bend_corr"] = float(np.corrcoef(bend[ok], d[ok])[0, 1])
        out["bend_slope"] = float(np.polyfit(bend[ok], d[ok], 1)[0])
    return out


def nexus_crosstalk(nexus: NexusOutput, rows: np.ndarray, side: str) -> tuple[float, float] | None:
    """Nexus's own knee varus-valgus / flexion crosstalk (:func:`~.compare.crosstalk`) of its
    KneeAngles' Y on X over ``rows`` (-1 skipped); None without the angles."""
    a = nexus.angles.get(f"{side.upper()}KneeAngles")
    if a is None:
        return None
    a = a[rows[rows >= 0]]
    return crosstalk(a[:, 0], a[:, 1])
