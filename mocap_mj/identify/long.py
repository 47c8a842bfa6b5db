"""Long recordings: identify on a pose-diverse subset, then IK of every frame in chunks.

Identification on all frames of an hour at 100 Hz (360,000 frames) costs about 15 minutes;
the model is determined by the distinct poses, which a subset of about a thousand frames
covers (:mod:`mocap_mj.identify.selection`). :func:`identify_long` therefore

1. selects ``count`` frames by pose diversity,
2. identifies the model on them (the joint LM, initial model scaled and its markers placed
   from the selected frames, as ``mocap-mj identify`` does by default),
3. solves the IK of every frame with the identified model, ``chunk`` frames at a time,
   writing each chunk's poses into ``qpos_out`` (an array or a memory-mapped ``.npy``) so
   that no more than one chunk's poses and Jacobians are in memory at once.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import check_shape
from ..ik import IKSolver
from ..kinematics import Kinematics
from ..parameters import ParameterSet
from .initial import place_markers, scaled_theta, segment_scales
from .lm import LMResult, LMSettings, TrialData, identify_lm
from .selection import Selection, select_frames

#: IK chunk [frames]: 20,000 frames' poses are 9 MB, their IK working set a few tens of MB.
CHUNK = 20_000


class LongResult(NamedTuple):
    """Outcome of :func:`identify_long`.

    Fields: selection (the kept frames); lm (the identification on them); marker_rmse [m]
    over all present samples of every solved frame; frames_solved; seconds per stage
    (``select``, ``identify``, ``ik``).
    """

    selection: Selection
    lm: LMResult
    marker_rmse: float
    frames_solved: int
    seconds: dict[str, float]


def identify_long(
    markers: NDArray[np.floating],
    times: NDArray[np.floating],
    pset: ParameterSet,
    qpos_out: NDArray[np.floating],
    *,
    count: int = 1000,
    settings: LMSettings | None = None,
    chunk: int = CHUNK,
) -> LongResult:
    """Identify a long recording on ``count`` selected frames, then IK every frame.

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing; a memory map is read chunk by chunk
    times : (T,) float [s]
    pset : the model's parameter set
    qpos_out : (T, nq) float, written: every frame's pose (NaN rows where too few markers)
    count : frames identified on (default 1000: see docs/long-recordings.md)
    settings : LM settings (default ``LMSettings()``)
    chunk : frames per IK chunk
    """
    n = len(markers)
    check_shape("markers", markers, (None, pset.n_markers, 3))
    check_shape("times", times, (n,))
    t0 = time.perf_counter()
    sel = select_frames(markers, pset.marker_names, count)
    t1 = time.perf_counter()
    sub = np.asarray(markers[sel.frames], dtype=float)
    scales = segment_scales(pset, [sub])
    theta0 = place_markers(pset, scaled_theta(pset, [sub], scales=scales), [sub])
    trial = TrialData("selection", sub, np.asarray(times[sel.frames], dtype=float))
    lm = identify_lm([trial], pset=pset, theta0=theta0, settings=settings or LMSettings())
    t2 = time.perf_counter()
    kin = Kinematics(pset)
    kin.set_theta(lm.theta)
    check_shape("qpos_out", qpos_out, (n, kin.nq))
    solver = IKSolver(kin)
    sq = 0.0
    present = 0
    solved = 0
    for s in range(0, n, chunk):
        r = solver.solve_trial(np.asarray(markers[s : s + chunk], dtype=float))
        qpos_out[s : s + chunk] = r.qpos
        ok = r.solved
        sq += float(np.sum(r.marker_rmse[ok] ** 2 * r.n_markers[ok]))
        present += int(r.n_markers[ok].sum())
        solved += int(ok.sum())
    t3 = time.perf_counter()
    rmse = float(np.sqrt(sq / present)) if present else float("nan")
    stages = {"select": t1 - t0, "identify": t2 - t1, "ik": t3 - t2}
    return LongResult(sel, lm, rmse, solved, stages)
