"""Plug-in Gait segment frames from the markers, the subject values and the joint centres.

A :class:`Segment` holds an origin (T, 3) [m] and axes (T, 3, 3) whose columns are the
segment's x, y, z in the lab. The frames follow Plug-in Gait's definitions: pelvis, femur,
tibia x anterior, y left, z proximal; foot z from the toe towards the heel (after the static
offsets), x up; thorax x anterior, z down; head x anterior, y left, z up; clavicle, humerus,
radius and hand z proximal with the y axes of Plug-in Gait's upper limb.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mocap_mj.capture.subject import Subject

from . import centres
from .geometry import chord, frame, frame_zx, frame_zy, rotate_about
from .subject import asis_trochanter

SIDES = ("l", "r")


@dataclass(frozen=True)
class Segment:
    """A segment's origin (T, 3) [m] and axes (T, 3, 3) (columns x, y, z)."""

    origin: np.ndarray
    axes: np.ndarray


class Markers:
    """Marker positions by name, (T, 3) [m]; an absent marker reads as NaN in every frame."""

    def __init__(self, positions: Mapping[str, np.ndarray], n_frames: int) -> None:
        self._p = dict(positions)
        self.n_frames = n_frames

    def __getitem__(self, name: str) -> np.ndarray:
        p = self._p.get(name)
        return np.full((self.n_frames, 3), np.nan) if p is None else p

    def __contains__(self, name: str) -> bool:
        return name in self._p

    def mid(self, a: str, b: str) -> np.ndarray:
        return 0.5 * (self[a] + self[b])

    def sacrum(self) -> np.ndarray:
        """SACR when recorded, else the mid-point of the PSIS markers."""
        return self["SACR"] if "SACR" in self._p else self.mid("LPSI", "RPSI")


def _lateral(side: str) -> float:
    """+1 for the left (y points laterally), -1 for the right (y points medially)."""
    return 1.0 if side == "l" else -1.0


def static_foot(
    m: Markers, side: str, tibia: np.ndarray, *, flat: bool = False, sole_delta: float = 0.0
) -> np.ndarray:
    """The foot of the static model (T, 3, 3): z from the toe to the heel marker, y from the
    ankle flexion axis (the torsioned tibia's y, ``tibia`` (T, 3, 3)). ``flat`` (Nexus's
    static "foot flat"): the heel taken at the toe marker's height plus ``sole_delta`` [m]
    (the heel's sole less the toe's), so the foot's long axis lies along the floor."""
    p = side.upper()
    heel = m[p + "HEE"]
    if flat:
        heel = heel.copy()
        heel[:, 2] = m[p + "TOE"][:, 2] + sole_delta
    return frame_zy(heel - m[p + "TOE"], tibia[..., 1])


def static_foot_of(m: Markers, side: str, tibia: np.ndarray, subject: Subject) -> np.ndarray:
    """:func:`static_foot` with the subject's ``flat_foot`` and ``sole_delta`` of ``side``."""
    flat = bool(subject.flag(f"flat_foot_{side}"))
    return static_foot(m, side, tibia, flat=flat, sole_delta=subject.pig(f"sole_delta_{side}"))


def pelvis_frame(m: Markers) -> np.ndarray:
    """The pelvis (T, 3, 3): y from RASI to LASI, x towards the mid-ASIS from the sacrum."""
    return frame(1, m["LASI"] - m["RASI"], 0, m.mid("LASI", "RASI") - m.sacrum())


def lower_body(
    m: Markers, subject: Subject, inter_asis: float, *, heel_foot: bool = False
) -> tuple[dict[str, Segment], dict[str, np.ndarray]]:
    """Pelvis, femur, tibia (untorsioned for the knee, torsioned for the ankle) and foot
    frames, and the hip, knee and ankle centres (keys ``hip_l``, ``knee_l``, ``ankle_l``...).

    The foot is the uncorrected foot (z from the toe marker to the ankle centre) turned by
    the static offsets, or with ``heel_foot`` the static model's foot (:func:`static_foot_of`:
    flat when the subject's ``flat_foot`` says so).
    Tibial torsion (positive external) turns the marker tibia, whose y follows the ankle
    axis, back about its z to the untorsioned tibia of the knee angles."""
    r = subject.marker_radius
    mid = m.mid("LASI", "RASI")
    pelvis = pelvis_frame(m)
    segs = {"pelvis": Segment(mid, pelvis)}
    jc: dict[str, np.ndarray] = {}
    leg = subject.leg_length()
    for s in SIDES:
        p, lat = s.upper(), _lateral(s)
        hip = centres.davis_hip(
            pelvis,
            mid,
            leg_length=leg,
            asis_trochanter=asis_trochanter(subject, s),
            inter_asis=inter_asis,
            marker_radius=r,
            side=s,
        )
        kne, ank = m[p + "KNE"], m[p + "ANK"]
        knee = chord(m[p + "THI"], hip, kne, 0.5 * subject.require(f"knee_width_{s}") + r)
        femur = frame_zy(hip - knee, lat * (kne - knee))
        ankle = chord(m[p + "TIB"], knee, ank, 0.5 * subject.require(f"ankle_width_{s}") + r)
        tibia = frame_zy(knee - ankle, lat * (ank - ankle))
        torsion = subject.pig(f"tibial_torsion_{s}")
        untorsioned = rotate_about(tibia, 2, -lat * torsion)
        raw = frame_zy(ankle - m[p + "TOE"], tibia[..., 1])
        rot_off = lat * subject.pig(f"static_rot_off_{s}")
        flex = subject.pig(f"static_plantar_flex_{s}")
        foot = rotate_about(rotate_about(raw, 1, -flex), 0, -rot_off)
        if heel_foot:
            foot = static_foot_of(m, s, tibia, subject)
        jc.update({f"hip_{s}": hip, f"knee_{s}": knee, f"ankle_{s}": ankle})
        segs.update(
            {
                f"femur_{s}": Segment(knee, femur),
                f"tibia_{s}": Segment(ankle, untorsioned),
                f"tibia_torsioned_{s}": Segment(ankle, tibia),
                f"foot_raw_{s}": Segment(m[p + "TOE"], raw),
                f"foot_{s}": Segment(m[p + "TOE"], foot),
            }
        )
    jc["pelvis"] = 0.5 * (jc["hip_l"] + jc["hip_r"])
    return segs, jc


def trunk(m: Markers, subject: Subject) -> dict[str, Segment]:
    """Thorax and head of :func:`trunk_frames` with the subject's marker radius and head
    offset."""
    return trunk_frames(m, subject.marker_radius, subject.pig("head_offset"))


def trunk_frames(m: Markers, marker_radius: float, head_offset: float) -> dict[str, Segment]:
    """Thorax (origin at CLAV moved ``marker_radius`` [m] posterior) and head (origin at the
    mid-point of the front head markers, pitched by ``head_offset`` [rad])."""
    upper, lower = m.mid("CLAV", "C7"), m.mid("STRN", "T10")
    front, back = m.mid("CLAV", "STRN"), m.mid("C7", "T10")
    thorax = frame_zx(lower - upper, front - back)
    origin = m["CLAV"] - marker_radius * thorax[..., 0]
    hfront, hback = m.mid("LFHD", "RFHD"), m.mid("LBHD", "RBHD")
    head = frame(0, hfront - hback, 1, m.mid("LFHD", "LBHD") - m.mid("RFHD", "RBHD"))
    head = rotate_about(head, 1, head_offset)
    return {"thorax": Segment(origin, thorax), "head": Segment(hfront, head)}


def upper_limbs(
    m: Markers, subject: Subject, thorax: Segment
) -> tuple[dict[str, Segment], dict[str, np.ndarray]]:
    """Clavicle, humerus, radius and hand frames, and the shoulder, elbow, wrist and hand
    centres (keys ``shoulder_l``, ``elbow_l``, ``wrist_l``, ``hand_l``...)."""
    r = subject.marker_radius
    segs: dict[str, Segment] = {}
    jc: dict[str, np.ndarray] = {}
    for s in SIDES:
        p, lat = s.upper(), _lateral(s)
        sho = m[p + "SHO"]
        wand = centres.wand_direction(thorax.axes, thorax.origin, sho, s)
        sjc = centres.shoulder(
            thorax.axes, thorax.origin, sho, subject.require(f"shoulder_offset_{s}"), r, s
        )
        wra, wrb = m[p + "WRA"], m[p + "WRB"]
        wri = 0.5 * (wra + wrb)
        ejc = centres.elbow(sjc, m[p + "ELB"], wri, subject.require(f"elbow_width_{s}"), r, s)
        forearm = frame_zx(ejc - wri, wra - wrb)
        wjc = centres.wrist(wri, forearm[..., 1], subject.require(f"wrist_width_{s}"), r, s)
        humerus = frame_zx(sjc - ejc, ejc - wjc)
        radius = frame(1, humerus[..., 1], 2, ejc - wjc)
        hjc = centres.hand(wri, wjc, m[p + "FIN"], subject.require(f"hand_thickness_{s}"), r)
        hand = frame_zy(wjc - hjc, lat * (wri - wra))
        clavicle = frame_zy(thorax.origin - sjc, lat * wand)
        jc.update({f"shoulder_{s}": sjc, f"elbow_{s}": ejc, f"wrist_{s}": wjc, f"hand_{s}": hjc})
        segs.update(
            {
                f"clavicle_{s}": Segment(sjc, clavicle),
                f"humerus_{s}": Segment(ejc, humerus),
                f"radius_{s}": Segment(wjc, radius),
                f"hand_{s}": Segment(hjc, hand),
            }
        )
    return segs, jc
