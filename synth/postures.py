"""Postures and heading of a synthetic capture: the pose a trial holds or starts in, the
direction the subject faces.

A posture is a set of joint angles of the bundled humanoid (degrees in the tables below, the
left side's; the right side mirrors them: a ball joint's rotation vector negates its x and z
components, a hinge keeps its angle), with the root lowered so that the lowest site (a heel or
a toe) is as high as in the standing pose ``qpos0``: the feet stay on the floor. Conventions of
the model: a shoulder's or hip's rotation vector is (abduction, -flexion, axial rotation) for
the left side; the root's is world-frame, +y turning the trunk forward; knee and elbow
flexion, ankle dorsiflexion positive; pronation 0 with the palm forward (anatomical position),
-90 degrees with the thumb forward.

``neutral``
    ``qpos0``: standing, arms at the sides (the motions' own standing pose).
``t-pose``
    Both arms abducted 90 degrees in the frontal plane, elbows 5 degrees from straight, palms
    down (pronation -90): the calibration pose of many labs, where the elbow's flexion axis is
    vertical and the arm's plane differs from the hanging arm's.
``arms-up``
    Arms raised overhead in the frontal plane: clavicles elevated 20 degrees, shoulders
    abducted 135 (the arm some 155 degrees from hanging), elbows 5, palms facing each other:
    the shoulder near its range, the upper arm's markers above the head.
``seated``
    Sitting upright on a chair: hips flexed 90 degrees and abducted 5, knees flexed 90, ankles
    neutral (shanks vertical, feet flat), hands on the thighs (shoulders flexed 30 and abducted
    10, elbows 60): the thigh horizontal, where the knee's and hip's markers crowd together.
``crouched``
    A deep crouch: pelvis pitched 15 degrees forward, lumbar flexed 10, hips flexed 80 and
    abducted 5, knees flexed 90, ankles dorsiflexed 25 (feet flat: 15 - 80 + 90 - 25 = 0),
    arms forward for balance (shoulders flexed 80, abducted 10, elbows 20).

A static in a posture (:func:`hold`) is the static preset's sway and small pose perturbation
added to the posture's angles (hinge angles, rotation vectors); a dynamic trial (:func:`start_in`)
starts in the posture at rest and blends into its preset's motion over :data:`BLEND_S` seconds
(quintic smoothstep, C2), the root's horizontal place starting where the motion's does. A
static's joint limits are enforced as the presets enforce them
(:func:`mocap_synth.motion.assemble`); a blend of two poses within the limits stays within them.

The heading (:func:`turn`) rotates the whole capture about the vertical through the origin:
the root's position and orientation, hence every body and marker, by the same rotation.
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from mocap_mj.errors import MocapError

from .config import POSES
from .motion import _quat_mul, assemble, joints, quat_to_rotvec, rotvec_to_quat

__all__ = [
    "BLEND_S",
    "POSES",
    "POSTURES",
    "apply",
    "blend_end",
    "hold",
    "pose_qpos",
    "start_in",
    "turn",
]

#: (hinges by base name [deg], balls by base name: left rotation vector [deg], root rotation
#: vector [deg]) of each posture; joints not named keep their ``qpos0``.
POSTURES: dict[str, tuple[Mapping[str, float], Mapping[str, tuple[float, float, float]],
                          tuple[float, float, float]]] = {
    "neutral": ({}, {}, (0.0, 0.0, 0.0)),
    "t-pose": (
        {"elbow": 5.0, "pronation": -90.0},
        {"shoulder": (90.0, 0.0, 0.0)},
        (0.0, 0.0, 0.0),
    ),
    "arms-up": (
        {"clav_elev": 20.0, "elbow": 5.0, "pronation": -90.0},
        {"shoulder": (135.0, 0.0, 0.0)},
        (0.0, 0.0, 0.0),
    ),
    "seated": (
        {"knee_flex": 90.0, "elbow": 60.0, "pronation": -90.0},
        {"hip": (5.0, -90.0, 0.0), "shoulder": (10.0, -30.0, 0.0)},
        (0.0, 0.0, 0.0),
    ),
    "crouched": (
        {"lumbar_flex": 10.0, "knee_flex": 90.0, "ankle": 25.0, "elbow": 20.0,
         "pronation": -90.0},
        {"hip": (5.0, -80.0, 0.0), "shoulder": (10.0, -80.0, 0.0)},
        (0.0, 15.0, 0.0),
    ),
}  # fmt: skip
#: Time [s] a dynamic trial takes to blend from its posture into its motion (a third of the
#: trial when shorter).
BLEND_S = 1.0

_DEG = np.pi / 180.0


def blend_end(pose: str, duration: float) -> float:
    """The time [s] at which a dynamic trial of ``duration`` [s] starting in ``pose`` is its
    motion alone (:func:`start_in`): 0 for the neutral posture."""
    return 0.0 if pose == "neutral" else min(BLEND_S, duration / 3.0)


def _angles(
    model: mujoco.MjModel, name: str
) -> tuple[dict[str, float], dict[str, np.ndarray], np.ndarray]:
    """The posture ``name``'s hinge angles [rad] and ball rotation vectors (3,) [rad] by joint
    name (the right side mirrored), and its root rotation vector (3,) [rad]."""
    if name not in POSTURES:
        raise MocapError(f"unknown posture {name!r}; expected one of {', '.join(POSES)}")
    hinges, balls, root = POSTURES[name]
    hinge: dict[str, float] = {}
    ball: dict[str, np.ndarray] = {}
    for j in joints(model):
        if j.kind == "hinge" and j.base in hinges:
            hinge[j.name] = hinges[j.base] * _DEG
        elif j.kind == "ball" and j.base in balls:
            rv = np.array(balls[j.base], dtype=float) * _DEG
            ball[j.name] = rv * (-1.0, 1.0, -1.0) if j.side == "r" else rv
    return hinge, ball, np.array(root, dtype=float) * _DEG


def _split(
    model: mujoco.MjModel, qpos: np.ndarray
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray | None, np.ndarray | None]:
    """qpos (T, nq) as :func:`~mocap_synth.motion.assemble` takes it: hinge angles (T,) [rad],
    ball rotation vectors (T, 3) [rad], the root's position (T, 3) [m] and its rotation vector
    (T, 3) [rad] on top of its ``qpos0`` orientation (None without a free joint)."""
    hinge: dict[str, np.ndarray] = {}
    ball: dict[str, np.ndarray] = {}
    root_pos = root_rv = None
    for j in joints(model):
        a = j.qadr
        if j.kind == "hinge":
            hinge[j.name] = qpos[:, a]
        elif j.kind == "ball":
            ball[j.name] = quat_to_rotvec(qpos[:, a : a + 4])
        else:
            q0 = np.array(model.qpos0[a + 3 : a + 7], dtype=float) * (1.0, -1.0, -1.0, -1.0)
            root_pos = qpos[:, a : a + 3]
            root_rv = quat_to_rotvec(_quat_mul(qpos[:, a + 3 : a + 7], q0))
    return hinge, ball, root_pos, root_rv


def pose_qpos(model: mujoco.MjModel, name: str) -> np.ndarray:
    """qpos (nq,) of the posture ``name`` on ``model``, its lowest site at ``qpos0``'s height.

    The root's horizontal place is ``qpos0``'s; it is lowered (or raised) by the difference of
    the lowest site's height [m] in the posture and in ``qpos0``.
    """
    hinge, ball, root_rv = _angles(model, name)
    qpos = assemble(
        model,
        1,
        {n: np.array([v]) for n, v in hinge.items()},
        {n: v[None] for n, v in ball.items()},
        None,
        root_rv[None],
    )[0]
    free = [j for j in joints(model) if j.kind == "free"]
    if free and model.nsite:
        data = mujoco.MjData(model)
        low = []
        for q in (model.qpos0, qpos):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            low.append(float(data.site_xpos[:, 2].min()))
        qpos[free[0].qadr + 2] -= low[1] - low[0]
    return qpos


def hold(model: mujoco.MjModel, qpos: np.ndarray, name: str) -> np.ndarray:
    """The static ``qpos`` (T, nq) (a sway about ``qpos0``) moved to sway about the posture
    ``name``: every joint's deviation from ``qpos0`` (hinge angle, rotation vector, root
    position and rotation vector) added to the posture's."""
    base = _split(model, pose_qpos(model, name)[None])
    zero = _split(model, np.array(model.qpos0, dtype=float)[None])
    motion = _split(model, qpos)
    hinge = {n: base[0][n] + v - zero[0][n] for n, v in motion[0].items()}
    ball = {n: base[1][n] + v - zero[1][n] for n, v in motion[1].items()}
    root = [
        None if m is None or b is None or z is None else b + m - z
        for b, m, z in zip(base[2:], motion[2:], zero[2:], strict=True)
    ]
    return assemble(model, len(qpos), hinge, ball, root[0], root[1])


def start_in(model: mujoco.MjModel, qpos: np.ndarray, name: str, rate: float) -> np.ndarray:
    """The dynamic ``qpos`` (T, nq) at ``rate`` [Hz] starting at rest in the posture ``name``
    and blending into the motion over :data:`BLEND_S` [s] (a third of a shorter trial; a
    one-frame trial is the posture): each joint's angle or rotation vector
    ``p + w(t) (m(t) - p)``, ``w`` rising from 0 to 1 (quintic smoothstep), the root's position
    and rotation vector likewise; the posture's root starts where the motion's first frame has
    it horizontally."""
    t = np.arange(len(qpos)) / float(rate)
    ramp = blend_end(name, float(t[-1]))
    x = np.clip(t / ramp, 0.0, 1.0) if ramp > 0 else np.zeros_like(t)
    w = x**3 * (10 - 15 * x + 6 * x**2)
    pose = pose_qpos(model, name)
    free = [j for j in joints(model) if j.kind == "free"]
    if free:
        pose[free[0].qadr : free[0].qadr + 2] = qpos[0, free[0].qadr : free[0].qadr + 2]
    base = _split(model, pose[None])
    motion = _split(model, qpos)

    def blend(p: np.ndarray, m: np.ndarray) -> np.ndarray:
        return p + (w if m.ndim == 1 else w[:, None]) * (m - p)

    # No clip: a blend of two poses within the limits is within them (a hinge's interval and a
    # ball's rotation-vector ball are convex), and where w = 1 it is the motion itself.
    out = np.array(qpos, dtype=float)
    for j in joints(model):
        a = j.qadr
        if j.kind == "hinge":
            out[:, a] = blend(base[0][j.name], motion[0][j.name])
        elif j.kind == "ball":
            out[:, a : a + 4] = rotvec_to_quat(blend(base[1][j.name], motion[1][j.name]))
        elif base[2] is not None and motion[2] is not None:
            assert base[3] is not None and motion[3] is not None
            q0 = np.array(model.qpos0[a + 3 : a + 7], dtype=float)
            out[:, a : a + 3] = blend(base[2], motion[2])
            out[:, a + 3 : a + 7] = _quat_mul(rotvec_to_quat(blend(base[3], motion[3])), q0)
    done = w >= 1.0
    out[done] = qpos[done]
    return out


def turn(model: mujoco.MjModel, qpos: np.ndarray, heading_deg: float) -> np.ndarray:
    """``qpos`` (T, nq) rotated by ``heading_deg`` [deg] about the vertical (z) through the
    origin: the root's position and orientation, so every body and marker turns alike."""
    free = [j for j in joints(model) if j.kind == "free"]
    out = np.array(qpos, dtype=float)
    if not free:
        return out
    a = free[0].qadr
    h = heading_deg * _DEG
    c, s = np.cos(h), np.sin(h)
    x, y = out[:, a].copy(), out[:, a + 1].copy()
    out[:, a], out[:, a + 1] = c * x - s * y, s * x + c * y
    yaw = rotvec_to_quat(np.array([0.0, 0.0, h]))
    out[:, a + 3 : a + 7] = _quat_mul(yaw, out[:, a + 3 : a + 7])
    return out


def apply(
    model: mujoco.MjModel, qpos: np.ndarray, motion: str, pose: str, heading_deg: float,
    rate: float,
) -> np.ndarray:  # fmt: skip
    """The preset ``motion``'s ``qpos`` (T, nq) in the posture ``pose`` (:func:`hold` for the
    static, :func:`start_in` otherwise) turned by ``heading_deg`` [deg] (:func:`turn`); the
    neutral posture facing +x (the defaults) returns ``qpos`` itself, unchanged."""
    if pose != "neutral":
        qpos = hold(model, qpos, pose) if motion == "static" else start_in(model, qpos, pose, rate)
    if heading_deg != 0.0:
        qpos = turn(model, qpos, heading_deg)
    return qpos
