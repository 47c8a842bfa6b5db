"""``plug_in_gait``: Plug-in Gait (the Conventional Gait Model 1.0) on a marker trajectory.

Steps: the subject values (the static trial's offsets and measurements when one is given),
the lower body (pelvis, Davis hip centres, chord knee and ankle centres, tibia, foot with the
static offsets), the trunk and upper limbs when their markers are present, the angles in
Vicon's conventions and the bone points. A trial that is itself static (the pelvis and leg
markers still) uses the static model's foot, from the heel marker, as Nexus does.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocap_mj.capture.subject import Subject

from ..errors import MocapError
from ..io.trajectory import MarkerTrajectory
from . import static as static_mod
from .angles import abs_ankle_angles, all_angles, progression_frame
from .bones import bone_points
from .segments import (
    SIDES,
    Markers,
    Segment,
    lower_body,
    static_foot,
    trunk,
    trunk_frames,
    upper_limbs,
)
from .subject import UPPER, not_applied, pig_dict

_log = logging.getLogger(__name__)

#: Markers the lower body needs; the trunk and upper limbs are computed when theirs exist.
LOWER_MARKERS = ("LASI", "RASI", "LTHI", "LKNE", "LTIB", "LANK", "LTOE",
                 "RTHI", "RKNE", "RTIB", "RANK", "RTOE")  # fmt: skip
UPPER_MARKERS = ("C7", "T10", "CLAV", "STRN", "LFHD", "RFHD", "LBHD", "RBHD", "LSHO", "LELB",
                 "LWRA", "LWRB", "LFIN", "RSHO", "RELB", "RWRA", "RWRB", "RFIN")  # fmt: skip


@dataclass
class PigResult:
    """Plug-in Gait's outputs for one trial.

    ``angles``: Vicon name (``LKneeAngles``...) -> (T, 3) [rad]; ``points``: Vicon bone
    point name (``LFEO``...) -> (T, 3) [m] in the recording's lab frame; ``times`` (T,) [s];
    ``frames`` (T,) the recording's own frame numbers; ``progression`` (3,) the direction
    of progression in the lab; ``static``: whether the trial was processed as a static one
    (its own offsets and the static model's foot); ``segments`` (name -> :class:`Segment`)
    and ``centres`` (``hip_l``... -> (T, 3) [m]) in the trajectory's Z-up frame, what the
    kinetics (:mod:`.kinetics`) start from.
    """

    times: np.ndarray
    frames: np.ndarray
    angles: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    subject: Subject
    progression: np.ndarray
    static: bool
    notes: list[str] = field(default_factory=list)
    segments: dict[str, Segment] = field(default_factory=dict)
    centres: dict[str, np.ndarray] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        return {
            "frames": len(self.times),
            "first_frame": int(self.frames[0]) if len(self.frames) else None,
            "static_trial": self.static,
            "progression_axis_lab": [float(v) for v in self.progression],
            "angles": sorted(self.angles),
            "points": sorted(self.points),
            "subject": pig_dict(self.subject),
            "notes": list(self.notes),
        }


def _markers(traj: MarkerTrajectory) -> Markers:
    return Markers({n: traj.positions[:, i] for i, n in enumerate(traj.names)}, traj.n_frames)


def _require(m: Markers, names: tuple[str, ...], where: str) -> None:
    missing = [n for n in names if n not in m]
    if "SACR" not in m and ("LPSI" not in m or "RPSI" not in m):
        missing.append("SACR (or LPSI and RPSI)")
    if missing:
        raise MocapError(f"{where}: Plug-in Gait needs the markers {', '.join(missing)}")


def _as_static(m: Markers, trial_type: str, has_static: bool, where: str) -> bool:
    if trial_type not in ("auto", "static", "dynamic"):
        raise MocapError(f"trial type {trial_type!r}: expected auto, static or dynamic")
    heels = all(n in m for n in ("LHEE", "RHEE"))
    if trial_type == "static" and not heels:
        raise MocapError(f"{where}: a static trial needs the LHEE and RHEE markers")
    if trial_type == "auto":
        return not has_static and heels and static_mod.is_static(m)
    return trial_type == "static"


def _refuse_moving_static(m: Markers, static: MarkerTrajectory, where: str) -> None:
    """Refuse a static trial whose pelvis and leg markers move (``trial-type auto``'s rule,
    :func:`~mocap_mj.clinical.static.trial_kind`): its offsets would be a walk's. The message
    names both files, and says they are swapped when the trial itself is the static one. A
    trial whose markers cannot tell (a still marker absent) is taken as given."""
    there = str(static.source.get("path", "static trial"))
    if static_mod.trial_kind(_markers(static)) != "dynamic":
        return
    rule = f"pelvis and leg markers move more than {static_mod.STILL_RADIUS:g} m"
    if static_mod.trial_kind(m) == "static":
        raise MocapError(
            f"the static {there} is a dynamic trial ({rule}) and the trial {where} a static "
            "one: the two are swapped"
        )
    raise MocapError(
        f"the static {there} is a dynamic trial ({rule}), expected a standing trial for "
        f"the trial {where}"
    )


#: Given static offsets [rad] that the flat-foot calibration reproduces within this (and
#: better than the plain one) tell that the static trial's foot was calibrated flat.
FLAT_MATCH = 1e-3


def calibrate(static: MarkerTrajectory, subject: Subject) -> Subject:
    """The subject with the offsets, inter-ASIS distance and leg lengths a static trial
    gives (measured values are kept; the offsets always come from the static trial).

    Nexus's static options: a foot is calibrated flat (:func:`~.segments.static_foot`, with
    the side's ``sole_delta``) when the subject's ``flat_foot`` says so, or, not given, when
    the subject's given static offsets (the PROCESSING group's, Nexus's calibration of this
    static) are the flat calibration's within :data:`FLAT_MATCH` and nearer than the plain
    one's; ``head_level`` computes the head offset of a level head
    (:func:`~.static.head_offset`), else the given head offset stands."""
    m = _markers(static)
    where = str(static.source.get("path", "static trial"))
    _require(m, (*LOWER_MARKERS, "LHEE", "RHEE"), where)
    subject = _with_marker_measures(m, subject, where)
    segs, _ = lower_body(m, subject, _inter_asis(m, subject))
    values, flats = {}, {}
    for s in SIDES:
        tibia, raw = segs[f"tibia_torsioned_{s}"].axes, segs[f"foot_raw_{s}"].axes
        delta = subject.pig(f"sole_delta_{s}")
        try:
            plain = static_mod.foot_offsets(raw, static_foot(m, s, tibia), s)
            flat = static_mod.foot_offsets(raw, static_foot(m, s, tibia, flat=True,
                                                             sole_delta=delta), s)  # fmt: skip
        except ValueError as exc:
            raise MocapError(f"{where}: {exc}") from None
        told = subject.flag(f"flat_foot_{s}")
        if told is None:
            told, why = _given_flat(subject, s, plain, flat)
            flats[f"flat_foot_{s}"] = (float(told), why)
        flex, rot = flat if told else plain
        values[f"static_plantar_flex_{s}"] = flex
        values[f"static_rot_off_{s}"] = rot
    if subject.flag("head_level") and all(n in m for n in UPPER_MARKERS[4:8]):
        try:
            values["head_offset"] = static_mod.head_offset(trunk_frames(m, 0.0, 0.0)["head"].axes)
        except ValueError as exc:
            raise MocapError(f"{where}: {exc}") from None
    subject = subject.with_pig(values, f"{where}: static trial")
    for name, (value, why) in flats.items():
        subject = subject.with_pig({name: value}, f"{where}: static trial ({why})")
    return subject


def _given_flat(
    subject: Subject, side: str, plain: tuple[float, float], flat: tuple[float, float]
) -> tuple[bool, str]:
    """Whether the subject's given static offsets of ``side`` are the flat calibration's
    (``flat``, within :data:`FLAT_MATCH`, nearer than ``plain``'s; False without them), and
    why, for the value's source."""
    names = (f"static_plantar_flex_{side}", f"static_rot_off_{side}")
    if not all(n in subject.pig_values for n in names):
        return False, "no static offsets given: not flat"
    given = np.array([subject.pig(n) for n in names])
    off_flat = float(np.max(np.abs(given - np.array(flat))))
    off_plain = float(np.max(np.abs(given - np.array(plain))))
    told = off_flat <= FLAT_MATCH and off_flat < off_plain
    return told, (
        f"the given offsets lie {off_flat:.1e} rad from its flat calibration, "
        f"{off_plain:.1e} from its plain one"
    )


def _with_marker_measures(m: Markers, subject: Subject, where: str) -> Subject:
    """Leg lengths from the markers where the subject values give none."""
    from mocap_mj.capture.subject import from_values

    missing = [s for s in SIDES if subject.get(f"leg_length_{s}") is None]
    if not missing:
        return subject
    est = from_values(
        [(f"leg_length_{s}", static_mod.leg_length(m, s)) for s in missing],
        f"{where}: markers (ASIS-KNE-ANK)",
    )
    return subject.update(est)


def _inter_asis(m: Markers, subject: Subject) -> float:
    given = subject.get("asis_distance")
    return given if given is not None else static_mod.inter_asis(m)


def plug_in_gait(
    trajectory: MarkerTrajectory,
    subject: Subject,
    static: MarkerTrajectory | None = None,
    *,
    frames: np.ndarray | None = None,
    to_lab: np.ndarray | None = None,
    override: Subject | None = None,
    trial_type: str = "auto",
) -> PigResult:
    """Plug-in Gait on ``trajectory`` (metres, Z up) with ``subject``'s values.

    ``static``: a static trial whose offsets replace the subject's; ``frames`` (T,) the
    recording's frame numbers (default: the trajectory's, ``first_frame + i``); ``to_lab``
    (3, 3) the rotation from the trajectory's Z-up frame back to the recording's lab frame
    for the points (default identity); ``override``: values that win over the static
    trial's (a subject file); ``trial_type``: "static" (the trial gives its own offsets and
    the static model's foot, as Nexus' static pipeline), "dynamic", or "auto" (static when
    no ``static`` is given and the pelvis and leg markers stay still). Missing markers give
    NaN in every output that depends on them.
    """
    where = str(trajectory.source.get("path", "trajectory"))
    m = _markers(trajectory)
    _require(m, LOWER_MARKERS, where)
    if override is not None:  # the measurements first, for the calibrations
        subject = subject.update(override)
    if static is not None:
        _refuse_moving_static(m, static, where)
        subject = calibrate(static, subject)
    notes = []
    as_static = _as_static(m, trial_type, static is not None, where)
    if as_static:
        subject = calibrate(trajectory, subject)
        flat = [w for s, w in zip(SIDES, ("left", "right"), strict=True)
                if subject.flag(f"flat_foot_{s}")]  # fmt: skip
        foot = f"flat: {' and '.join(flat)}" if flat else "not flat"
        notes.append(f"static trial: its own offsets; the foot is the static model's ({foot})")
    if override is not None:  # and its offsets over the calibrations'
        subject = subject.update(override)
    subject = _with_marker_measures(m, subject, where)
    notes += not_applied(subject)
    segs, jc = lower_body(m, subject, _inter_asis(m, subject), heel_foot=as_static)
    upper = all(n in m for n in UPPER_MARKERS) and all(
        subject.get(f"{b}_{s}") is not None for b in UPPER for s in SIDES
    )
    if upper:
        segs |= trunk(m, subject)
        limbs, ujc = upper_limbs(m, subject, segs["thorax"])
        segs |= limbs
        jc |= ujc
    else:
        notes.append("no trunk or upper-limb outputs: markers or measurements missing")
    prog = progression_frame(segs["pelvis"].axes, segs["pelvis"].origin)
    widths = {s: subject.require(f"knee_width_{s}") for s in SIDES}
    feet = {s: static_mod.foot_length(m, s, subject.marker_radius) for s in SIDES}
    rot = np.eye(3) if to_lab is None else np.asarray(to_lab)
    head = static_mod.head_size(m, subject.marker_radius)
    points = bone_points(segs, jc, widths, feet, upper=upper, head_size=head)
    n = trajectory.n_frames
    numbers = trajectory.first_frame + np.arange(n) if frames is None else np.asarray(frames)
    return PigResult(
        times=np.asarray(trajectory.times),
        frames=numbers,
        angles=all_angles(segs, prog) | abs_ankle_angles(segs),
        points={k: v @ rot.T for k, v in points.items()},
        subject=subject,
        progression=rot @ prog[:, 0],
        static=as_static,
        notes=notes,
        segments=segs,
        centres=jc,
    )
