"""Frames worth identifying on: a pose-diverse subset of a long recording.

Identification cost is linear in frames, and an hour of motion repeats itself: the model's
parameters are determined by how many *different* poses see each marker, not by how many
times the same pose is seen. :func:`select_frames` keeps ``count`` frames spread over the
recording's poses by farthest-point sampling:

1. Each frame's pose feature is its markers in the pelvis's own frame (origin between the
   ASIS, axes from the ASIS and PSIS markers), which removes where the subject stands and
   faces; missing markers take the pool's mean (they add no distance).
2. A candidate pool of at most ``pool`` frames, evenly spaced (consecutive frames at 100 Hz
   differ by less than the noise), is projected on its ``dims`` principal components.
3. Starting from the pose farthest from the mean, the next frame is always the pool frame
   farthest from every frame kept so far, until ``count`` are kept.

The result states how well the kept frames cover the pool: the largest and the median
distance [m] of a pool frame to its nearest kept frame (in the reduced feature space).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mocap_mj.kernels._threads import single_blas_thread

from ..errors import MocapError, check_shape

#: Pelvis markers that define the feature frame (left/right ASIS, left/right PSIS).
PELVIS = ("LASI", "RASI", "LPSI", "RPSI")


class Selection(NamedTuple):
    """Frames kept: ``frames`` (K,) int, sorted indices into the recording; ``pool`` the
    number of candidate frames; ``cover_max`` and ``cover_median`` [m]: largest and median
    distance of a candidate's pose to the nearest kept pose."""

    frames: np.ndarray
    pool: int
    cover_max: float
    cover_median: float


def pose_features(markers: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Markers in the pelvis frame, (T, 3 M) [m], NaN where a marker or the pelvis is missing.

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing
    names : (M,) marker names, containing :data:`PELVIS`
    """
    check_shape("markers", markers, (None, len(names), 3))
    missing = [n for n in PELVIS if n not in names]
    if missing:
        raise MocapError(f"pose features need the pelvis markers; missing: {', '.join(missing)}")
    la, ra, lp, rp = (markers[:, names.index(n)] for n in PELVIS)
    origin = 0.5 * (la + ra)
    x = ra - la
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    back = 0.5 * (lp + rp) - origin
    z = np.cross(x, -back)  # up: right x forward
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    y = np.cross(z, x)
    rot = np.stack([x, y, z], axis=2)  # (T, 3, 3): columns are the pelvis axes
    local = np.einsum("tmc,tcd->tmd", markers - origin[:, None, :], rot)
    return local.reshape(len(markers), -1)


@single_blas_thread
def select_frames(
    markers: np.ndarray,
    names: tuple[str, ...],
    count: int,
    *,
    pool: int = 20_000,
    dims: int = 24,
) -> Selection:
    """``count`` pose-diverse frames of a recording (farthest-point sampling).

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing (a memory map is fine: only the pool
        frames are read)
    names : (M,) marker names
    count : frames to keep (all frames when the recording is shorter)
    pool : at most this many evenly spaced candidates (default 20,000: at 100 Hz an hour's
        every 18th frame; farthest-point sampling costs pool x count x dims)
    dims : principal components of the pose features kept (default 24, enough for the
        poses of a 48-DOF skeleton to stay apart; fewer makes the sampling faster)
    """
    n = len(markers)
    if count < 1:
        raise MocapError(f"count: expected at least 1 frame, got {count}")
    stride = max(1, -(-n // pool))
    cand = np.arange(0, n, stride)
    feats = pose_features(np.asarray(markers[cand], dtype=float), names)
    pelvis_rows = [names.index(p) for p in PELVIS]
    cols = np.concatenate([np.arange(3 * i, 3 * i + 3) for i in pelvis_rows])
    usable = np.all(np.isfinite(feats[:, cols]), axis=1) & np.isfinite(feats).any(axis=1)
    cand, feats = cand[usable], feats[usable]
    if len(cand) == 0:
        raise MocapError("no frame has all four pelvis markers: cannot select frames")
    if count >= len(cand) and stride == 1:
        return Selection(cand, len(cand), 0.0, 0.0)
    seen = np.isfinite(feats).sum(axis=0)  # a marker missing throughout gives a column of NaN
    mean = np.where(seen > 0, np.nansum(feats, axis=0) / np.maximum(seen, 1), 0.0)
    feats = np.where(np.isfinite(feats), feats, mean)
    centred = feats - mean
    _, vec = np.linalg.eigh(centred.T @ centred)  # principal axes, ascending variance
    z = centred @ vec[:, ::-1][:, :dims]
    norms = np.einsum("nd,nd->n", z, z)
    k = min(count, len(cand))
    kept = np.empty(k, dtype=int)
    kept[0] = int(np.argmax(norms))
    dist = np.full(len(z), np.inf)
    for i in range(k):
        if i:
            kept[i] = int(np.argmax(dist))
        zi = z[kept[i]]
        np.minimum(dist, norms - 2.0 * (z @ zi) + zi @ zi, out=dist)
    dist = np.maximum(dist, 0.0)
    cover = np.sqrt(dist)
    return Selection(np.sort(cand[kept]), len(cand), float(cover.max()), float(np.median(cover)))


def select_in_trials(
    markers: list[np.ndarray], names: tuple[str, ...], count: int
) -> list[np.ndarray]:
    """``count`` pose-diverse frames over several trials: sorted frame indices (K_i,) int per
    trial.

    The count is shared in proportion to the trials' frames (at least one frame each) and
    each trial's share is chosen by :func:`select_frames`; a trial shorter than its share
    keeps every frame.

    Parameters
    ----------
    markers : per trial (T_i, M, 3) float [m], NaN where missing
    names : (M,) marker names
    count : frames to keep in all (at least one per trial)
    """
    total = sum(len(m) for m in markers)
    if count < len(markers):
        raise MocapError(f"count: expected at least one frame per trial, got {count}")
    shares = [max(1, round(count * len(m) / total)) for m in markers]
    return [select_frames(m, names, k).frames for m, k in zip(markers, shares, strict=True)]
