"""Long recordings: identify on a pose-diverse subset, refine on every frame, IK in chunks.

Identification on all frames of an hour at 100 Hz (360,000 frames) by the joint LM costs
many minutes. A subset of about a thousand pose-diverse frames
(:mod:`mocap_mj.solve.selection`) gives a consistent estimate cheaply, but its error is
that of a thousand frames, not of the hour. :func:`identify_long` therefore

1. selects ``count`` frames by pose diversity,
2. identifies the model on them (the joint LM, initial model scaled and its markers placed
   from the selected frames, as ``mocap-mj identify`` does by default),
3. refines the model on every frame (:func:`~mocap_mj.long.refine.refine`): the one-step estimator
(Le Cam),
   with its start brought closer first. One Gauss-Newton step on the reduced system of
   *every* frame, ``theta_1 = theta_0 + S^-1 g``, is asymptotically efficient from a
   root-n-consistent start theta_0; g, the reduced gradient
   (:func:`mocap_mj.kernels._schur.reduced_gradient`), is summed over every frame at its IK pose
   under theta_0 in one streamed pass, and S, the reduced information, only has to be a
   consistent estimate, so it comes from an evenly spaced sample, scaled. From the subset's
   estimate the step was not enough: directions the subset barely determined start
   millimetres away, where the curvature changes over the step. So theta_0 is first
   brought to the sample's own optimum by Gauss-Newton steps on the sample (``sample``
   frames, default 20,000; the information recomputed at every step: kept fixed, the steps
   diverged), which costs a fraction of a pass over every frame; the last step is the
   one on every frame. Joint limits are not held in these steps (g and S of the problem
   without limits, like the Cramer-Rao bound): held, the set of frames at a limit changed
   with theta and the steps oscillated or diverged. The sample's gradient, information and
   cost are scaled to every frame, so that priors (``identify``'s landmark rows, its box)
   weigh against the whole recording; a sample step that raises that cost is taken back and
   the next one damped (Levenberg-Marquardt): on a real trial with its priors the undamped
   steps did not converge (docs/method.md#long-recordings). The pass over every frame solves
   each frame's IK as a chain from the nearest earlier frame of the sample, whose pose
   under the same model the sample's last step has
   (:meth:`~mocap_mj.solve.ik.IKSolver.solve_from_heads`): no chain starts cold,
4. solves the IK of every frame with the refined model, warm-started from the poses of
   the pass of step 3 (theta moved by a fraction of a millimetre: about two iterations per
   frame).

Steps 3 and 4 stream ``chunk`` frames at a time through ``qpos_out`` (an array or a
memory-mapped ``.npy``): no more than one chunk's poses and per-frame work arrays are in
memory at once, never all Jacobians.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from mocap_mj.anatomy.initial import place_markers, scaled_theta, segment_scales
from mocap_mj.long.chunks import CHUNK, Parts, Robust, _ik_pass
from mocap_mj.long.refine import RefineOptions, refine
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import (
    LMResult,
    LMSettings,
    TrialData,
    identify_lm,
    solver_joint_range,
)
from mocap_mj.solve.problem import reduced_information
from mocap_mj.solve.selection import Selection, select_frames
from mocap_mj.solve.solver_result import IdentificationResult

from ..errors import check_shape


class LongResult(NamedTuple):
    """Outcome of :func:`identify_long`.

    Fields
    ------
    selection : the kept frames
    lm : the identification on them (its theta is the start of the refinement)
    theta : (P,) [m], the model: ``lm.theta`` refined on every frame (itself unrefined)
    information : (P, P) [1], the refinement's last matrix: the reduced information of
        every frame, estimated from the sample (:class:`~mocap_mj.long.refine.Refinement`;
        unrefined:
        ``lm.reduced_information``), frozen rows and columns zero
    steps : list of float, the refinement steps' sizes (:class:`~mocap_mj.long.refine.Refinement`)
    marker_rmse : [m] over all present samples of every solved frame under ``theta``
    frames_solved : int
    seconds : per stage (``select``, ``identify``, ``refine``: its sample steps and its pass
        over every frame, also apart as ``refine_sample`` and ``refine_pass``; ``ik``: the
        last IK, under theta)
    """

    selection: Selection
    lm: LMResult
    theta: np.ndarray
    information: np.ndarray
    steps: list[float]
    marker_rmse: float
    frames_solved: int
    seconds: dict[str, float]


def refit_all(
    markers: Parts,
    pset: ParameterSet,
    theta: np.ndarray,
    qpos: Parts,
    *,
    chunk: int = CHUNK,
) -> tuple[float, int]:
    """IK of every frame under theta (P,) [m], ``chunk`` frames at a time, in place in qpos
    (T, nq) (one per trial of ``markers``): warm from its finite rows, chained in chunks of
    NaN rows.

    Returns the marker RMSE [m] over the present samples of the solved frames, and their
    number."""
    kin = Kinematics(pset)
    kin.set_theta(theta)
    fit, _ = _ik_pass(markers, kin, qpos, chunk, gradient=False)
    return fit.rmse, fit.solved


def identify_long(
    markers: NDArray[np.floating],
    times: NDArray[np.floating],
    pset: ParameterSet,
    qpos_out: NDArray[np.floating],
    *,
    count: int = 1000,
    settings: LMSettings | None = None,
    refine_on_all: bool = True,
    refinement: RefineOptions | None = None,
) -> LongResult:
    """Identify a long recording on ``count`` selected frames, IK every frame, refine the
    model on every frame (:func:`~mocap_mj.long.refine.refine`), then IK every frame again (warm)
    with it.

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing; a memory map is read chunk by chunk
    times : (T,) float [s]
    pset : the model's parameter set
    qpos_out : (T, nq) float, written: every frame's pose (NaN rows where too few markers)
    count : frames identified on (default 1000: see docs/method.md#long-recordings)
    settings : LM settings (default ``LMSettings()``)
    refine_on_all : refine the model on every frame (:func:`~mocap_mj.long.refine.refine`;
        default on: without, the model's error is that of ``count`` frames, many times the
        bound of the whole recording)
    refinement : the refinement's options (:class:`~mocap_mj.long.refine.RefineOptions`: its
        sample, steps, ...; default ``RefineOptions()``); its ``chunk`` is the frames per IK
        chunk of every pass, the last IK's too
    """
    n = len(markers)
    st = settings or LMSettings()
    options = refinement or RefineOptions()
    check_shape("markers", markers, (None, pset.n_markers, 3))
    check_shape("times", times, (n,))
    check_shape("qpos_out", qpos_out, (n, pset.model.nq))
    t0 = time.perf_counter()
    sel = select_frames(markers, pset.marker_names, count)
    t1 = time.perf_counter()
    sub = np.asarray(markers[sel.frames], dtype=float)
    scales = segment_scales(pset, [sub])
    theta0 = place_markers(pset, scaled_theta(pset, [sub], scales=scales), [sub])
    trial = TrialData("selection", sub, np.asarray(times[sel.frames], dtype=float))
    lm = identify_lm([trial], pset=pset, theta0=theta0, settings=st)
    t2 = time.perf_counter()
    qpos_out[:] = np.nan
    theta, info, sizes = lm.theta, lm.reduced_information, []
    extra: dict[str, float] = {}
    t3 = time.perf_counter()
    if refine_on_all:
        ref = refine(markers, pset, lm.theta, qpos_out, lm.sigma, settings=st, options=options)
        theta, info, sizes = ref.theta, ref.information, ref.steps
        extra = {f"refine_{k}": v for k, v in ref.seconds.items()}
        t3 = time.perf_counter()
    rmse, solved = refit_all(markers, pset, theta, qpos_out, chunk=options.chunk)
    t4 = time.perf_counter()
    stages = {"select": t1 - t0, "identify": t2 - t1, "refine": t3 - t2, "ik": t4 - t3, **extra}
    return LongResult(sel, lm, theta, info, sizes, rmse, solved, stages)


def result_at(
    result: IdentificationResult,
    trials: Sequence[TrialData],
    pset: ParameterSet,
    theta: np.ndarray,
    settings: LMSettings,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    robust: Robust | None = None,
) -> IdentificationResult:
    """The identification's ``result`` on ``trials`` described at another model theta (P,)
    [m] (the refined one): the trials' poses solved again under theta (warm from the
    result's, with the solver's joint limits; with ``robust``, weighted by the result's
    final IRLS weights, as the robust fit's poses were), their fit (RMSE, sigma), the reduced
    information at them and the parameters on a bound of ``box`` (lower, upper) (P,) [m];
    the initial model, iterations and trace stay the identification's."""
    kin = Kinematics(pset)
    kin.model.jnt_range[:] = solver_joint_range(kin.model, settings)
    kin.set_theta(theta)
    solver = IKSolver(kin)
    qpos, frame_rmse = [], []
    for i, (t, q0) in enumerate(zip(trials, result.qpos, strict=True)):
        q, f = np.array(q0, dtype=float), np.full(len(q0), np.nan)
        ok = np.isfinite(q[:, 0])
        if ok.any():
            w = None if robust is None else np.asarray(result.weights[i])[ok]
            r = solver.solve_frames(np.asarray(t.markers, dtype=float)[ok], q[ok], w)
            q[ok], f[ok] = r.qpos, r.marker_rmse
        qpos.append(q)
        frame_rmse.append(f)
    info, sigma, n_res, n_unk = reduced_information(pset, theta, trials, qpos)
    used = [np.isfinite(q[:, 0]) for q in qpos]
    n_markers = [
        np.all(np.isfinite(np.asarray(t.markers, dtype=float)), axis=2).sum(axis=1) for t in trials
    ]
    sq = sum(
        float(np.sum(f[u] ** 2 * k[u])) for f, u, k in zip(frame_rmse, used, n_markers, strict=True)
    )
    present = sum(int(k[u].sum()) for u, k in zip(used, n_markers, strict=True))
    lower, upper = (
        box if box is not None else (np.full(pset.size, -np.inf), np.full(pset.size, np.inf))
    )
    eps = 1e-12 * np.maximum(1.0, np.abs(theta))
    at_bound = result.free & ((theta <= lower + eps) | (theta >= upper - eps))
    return dataclasses.replace(
        result,
        theta=np.array(theta, dtype=float),
        qpos=qpos,
        used=used,
        marker_rmse=float(np.sqrt(sq / present)) if present else float("nan"),
        frame_rmse=frame_rmse,
        reduced_information=info,
        sigma=sigma,
        n_residuals=n_res,
        n_unknowns=n_unk,
        at_bound=at_bound,
    )
