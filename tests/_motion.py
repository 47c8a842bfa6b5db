"""A smooth random motion inside the joint limits, for tests that need no synthesizer."""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj import Kinematics
from mocap_mj.solve.ik import IKSolver


def smooth_motion(kin: Kinematics, frames: int, *, seed: int = 0, amp: float = 0.5) -> np.ndarray:
    """qpos (T, nq) at 100 Hz: sinusoids of random frequency (0.2-1.2 Hz) on every dof.

    Hinges swing about the middle of their range over at most 40% of it; ball joints rotate by
    up to ``amp`` rad per axis; the root translates and turns.
    """
    m = kin.model
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / 100.0
    freqs = rng.uniform(0.2, 1.2, kin.nv)
    phase = rng.uniform(0, 2 * np.pi, kin.nv)
    a = rng.uniform(0.3, 1.0, kin.nv) * amp
    wave = np.sin(2 * np.pi * freqs * t[:, None] + phase)
    qpos = np.tile(m.qpos0, (frames, 1))
    dv = a * wave
    dv[:, :3] = 0.0
    for j in range(m.njnt):
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            lo, hi = m.jnt_range[j]
            dof = m.jnt_dofadr[j]
            dv[:, dof] = 0.5 * (lo + hi) + 0.4 * (hi - lo) * rng.uniform(0.5, 1.0) * wave[:, dof]
    qpos[:, 0] += 0.3 * np.sin(0.3 * t)
    qpos[:, 1] += 0.2 * np.sin(0.25 * t)
    qpos = kin.integrate(qpos, dv)
    return IKSolver(kin).project(qpos)


def random_poses(kin: Kinematics, n: int, seed: int, scale: float = 0.5) -> np.ndarray:
    """n random poses (n, nq): the root moved by ~1 m, every dof turned by N(0, scale) rad."""
    rng = np.random.default_rng(seed)
    q0 = np.tile(kin.model.qpos0, (n, 1))
    q0[:, :3] += rng.normal(0, 1.0, (n, 3))
    return kin.integrate(q0, rng.normal(0, scale, (n, kin.nv)))
