"""Clinical joint angles: hip, knee, ankle, pelvis, trunk, shoulder, elbow, wrist.

Convention (Grood & Suntay 1983; Wu et al. 2002/2005, ISB): the rotation of the distal segment
relative to the proximal one is split into three Cardan angles, in this order:

1. flexion about the proximal segment's mediolateral axis (y, pointing left),
2. adduction about the floating axis (anteroposterior, x, after the flexion),
3. internal rotation about the distal segment's long axis (z, up in the reference pose),

i.e. the intrinsic Y-X-Z decomposition of ``R_proximal^T R_distal``. Every body frame of the
humanoid is x anterior, y left, z up in the reference pose (standing, palms forward), where
every angle is zero. The middle angle has the gimbal singularity: at +-90 degrees of adduction
(a shoulder abducted to the horizontal) the other two are not defined apart.

Signs (degrees; L = left, R = right; both sides read the same for the same anatomical motion):

=========  =========================  =======================  =========================
joint      flexion (+)                adduction (+)            internal rotation (+)
=========  =========================  =======================  =========================
pelvis     anterior tilt              obliquity, left side up  rotation, left side forward
           (lab frame)
trunk      flexion (thorax forward)   lateral bending to the   rotation to the left
           (thorax rel. pelvis)       right
hip        flexion                    adduction                internal rotation
knee       flexion                    adduction (varus)        internal rotation
ankle      dorsiflexion               inversion                internal rotation (toe in)
shoulder   flexion (thorax-humerus)   adduction                internal rotation
elbow      flexion (humerus-radius)   adduction (varus)        pronation
wrist      flexion (palmar)           ulnar deviation          pronation
=========  =========================  =======================  =========================

Pelvis angles are relative to the lab (world) axes, so a subject walking along -x reads a
pelvic rotation near 180 degrees (Plug-in Gait uses the direction of progression instead).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import check_shape
from .result import posed_frames


@dataclass(frozen=True)
class ClinicalJoint:
    """One joint's angles.

    Attributes
    ----------
    name : str
        Column prefix, e.g. ``"hip_l"``.
    c3d_label : str
        Point label in a C3D file, Plug-in Gait style (``"LHipAngles"``).
    proximal : str or None
        Body the angles are relative to (None: the lab/world frame).
    distal : str
    components : (3,) tuple of str
        Names of the three angles (flexion, adduction, rotation analogues).
    signs : (3,) tuple of float
        Factors turning the Y-X-Z Cardan angles into the signed clinical angles.
    """

    name: str
    c3d_label: str
    proximal: str | None
    distal: str
    components: tuple[str, str, str]
    signs: tuple[float, float, float]

    @property
    def columns(self) -> tuple[str, str, str]:
        """CSV column names, ``<name>_<component>``."""
        return tuple(f"{self.name}_{c}" for c in self.components)  # type: ignore[return-value]


_FAI = ("flexion", "adduction", "internal_rotation")


def _pair(
    joint: str,
    label: str,
    proximal: str,
    distal: str,
    flexion: float,
    components: tuple[str, str, str] = _FAI,
) -> tuple[ClinicalJoint, ClinicalJoint]:
    """Left and right joints (``{s}`` in a body name is the side): the flexion sign is shared,
    adduction and rotation change sign between sides (y points left on both)."""
    return tuple(  # type: ignore[return-value]
        ClinicalJoint(
            f"{joint}_{s}",
            f"{s.upper()}{label}Angles",
            proximal.format(s=s),
            distal.format(s=s),
            components,
            (flexion, sign, sign),
        )
        for s, sign in (("l", -1.0), ("r", 1.0))
    )


#: The clinical joints of the humanoid, in output order.
CLINICAL_JOINTS: tuple[ClinicalJoint, ...] = (
    ClinicalJoint(
        "pelvis",
        "PelvisAngles",
        None,
        "pelvis",
        ("tilt", "obliquity", "rotation"),
        (1.0, 1.0, -1.0),
    ),
    ClinicalJoint(
        "trunk",
        "SpineAngles",
        "pelvis",
        "thorax",
        ("flexion", "lateral_bending", "rotation"),
        (1.0, 1.0, 1.0),
    ),
    *_pair("hip", "Hip", "pelvis", "thigh_{s}", -1.0),
    *_pair("knee", "Knee", "thigh_{s}", "shank_{s}", 1.0),
    *_pair(
        "ankle",
        "Ankle",
        "shank_{s}",
        "foot_{s}",
        -1.0,
        ("dorsiflexion", "inversion", "internal_rotation"),
    ),
    *_pair("shoulder", "Shoulder", "thorax", "upperarm_{s}", -1.0),
    *_pair(
        "elbow", "Elbow", "upperarm_{s}", "radius_{s}", -1.0, ("flexion", "adduction", "pronation")
    ),
    *_pair(
        "wrist",
        "Wrist",
        "radius_{s}",
        "hand_{s}",
        -1.0,
        ("flexion", "ulnar_deviation", "pronation"),
    ),
)


def clinical_columns(joints: tuple[ClinicalJoint, ...] = CLINICAL_JOINTS) -> list[str]:
    """Column names of :func:`clinical_angles`, flattened (3 per joint)."""
    return [c for j in joints for c in j.columns]


def clinical_angles(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    joints: tuple[ClinicalJoint, ...] = CLINICAL_JOINTS,
) -> np.ndarray:
    """Clinical angles (T, J, 3) [rad] of qpos (T, nq) (see the module doc for the convention).

    Frames whose qpos has a NaN give NaN rows.
    """
    qpos = np.asarray(qpos, dtype=float)
    check_shape("qpos", qpos, (None, model.nq))
    prox = [model.body(j.proximal).id if j.proximal else 0 for j in joints]
    dist = [model.body(j.distal).id for j in joints]
    signs = np.array([j.signs for j in joints])
    rel = np.tile(np.eye(3), (len(qpos), len(joints), 1, 1))
    ok = np.all(np.isfinite(qpos), axis=1)
    for t, data in posed_frames(model, qpos):
        xmat = data.xmat.reshape(-1, 3, 3)
        rel[t] = np.transpose(xmat[prox], (0, 2, 1)) @ xmat[dist]
    angles = Rotation.from_matrix(rel.reshape(-1, 3, 3)).as_euler("YXZ")
    out = angles.reshape(len(qpos), len(joints), 3) * signs
    out[~ok] = np.nan
    return out + 0.0  # no negative zeros in the files
