"""Plug-in Gait joint and progression angles from the segment frames.

Every angle is a Cardan decomposition of one frame in another (:func:`relative`): YXZ
(flexion about the proximal y, then the floating x, then the distal z) for the hip, knee,
ankle, elbow, wrist, the progression angles of the pelvis, foot, thorax and head, and the
neck; XYZ for the shoulder; ZXY for the spine. :data:`ANGLES` maps the three Cardan angles
onto Vicon's components, each with its per-side sign and offset, so that in every table:
flexion, adduction (varus) and internal rotation are positive on both sides; pelvic tilt is
positive anterior, obliquity positive when that side is up, rotation positive when that
side is forward; ankle dorsiflexion, inversion and internal rotation positive.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .geometry import cardan_xyz, cardan_yxz, cardan_zxy, relative

#: The thorax turned into the lower body's orientation (x anterior, y left, z up).
FLIP_YZ = np.diag([1.0, -1.0, -1.0])
#: The humerus turned half a turn about its long axis (x anterior).
FLIP_XY = np.diag([-1.0, -1.0, 1.0])


@dataclass(frozen=True)
class AngleSpec:
    """One output angle: proximal and distal frame names ({s}: side letter), the Cardan
    sequence, and per output component (Cardan index, sign on the left, sign on the right,
    offset [deg])."""

    proximal: str
    distal: str
    sequence: str
    components: tuple[tuple[int, float, float, float], ...]


def _C(
    index: int, left: float, right: float, offset: float = 0.0
) -> tuple[int, float, float, float]:
    return (index, left, right, offset)


_DECOMPOSE = {"yxz": cardan_yxz, "xyz": cardan_xyz, "zxy": cardan_zxy}

#: Vicon's angle name (without the side letter) -> definition. "progression" is the
#: progression frame (x along the direction of progression, z up), "thorax_up" the thorax
#: with y and z reversed.
ANGLES: dict[str, AngleSpec] = {
    "PelvisAngles": AngleSpec(
        "progression", "pelvis", "yxz", (_C(0, 1, 1), _C(1, 1, -1), _C(2, -1, 1))
    ),
    "HipAngles": AngleSpec(
        "pelvis", "femur_{s}", "yxz", (_C(0, -1, -1), _C(1, -1, 1), _C(2, -1, 1))
    ),
    "KneeAngles": AngleSpec(
        "femur_{s}", "tibia_{s}", "yxz", (_C(0, 1, 1), _C(1, -1, 1), _C(2, -1, 1))
    ),
    "AnkleAngles": AngleSpec(
        "tibia_torsioned_{s}", "foot_{s}", "yxz", (_C(0, -1, -1, -90), _C(2, -1, 1), _C(1, -1, 1))
    ),
    "FootProgressAngles": AngleSpec(
        "progression", "foot_{s}", "yxz", (_C(0, 1, 1), _C(2, 1, -1), _C(1, -1, 1))
    ),
    "ThoraxAngles": AngleSpec(
        "progression", "thorax_up", "yxz", (_C(0, 1, 1), _C(1, 1, -1), _C(2, -1, 1))
    ),
    "SpineAngles": AngleSpec(
        "pelvis", "thorax_up", "zxy", (_C(2, 1, 1), _C(1, -1, 1), _C(0, 1, -1))
    ),
    "NeckAngles": AngleSpec("thorax_up", "head", "zxy", (_C(2, 1, 1), _C(1, -1, 1), _C(0, 1, -1))),
    "HeadAngles": AngleSpec(
        "progression", "head", "yxz", (_C(0, -1, -1), _C(1, 1, -1), _C(2, -1, 1))
    ),
    "ShoulderAngles": AngleSpec(
        "thorax_up", "humerus_up_{s}", "xyz", (_C(1, -1, -1), _C(0, 1, -1), _C(2, -1, 1))
    ),
    "ElbowAngles": AngleSpec(
        "humerus_{s}", "radius_{s}", "yxz", (_C(0, 1, 1), _C(1, 1, 1), _C(2, -1, -1))
    ),
    "WristAngles": AngleSpec(
        "radius_{s}", "hand_{s}", "yxz", (_C(0, 1, 1), _C(1, -1, 1), _C(2, -1, 1))
    ),
}


def progression_frame(pelvis_axes: np.ndarray, pelvis_origin: np.ndarray) -> np.ndarray:
    """The progression frame (3, 3): x along the lab's horizontal axis (+-X or +-Y) closest
    to the direction of progression, z up, y = z x x.

    The direction of progression is the pelvis' displacement over the trial when it moves
    more than 0.5 m horizontally (walking), else the median direction the pelvis faces
    (a static trial, a jump in place): so a subject facing -X reads the same angles as one
    facing +X.
    """
    ok = np.all(np.isfinite(pelvis_origin), axis=1)
    direction = np.zeros(3)
    if ok.sum() >= 2:
        first, last = pelvis_origin[ok][0], pelvis_origin[ok][-1]
        step = (last - first) * np.array([1.0, 1.0, 0.0])
        if np.linalg.norm(step) > 0.5:
            direction = step
    if not np.any(direction):
        facing = pelvis_axes[:, :, 0]
        direction = (
            np.nanmedian(facing, axis=0) if np.any(np.isfinite(facing)) else np.array([1.0, 0, 0])
        )
    axis = int(np.argmax(np.abs(direction[:2])))
    x = np.zeros(3)
    x[axis] = np.sign(direction[axis]) or 1.0
    z = np.array([0.0, 0.0, 1.0])
    return np.stack([x, np.cross(z, x), z], axis=-1)


def angle(spec: AngleSpec, side: str, frames: dict[str, np.ndarray]) -> np.ndarray:
    """One angle (T, 3) [rad] in Vicon's components and signs for ``side``."""
    p = frames[spec.proximal.format(s=side)]
    d = frames[spec.distal.format(s=side)]
    if p.ndim == 2:
        p = np.broadcast_to(p, d.shape)
    raw = _DECOMPOSE[spec.sequence](relative(p, d))
    out = np.empty_like(raw)
    for k, (i, left, right, offset) in enumerate(spec.components):
        v = (left if side == "l" else right) * raw[:, i] + np.deg2rad(offset)
        out[:, k] = np.angle(np.exp(1j * v))
    return out


def all_angles(segments: Mapping[str, Any], progression: np.ndarray) -> dict[str, np.ndarray]:
    """Every angle of :data:`ANGLES` whose segments exist, by Vicon name (``LKneeAngles``)
    -> (T, 3) [rad]. ``segments``: name -> object with ``axes`` (T, 3, 3);
    ``progression`` (3, 3) from :func:`progression_frame`."""
    axes = {k: v.axes for k, v in segments.items()}
    axes["progression"] = np.broadcast_to(progression, axes["pelvis"].shape)
    if "thorax" in axes:
        axes["thorax_up"] = axes["thorax"] @ FLIP_YZ
    for s in ("l", "r"):
        if f"humerus_{s}" in axes:
            axes[f"humerus_up_{s}"] = axes[f"humerus_{s}"] @ FLIP_XY
    out = {}
    for name, spec in ANGLES.items():
        for s in ("l", "r"):
            if spec.proximal.format(s=s) in axes and spec.distal.format(s=s) in axes:
                out[s.upper() + name] = angle(spec, s, axes)
    return out


def abs_ankle_angles(segments: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Vicon's ``LAbsAnkleAngle`` and ``RAbsAnkleAngle`` (T, 3) [rad]: in X the angle between
    the tibia's and the foot's long axes (z) less a right angle, the ankle's flexion
    whatever its rotation and inversion (positive dorsiflexion); Y and Z are 0, as Nexus
    writes them. Only the sides whose tibia and foot exist."""
    out = {}
    for s in ("l", "r"):
        tibia, foot = segments.get(f"tibia_torsioned_{s}"), segments.get(f"foot_{s}")
        if tibia is None or foot is None:
            continue
        cos = np.einsum("ti,ti->t", tibia.axes[..., 2], foot.axes[..., 2])
        x = np.arccos(np.clip(cos, -1.0, 1.0)) - 0.5 * np.pi
        out[s.upper() + "AbsAnkleAngle"] = np.stack([x, 0.0 * x, 0.0 * x], axis=-1)
    return out
