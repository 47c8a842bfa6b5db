"""Long recordings: identify on a pose-diverse subset, refine on every frame, IK in chunks.

Identification on all frames of an hour at 100 Hz (360,000 frames) by the joint LM costs
many minutes. A subset of about a thousand pose-diverse frames
(:mod:`mocap_mj.identify.selection`) gives a consistent estimate cheaply, but its error is
that of a thousand frames, not of the hour. :func:`identify_long` therefore

1. selects ``count`` frames by pose diversity,
2. identifies the model on them (the joint LM, initial model scaled and its markers placed
   from the selected frames, as ``mocap-mj identify`` does by default),
3. solves the IK of every frame with that model (chained, ``chunk`` frames at a time),
4. refines the model on every frame: the one-step estimator (Le Cam), iterated.
   From the subset's estimate theta_0, Gauss-Newton steps on the reduced system of
   *every* frame, ``theta_k+1 = theta_k + S^-1 g(theta_k)``. g
   (:func:`mocap_mj._schur.reduced_gradient`) is summed over every frame at its IK pose
   under theta_k; S, the reduced information with the joint limits held as in g (the
   curvature of the same objective), is summed over at most ``info_frames`` evenly spaced
   frames and scaled to all, at every step (the set of frames at a limit changes with
   theta: a matrix kept from the start let later steps diverge). S only has to be a
   consistent estimate; g includes every frame, since it carries their averaging of the
   noise. From a root-n-consistent start one step is asymptotically efficient; up to
   ``steps`` are taken, until one is below ``tol_std`` of a standard deviation,
5. solves the IK of every frame again with the refined model, warm-started from step 3's
   poses (theta moved by a fraction of a millimetre: about two iterations per frame).

Steps 3 to 5 stream ``chunk`` frames at a time through ``qpos_out`` (an array or a
memory-mapped ``.npy``): no more than one chunk's poses and per-frame work arrays are in
memory at once, never all Jacobians.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .. import _schur
from .._threads import single_blas_thread
from ..errors import check_shape
from ..ik import IKResult, IKSolver
from ..kinematics import Kinematics
from ..parameters import ParameterSet
from .initial import place_markers, scaled_theta, segment_scales
from .lm import LMResult, LMSettings, TrialData, identify_lm, informed_solve
from .problem import IdentificationProblem
from .selection import Selection, select_frames

#: IK chunk [frames]: 20,000 frames' poses are 9 MB, their IK working set a few tens of MB.
CHUNK = 20_000
#: The reduced information of at most INFO_FRAMES evenly spaced frames, scaled, estimates
#: all frames' (docs/long-recordings.md: the one-step estimate's error against it).
INFO_FRAMES = 20_000
#: Refinement steps at most, and the step (in standard deviations) below which they stop.
STEPS = 3
TOL_STD = 0.05


class LongResult(NamedTuple):
    """Outcome of :func:`identify_long`.

    Fields
    ------
    selection : the kept frames
    lm : the identification on them (its theta is the start of the refinement)
    theta : (P,) [m], the model: ``lm.theta`` refined on every frame (itself with no steps)
    information : (P, P) [1], the refinement's matrix: reduced information of every solved
        frame at ``lm.theta``, joint limits held (:func:`refine`; ``lm.reduced_information``
        with no steps), frozen rows and columns zero
    steps : list of float, the refinement steps' sizes (:class:`Refinement`)
    marker_rmse : [m] over all present samples of every solved frame under ``theta``
    frames_solved : int
    seconds : per stage (``select``, ``identify``, ``refine``: its IK and gradient passes,
        ``ik``: the last IK, under theta)
    """

    selection: Selection
    lm: LMResult
    theta: np.ndarray
    information: np.ndarray
    steps: list[float]
    marker_rmse: float
    frames_solved: int
    seconds: dict[str, float]


class Refinement(NamedTuple):
    """The refinement on every frame (:func:`refine`).

    Fields
    ------
    theta : (P,) [m], the refined model
    information : (P, P) [1], reduced information of every solved frame at the start, joint
        limits held (the steps' matrix), frozen rows and columns zero
    gradient : (P,) [m], the reduced gradient of every solved frame at the start
    steps : list of float, each step's largest component in units of that parameter's
        standard deviation (informed directions; sigma the noise of the start)
    """

    theta: np.ndarray
    information: np.ndarray
    gradient: np.ndarray
    steps: list[float]


class _Fit(NamedTuple):
    """Sums over the solved frames of an IK pass: squared marker distances [m^2], present
    samples, frames."""

    sq: float
    present: int
    solved: int

    @property
    def rmse(self) -> float:
        return float(np.sqrt(self.sq / self.present)) if self.present else float("nan")


def _solve_chunk(solver: IKSolver, m: np.ndarray, q: np.ndarray) -> _Fit:
    """IK of one chunk's markers m (n, M, 3) [m] in place in q (n, nq): frames with a pose
    (finite rows) start there (warm; NaN rows had too few markers and stay NaN); a chunk of
    NaN rows is solved afresh (chained, :meth:`IKSolver.solve_trial`)."""
    warm = np.isfinite(q[:, 0])
    r: IKResult
    if warm.any():
        r = solver.solve_frames(m[warm], q[warm])
        q[warm] = r.qpos
    else:
        r = solver.solve_trial(m)
        q[:] = r.qpos
    ok = r.solved
    return _Fit(
        float(np.sum(r.marker_rmse[ok] ** 2 * r.n_markers[ok])),
        int(r.n_markers[ok].sum()),
        int(ok.sum()),
    )


def _ik_pass(
    markers: NDArray[np.floating],
    kin: Kinematics,
    qpos: NDArray[np.floating],
    chunk: int,
    gradient: bool,
) -> tuple[_Fit, np.ndarray]:
    """IK of every frame under kin's theta, chunk by chunk, in place in qpos (T, nq)
    (:func:`_solve_chunk`); with ``gradient``, each chunk's reduced gradient at its new
    poses is summed (P,) [m] (zeros otherwise)."""
    solver = IKSolver(kin)
    tree, kt = kin.tree(), kin.kappa_tables()
    grad = np.zeros(kin.pset.size)
    fit = _Fit(0.0, 0, 0)
    for s in range(0, len(markers), chunk):
        m = np.asarray(markers[s : s + chunk], dtype=float)
        q = np.array(qpos[s : s + chunk], dtype=float)
        f = _solve_chunk(solver, m, q)
        qpos[s : s + chunk] = q
        fit = _Fit(fit.sq + f.sq, fit.present + f.present, fit.solved + f.solved)
        if gradient:
            present = np.all(np.isfinite(m), axis=2)
            target = np.where(present[..., None], m, 0.0)
            grad += _schur.reduced_gradient(tree, kt, target, present.astype(float), q)
    return fit, grad


def _information(
    markers: NDArray[np.floating],
    kin: Kinematics,
    qpos: NDArray[np.floating],
    free: np.ndarray,
    info_frames: int,
) -> np.ndarray:
    """Reduced information (P, P) [1] of every solved frame, joint limits held, from every
    k-th frame (k = ceil(T / info_frames)) times k."""
    stride = max(1, -(-len(markers) // max(info_frames, 1)))
    rows = np.arange(0, len(markers), stride)
    q = np.asarray(qpos[rows], dtype=float)
    ok = np.isfinite(q[:, 0])
    if not ok.any():
        return np.zeros((kin.pset.size,) * 2)
    m = np.asarray(markers[rows[ok]], dtype=float)
    prob = IdentificationProblem(kin, m, q[ok], free, theta0=kin.theta.copy())
    return stride * prob.information(prob.present.astype(float), limits=True)


@single_blas_thread
def refine(
    markers: NDArray[np.floating],
    pset: ParameterSet,
    theta0: np.ndarray,
    qpos: NDArray[np.floating],
    sigma: float,
    *,
    settings: LMSettings | None = None,
    steps: int = STEPS,
    tol_std: float = TOL_STD,
    chunk: int = CHUNK,
    info_frames: int = INFO_FRAMES,
) -> Refinement:
    """Gauss-Newton steps of theta on the reduced system of every frame (module docstring).

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing; read ``chunk`` frames at a time
    theta0 : (P,) [m], a consistent start (the identification on a subset); also the mean of
        the weak prior (``settings.weak_prior``), as in the identification
    qpos : (T, nq) float, written: every frame's IK pose under the last step's start (NaN
        rows: too few markers); its finite rows are the first IK's warm starts (NaN: a
        chained IK). Each step solves every frame's IK (warm) under the current theta and
        sums the reduced gradient at those poses, in one pass over the markers
    sigma : [m], per-axis marker noise (the start's estimate), for ``tol_std``
    settings : LM settings for the prior and the informed directions (``prior_ratio``:
        directions with less information keep their value, as in every LM step)
    steps : at most this many steps (default 3: from the 1000-frame start on the hour-long
        benchmark the first step leaves weakly determined directions mm away, which the
        next ones correct; docs/long-recordings.md)
    tol_std : stop once a step's largest component is below this fraction of its
        parameter's standard deviation (default 0.05: further steps cannot change the
        estimate measurably)
    info_frames : the information is summed over every k-th frame, k = ceil(T / info_frames),
        and scaled by k (default 20,000 frames; an estimate of the information only slows
        the steps' convergence, the gradient over every frame decides where they converge)
    """
    st = settings or LMSettings()
    kin = Kinematics(pset)
    check_shape("qpos", qpos, (len(markers), kin.nq))
    free = np.flatnonzero(~pset.frozen)
    prior = st.weak_prior(theta0)
    floor = st.prior_ratio * st.prior_weight
    theta = np.array(theta0, dtype=float)
    sizes: list[float] = []
    info = np.zeros((pset.size, pset.size))
    grad0 = np.zeros(pset.size)
    for i in range(steps):
        kin.set_theta(theta)
        _, grad = _ik_pass(markers, kin, qpos, chunk, gradient=True)
        # The matrix at every step: with the joint limits held, the set of frames at a limit
        # changes with theta, and a matrix kept from the start let later steps diverge.
        s_info = _information(markers, kin, qpos, free, info_frames)
        if i == 0:
            grad0, info = grad, s_info
        s_mat = s_info[np.ix_(free, free)] + prior.hessian()[np.ix_(free, free)]
        lam, vec = np.linalg.eigh(0.5 * (s_mat + s_mat.T))
        basis, lam = vec[:, lam > floor], lam[lam > floor]
        std = sigma * np.sqrt(np.einsum("ij,j,ij->i", basis, 1.0 / lam, basis))
        dth = informed_solve(s_mat, s_mat, grad[free] - prior.gradient(theta)[free], floor)
        theta[free] += dth
        sizes.append(float(np.max(np.abs(dth) / np.maximum(std, 1e-300), initial=0.0)))
        if sizes[-1] < tol_std:
            break
    return Refinement(theta, info, grad0, sizes)


def refit_all(
    markers: NDArray[np.floating],
    pset: ParameterSet,
    theta: np.ndarray,
    qpos: NDArray[np.floating],
    *,
    chunk: int = CHUNK,
) -> tuple[float, int]:
    """IK of every frame under theta (P,) [m], ``chunk`` frames at a time, in place in qpos
    (T, nq): warm from its finite rows, chained in chunks of NaN rows.

    Returns the marker RMSE [m] over the present samples of the solved frames, and their
    number."""
    kin = Kinematics(pset)
    kin.set_theta(theta)
    check_shape("qpos", qpos, (len(markers), kin.nq))
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
    chunk: int = CHUNK,
    steps: int = STEPS,
    info_frames: int = INFO_FRAMES,
) -> LongResult:
    """Identify a long recording on ``count`` selected frames, IK every frame, refine the
    model on every frame (:func:`refine`), then IK every frame again (warm) with it.

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing; a memory map is read chunk by chunk
    times : (T,) float [s]
    pset : the model's parameter set
    qpos_out : (T, nq) float, written: every frame's pose (NaN rows where too few markers)
    count : frames identified on (default 1000: see docs/long-recordings.md)
    settings : LM settings (default ``LMSettings()``)
    chunk : frames per IK chunk
    steps : refinement steps on every frame at most (:func:`refine`; 0: none, the model's
        error is then that of ``count`` frames, many times the bound of the whole recording)
    info_frames : see :func:`refine`
    """
    n = len(markers)
    st = settings or LMSettings()
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
    t3 = time.perf_counter()
    if steps > 0:
        ref = refine(
            markers, pset, lm.theta, qpos_out, lm.sigma, settings=st, steps=steps,
            chunk=chunk, info_frames=info_frames,
        )  # fmt: skip
        theta, info, sizes = ref.theta, ref.information, ref.steps
        t3 = time.perf_counter()
    rmse, solved = refit_all(markers, pset, theta, qpos_out, chunk=chunk)
    t4 = time.perf_counter()
    stages = {"select": t1 - t0, "identify": t2 - t1, "refine": t3 - t2, "ik": t4 - t3}
    return LongResult(sel, lm, theta, info, sizes, rmse, solved, stages)
