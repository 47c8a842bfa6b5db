"""Inverse dynamics of a motion on a MuJoCo model: joint moments, powers and root residuals.

The model is the one a result folder's ``model.xml`` is as plain MuJoCo compiles it
(:func:`mocap_mj.skeleton.mjcf.load_written`, or with de Leva's segment parameters
:func:`mocap_mj.anatomy.inertia.inertial_model`), and qpos is in its layout (``motion.npz``'s):
the 48 degrees of freedom and the knees' four slide joints, which carry the rolling of the knee
(docs/mujoco.md). The computation runs on that model, not on the tool's internal one: there the
knee centre moves through ``body_pos``, which MuJoCo's dynamics does not see, while a slide is
a degree of freedom whose velocity and acceleration enter the equations of motion. A slide's
generalised force is the force [N] the knee transmits along it; the flexion hinge's is the
moment about its axis through the moving knee centre.

Steps (docs/dynamics.md):

1. the joint coordinates as tangent coordinates: u[0] = 0, u[t] = u[t-1] +
   ``mj_differentiatePos(q[t-1], q[t])`` (the free joint's and the ball joints' quaternions
   as rotation vectors in the body frame, so that their derivatives are MuJoCo's qvel);
2. u smoothed by a low-pass Butterworth filter, 4th order zero-lag (a 2nd-order filter run
   forward and backward), cutoff ``cutoff_hz`` (6 Hz by default, the usual choice for gait
   kinematics: gait's own content is below it, marker noise and soft-tissue jitter above);
   qpos rebuilt from the smoothed u by ``mj_integratePos``;
3. qvel and qacc by central differences of the smoothed u (second order, one-sided at the
   ends);
4. MuJoCo's inverse dynamics (``mj_inverse``'s qfrc_inverse, computed by ``mj_rne`` with the
   acceleration, :func:`_generalised_forces`) with contacts, constraints (joint limits, the
   knees' equalities: qpos already holds the exact coupling), springs and dampers off and
   the joints' armature at 0 (a model-stability device, not a property of the body):
   M qacc + bias;
5. the measured external loads (:class:`BodyLoad`) as generalised forces through
   ``mj_applyFT``, subtracted: tau = qfrc_inverse - J^T f. Each load is smoothed by the
   filter of step 2 (:func:`filtered_loads`): its force and its moment about the world
   origin (the centre of pressure's moment plus the free moment), both linear in the
   wrench, so that a wrench the plates measure sharply and the kinematics see through the
   filter meet with the same bandwidth (Kristianslund, Krosshaug and van den Bogert 2012,
   J Biomech 45:666: kinematics filtered below the loads' band leave spurious moments and
   residuals at every impact); it then acts on its body at the origin. The root's share of
   tau is the residual: the wrench the free joint must add for the motion to follow from the
   loads and gravity.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy import signal

from mocap_mj.errors import MocapError, ShapeError, UnknownNameError, check_shape
from mocap_mj.skeleton import rolling

#: The Butterworth filter's default cutoff [Hz].
CUTOFF_HZ = 6.0
#: Order of the filter run in each direction (twice that after both passes).
PASS_ORDER = 2
#: The filter's ends are padded by this many periods of the cutoff (odd extension: a line
#: continues as a line), so that its start-up transient settles before the data begin.
PAD_PERIODS = 3.0
#: Relative spread of the time steps tolerated as uniform sampling.
STEP_TOLERANCE = 1e-3


@dataclass(frozen=True)
class BodyLoad:
    """A measured external load on one body (a foot), every frame.

    Attributes
    ----------
    body : str
        MuJoCo body name.
    force : (T, 3) float [N]
        World frame, applied on the body.
    point : (T, 3) float [m]
        World point of application (the centre of pressure); NaN where there is no load.
    moment : (T, 3) float [N m]
        Free moment, world frame.
    """

    body: str
    force: np.ndarray
    point: np.ndarray
    moment: np.ndarray


@dataclass(frozen=True)
class Dynamics:
    """The inverse dynamics of a motion (T frames, nv degrees of freedom).

    Attributes
    ----------
    times : (T,) float [s]
    tau : (T, nv) float [N m or N]
        Generalised force of every degree of freedom (N m for rotations, N for translations),
        net of the external loads; NaN on frames not computed (NaN qpos, or a run of finite
        frames too short to filter).
    root_force : (T, 3) float [N]
        Residual force at the root (the free joint), world frame.
    root_moment : (T, 3) float [N m]
        Residual moment about the root body's origin, world frame.
    power : (T, nv) float [W]
        tau * qvel.
    dof_names : tuple of str, (nv,)
        :func:`dof_names`.
    qpos : (T, nq) float
        The smoothed positions the dynamics used.
    qvel, qacc : (T, nv) float [rad/s, m/s; rad/s^2, m/s^2]
        Their velocities and accelerations.
    """

    times: np.ndarray
    tau: np.ndarray
    root_force: np.ndarray
    root_moment: np.ndarray
    power: np.ndarray
    dof_names: tuple[str, ...]
    qpos: np.ndarray
    qvel: np.ndarray
    qacc: np.ndarray


def dof_names(model: mujoco.MjModel) -> tuple[str, ...]:
    """Name of every degree of freedom (nv,): a hinge or slide by its joint's name, a ball's
    three ``JOINT_x``, ``_y``, ``_z`` (body-frame axes), the free joint's ``JOINT_x``, ``_y``,
    ``_z`` (world translation) and ``JOINT_rx``, ``_ry``, ``_rz`` (body-frame rotation)."""
    out: list[str] = []
    for j in range(model.njnt):
        name = str(model.joint(j).name)
        kind = int(model.jnt_type[j])
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            out += [f"{name}_{a}" for a in ("x", "y", "z", "rx", "ry", "rz")]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            out += [f"{name}_{a}" for a in "xyz"]
        else:
            out.append(name)
    return tuple(out)


def translational(model: mujoco.MjModel) -> np.ndarray:
    """(nv,) bool: the degrees of freedom that translate (slides, the free joint's first
    three), whose tau is a force [N]."""
    out = np.zeros(model.nv, dtype=bool)
    for j in range(model.njnt):
        adr = int(model.jnt_dofadr[j])
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            out[adr : adr + 3] = True
        elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            out[adr] = True
    return out


def frame_step(times: np.ndarray) -> float:
    """The time step [s] of uniformly sampled times (T,) [s]; raises ShapeError naming the
    first row whose step differs from the median by more than :data:`STEP_TOLERANCE`."""
    t = np.asarray(times, dtype=float)
    check_shape("times", t, (None,))
    if len(t) < 2 or not np.all(np.isfinite(t)):
        raise ShapeError("times: expected at least 2 finite times [s]")
    steps = np.diff(t)
    dt = float(np.median(steps))
    bad = np.flatnonzero(np.abs(steps - dt) > STEP_TOLERANCE * abs(dt))
    if not dt > 0 or len(bad):
        row = int(bad[0]) + 1 if len(bad) else 1
        raise ShapeError(
            f"times: expected uniform sampling, row {row} steps {steps[row - 1]:.6g} s "
            f"against the median {dt:.6g} s"
        )
    return dt


def lowpass(x: np.ndarray, rate: float, cutoff_hz: float) -> np.ndarray:
    """x (T, ...) filtered along axis 0 by a zero-lag Butterworth low-pass (order
    :data:`PASS_ORDER` each way, cutoff ``cutoff_hz`` [Hz] the single pass's -3 dB point),
    sampled at ``rate`` [Hz], the ends padded (:data:`PAD_PERIODS`). Needs 10 samples or more."""
    if not 0 < cutoff_hz < rate / 2:
        raise MocapError(
            f"cutoff: expected 0 < cutoff < {rate / 2:g} Hz (half the frame rate), got {cutoff_hz}"
        )
    b, a = signal.butter(PASS_ORDER, cutoff_hz / (rate / 2))
    pad = min(len(x) - 1, max(9, round(PAD_PERIODS * rate / cutoff_hz)))
    return np.asarray(signal.filtfilt(b, a, x, axis=0, padlen=pad))


def derivatives(u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives (T, n) of u (T, n) sampled at step ``dt`` [s]: central
    differences inside, second-order one-sided at the ends (T >= 4)."""
    u = np.asarray(u, dtype=float)
    vel = np.gradient(u, dt, axis=0, edge_order=2)
    acc = np.empty_like(u)
    acc[1:-1] = (u[2:] - 2 * u[1:-1] + u[:-2]) / dt**2
    acc[0] = (2 * u[0] - 5 * u[1] + 4 * u[2] - u[3]) / dt**2
    acc[-1] = (2 * u[-1] - 5 * u[-2] + 4 * u[-3] - u[-4]) / dt**2
    return vel, acc


def tangent_coordinates(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """u (T, nv): u[0] = 0, u[t] = u[t-1] + mj_differentiatePos(q[t-1], q[t]) of qpos (T, nq)."""
    u = np.zeros((len(qpos), model.nv))
    step = np.zeros(model.nv)
    for t in range(1, len(qpos)):
        mujoco.mj_differentiatePos(model, step, 1.0, qpos[t - 1], qpos[t])
        u[t] = u[t - 1] + step
    return u


def smoothed(
    model: mujoco.MjModel, qpos: np.ndarray, dt: float, cutoff_hz: float | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(qpos (T, nq), qvel (T, nv), qacc (T, nv)) of a run of finite qpos (T, nq) sampled at
    ``dt`` [s]: steps 1-3 of the module docstring (``cutoff_hz`` None: no filter)."""
    u = tangent_coordinates(model, qpos)
    if cutoff_hz is None:
        q = np.array(qpos, dtype=float)
    else:
        uf = lowpass(u, 1.0 / dt, cutoff_hz)
        q = np.empty_like(qpos, dtype=float)
        cur = np.array(qpos[0], dtype=float)
        mujoco.mj_integratePos(model, cur, uf[0] - u[0], 1.0)
        q[0] = cur
        for t in range(1, len(qpos)):
            mujoco.mj_integratePos(model, cur, uf[t] - uf[t - 1], 1.0)
            q[t] = cur
        u = uf
    vel, acc = derivatives(u, dt)
    return q, vel, acc


def dynamics_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` for inverse dynamics: contacts, constraints, springs and dampers
    disabled, armature 0 (step 4 of the module docstring)."""
    import copy

    out = copy.copy(model)
    flags = mujoco.mjtDisableBit
    for flag in (flags.mjDSBL_CONTACT, flags.mjDSBL_CONSTRAINT, flags.mjDSBL_SPRING,
                 flags.mjDSBL_DAMPER):  # fmt: skip
        out.opt.disableflags |= int(flag)
    out.dof_armature[:] = 0.0
    return out


def _runs(finite: np.ndarray, shortest: int) -> list[tuple[int, int]]:
    """[start, stop) of every run of True in finite (T,) at least ``shortest`` long."""
    edges = np.diff(np.concatenate([[0], finite.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True) if b - a >= shortest]


def _check_loads(model: mujoco.MjModel, loads: Sequence[BodyLoad], frames: int) -> list[int]:
    ids = []
    names = [str(model.body(b).name) for b in range(1, model.nbody)]
    for load in loads:
        if load.body not in names:
            raise UnknownNameError("body", load.body, names)
        for field in ("force", "point", "moment"):
            check_shape(f"load on {load.body}: {field}", getattr(load, field), (frames, 3))
        ids.append(int(model.body(load.body).id))
    return ids


def filtered_loads(
    loads: Sequence[BodyLoad], runs: Sequence[tuple[int, int]], dt: float, cutoff_hz: float
) -> list[BodyLoad]:
    """``loads`` filtered as the kinematics are (:func:`lowpass` at ``cutoff_hz`` [Hz], each
    run [start, stop) of ``runs`` on its own, sampled at ``dt`` [s]): per load its force (T, 3)
    [N] (0 where its point is NaN: no load) and its moment about the world origin (T, 3)
    [N m], ``point x force + moment``, applied at the origin (point 0 on the runs' frames,
    NaN elsewhere). The wrench on the body is the same as the load's wherever the filter
    leaves it unchanged."""
    out = []
    for load in loads:
        on = np.all(np.isfinite(load.point), axis=1) & np.all(np.isfinite(load.force), axis=1)
        force = np.where(on[:, None], np.nan_to_num(load.force), 0.0)
        moment = np.cross(np.where(on[:, None], np.nan_to_num(load.point), 0.0), force)
        moment += np.where(on[:, None], np.nan_to_num(load.moment), 0.0)
        f_out, m_out = np.zeros_like(force), np.zeros_like(moment)
        point = np.full_like(force, np.nan)
        for a, b in runs:
            f_out[a:b] = lowpass(force[a:b], 1.0 / dt, cutoff_hz)
            m_out[a:b] = lowpass(moment[a:b], 1.0 / dt, cutoff_hz)
            point[a:b] = 0.0
        out.append(BodyLoad(load.body, f_out, point, m_out))
    return out


def _generalised_forces(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    qvel: np.ndarray,
    qacc: np.ndarray,
    loads: Sequence[BodyLoad],
    bodies: list[int],
    frames: list[int],
) -> tuple[np.ndarray, np.ndarray]:
    """tau (T, nv) = M qacc + bias - J^T f of the loads, and the root body's orientation
    (T, 9), on the given frames (NaN elsewhere).

    Per frame: ``mj_kinematics``, ``mj_comPos``, ``mj_comVel`` and ``mj_rne`` with the
    acceleration, which is ``mj_inverse``'s qfrc_inverse on :func:`dynamics_model` (no
    constraint, passive force or armature) without the mass matrix and its factorisation
    that ``mj_inverse`` also computes (``tests/test_dynamics.py`` checks the two agree); then
    ``mj_applyFT`` for each load with a finite point and force.
    """
    dyn = dynamics_model(model)
    data = mujoco.MjData(dyn)
    n = len(qpos)
    tau = np.full((n, model.nv), np.nan)
    rot = np.full((n, 9), np.nan)
    root = int(model.jnt_bodyid[0]) if model.njnt else 0
    out = np.zeros(model.nv)
    applied = np.zeros(model.nv)
    forces = [np.ascontiguousarray(ld.force, dtype=float) for ld in loads]
    points = [np.ascontiguousarray(ld.point, dtype=float) for ld in loads]
    moments = [np.nan_to_num(np.asarray(ld.moment, dtype=float)) for ld in loads]
    active = np.stack(
        [np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(f), axis=1)
         for p, f in zip(points, forces, strict=True)] or [np.zeros(n, dtype=bool)]
    )  # fmt: skip
    loaded: np.ndarray = np.any(active, axis=0)
    for t in frames:
        data.qpos[:] = qpos[t]
        data.qvel[:] = qvel[t]
        data.qacc[:] = qacc[t]
        mujoco.mj_kinematics(dyn, data)
        mujoco.mj_comPos(dyn, data)
        mujoco.mj_comVel(dyn, data)
        mujoco.mj_rne(dyn, data, 1, out)
        if loaded[t]:
            applied[:] = 0.0
            for k, body in enumerate(bodies):
                if active[k, t]:
                    mujoco.mj_applyFT(
                        dyn, data, forces[k][t], moments[k][t], points[k][t], body, applied
                    )
            out -= applied
        tau[t] = out
        rot[t] = data.xmat[root]
    return tau, rot


def inverse_dynamics(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    times: np.ndarray,
    loads: Sequence[BodyLoad] = (),
    *,
    cutoff_hz: float | None = CUTOFF_HZ,
) -> Dynamics:
    """The inverse dynamics of qpos (T, model.nq) at times (T,) [s] (uniform) on ``model``
    (module docstring) under the external ``loads``.

    ``cutoff_hz`` [Hz]: the low-pass filter's cutoff, of qpos and of the loads alike; None
    leaves both unfiltered. Frames with NaN in qpos are NaN in the result, and so is a run
    of finite frames shorter than 10 (4 without the filter). A model with a free root reports
    its residual in ``root_force`` and ``root_moment``; a model without one has NaN there.

    Raises MocapError (a subclass) for a model whose knee rolling is recorded but not carried
    by slide joints (the tool's internal model: pass the model as written), a qpos or load of
    the wrong shape, an unknown load body, times not uniformly sampled, or a cutoff outside
    (0, rate / 2).
    """
    if rolling.read(model) is not None:
        raise MocapError(
            "inverse dynamics: the model's knee rolling is recorded but not carried by slide "
            "joints (the tool's internal model); pass the model as written "
            "(model.xml compiled by plain MuJoCo, mocap_mj.skeleton.mjcf.load_written)"
        )
    q_in = np.asarray(qpos, dtype=float)
    check_shape("qpos", q_in, (None, model.nq))
    t_in = np.asarray(times, dtype=float)
    check_shape("times", t_in, (len(q_in),))
    dt = frame_step(t_in)
    if cutoff_hz is not None:
        lowpass(np.zeros((10, 1)), 1.0 / dt, cutoff_hz)  # validates the cutoff up front
    bodies = _check_loads(model, loads, len(q_in))

    frames, nv = len(q_in), model.nv
    q_out = np.full((frames, model.nq), np.nan)
    vel = np.full((frames, nv), np.nan)
    acc = np.full((frames, nv), np.nan)
    shortest = 10 if cutoff_hz is not None else 4
    runs = _runs(np.all(np.isfinite(q_in), axis=1), shortest)
    for a, b in runs:
        q_out[a:b], vel[a:b], acc[a:b] = smoothed(model, q_in[a:b], dt, cutoff_hz)

    free = model.njnt > 0 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    frames_run = [t for a, b in runs for t in range(a, b)]
    if cutoff_hz is not None:
        loads = filtered_loads(loads, runs, dt, cutoff_hz)
    tau, rot = _generalised_forces(model, q_out, vel, acc, loads, bodies, frames_run)
    if free:
        adr = int(model.jnt_dofadr[0])
        root_force = tau[:, adr : adr + 3].copy()
        rot = rot.reshape(frames, 3, 3)
        root_moment = np.einsum("tij,tj->ti", rot, tau[:, adr + 3 : adr + 6])
    else:
        root_force = np.full((frames, 3), np.nan)
        root_moment = np.full((frames, 3), np.nan)
    return Dynamics(
        times=t_in,
        tau=tau,
        root_force=root_force,
        root_moment=root_moment,
        power=tau * vel,
        dof_names=dof_names(model),
        qpos=q_out,
        qvel=vel,
        qacc=acc,
    )


__all__ = [
    "CUTOFF_HZ",
    "PAD_PERIODS",
    "PASS_ORDER",
    "STEP_TOLERANCE",
    "BodyLoad",
    "Dynamics",
    "derivatives",
    "dof_names",
    "dynamics_model",
    "filtered_loads",
    "frame_step",
    "inverse_dynamics",
    "lowpass",
    "smoothed",
    "tangent_coordinates",
    "translational",
]
