"""Truth-motion presets: smooth joint trajectories within the joint limits, for any rate and length.

Every preset is a function ``preset(model, frames, rate, rng) -> qpos (T, nq)`` of an
``MjModel`` (joint types, ranges and ``qpos0`` are read from it), the number of frames T, the
frame rate [Hz] and a NumPy ``Generator``; the same generator state gives the same motion.

A preset describes its motion as hinge angles [rad], ball-joint rotation vectors [rad] and the
root's position [m] and rotation vector [rad] (world frame, applied on top of the root's
``qpos0`` orientation); :func:`assemble` turns these into ``qpos``. Every signal is a sum of
sinusoids or a periodic cubic spline (C2 or smoother). The joint limits are enforced with a
C2 soft clip: identity well inside the range, a ``tanh`` saturation in a band near each limit
that never reaches the limit minus a small margin (hinges: the hinge range; ball joints: the
total rotation angle, MuJoCo's ball ``range``).

Presets
-------
``rom``
    Range-of-motion calibration trial: every hinge sweeps most of its range, every ball joint
    rotates about all three axes over an anatomical range, the root translates (-/+ 0.15 m)
    and rotates (yaw -/+ 80 degrees); all at once, each degree of freedom with its own
    frequencies (incommensurate with probability 1): a frequency-modulated sinusoid (carrier
    0.25-0.6 Hz, root 0.15-0.3 Hz) plus two smaller sinusoids, scaled so that its swing fills
    the interval. In trials of 3 s or more the first and last 0.75 s ease in from and out to
    the standing pose (``qpos0``).
``walk``
    Level walking at about 1.3 m/s along +x: sagittal hip, knee, ankle and toe angles from
    periodic splines through textbook gait curves, with frontal/transverse hip, subtalar and
    pelvis motion, arm swing opposite to the legs and trunk counter-rotation; the subject's
    stride period, stride length and the curves' amplitudes vary with the seed.
``static``
    Standing still: a slightly perturbed standing pose with postural sway (root centimetres,
    joints about a degree).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.interpolate import CubicSpline

from mocap_mj.errors import MocapError

__all__ = [
    "PRESETS",
    "WALK_FOOT_OFF",
    "JointInfo",
    "assemble",
    "ball_angle",
    "generate",
    "joints",
    "quat_to_rotvec",
    "rom",
    "rotvec_to_quat",
    "soft_clip",
    "soft_clip_norm",
    "static",
    "walk",
    "walk_gait",
]

_DEG = np.pi / 180.0
#: Distance kept from every joint limit [rad] (at most 5% of a hinge's range).
LIMIT_MARGIN = 2.0 * _DEG
#: Width of the soft-clip band inside each limit: a fraction of the range (for hinges at most
#: LIMIT_BAND_MAX [rad], so that a standing pose 5 degrees from a limit is left as it is).
LIMIT_BAND = 0.08
LIMIT_BAND_MAX = 3.0 * _DEG


# ------------------------------------------------------------------------------- rotations
def rotvec_to_quat(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) (..., 4) of rotation vectors (..., 3) [rad]."""
    r = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    # sin(a/2)/a = sinc(a/2pi)/2, smooth through a = 0
    return np.concatenate([np.cos(angle / 2), 0.5 * np.sinc(angle / (2 * np.pi)) * r], axis=-1)


def quat_to_rotvec(quat: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) [rad], angle in [0, pi], of quaternions (w, x, y, z) (..., 4)."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[..., :1] < 0, -q, q)
    vec_norm = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(vec_norm, q[..., :1])
    return 2.0 * q[..., 1:] / np.maximum(np.sinc(angle / (2 * np.pi)), 1e-12)


def ball_angle(quat: np.ndarray) -> np.ndarray:
    """Total rotation angle (...,) [rad] in [0, pi] of quaternions (w, x, y, z) (..., 4)."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products (..., 4) of quaternions (w, x, y, z)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


# ------------------------------------------------------------------------------ soft limits
def soft_clip(
    x: np.ndarray, lo: float | np.ndarray, hi: float | np.ndarray, band: float | np.ndarray
) -> np.ndarray:
    """C2 soft clip of x into the open interval (lo, hi).

    Identity on ``[lo + band, hi - band]``; beyond, ``tanh`` saturation towards the limit.

    Parameters
    ----------
    x : (...,) float
    lo, hi, band : float or arrays broadcasting with x (same unit as x); ``0 < band <= (hi -
        lo) / 2``.
    """
    x = np.asarray(x, dtype=float)
    a, b = lo + band, hi - band
    over = band * np.tanh((x - b) / band) + b
    under = a - band * np.tanh((a - x) / band)
    return np.where(x > b, over, np.where(x < a, under, x))


def soft_clip_norm(r: np.ndarray, rmax: float, band: float) -> np.ndarray:
    """C2 soft clip of the length of vectors r (..., 3) below rmax, keeping their direction."""
    r = np.asarray(r, dtype=float)
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    k = rmax - band
    safe = np.maximum(n, 1e-12)
    scale = np.where(n > k, (k + band * np.tanh((n - k) / band)) / safe, 1.0)
    return r * scale


# ----------------------------------------------------------------------------- joint table
@dataclass(frozen=True)
class JointInfo:
    """One joint of the model, as the presets need it.

    Attributes
    ----------
    name : str
    kind : str
        ``"free"``, ``"ball"`` or ``"hinge"``.
    qadr : int
        First index in qpos.
    limited : bool
    lo, hi : float [rad]
        Hinge range; for a ball joint ``lo = 0`` and ``hi`` the maximum rotation angle.
    base, side : str
        The name without a ``_l``/``_r`` suffix, and ``"l"``, ``"r"`` or ``""``.
    """

    name: str
    kind: str
    qadr: int
    limited: bool
    lo: float
    hi: float
    base: str
    side: str

    @property
    def margin(self) -> float:
        """Distance [rad] the motion keeps from each limit."""
        return min(LIMIT_MARGIN, 0.05 * (self.hi - self.lo))

    @property
    def band(self) -> float:
        """Width [rad] of the soft-clip band."""
        band = LIMIT_BAND * (self.hi - self.lo)
        return min(band, LIMIT_BAND_MAX) if self.kind == "hinge" else band


_KINDS = {
    mujoco.mjtJoint.mjJNT_FREE: "free",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
}


def joints(model: mujoco.MjModel) -> list[JointInfo]:
    """The model's joints in order; raises MocapError for slide joints."""
    out = []
    for j in range(model.njnt):
        kind = _KINDS.get(mujoco.mjtJoint(model.jnt_type[j]))
        name = model.joint(j).name
        if kind is None:
            raise MocapError(f"joint {name}: the synthesizer supports free, ball and hinge joints")
        side = name[-1] if name[-2:] in ("_l", "_r") else ""
        base = name[:-2] if side else name
        lo, hi = (float(v) for v in model.jnt_range[j])
        out.append(
            JointInfo(
                name=name,
                kind=kind,
                qadr=int(model.jnt_qposadr[j]),
                limited=bool(model.jnt_limited[j]) and hi > lo,
                lo=lo,
                hi=hi,
                base=base,
                side=side,
            )
        )
    return out


def _free(model: mujoco.MjModel) -> JointInfo | None:
    found = [j for j in joints(model) if j.kind == "free"]
    return found[0] if found else None


# -------------------------------------------------------------------------------- assembly
def assemble(
    model: mujoco.MjModel,
    frames: int,
    hinge: dict[str, np.ndarray],
    ball: dict[str, np.ndarray],
    root_pos: np.ndarray | None = None,
    root_rotvec: np.ndarray | None = None,
) -> np.ndarray:
    """qpos (T, nq) from per-joint trajectories, with the joint limits soft-clipped.

    Parameters
    ----------
    model : MjModel
    frames : int
        T.
    hinge : dict of joint name -> (T,) float [rad]
        Hinge angles; hinges not listed stay at ``qpos0``.
    ball : dict of joint name -> (T, 3) float [rad]
        Ball-joint rotation vectors (parent frame); balls not listed stay at ``qpos0``.
    root_pos : (T, 3) float [m], optional
        Position of the free root (default: its ``qpos0``).
    root_rotvec : (T, 3) float [rad], optional
        World-frame rotation applied on top of the root's ``qpos0`` orientation.

    Returns
    -------
    (T, nq) float [m, unit quaternions, rad]
    """
    qpos = np.tile(np.array(model.qpos0, dtype=float), (frames, 1))
    known = {j.name for j in joints(model)}
    unknown = sorted((set(hinge) | set(ball)) - known)
    if unknown:
        raise MocapError(f"motion names joints the model does not have: {unknown}")
    for j in joints(model):
        a = j.qadr
        if j.kind == "free":
            if root_pos is not None:
                qpos[:, a : a + 3] = root_pos
            if root_rotvec is not None:
                q0 = np.array(model.qpos0[a + 3 : a + 7], dtype=float)
                qpos[:, a + 3 : a + 7] = _quat_mul(rotvec_to_quat(root_rotvec), q0)
        elif j.kind == "ball" and j.name in ball:
            r = np.asarray(ball[j.name], dtype=float)
            if j.limited:
                r = soft_clip_norm(r, j.hi - j.margin, j.band)
            qpos[:, a : a + 4] = rotvec_to_quat(r)
        elif j.kind == "hinge" and j.name in hinge:
            x = np.asarray(hinge[j.name], dtype=float)
            if j.limited:
                x = soft_clip(x, j.lo + j.margin, j.hi - j.margin, j.band)
            qpos[:, a] = x
    return qpos


# --------------------------------------------------------------------------- signal pieces
def _times(frames: int, rate: float) -> np.ndarray:
    if frames < 1 or not rate > 0:
        raise MocapError(f"need frames >= 1 and rate > 0, got {frames} frames at {rate} Hz")
    return np.arange(frames) / float(rate)


def _sines(
    rng: np.random.Generator, t: np.ndarray, n: int, f_lo: float, f_hi: float, terms: int = 3
) -> np.ndarray:
    """n smooth signals (T, n): sums of ``terms`` sinusoids, weights summing to 1.

    Frequencies [Hz] are log-uniform in [f_lo, f_hi] (incommensurate with probability 1),
    phases uniform; so every signal is within [-1, 1].
    """
    w = rng.uniform(0.5, 1.0, (terms, n))
    w /= w.sum(axis=0)
    f = np.exp(rng.uniform(np.log(f_lo), np.log(f_hi), (terms, n)))
    phase = rng.uniform(0.0, 2 * np.pi, (terms, n))
    return np.einsum("kn,tkn->tn", w, np.sin(2 * np.pi * f[None] * t[:, None, None] + phase))


def _sweeps(
    rng: np.random.Generator, t: np.ndarray, n: int, band: tuple[float, float]
) -> np.ndarray:
    """n range-of-motion signals (T, n) within [-1, 1], each with its own frequencies.

    65 % a frequency-modulated sinusoid (carrier log-uniform in ``band`` [Hz], its frequency
    modulated by -/+ 40 % at 0.1-0.3 Hz), which swings through its whole amplitude in every
    period, plus 35 % two sinusoids of their own frequencies (0.5 x the band's low end to
    2 x its high end), so that the joints move at varied speeds and not in lockstep.
    """
    f0 = np.exp(rng.uniform(np.log(band[0]), np.log(band[1]), n))
    fm = rng.uniform(0.1, 0.3, n)
    depth = 0.4 * f0 / fm
    phase0, phase_m = rng.uniform(0.0, 2 * np.pi, (2, n))
    tt = t[:, None]
    carrier = np.sin(2 * np.pi * f0 * tt + depth * np.sin(2 * np.pi * fm * tt + phase_m) + phase0)
    return 0.65 * carrier + 0.35 * _sines(rng, t, n, 0.5 * band[0], 2.0 * band[1], terms=2)


def _fill(s: np.ndarray, lo: np.ndarray, hi: np.ndarray, interior: np.ndarray) -> np.ndarray:
    """Signals s (T, n) mapped so that their range over the ``interior`` frames fills [lo, hi].

    An affine map per column, then a soft clip into [lo, hi] for the frames outside the
    interior. A signal that varies little in a short trial is amplified at most
    1 / FILL_FLOOR times (its half range is floored at FILL_FLOOR, the signals being within
    [-1, 1]).
    """
    part = s[interior] if np.any(interior) else s
    smin, smax = part.min(axis=0), part.max(axis=0)
    half = np.maximum((smax - smin) / 2, FILL_FLOOR)
    x = (lo + hi) / 2 + (hi - lo) / 2 * (s - (smin + smax) / 2) / half
    return soft_clip(x, lo, hi, LIMIT_BAND * (hi - lo))


def _ease(t: np.ndarray, ramp: float) -> np.ndarray:
    """Weights (T,): 0 at both ends rising to 1 over ``ramp`` seconds (quintic smoothstep, C2)."""
    if ramp <= 0:
        return np.ones_like(t)
    duration = t[-1] if len(t) else 0.0
    x = np.clip(np.minimum(t, duration - t) / ramp, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x**2)


def _mirror_interval(lo: float, hi: float, flip: bool) -> tuple[float, float]:
    return (-hi, -lo) if flip else (lo, hi)


# -------------------------------------------------------------------------------- rom
#: Rotation-vector intervals [deg] per axis (x, y, z) of the ball joints in a ROM trial, for
#: the left side (the right side mirrors them: x and z negate). Left shoulder and hip: +x is
#: abduction, -y flexion, z axial rotation.
ROM_BALL: dict[str, tuple[tuple[float, float], ...]] = {
    "thorax": ((-25, 25), (-15, 30), (-30, 30)),
    "neck": ((-35, 35), (-45, 55), (-60, 60)),
    "shoulder": ((-10, 110), (-110, 40), (-45, 45)),
    "hip": ((-20, 40), (-100, 20), (-40, 40)),
}
#: Root excursions in a ROM trial: position [m] about qpos0, rotation vector [deg].
ROM_ROOT_POS = ((-0.15, 0.15), (-0.15, 0.15), (-0.05, 0.02))
ROM_ROOT_ROT = ((-15, 15), (-10, 25), (-80, 80))
#: ROM carrier frequency bands [Hz] of the joints and of the root; ease-in/out time [s], used
#: in trials of at least ROM_EASE_MIN_S [s].
ROM_FREQ = (0.25, 0.6)
ROM_ROOT_FREQ = (0.15, 0.3)
#: Least half range of a ROM signal before it is scaled to its interval (see ``_fill``).
FILL_FLOOR = 0.3
ROM_EASE_S = 0.75
ROM_EASE_MIN_S = 3.0


def rom(model: mujoco.MjModel, frames: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Range-of-motion calibration trial (see the module docstring).

    Parameters
    ----------
    model : MjModel
    frames : int
        T (>= 1).
    rate : float
        Frame rate [Hz].
    rng : numpy.random.Generator

    Returns
    -------
    qpos : (T, nq) float [m, unit quaternions, rad]
    """
    t = _times(frames, rate)
    duration = float(t[-1])
    ramp = ROM_EASE_S if duration >= ROM_EASE_MIN_S else 0.0
    w = _ease(t, ramp)[:, None]
    interior = (t >= ramp) & (t <= duration - ramp)
    js = joints(model)
    hinges = [j for j in js if j.kind == "hinge"]
    balls = [j for j in js if j.kind == "ball"]

    # Hinges: the usable range (limits minus margin); unlimited hinges swing -/+ 90 degrees.
    lo = np.array([j.lo + j.margin if j.limited else -90 * _DEG for j in hinges])
    hi = np.array([j.hi - j.margin if j.limited else 90 * _DEG for j in hinges])
    q0 = np.array([model.qpos0[j.qadr] for j in hinges])
    target = _fill(_sweeps(rng, t, len(hinges), ROM_FREQ), lo, hi, interior)
    hinge_q = q0 + w * (target - q0)

    # Ball joints: per-axis rotation-vector intervals (anatomical table or -/+ 0.6 range).
    blo, bhi = [], []
    for j in balls:
        limit = j.hi if j.limited else np.pi
        axes = ROM_BALL.get(j.base)
        for axis in range(3):
            if axes is None:
                a, b = -0.6 * limit, 0.6 * limit
            else:
                a, b = (v * _DEG for v in axes[axis])
                a, b = _mirror_interval(a, b, j.side == "r" and axis != 1)
            blo.append(a)
            bhi.append(b)
    rv = _fill(_sweeps(rng, t, 3 * len(balls), ROM_FREQ), np.array(blo), np.array(bhi), interior)
    rv = w * rv

    free = _free(model)
    root_pos = root_rv = None
    if free is not None:
        lo_r = np.array([a for a, _ in ROM_ROOT_POS] + [a * _DEG for a, _ in ROM_ROOT_ROT])
        hi_r = np.array([b for _, b in ROM_ROOT_POS] + [b * _DEG for _, b in ROM_ROOT_ROT])
        root = w * _fill(_sweeps(rng, t, 6, ROM_ROOT_FREQ), lo_r, hi_r, interior)
        root_pos = np.array(model.qpos0[free.qadr : free.qadr + 3]) + root[:, :3]
        root_rv = root[:, 3:]
    return assemble(
        model,
        frames,
        {j.name: hinge_q[:, i] for i, j in enumerate(hinges)},
        {j.name: rv[:, 3 * i : 3 * i + 3] for i, j in enumerate(balls)},
        root_pos,
        root_rv,
    )


# ------------------------------------------------------------------------------- walk
#: Gait curves [deg] as (fraction of the gait cycle from heel strike, angle) key points of
#: periodic cubic splines, after the sagittal curves of normal walking in D. A. Winter,
#: "Biomechanics and Motor Control of Human Movement" (4th ed., 2009) and J. Perry, "Gait
#: Analysis" (1992). Positive: hip flexion, knee flexion, ankle dorsiflexion, toe extension,
#: hip abduction, hip internal rotation, subtalar inversion.
GAIT_CURVES: dict[str, tuple[tuple[float, float], ...]] = {
    "hip_flex": ((0.0, 30), (0.1, 27), (0.3, 8), (0.5, -10), (0.6, -2), (0.75, 22), (0.88, 33)),
    "knee_flex": (
        (0.0, 4), (0.15, 18), (0.4, 4), (0.55, 22), (0.62, 40), (0.72, 62), (0.82, 45),
        (0.92, 12),
    ),
    "ankle": (
        (0.0, 0), (0.07, -6), (0.25, 5), (0.45, 10), (0.55, 2), (0.62, -17), (0.72, -8),
        (0.85, 1),
    ),
    "mtp": ((0.0, 8), (0.15, 2), (0.4, 5), (0.55, 28), (0.62, 35), (0.7, 15), (0.85, 8)),
    "hip_abd": ((0.0, 0), (0.15, -6), (0.45, 2), (0.7, 5), (0.85, 2)),
    "hip_rot": ((0.0, 4), (0.3, 0), (0.6, -6), (0.85, 2)),
    "subtalar": ((0.0, 2), (0.15, -4), (0.5, 0), (0.62, 6), (0.8, 2)),
    "knee_rot": ((0.0, 0), (0.2, 3), (0.6, -3)),
}  # fmt: skip


def _gait_curve(name: str, phase: np.ndarray, gain: float) -> np.ndarray:
    """The gait curve ``name`` [rad] at phases (T,) (cycles), its swing scaled by ``gain``."""
    pts = GAIT_CURVES[name]
    x = np.array([p for p, _ in pts] + [1.0])
    y = np.array([v for _, v in pts] + [pts[0][1]]) * _DEG
    spline = CubicSpline(x, y, bc_type="periodic")
    values = spline(np.mod(phase, 1.0))
    mean = float(np.mean(spline(np.linspace(0.0, 1.0, 200, endpoint=False))))
    return mean + gain * (values - mean)


#: The walk's foot off [fraction of the cycle from its foot strike, phase 0 of the curves]:
#: the knee flexing fast and the ankle plantar-flexing to its peak (:data:`GAIT_CURVES`).
WALK_FOOT_OFF = 0.6


def walk_gait(rng: np.random.Generator) -> tuple[float, float, float]:
    """The walk's first draws from ``rng``: its stride period [s] (two steps), stride length
    [m] and the left leg's phase at time 0 [cycles] (its foot strikes at phase 0, the right
    leg's half a cycle later)."""
    period = rng.uniform(1.0, 1.15)
    stride = rng.uniform(1.3, 1.5)
    phase0 = rng.uniform(0.0, 1.0)
    return float(period), float(stride), float(phase0)


def walk(model: mujoco.MjModel, frames: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Level walking along +x (see the module docstring).

    Parameters
    ----------
    model : MjModel
        Joints are matched by name to the bundled humanoid's; others stay at ``qpos0``.
    frames : int
        T (>= 1).
    rate : float
        Frame rate [Hz].
    rng : numpy.random.Generator

    Returns
    -------
    qpos : (T, nq) float [m, unit quaternions, rad]
    """
    t = _times(frames, rate)
    period, stride, phase0 = walk_gait(rng)
    gains = {(n, s): rng.uniform(0.9, 1.1) for n in GAIT_CURVES for s in "lr"}
    wobble = _sines(rng, t, 64, 0.1, 0.5) * _DEG  # small non-periodic variation, -/+ 1 deg
    names = {j.name for j in joints(model)}
    d = _DEG

    hinge: dict[str, np.ndarray] = {}
    ball: dict[str, np.ndarray] = {}
    k = 0

    def jitter() -> np.ndarray:
        nonlocal k
        k += 1
        return wobble[:, (k - 1) % wobble.shape[1]]

    for side, shift in (("l", 0.0), ("r", 0.5)):
        ph = phase0 + t / period + shift
        flip = -1.0 if side == "r" else 1.0  # mirror of axial vectors: x and z negate

        def g(name: str, ph: np.ndarray = ph, side: str = side) -> np.ndarray:
            return _gait_curve(name, ph, gains[(name, side)])

        hip_flex = g("hip_flex")
        ball[f"hip_{side}"] = np.stack(
            [flip * (g("hip_abd") + jitter()), -hip_flex, -flip * (g("hip_rot") + jitter())],
            axis=-1,
        )
        hinge[f"knee_flex_{side}"] = g("knee_flex")
        hinge[f"knee_rot_{side}"] = g("knee_rot") + jitter()
        hinge[f"ankle_{side}"] = g("ankle")
        hinge[f"subtalar_{side}"] = g("subtalar")
        hinge[f"mtp_{side}"] = g("mtp")
        # Arm swing opposite to the ipsilateral leg; elbow flexes with the forward swing.
        arm_flex = 5 * d - 0.5 * (hip_flex - 10 * d) + jitter()
        ball[f"shoulder_{side}"] = np.stack(
            [flip * (8 * d + jitter()), -arm_flex, -flip * (5 * d + jitter())], axis=-1
        )
        hinge[f"elbow_{side}"] = 22 * d + 0.8 * (arm_flex - 5 * d)
        # Forearm half pronated from palms forward (thumb forward at -90 degrees).
        hinge[f"pronation_{side}"] = -60 * d + jitter()
        hinge[f"wrist_flex_{side}"] = 5 * d + jitter()
        hinge[f"wrist_dev_{side}"] = 5 * d + jitter()
        hinge[f"clav_elev_{side}"] = 3 * d + 0.1 * arm_flex
        hinge[f"clav_prot_{side}"] = 0.15 * arm_flex

    cyc = 2 * np.pi * (phase0 + t / period)
    hinge["lumbar_flex"] = 3 * d + 2 * d * np.cos(2 * cyc) + jitter()
    hinge["lumbar_bend"] = -3 * d * np.sin(cyc) + jitter()
    ball["thorax"] = np.stack([jitter(), 2 * d + jitter(), 5 * d * np.cos(cyc) + jitter()], axis=-1)
    ball["neck"] = np.stack([jitter(), -3 * d + jitter(), jitter()], axis=-1)
    hinge = {n: v for n, v in hinge.items() if n in names}
    ball = {n: v for n, v in ball.items() if n in names}

    root_pos, root_rv = _walk_root(model, t, cyc, stride / period)
    return assemble(model, frames, hinge, ball, root_pos, root_rv)


def _walk_root(
    model: mujoco.MjModel, t: np.ndarray, cyc: np.ndarray, speed: float
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The walk's root: position (T, 3) [m] along +x at ``speed`` [m/s] with the stride's
    sway and bounce, and rotation vector (T, 3) [rad], over the times ``t`` (T,) [s] and
    stride phase ``cyc`` (T,) [rad]; (None, None) for a model without a free joint."""
    free = _free(model)
    if free is None:
        return None, None
    d = _DEG
    p0 = np.array(model.qpos0[free.qadr : free.qadr + 3], dtype=float)
    root_pos = np.stack(
        [
            p0[0] + speed * (t - t[-1] / 2) + 0.01 * np.sin(2 * cyc),
            p0[1] + 0.02 * np.sin(cyc),
            p0[2] - 0.03 - 0.015 * np.cos(2 * cyc),
        ],
        axis=-1,
    )
    root_rv = np.stack(
        [4 * d * np.sin(cyc), 2 * d * np.cos(2 * cyc), -5 * d * np.cos(cyc)], axis=-1
    )
    return root_pos, root_rv


# ------------------------------------------------------------------------------ static
def static(model: mujoco.MjModel, frames: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Quiet standing: a slightly perturbed standing pose with postural sway.

    The pose: ``qpos0`` with each hinge moved by about 3 degrees (normal), each ball joint by
    about 3 degrees per axis; the sway: joints -/+ 1 degree, root -/+ 1 cm horizontally,
    -/+ 2 mm vertically and -/+ 1 degree, at 0.05-0.4 Hz.

    Parameters
    ----------
    model : MjModel
    frames : int
        T (>= 1).
    rate : float
        Frame rate [Hz].
    rng : numpy.random.Generator

    Returns
    -------
    qpos : (T, nq) float [m, unit quaternions, rad]
    """
    t = _times(frames, rate)
    js = joints(model)
    hinges = [j for j in js if j.kind == "hinge"]
    balls = [j for j in js if j.kind == "ball"]
    pose_h = rng.normal(0.0, 3 * _DEG, len(hinges))
    pose_b = rng.normal(0.0, 3 * _DEG, (len(balls), 3))
    sway_h = _sines(rng, t, len(hinges), 0.05, 0.4) * _DEG
    sway_b = _sines(rng, t, 3 * len(balls), 0.05, 0.4) * _DEG
    sway_r = _sines(rng, t, 6, 0.05, 0.4) * np.array([0.01, 0.01, 0.002, _DEG, _DEG, _DEG])
    hinge = {j.name: model.qpos0[j.qadr] + pose_h[i] + sway_h[:, i] for i, j in enumerate(hinges)}
    ball = {j.name: pose_b[i] + sway_b[:, 3 * i : 3 * i + 3] for i, j in enumerate(balls)}
    free = _free(model)
    root_pos = root_rv = None
    if free is not None:
        root_pos = np.array(model.qpos0[free.qadr : free.qadr + 3]) + sway_r[:, :3]
        root_rv = sway_r[:, 3:]
    return assemble(model, frames, hinge, ball, root_pos, root_rv)


#: The presets by name.
PRESETS: dict[str, Callable[[mujoco.MjModel, int, float, np.random.Generator], np.ndarray]] = {
    "rom": rom,
    "walk": walk,
    "static": static,
}


def generate(
    name: str, model: mujoco.MjModel, frames: int, rate: float, rng: np.random.Generator
) -> np.ndarray:
    """qpos (T, nq) of the preset ``name`` (``"rom"``, ``"walk"`` or ``"static"``)."""
    try:
        preset = PRESETS[name]
    except KeyError:
        raise MocapError(
            f"unknown motion preset {name!r}; expected one of {', '.join(PRESETS)}"
        ) from None
    return preset(model, frames, rate, rng)
