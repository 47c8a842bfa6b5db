"""The measurement model: white noise, soft-tissue artefact and data corruptions.

Symbols: T frames, M markers, nq the model's position size. Every function draws only from
the generator it is given, in a fixed order, so a seed reproduces its output.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj.errors import MocapError

from .motion import joints, quat_to_rotvec
from .perturb import mirror_pairs

__all__ = [
    "apply_swaps",
    "occlusion_gaps",
    "outlier_displacements",
    "outlier_mask",
    "pick_swaps",
    "soft_tissue",
    "sta_drivers",
    "white_noise",
]


def white_noise(shape: tuple[int, ...], sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Independent Gaussian noise of standard deviation ``sigma`` [m], ``shape`` e.g. (T, M, 3).

    Always draws the samples (zeros when ``sigma`` is 0), so the streams that follow do not
    depend on ``sigma``.
    """
    return rng.standard_normal(shape) * sigma


# ---------------------------------------------------------------------- soft-tissue artefact
def joint_signals(model: mujoco.MjModel, qpos: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Joint rotations away from ``qpos0``: (T, n) [rad] and the joint of each column.

    A hinge gives its angle minus ``qpos0``; a ball joint the three components of its rotation
    vector; the free root gives none (it moves the whole body rigidly).
    """
    cols, owner = [], []
    for j, info in enumerate(joints(model)):
        a = info.qadr
        if info.kind == "hinge":
            cols.append(qpos[:, a : a + 1] - model.qpos0[a])
            owner.append(j)
        elif info.kind == "ball":
            cols.append(quat_to_rotvec(qpos[:, a : a + 4]))
            owner.extend([j, j, j])
    if not cols:
        return np.zeros((len(qpos), 0)), []
    return np.concatenate(cols, axis=1), owner


def sta_drivers(model: mujoco.MjModel) -> list[list[int]]:
    """Per body: the non-free joints that drive its markers' soft-tissue artefact.

    The joints of the body itself (the joint above its segment) and of its child bodies (the
    joints below), as joint indices.
    """
    parent = np.array(model.body_parentid)
    jbody = np.array(model.jnt_bodyid)
    free = {j for j, info in enumerate(joints(model)) if info.kind == "free"}
    out = []
    for b in range(model.nbody):
        own = [j for j in range(model.njnt) if jbody[j] == b and j not in free]
        below = [j for j in range(model.njnt) if parent[jbody[j]] == b and jbody[j] != b]
        out.append(sorted(set(own) | {j for j in below if j not in free}))
    return out


def soft_tissue(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    xmat: np.ndarray,
    gain_m: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Soft-tissue artefact: smooth marker displacements driven by the adjacent joints.

    Marker m on body b moves, in b's frame, by ``gain_m * C_m @ s_b(t)``: ``s_b`` the rotations
    [rad] (from ``qpos0``) of the joints above and below b (:func:`sta_drivers`,
    :func:`joint_signals`: n_b rotation coordinates), ``C_m`` (3, n_b) a random matrix with
    independent N(0, 1 / (3 n_b)) entries: the marker moves by about ``gain_m`` (RMS) when the
    driving rotations are one radian each (RMS). The artefact is zero in the standing pose, as
    smooth as the motion, and different for every marker.

    Parameters
    ----------
    model : MjModel
    qpos : (T, nq) float [m, quaternion, rad]
    xmat : (T, nbody, 3, 3) float
        Body orientations (columns: body axes in world), e.g. ``Kinematics.forward(qpos).xmat``.
    gain_m : float
        Displacement per radian [m].
    rng : numpy.random.Generator
        Draws the matrices, one per marker in site order (always, even for ``gain_m = 0``).

    Returns
    -------
    (T, M, 3) float [m], world frame
    """
    signals, owner = joint_signals(model, qpos)
    drivers = sta_drivers(model)
    owner_arr = np.array(owner, dtype=int)
    out = np.zeros((len(qpos), model.nsite, 3))
    for m in range(model.nsite):
        b = int(model.site_bodyid[m])
        cols = np.flatnonzero(np.isin(owner_arr, drivers[b])) if len(owner) else np.array([])
        coef = rng.normal(0.0, np.sqrt(1.0 / (3.0 * max(len(cols), 1))), (3, len(cols)))
        local = gain_m * signals[:, cols] @ coef.T  # (T, 3) in the body frame
        out[:, m] = np.einsum("tij,tj->ti", xmat[:, b], local)
    return out


# ------------------------------------------------------------------------------- corruptions
def occlusion_gaps(
    frames: int, markers: int, fraction: float, rate: float, rng: np.random.Generator
) -> np.ndarray:
    """Occlusion mask (T, M): runs of missing frames totalling ``fraction`` of the samples.

    Runs of 0.05-0.5 s (at least one frame, at most the trial), at a random marker and start,
    are added until exactly ``round(fraction * T * M)`` samples are missing (a run that would
    overshoot is cut short; overlapping runs join into longer ones).

    Parameters
    ----------
    frames, markers : int
        T and M.
    fraction : float
        In [0, 1).
    rate : float
        Frame rate [Hz], for the run lengths.
    rng : numpy.random.Generator

    Returns
    -------
    (T, M) bool, True where a sample is missing
    """
    if not 0.0 <= fraction < 1.0:
        raise MocapError(f"gaps: expected a fraction in [0, 1), got {fraction:g}")
    mask = np.zeros((frames, markers), dtype=bool)
    need = round(fraction * frames * markers)
    shortest = max(1, min(frames, round(0.05 * rate)))
    longest = max(shortest, min(frames, round(0.5 * rate)))
    tries = 0
    while need > 0 and tries < 100_000:
        tries += 1
        m = int(rng.integers(markers))
        length = int(rng.integers(shortest, longest + 1))
        start = int(rng.integers(0, frames - length + 1))
        free = start + np.flatnonzero(~mask[start : start + length, m])[:need]
        mask[free, m] = True
        need -= len(free)
    if need > 0:  # nearly everything is missing already: take single samples
        free = np.flatnonzero(~mask.ravel())
        mask.ravel()[rng.choice(free, need, replace=False)] = True
    return mask


def outlier_mask(visible: np.ndarray, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """Outlier mask (T, M): ``round(fraction * T * M)`` visible samples drawn at random.

    Parameters
    ----------
    visible : (T, M) bool
        Samples that can be outliers (not missing); the count is capped at their number.
    fraction : float
        In [0, 1).
    rng : numpy.random.Generator

    Returns
    -------
    (T, M) bool
    """
    if not 0.0 <= fraction < 1.0:
        raise MocapError(f"outliers: expected a fraction in [0, 1), got {fraction:g}")
    cells = np.flatnonzero(visible.ravel())
    count = min(round(fraction * visible.size), len(cells))
    mask = np.zeros(visible.size, dtype=bool)
    mask[rng.choice(cells, count, replace=False)] = True
    return mask.reshape(visible.shape)


def outlier_displacements(count: int, size_m: float, rng: np.random.Generator) -> np.ndarray:
    """``count`` displacements (count, 3) [m] of length ``size_m`` in uniform random directions."""
    v = rng.standard_normal((count, 3))
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return size_m * v / np.maximum(norm, 1e-12)


def pick_swaps(
    names: tuple[str, ...], frames: int, count: int, rng: np.random.Generator
) -> list[tuple[str, str, int, int]]:
    """Left/right label swaps: ``count`` distinct marker pairs, each over one time window.

    Pairs are ``L<name>``/``R<name>`` markers; each window lasts 10-30 % of the trial (at
    least one frame) at a random start.

    Returns
    -------
    list of (marker_a, marker_b, first_frame, last_frame)
        Left name, right name, first and last swapped frame (inclusive), in pair order.
    """
    pairs = mirror_pairs(names)
    if count > len(pairs):
        raise MocapError(
            f"swaps: asked for {count} label swaps but the markers form only {len(pairs)} "
            "left/right pairs"
        )
    chosen = sorted(int(i) for i in rng.choice(len(pairs), count, replace=False))
    out = []
    shortest = max(1, round(0.1 * frames))
    longest = max(shortest, round(0.3 * frames))
    for i in chosen:
        length = min(frames, int(rng.integers(shortest, longest + 1)))
        first = int(rng.integers(0, frames - length + 1))
        a, b = pairs[i]
        out.append((names[a], names[b], first, first + length - 1))
    return out


def apply_swaps(
    positions: np.ndarray, names: tuple[str, ...], swaps: list[tuple[str, str, int, int]]
) -> np.ndarray:
    """A copy of positions (T, M, 3) with the labels of each swap exchanged in its window."""
    out = np.array(positions, dtype=float, copy=True)
    index = {n: i for i, n in enumerate(names)}
    for a, b, first, last in swaps:
        ia, ib = index[a], index[b]
        window = slice(first, last + 1)
        out[window, ia], out[window, ib] = positions[window, ib], positions[window, ia]
    return out
