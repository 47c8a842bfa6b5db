"""Plug-in Gait's angles of an identified model: its segments built the Plug-in Gait way from
the model's own joint centres, joint axes and marker sites, then the angles of
:mod:`mocap_mj.clinical.angles` (the same Cardan sequences, signs and progression frame).

Segment frames (columns x, y, z in the lab), per side:

- pelvis: y from the RASI to the LASI site, x towards the mid-ASIS from the mid-PSIS
  (the model's pelvis body frame when those sites are absent);
- femur: z from the knee centre (where the thigh carries it: the knee's rolling moves the
  shank's origin, not the femur) to the hip centre, y along the knee's flexion axis (where
  Plug-in Gait takes the plane of the thigh wand);
- tibia (knee angles): z from the ankle centre to the knee centre, y along the knee's
  flexion axis carried by the shank; tibia (ankle angles): y along the ankle axis;
- foot: z from the TOE to the HEE marker site (the model foot's x reversed without them),
  y along the tibia's ankle axis: Plug-in Gait's static foot, the heel-toe line that its
  static plantar-flexion and rotation offsets turn the toe-to-ankle line onto;
- thorax and head: from the C7, T10, CLAV, STRN and head marker sites (the body frames when
  those sites are absent), head offset 0;
- humerus: z from the elbow centre to the shoulder centre, y along the elbow's flexion axis;
  radius: the same y, z from the wrist centre to the elbow centre; hand: z along the model
  hand's long axis, y along the wrist's flexion axis carried by the hand.

Every axis is oriented as Plug-in Gait's in the model's reference pose: the knee and ankle
axes point left, the elbow and wrist axes right, on both sides.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mocap_mj.skeleton import rolling

from ..errors import check_shape
from .angles import FLIP_YZ, all_angles, progression_frame
from .geometry import frame, frame_zy
from .segments import SIDES, Markers, Segment, pelvis_frame, trunk_frames

#: Marker sites the pelvis, thorax and head frames are built from.
TRUNK_SITES = ("LASI", "RASI", "LPSI", "RPSI", "SACR", "C7", "T10", "CLAV", "STRN",
               "LFHD", "RFHD", "LBHD", "RBHD")  # fmt: skip
#: Marker sites of the feet's long axes.
FOOT_SITES = ("LHEE", "LTOE", "RHEE", "RTOE")
#: Bodies whose origins are the joint centres: (key, body with ``{s}`` for the side).
CENTRES = (("hip_{s}", "thigh_{s}"), ("knee_{s}", "shank_{s}"), ("ankle_{s}", "foot_{s}"),
           ("shoulder_{s}", "upperarm_{s}"), ("elbow_{s}", "ulna_{s}"),
           ("wrist_{s}", "hand_{s}"))  # fmt: skip
#: Joint axes: (key, hinge joint, body that carries the axis or None for the joint's own
#: axis in the lab, direction in the reference pose: +1 left, -1 right).
AXES = (("knee_femur_{s}", "knee_flex_{s}", None, 1.0),
        ("knee_tibia_{s}", "knee_flex_{s}", "shank_{s}", 1.0),
        ("ankle_tibia_{s}", "ankle_{s}", None, 1.0),
        ("ankle_foot_{s}", "ankle_{s}", "foot_{s}", 1.0),
        ("elbow_{s}", "elbow_{s}", None, -1.0),
        ("wrist_hand_{s}", "wrist_flex_{s}", "hand_{s}", -1.0))  # fmt: skip
#: Bodies whose frames are read: the fallbacks of the trunk and the foot and hand axes.
BODIES = ("pelvis", "thorax", "head", "foot_l", "foot_r", "hand_l", "hand_r")


@dataclass(frozen=True)
class _Layout:
    """What to read from each posed frame of a model."""

    sites: dict[str, int]
    centres: dict[str, int]
    joints: dict[str, tuple[int, int | None, float]]
    bodies: dict[str, int]
    carried: dict[str, tuple[int, np.ndarray]]


def _layout(model: mujoco.MjModel) -> _Layout:
    sites = {
        n: model.site(n).id
        for n in (*TRUNK_SITES, *FOOT_SITES)
        if _has(model, mujoco.mjtObj.mjOBJ_SITE, n)
    }
    centres = {k.format(s=s): model.body(b.format(s=s)).id for k, b in CENTRES for s in SIDES}
    bodies = {b: model.body(b).id for b in BODIES}
    data = mujoco.MjData(model)
    rolling.kinematics(model, data)  # the reference pose (qpos0): x anterior, y left
    left = data.xmat[bodies["pelvis"]].reshape(3, 3)[:, 1]
    joints: dict[str, tuple[int, int | None, float]] = {}
    for key, joint, carrier, direction in AXES:
        for s in SIDES:
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.format(s=s))
            if j < 0:  # a model without this hinge: the angles that need it are NaN
                continue
            sign = direction * np.sign(float(data.xaxis[j] @ left)) or 1.0
            body = None if carrier is None else model.body(carrier.format(s=s)).id
            joints[key.format(s=s)] = (j, body, float(sign))
    carried = {  # the knee centre where the thigh carries it (the knee's rolling aside)
        f"knee_thigh_{s}": (model.body(f"thigh_{s}").id, model.body(f"shank_{s}").pos.copy())
        for s in SIDES
    }
    return _Layout(sites, centres, joints, bodies, carried)


def _has(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> bool:
    return mujoco.mj_name2id(model, kind, name) >= 0


def _read(
    model: mujoco.MjModel, qpos: np.ndarray, lay: _Layout
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """(points (T, 3) [m], unit axes (T, 3), body frames (T, 3, 3)) per key; NaN in the
    frames whose qpos has a NaN."""
    n = len(qpos)
    pts = {k: np.full((n, 3), np.nan) for k in [*lay.sites, *lay.centres, *lay.carried]}
    axes = {k.format(s=s): np.full((n, 3), np.nan) for k, *_ in AXES for s in SIDES}
    mats = {k: np.full((n, 3, 3), np.nan) for k in lay.bodies}
    for t, data in rolling.posed(model, qpos):
        for k, i in lay.sites.items():
            pts[k][t] = data.site_xpos[i]
        for k, i in lay.centres.items():
            pts[k][t] = data.xpos[i]
        for k, (i, local) in lay.carried.items():
            pts[k][t] = data.xpos[i] + data.xmat[i].reshape(3, 3) @ local
        for k, i in lay.bodies.items():
            mats[k][t] = data.xmat[i].reshape(3, 3)
        for k, (j, body, sign) in lay.joints.items():
            if body is None:
                axes[k][t] = sign * data.xaxis[j]
            else:
                axes[k][t] = sign * data.xmat[body].reshape(3, 3) @ model.jnt_axis[j]
    return pts, axes, mats


def _heelward(m: Markers, side: str, mats: dict[str, np.ndarray]) -> np.ndarray:
    """The foot's long axis (T, 3), towards the heel: from the TOE to the HEE site (Plug-in
    Gait's static foot), else the model foot's x reversed."""
    p = side.upper()
    if p + "HEE" in m and p + "TOE" in m:
        return m[p + "HEE"] - m[p + "TOE"]
    return -mats[f"foot_{side}"][..., 0]


def model_segments(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, Segment]:
    """The Plug-in Gait segments (see the module doc) of ``model`` posed at qpos (T, nq):
    ``pelvis``, ``thorax``, ``head`` and per side ``femur_l``, ``tibia_l``,
    ``tibia_torsioned_l``, ``foot_l``, ``humerus_l``, ``radius_l``, ``hand_l``."""
    qpos = np.asarray(qpos, dtype=float)
    check_shape("qpos", qpos, (None, model.nq))
    lay = _layout(model)
    pts, ax, mats = _read(model, qpos, lay)
    m = Markers({k: pts[k] for k in lay.sites}, len(qpos))
    pelvic = all(n in m for n in ("LASI", "RASI")) and ("SACR" in m or "LPSI" in m)
    segs = {
        "pelvis": Segment(
            m.mid("LASI", "RASI") if pelvic else pts["hip_l"] * 0.5 + pts["hip_r"] * 0.5,
            pelvis_frame(m) if pelvic else mats["pelvis"],
        )
    }
    if all(n in m for n in TRUNK_SITES[5:13]):
        segs |= trunk_frames(m, 0.0, 0.0)
    else:
        nowhere = np.full((len(qpos), 3), np.nan)  # no angle uses these origins
        segs["thorax"] = Segment(nowhere, mats["thorax"] @ FLIP_YZ)
        segs["head"] = Segment(nowhere, mats["head"])
    for s in SIDES:
        hip, knee, ankle = pts[f"hip_{s}"], pts[f"knee_{s}"], pts[f"ankle_{s}"]
        sho, elbow, wrist = pts[f"shoulder_{s}"], pts[f"elbow_{s}"], pts[f"wrist_{s}"]
        humerus = frame_zy(sho - elbow, ax[f"elbow_{s}"])
        segs |= {
            f"femur_{s}": Segment(
                knee, frame_zy(hip - pts[f"knee_thigh_{s}"], ax[f"knee_femur_{s}"])
            ),
            f"tibia_{s}": Segment(ankle, frame_zy(knee - ankle, ax[f"knee_tibia_{s}"])),
            f"tibia_torsioned_{s}": Segment(ankle, frame_zy(knee - ankle, ax[f"ankle_tibia_{s}"])),
            f"foot_{s}": Segment(ankle, frame_zy(_heelward(m, s, mats), ax[f"ankle_tibia_{s}"])),
            f"humerus_{s}": Segment(elbow, humerus),
            f"radius_{s}": Segment(wrist, frame(1, humerus[..., 1], 2, elbow - wrist)),
            f"hand_{s}": Segment(wrist, frame_zy(mats[f"hand_{s}"][..., 2], ax[f"wrist_hand_{s}"])),
        }
    for seg in segs.values():  # a frame with one axis undefined is undefined
        seg.axes[~np.all(np.isfinite(seg.axes), axis=(-2, -1))] = np.nan
    return segs


def model_angles(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Plug-in Gait's angles of ``model`` posed at qpos (T, nq), by Vicon name
    (``LKneeAngles``...) -> (T, 3) [rad], in the order of ``mocap-mj plug-in-gait``'s
    angles.csv; NaN rows where qpos has a NaN."""
    segs = model_segments(model, qpos)
    pelvis = segs["pelvis"]
    return all_angles(segs, progression_frame(pelvis.axes, pelvis.origin))
