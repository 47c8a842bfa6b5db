"""IK of a trial under the identification's loss (``ik --loss``), to reproduce a robust fit.

``identify --loss cauchy`` finds the poses that minimise a Cauchy (or Huber) cost of the marker
distances, with the threshold c = ``loss_scale`` sigma re-estimated from the current
distances (sigma = median distance / the chi-3 median; :mod:`mocap_mj.solve.lm`). A
least-squares IK with the identified model finds other poses (lower RMSE, outliers pulled
in), so its RMSE cannot be compared with the fit's. :func:`solve_trial_loss` solves the same
per-frame problem by iteratively reweighted least squares: the least-squares IK, then rounds
of weights from the current distances and a weighted per-frame IK from the current poses,
until the robust cost changes by less than ``tol`` (relative).

A model identified with the landmarks' sliding model (:mod:`mocap_mj.anatomy.tissue`,
recorded in its model.xml) was fitted with per-sample weights from the knee flexion of an
unweighted fit; ``sliding`` solves the same problem: the sliding weights from the
least-squares IK's poses, then the weighted IK (with a robust loss, the loss of the normalised
distances, as :class:`~mocap_mj.solve.losses.Weighted`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from mocap_mj.anatomy.tissue import SlidingModel, recorded_sliding_model
from mocap_mj.pipeline.arguments import SOLVE_MOTION, solve_motion_call
from mocap_mj.pipeline.motion import Motion
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKResult, IKSettings, IKSolver
from mocap_mj.solve.lm import LMSettings, Tolerances
from mocap_mj.solve.losses import LossName, Weighted, loss_named
from mocap_mj.solve.problem import TrialData, loss_threshold

from ..arguments import validated


@validated(solve_motion_call, **SOLVE_MOTION)
def solve_motion(
    model: ParameterSet | str | Path,
    trial: TrialData,
    *,
    loss: LossName = "l2",
    settings: IKSettings | None = None,
    sliding: bool = True,
    progress: Callable[[int], None] | None = None,
) -> Motion:
    """The motion of ``trial`` (markers (T, M, 3) [m] in the model's marker order, NaN where
    missing; times (T,) [s]) with ``model`` (a parameter set, or an MJCF file such as an
    identified model.xml): what ``mocap-mj ik`` computes. Each frame's pose minimises
    ``loss`` of the marker distances (:func:`solve_trial_loss`); a model that records the
    landmarks' sliding model weighs them as its identification did unless ``sliding`` is
    False. ``settings``: the per-frame IK's (default :class:`IKSettings`); ``progress`` is
    called with the frames done. Returns poses (T, nq), the trial's times and markers, and
    ``Motion.ik``: each frame's status, iterations and marker RMSE."""
    pset = model if isinstance(model, ParameterSet) else ParameterSet(model)
    solver = IKSolver(Kinematics(pset), settings or IKSettings())
    slid = recorded_sliding_model(pset.model) if sliding else None
    result = solve_trial_loss(solver, trial.markers, loss, progress=progress, sliding=slid)
    return Motion(result.qpos, trial.times, trial.markers, pset.marker_names, ik=result)


def solve_trial_loss(
    solver: IKSolver,
    markers: np.ndarray,
    loss: str = "l2",
    *,
    loss_scale: float = LMSettings.loss_scale,
    max_rounds: int = 30,
    tol_noise: float = Tolerances.tol_noise,
    progress: Callable[[int], None] | None = None,
    sliding: SlidingModel | None = None,
) -> IKResult:
    """IK of every frame of markers (T, M, 3) [m] (NaN where missing) under ``loss`` ("l2",
    "huber" or "cauchy", as ``LMSettings.loss``, threshold ``loss_scale`` sigma), with the
    samples weighed by ``sliding`` (default None: every sample alike; see the module).

    The result's ``marker_rmse`` (T,) [m] is the unweighted RMS distance of each frame, as the
    identification reports it.
    """
    rho = loss_named(loss)  # validates the name
    first = solver.solve_trial(markers, progress=progress)
    if loss == "l2" and sliding is None:
        return first
    kin = solver.kin
    markers = np.asarray(markers, dtype=float)
    ok = np.all(np.isfinite(first.qpos), axis=1)
    if sliding is not None:
        rho = Weighted(rho, sliding.weights(kin.pset, first.qpos[ok]))
    target = markers[ok]
    present = np.all(np.isfinite(target), axis=2)
    q = first.qpos[ok].copy()
    iterations = first.iterations.copy()
    status = first.status.copy()

    def distances(qpos: np.ndarray) -> np.ndarray:
        d = np.linalg.norm(kin.marker_positions(qpos) - target, axis=2)
        return np.where(present, d, 0.0)

    dist = distances(q)
    for _ in range(max_rounds):
        c = loss_threshold(dist[present], loss_scale)
        before = rho.value(dist, present, c)
        r = solver.solve_frames(target, q, rho.weights(dist, present, c))
        q = r.qpos
        iterations[ok] += r.iterations
        status[ok] = r.status
        dist = distances(q)
        sigma2 = float(np.sum(dist**2)) / (3.0 * max(int(present.sum()), 1))
        if before - rho.value(dist, present, c) <= tol_noise * sigma2:
            break
    qpos = np.full_like(first.qpos, np.nan)
    qpos[ok] = q
    rmse = np.full(len(markers), np.nan)
    rmse[ok] = np.sqrt(np.sum(dist**2, axis=1) / np.maximum(present.sum(axis=1), 1))
    return IKResult(qpos, rmse, iterations, status, first.n_markers)
