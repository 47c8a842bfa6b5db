"""Inverse kinematics: Levenberg-Marquardt on the marker residual, vectorised over frames.

Per frame it minimises ``F(q) = 1/2 sum_m w_m |p_m - x_m(q)|^2`` over the nv = 48 velocity
coordinates with the analytic Jacobian (:meth:`Kinematics.jac_q`). Two damping rules:

``adaptive`` (default)
    Marquardt-scaled damping ``(H + mu D) dv = g`` with ``D = diag(H) + eps``, ``mu`` updated
    from the gain ratio (Nielsen 1999: ``mu *= max(1/3, 1 - (2 rho - 1)^3)`` on success,
    ``mu *= nu, nu *= 2`` on failure, which also rejects the step).
``sugihara``
    Sugihara's rule (T. Sugihara, IEEE T-RO 27(5), 2011): ``W_N = (E + wbar) I`` with
    ``E = 1/2 sum w |e|^2`` [m^2], every step taken. Kept as the paper's method; it converges
    linearly once ``E`` stops falling (noisy markers), see ``benchmarks/ik.py``.

Free and ball joints are updated on their manifold (``mj_integratePos``); after each step hinge
angles are clipped to their range and ball rotations longer than their range are shortened
to it (projected step). A step is first re-solved with the hinges at a limit that it pushes
outward held, and with the radial component (along the rotation axis) of a ball at its
largest rotation held, so the ball slides along its cone. Missing markers (NaN) have weight 0
in that frame. A frame with fewer than ``min_markers`` present markers
is not solved: status ``TOO_FEW_MARKERS``, qpos NaN.

A whole trial is solved as parallel chains: the trial is cut into chains of consecutive frames;
every chain's first frame starts from a rigid fit of the pelvis to its markers (Kabsch), every
later frame from the previous frame's solution plus its velocity (constant-velocity
prediction). Frames that fit clearly worse than the trial (a chain start caught in a local
minimum) are re-solved walking in from a good neighbour.

The solver runs on the compiled kernels of :mod:`mocap_mj.kernels._tree`: each chain runs frame by
frame in one thread, the chains spread over the cores; per iteration one forward kinematics,
``J^T W J`` assembled site by site from the dofs that move each site, and MuJoCo's sparse tree
factorisation (no fill-in) instead of a dense 48 x 48 solve. The chains' length depends on T
only, so results do not depend on the number of threads. A plain NumPy version of the
per-frame LM is the test oracle (``tests/_oracles.py``).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, NamedTuple

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.capture.checks import frame_floor
from mocap_mj.errors import MocapError, ShapeError, SolverError, check_shape
from mocap_mj.kernels import _tree, _tree_ik
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.rigid import rigid_fit

PELVIS_MARKERS = ("LASI", "RASI", "LPSI", "RPSI")


def _pelvis_markers(kin: Kinematics) -> np.ndarray:
    """(K,) int: the markers a frame's cold start fits the pelvis to: Plug-in Gait's
    :data:`PELVIS_MARKERS`, else (a set that names them otherwise: R.ASIS, L_IAS) every
    marker on the root body (the body of the free joint)."""
    pset, m = kin.pset, kin.model
    names = [n for n in PELVIS_MARKERS if n in pset.marker_names]
    if not names:
        root = int(m.jnt_bodyid[0])
        names = [m.site(i).name for i in range(m.nsite) if int(m.site_bodyid[i]) == root]
    return np.array([pset.marker_index(n) for n in names], dtype=int)


Damping = Literal["adaptive", "sugihara"]
COMPILED_CHAIN = 32  # longest chain of the compiled solver (chain_length=0)
PROGRESS_FRAMES = 20_000  # frames per kernel call when progress is reported
#: A joint turning by more than this [rad] between consecutive frames of a chain is taken for
#: a change of local minimum, and the frames on either side are re-solved from the other
#: side (:meth:`IKSolver._seams`). 0.3 rad a frame is 1700 deg/s at 100 Hz, beyond most
#: human joint speeds; a real movement that fast (a pitcher's shoulder) costs a few
#: warm-started frames, since a re-solve is kept only where it fits better.
JUMP = 0.3
#: Alternative arm configurations a chain's first frame is also solved from (ball joint ->
#: rotation vector [rad] in its parent's frame): arms abducted and arms forward, besides the
#: reference pose (arms at the sides). A static trial in a T-pose or with the arms abducted
#: has a single pose, and a start with the arms down can settle with an arm twisted about
#: itself in every frame; the chain starts where the first frame fits best.
ARM_STARTS: tuple[dict[str, tuple[float, float, float]], ...] = (
    {"shoulder_l": (np.pi / 2, 0.0, 0.0), "shoulder_r": (-np.pi / 2, 0.0, 0.0)},
    {"shoulder_l": (0.0, -np.pi / 2, 0.0), "shoulder_r": (0.0, -np.pi / 2, 0.0)},
)


#: Fewest frames a thread takes in a batch of cold starts (:meth:`IKSolver._best_start`): from
#: a rigid fit of the root a frame takes tens of iterations (a few hundred microseconds), so a
#: handful outweighs the hand-off to a worker thread.
COLD_BLOCK = 4


class Status(enum.IntEnum):
    """Outcome of a frame's solve."""

    CONVERGED = 0
    MAX_ITERATIONS = 1
    TOO_FEW_MARKERS = 2


STATUS_MESSAGES = {
    Status.CONVERGED: "converged (step or relative cost change below tolerance)",
    Status.MAX_ITERATIONS: "stopped at the iteration limit",
    Status.TOO_FEW_MARKERS: "not solved: fewer present markers than min_markers",
}


@dataclass(frozen=True)
class IKSettings:
    """Solver settings.

    Attributes
    ----------
    damping : {"adaptive", "sugihara"}
    max_iterations : int
        Iteration limit per frame.
    tol_step : float
        Converged when the largest step component is below this [rad or m].
    tol_cost : float
        Converged when an accepted step lowers F by less than ``tol_cost * F``.
    tol_rmse : float
        Converged when an accepted step lowers the frame's marker RMSE by less than this
        fraction of it: 1e-3 keeps a frame with 1.3 mm RMSE within about 0.002 mm of its
        converged RMSE, and noise-free frames converge fully.
    mu0 : float
        Initial Marquardt damping (dimensionless, relative to diag(H)) of the adaptive rule.
    wbar : float
        Sugihara's constant damping term [m^2].
    min_markers : int or None
        Frames with fewer present markers are reported (status TOO_FEW_MARKERS), not solved.
        None (default): :func:`mocap_mj.capture.checks.frame_floor` of the markers the call's
        frames record (16 for a full set, three quarters of a partial set's, at least 4).
    chain_length : int
        Frames per chain (0: automatic: T / 16 clipped to [4, 32]).
    """

    damping: Damping = "adaptive"
    max_iterations: int = 100
    tol_step: float = 1e-8
    tol_cost: float = 1e-8
    tol_rmse: float = 1e-3
    mu0: float = 1e-6
    wbar: float = 1e-6
    min_markers: int | None = None
    chain_length: int = 0

    def __post_init__(self) -> None:
        if self.damping not in ("adaptive", "sugihara"):
            raise MocapError(f"damping must be 'adaptive' or 'sugihara', got {self.damping!r}")
        if self.max_iterations < 1:
            raise MocapError("iteration limits must be at least 1")
        if self.min_markers is not None and self.min_markers < 1:
            raise MocapError("min_markers must be at least 1")


class IKResult(NamedTuple):
    """Solution of a trial.

    Fields
    ------
    qpos : (T, nq) float [m, quaternion, rad]; NaN rows for unsolved frames
    marker_rmse : (T,) float [m]; RMS of the 3D marker distance over present markers
    iterations : (T,) int
    status : (T,) int, values of :class:`Status`
    n_markers : (T,) int, present markers per frame
    """

    qpos: np.ndarray
    marker_rmse: np.ndarray
    iterations: np.ndarray
    status: np.ndarray
    n_markers: np.ndarray

    @property
    def solved(self) -> np.ndarray:
        """(T,) bool: frames that were solved (converged or at the iteration limit)."""
        return self.status != Status.TOO_FEW_MARKERS

    def rmse(self) -> float:
        """Marker RMSE [m] over all present samples of the solved frames."""
        ok = self.solved
        n = self.n_markers[ok]
        if n.sum() == 0:
            return float("nan")
        return float(np.sqrt(np.sum(self.marker_rmse[ok] ** 2 * n) / n.sum()))


class IKSolver:
    """Levenberg-Marquardt IK for a :class:`Kinematics` (its current theta).

    Parameters
    ----------
    kin : Kinematics
    settings : IKSettings
    """

    def __init__(self, kin: Kinematics, settings: IKSettings | None = None) -> None:
        self.kin = kin
        self.settings = settings or IKSettings()
        self._pelvis_idx = _pelvis_markers(kin)

    # ------------------------------------------------------------------ input
    def _floor(self, w: np.ndarray) -> int:
        """Present markers a frame of these weights (T, M) needs (:class:`IKSettings`)."""
        if self.settings.min_markers is not None:
            return self.settings.min_markers
        return frame_floor(int(np.count_nonzero(np.any(w > 0, axis=0))))

    def _prepare(
        self, markers: np.ndarray, weights: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        markers = np.asarray(markers, dtype=float)
        if markers.ndim == 2:
            markers = markers[None]
        check_shape("markers", markers, (None, self.kin.n_markers, 3))
        n, m = markers.shape[:2]
        if weights is None:
            w = np.ones((n, m))
        else:
            w = np.asarray(weights, dtype=float)
            if w.shape == (m,):
                w = np.broadcast_to(w, (n, m)).copy()
            elif w.shape != (n, m):
                raise ShapeError(f"weights: expected shape ({m},) or ({n}, {m}), got {w.shape}")
            else:
                w = w.copy()
            if np.any(~np.isfinite(w)) or np.any(w < 0):
                raise ShapeError("weights: must be finite and non-negative")
        present = np.all(np.isfinite(markers), axis=2)
        w[~present] = 0.0
        return np.where(present[..., None], markers, 0.0), w

    # ------------------------------------------------------------- one batch
    def project(self, qpos: np.ndarray) -> np.ndarray:
        """Joint limits applied in place to qpos (B, nq): hinges clipped, balls shortened
        (:func:`mocap_mj.kernels._tree.project_rows`)."""
        _tree.project_rows(self.kin.tree(), qpos)
        return qpos

    @single_blas_thread
    def solve_frames(
        self,
        markers: np.ndarray,
        qpos0: np.ndarray,
        weights: np.ndarray | None = None,
        *,
        max_iterations: int | None = None,
        tree: _tree.Tree | None = None,
        min_block: int = _tree.PARALLEL_MIN,
        prepared: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> IKResult:
        """Solve B independent frames from the given starting poses.

        Parameters
        ----------
        markers : (B, M, 3) float [m], NaN where missing
        qpos0 : (B, nq) float, starting poses
        weights : (M,) or (B, M) float, optional, per-marker weights (default 1)
        tree : compiled model to solve with, optional (default: the kinematics' at its
            theta; Algorithm 1 passes models with one parameter perturbed)
        min_block : int
            Fewest frames a thread takes (:func:`mocap_mj.kernels._tree.blocks`; default
            ``PARALLEL_MIN``, sized for warm starts of a few iterations each).
        prepared : (target (B, M, 3) [m], weights (B, M)), optional
            ``markers`` and ``weights`` already checked: finite targets, weights finite,
            non-negative and 0 where a marker is missing (as the joint LM's problem holds
            them); used as they are instead of checked and copied again (the joint LM's pose
            finish, after every step). Default None: checked.
        """
        kin, st = self.kin, self.settings
        target, w = self._prepare(markers, weights) if prepared is None else prepared
        n = len(target)
        qpos = np.array(qpos0, dtype=float, copy=True)
        check_shape("qpos0", qpos, (n, kin.nq))
        limit = st.max_iterations if max_iterations is None else max_iterations
        n_present = np.count_nonzero(w > 0, axis=1)
        rmse, iterations, status = _tree_ik.solve_batch(
            kin.tree() if tree is None else tree,
            target,
            w,
            qpos,
            limit,
            *self._kernel_settings(),
            self._floor(w),
            min_block=min_block,
        )
        return IKResult(qpos, rmse, iterations, status, n_present)

    def _kernel_settings(self) -> tuple[int, float, float, float, float, float]:
        st = self.settings
        damping = _tree.ADAPTIVE if st.damping == "adaptive" else _tree.SUGIHARA
        return damping, st.tol_step, st.tol_cost, st.tol_rmse, st.mu0, st.wbar

    # ------------------------------------------------------------ whole trial
    def root_from_pelvis(self, markers: np.ndarray) -> np.ndarray:
        """Starting poses (T, nq): joints at qpos0, root from a rigid fit of the pelvis.

        The pelvis markers' model positions (at qpos0 with the root at the origin) are fitted
        to the measured ones by the Kabsch algorithm; with fewer than three pelvis markers,
        all present markers of the neutral pose are used.
        """
        kin = self.kin
        markers = np.asarray(markers, dtype=float)
        n = len(markers)
        q0 = np.array(kin.model.qpos0, dtype=float)
        q0[:3] = 0.0
        q0[3:7] = (1, 0, 0, 0)
        ref = kin.marker_positions(q0)[0]  # (M, 3) in the pelvis frame
        present = np.all(np.isfinite(markers), axis=2)
        use = np.zeros_like(present)
        pel = self._pelvis_idx
        enough = present[:, pel].sum(axis=1) >= 3
        use[np.ix_(enough, pel)] = present[np.ix_(enough, pel)]
        use[~enough] = present[~enough]
        rot, pos = rigid_fit(np.where(use[..., None], markers, np.nan), ref)
        qpos = np.tile(np.array(kin.model.qpos0, dtype=float), (n, 1))
        ok = np.isfinite(pos[:, 0])
        qpos[ok, 3:7] = Rotation.from_matrix(rot[ok]).as_quat(scalar_first=True)
        qpos[ok, :3] = pos[ok]
        return qpos

    def _arm_starts(self, cold: np.ndarray) -> list[np.ndarray]:
        """``cold`` (B, nq) with the arms set to each configuration of :data:`ARM_STARTS`
        (the ones whose joints the model has)."""
        m = self.kin.model
        names = {m.joint(j).name: j for j in range(m.njnt)}
        out = []
        for config in ARM_STARTS:
            if not all(n in names for n in config):
                continue
            q = cold.copy()
            for name, rotvec in config.items():
                adr = int(m.jnt_qposadr[names[name]])
                q[:, adr : adr + 4] = Rotation.from_rotvec(rotvec).as_quat(scalar_first=True)
            out.append(self.project(q))
        return out

    def _best_start(self, markers: np.ndarray, w: np.ndarray, cold: np.ndarray) -> np.ndarray:
        """Starting poses (B, nq) of chain heads: ``cold`` or, where one fits the frame better
        once solved, the solution from one of the arm configurations of :data:`ARM_STARTS`."""
        alternatives = self._arm_starts(cold)
        if not alternatives:
            return cold.copy()
        # The solution from ``cold`` is a start too: the chain then only confirms it. Every
        # start of every head is one batch (the frames are independent): cold solves take
        # tens of iterations each, so a few frames are worth a thread (COLD_BLOCK).
        k, starts = len(cold), len(alternatives) + 1
        solved = self.solve_frames(
            np.concatenate([markers] * starts),
            np.concatenate([cold, *alternatives]),
            np.concatenate([w] * starts),
            min_block=COLD_BLOCK,
        )
        rmse = np.nan_to_num(solved.marker_rmse, nan=np.inf).reshape(starts, k)
        qpos = solved.qpos.reshape(starts, k, -1)
        fit = rmse[0]
        best = np.where(np.isfinite(fit)[:, None], qpos[0], cold)
        for i in range(1, starts):
            better = rmse[i] < 0.9 * fit
            best[better] = qpos[i][better]
            fit = np.where(better, rmse[i], fit)
        return best

    def _chain_length(self, n: int) -> int:
        if self.settings.chain_length > 0:
            return self.settings.chain_length
        # Enough chain starts that most of them land in the right pose (about one in four
        # cold starts of a range-of-motion trial does not): the trial's median RMSE then
        # tells the bad frames, which are walked in from their good neighbours.
        return int(np.clip(n // 16, 4, COMPILED_CHAIN))

    @single_blas_thread
    def solve_trial(
        self,
        markers: np.ndarray,
        weights: np.ndarray | None = None,
        *,
        qpos_init: np.ndarray | None = None,
        progress: Callable[[int], None] | None = None,
    ) -> IKResult:
        """Solve every frame of a trial (see the module docstring for the scheme).

        Parameters
        ----------
        markers : (T, M, 3) float [m], NaN where missing
        weights : (M,) or (T, M) float, optional
        qpos_init : (T, nq) float, optional
            Starting poses for every frame (e.g. the previous solution when only theta
            changed); then every frame starts there and the trial is one batch.
        progress : callable, optional
            Called with the number of frames solved so far, after every block of about
            20,000 frames (the chains then run in blocks).
        """
        kin = self.kin
        markers = np.asarray(markers, dtype=float)
        check_shape("markers", markers, (None, kin.n_markers, 3))
        n = len(markers)
        if n == 0:
            raise SolverError("markers: the trial has no frames")
        if qpos_init is not None:
            check_shape("qpos_init", qpos_init, (n, kin.nq))
            return self.solve_frames(markers, qpos_init, weights)
        return self._solve_chains(markers, weights, progress)

    def _solve_chains(
        self,
        markers: np.ndarray,
        weights: np.ndarray | None,
        progress: Callable[[int], None] | None,
    ) -> IKResult:
        """:meth:`solve_trial` with the compiled kernels: each chain runs sequentially in one
        thread (no lock-step batches), chains in parallel, in blocks for the progress bar."""
        st = self.settings
        target, w = self._prepare(markers, weights)
        n = len(target)
        cold = self.root_from_pelvis(markers)
        length = self._chain_length(n)
        starts = np.arange(0, n, length)
        ends = np.minimum(starts + length, n)
        cold[starts] = self._best_start(markers[starts], w[starts], cold[starts])
        qpos = np.full((n, self.kin.nq), np.nan)
        rmse = np.full(n, np.nan)
        iters = np.zeros(n, dtype=int)
        status = np.zeros(n, dtype=int)
        block = starts.size if progress is None else max(1, PROGRESS_FRAMES // length)
        tree, settings = self.kin.tree(), self._kernel_settings()
        for b in range(0, starts.size, block):
            s0, s1 = starts[b], ends[min(b + block, starts.size) - 1]
            rows = slice(s0, s1)
            q, r, it, stat = _tree_ik.solve_chains(
                tree,
                target[rows],
                w[rows],
                cold[rows],
                starts[b : b + block] - s0,
                ends[b : b + block] - s0,
                st.max_iterations,
                *settings,
                self._floor(w),
            )
            qpos[rows], rmse[rows], iters[rows], status[rows] = q, r, it, stat
            if progress is not None:
                progress(int(s1))
        self._seams(target, w, qpos, rmse, iters, status, starts, ends)
        # A chain can also change basin inside itself (its head in a wrong local minimum,
        # a later frame's warm start falling into the right one): its pose jumps there, and
        # the frames before the jump are re-solved from the frame after it, and vice versa.
        cuts = np.flatnonzero(pose_jumps(self.kin.model, qpos) > JUMP) + 1
        if cuts.size:
            bounds = np.concatenate([[0], cuts])
            self._seams(target, w, qpos, rmse, iters, status, bounds, np.append(cuts, n))
        result = IKResult(qpos, rmse, iters, status, np.count_nonzero(w > 0, axis=1))
        self._repair(markers, w, result)
        return result

    @single_blas_thread
    def solve_from_heads(self, markers: np.ndarray, heads: np.ndarray) -> IKResult:
        """Every frame of markers (T, M, 3) [m] solved as chains from known poses.

        ``heads`` (T, nq): finite rows are poses to start chains at (e.g. every k-th frame
        solved under the same model, as ``identify``'s refinement has them); each chain runs
        from its head to the frame before the next one, every later frame starting from the
        constant-velocity prediction (:func:`mocap_mj.kernels._tree_ik.solve_chains`). The trial's
        first frame always heads a chain; a head without a pose (NaN row) and a frame after an
        unsolved one start from the pelvis's rigid fit (:meth:`root_from_pelvis`). Frames
        that then fit clearly worse than the trial are re-solved as :meth:`solve_trial`
        does. Compared with :meth:`solve_trial`, no chain start is solved cold from several
        arm configurations (known heads need none), which is most of the cost of a cold
        chained solve of a long trial.
        """
        kin, st = self.kin, self.settings
        markers = np.asarray(markers, dtype=float)
        check_shape("markers", markers, (None, kin.n_markers, 3))
        n = len(markers)
        check_shape("heads", heads, (n, kin.nq))
        target, w = self._prepare(markers, None)
        known = np.all(np.isfinite(heads), axis=1)
        known[0] = True
        starts = np.flatnonzero(known)
        ends = np.append(starts[1:], n)
        cold = np.array(heads, dtype=float)
        # Frames the chains' kernel starts from ``cold``: heads without a pose, and frames
        # after an unsolved one (too few markers).
        npres = np.count_nonzero(w > 0, axis=1)
        few = npres < self._floor(w)
        needs = np.zeros(n, dtype=bool)
        needs[starts] = ~np.all(np.isfinite(cold[starts]), axis=1)
        needs[1:] |= few[:-1]
        if needs.any():
            cold[needs] = self.root_from_pelvis(markers[needs])
        q, rmse, iters, status = _tree_ik.solve_chains(
            kin.tree(),
            target,
            w,
            np.nan_to_num(cold),
            starts,
            ends,
            st.max_iterations,
            *self._kernel_settings(),
            self._floor(w),
        )
        result = IKResult(q, rmse, iters, status, npres)
        self._repair(markers, w, result)
        return result

    @single_blas_thread
    def repair(
        self,
        markers: np.ndarray,
        qpos: np.ndarray,
        weights: np.ndarray | None = None,
        *,
        factor: float = 3.0,
        margin: float = 1e-3,
    ) -> np.ndarray:
        """Re-solve, in place, frames of qpos (T, nq) that fit clearly worse than the trial.

        Returns the indices of the frames that changed (see :meth:`_repair`).
        """
        kin = self.kin
        markers = np.asarray(markers, dtype=float)
        target, w = self._prepare(markers, weights)
        n = len(markers)
        ok = np.all(np.isfinite(qpos), axis=1)
        rmse = np.full(n, np.nan)
        x = kin.marker_positions(np.where(ok[:, None], qpos, kin.model.qpos0))
        d2 = np.sum((target - x) ** 2, axis=2) * (w > 0)
        npres = np.count_nonzero(w > 0, axis=1)
        rmse[ok] = np.sqrt(d2[ok].sum(axis=1) / np.maximum(npres[ok], 1))
        status = np.where(ok, Status.CONVERGED, Status.TOO_FEW_MARKERS).astype(int)
        before = qpos.copy()
        fits = IKResult(qpos, rmse, np.zeros(n, dtype=int), status, npres)
        self._repair(markers, w, fits, factor, margin)
        changed = np.any(before != qpos, axis=1) & ok
        return np.flatnonzero(changed)

    def _walk_runs(
        self,
        markers: np.ndarray,
        w: np.ndarray,
        qpos: np.ndarray,
        rmse: np.ndarray,
        iters: np.ndarray,
        status: np.ndarray,
        solvable: np.ndarray,
        limit: float,
    ) -> None:
        """Compiled repair: every run of bad frames is walked from its good left neighbour
        (forwards), then what is still bad from its good right neighbour (backwards)."""
        target = np.where(np.isfinite(markers), markers, 0.0)
        n = len(markers)
        for forward in (True, False):
            bad = solvable & ~(rmse <= limit)
            first, last = _runs(bad)
            seed = first - 1 if forward else last + 1
            ok = (seed >= 0) & (seed < n)
            ok[ok] = solvable[seed[ok]] & ~bad[seed[ok]]
            if not np.any(ok):
                continue
            a, b = (first[ok], last[ok]) if forward else (last[ok], first[ok])
            self._walk(target, w, (qpos, rmse, iters, status), qpos[seed[ok]], a, b, False)

    def _walk(
        self,
        target: np.ndarray,
        w: np.ndarray,
        out: _tree_ik.Fits,
        seeds: np.ndarray,
        firsts: np.ndarray,
        lasts: np.ndarray,
        seams: bool,
    ) -> None:
        """:func:`mocap_mj.kernels._tree_ik.walk` with this solver's settings: frames firsts ->
        lasts re-solved from seeds (k, nq), into out = (qpos, rmse, iters, status)."""
        st = self.settings
        _tree_ik.walk(
            self.kin.tree(),
            target,
            w,
            out,
            seeds,
            firsts,
            lasts,
            seams,
            st.max_iterations,
            *self._kernel_settings(),
            self._floor(w),
        )

    def _seams(
        self,
        target: np.ndarray,
        w: np.ndarray,
        qpos: np.ndarray,
        rmse: np.ndarray,
        iters: np.ndarray,
        status: np.ndarray,
        starts: np.ndarray,
        ends: np.ndarray,
    ) -> None:
        """Carry every chain's solution across its seams: walk each chain's first frames from
        the previous chain's last pose, then each chain's last frames backwards from the next
        chain's first pose, keeping better fits and stopping where the basins agree.

        A chain whose cold start landed in a wrong local minimum (which can fit only slightly
        worse, below what :meth:`_repair` calls bad) is so re-solved from its neighbour; a
        good chain costs one warm-started frame per seam."""
        if starts.size < 2:
            return
        for forward in (True, False):
            if forward:
                seed_rows, firsts, lasts = ends[:-1] - 1, starts[1:], ends[1:] - 1
            else:
                seed_rows, firsts, lasts = starts[1:], ends[:-1] - 1, starts[:-1]
            ok = (status[seed_rows] != Status.TOO_FEW_MARKERS) & np.all(
                np.isfinite(qpos[seed_rows]), axis=1
            )
            if not np.any(ok):
                continue
            seeds = qpos[seed_rows[ok]].copy()  # snapshot: a walk may rewrite another's seed
            self._walk(target, w, (qpos, rmse, iters, status), seeds, firsts[ok], lasts[ok], True)

    def _repair(
        self,
        markers: np.ndarray,
        w: np.ndarray,
        fits: IKResult,
        factor: float = 3.0,
        margin: float = 1e-3,
    ) -> None:
        """Re-solve frames that fit clearly worse than the trial, from a good neighbour.

        markers (T, M, 3) [m] with weights w (T, M); ``fits``: every frame's fit so far
        (its qpos, marker_rmse, iterations and status updated in place; n_markers unused).
        A frame is bad when its RMSE exceeds ``factor * median + margin`` (default 3 and
        1 mm): a local minimum, typically a chain start that began far from its pose. Runs of
        bad frames are walked inwards from their good ends, one frame per round on every run
        at once; a re-solve is kept when it fits better.
        """
        solvable = fits.status != Status.TOO_FEW_MARKERS
        if not np.any(solvable):
            return
        ref = float(np.nanmedian(fits.marker_rmse[solvable]))
        limit = factor * ref + margin
        qpos, rmse, iters, status, _ = fits
        self._walk_runs(markers, w, qpos, rmse, iters, status, solvable, limit)


def pose_jumps(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """The largest rotation [rad] of any joint between consecutive poses of qpos (T, nq):
    (T - 1,), NaN where either pose is unsolved. A hinge's change of angle, a ball's or a
    free joint's rotation angle (a free joint's translation is not counted)."""
    q = np.asarray(qpos, dtype=float)
    out = np.zeros(max(len(q) - 1, 0))
    for j in range(model.njnt):
        adr, typ = int(model.jnt_qposadr[j]), int(model.jnt_type[j])
        if typ == mujoco.mjtJoint.mjJNT_HINGE:
            step = np.abs(np.diff(q[:, adr]))
        elif typ in (mujoco.mjtJoint.mjJNT_BALL, mujoco.mjtJoint.mjJNT_FREE):
            a = adr + (3 if typ == mujoco.mjtJoint.mjJNT_FREE else 0)
            quat = q[:, a : a + 4] / np.linalg.norm(q[:, a : a + 4], axis=1, keepdims=True)
            dot = np.abs(np.sum(quat[1:] * quat[:-1], axis=1))
            step = 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))
        else:
            continue
        out = np.fmax(out, step)
    out[~(np.all(np.isfinite(q[1:]), axis=1) & np.all(np.isfinite(q[:-1]), axis=1))] = np.nan
    return out


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last index of every run of consecutive True values in mask (T,)."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1


def weights_from_names(
    marker_names: tuple[str, ...], weights: dict[str, float], default: float = 1.0
) -> np.ndarray:
    """Per-marker weights (M,) from ``{name: weight}``; an unknown name lists the valid ones."""
    from mocap_mj.errors import UnknownNameError

    out = np.full(len(marker_names), float(default))
    for name, value in weights.items():
        if name not in marker_names:
            raise UnknownNameError("marker", name, marker_names)
        out[marker_names.index(name)] = float(value)
    return out
