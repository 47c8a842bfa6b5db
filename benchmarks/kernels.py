"""The compiled kernels of a 500-frame identification, each timed alone (us per frame).

Fixed inputs, made once: the synthetic ROM trial of seed 0 (500 frames, `mocap_synth`) at
its start (the nominal model, poses of a cold IK) and at its solution (`identify_lm`'s theta
and poses), with the joint LM's joint range. Each kernel is called --repeats times on the
same inputs and the minimum and median wall time are printed per frame, on one thread and
on numba's thread count (one BLAS thread throughout, as the solvers run). A kernel alone is
far less noisy than whole runs on a shared machine: this is how a change to a kernel is
judged (docs/validation.md#speed).

Timed: the Schur pass (`_schur._schur_range` alone, and `frame_blocks`: the kernel with its
Gram products), the pose finish (one and two IK iterations from the poses), the cold IK of
the coarse phase's 100-frame subset (`IKSolver.solve_trial`), `fk` (`_tree.forward`),
fk plus `normal_equations` (the IK's and the Schur pass's per-frame start, in a kernel of
this script's own), the Gram products of the packed Y (`PackedY.gram`), the reduced gradient
(`_schur.reduced_gradient`) and the IK of every frame (`IKSolver.solve_trial`: chains from
cold starts, as `mocap-mj ik` runs).

Run: python benchmarks/kernels.py [--repeats 40] [--only schur]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.kernels import _schur, _tree
from mocap_mj.kernels._threads import one_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.coarse import coarse_rows
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, identify_lm, solver_joint_range
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

FRAMES = 500


class State:
    """One fixed input: the kinematics at a theta and the poses (n, nq) of every frame."""

    def __init__(self, name: str, kin: Kinematics, qpos: np.ndarray) -> None:
        self.name, self.kin = name, kin
        self.qpos = np.ascontiguousarray(qpos, dtype=float)
        self.tree, self.kt = kin.tree(), kin.kappa_tables()


def inputs() -> tuple[np.ndarray, np.ndarray, list[State], np.ndarray]:
    """(target (n, M, 3) [m], weights (n, M), [start, solution], free (Pf,) int)."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=FRAMES, seed=0), pset)
    markers = np.asarray(exp.markers)
    data = TrialData("rom", markers, np.asarray(exp.times))
    lm = identify_lm([data], pset=pset)
    states = []
    for name, theta, qpos in (("start", pset.nominal, None), ("solution", lm.theta, lm.qpos[0])):
        kin = Kinematics(pset)
        kin.model.jnt_range[:] = solver_joint_range(kin.model, LMSettings())
        kin.set_theta(theta)
        if qpos is None:
            qpos = IKSolver(kin).solve_trial(markers).qpos
        states.append(State(name, kin, qpos))
    present = np.all(np.isfinite(markers), axis=2)
    target, w = _tree._floats(np.nan_to_num(markers), present.astype(float))
    return target, w, states, np.flatnonzero(~pset.frozen)


@numba.njit(nogil=True, cache=False)
def _fk_normal(tr, target, wts, qpos):  # type: ignore[no-untyped-def]
    """fk and the normal equations of every frame, nothing else (the result discarded)."""
    w = _tree.work_arrays(
        tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size, qpos.shape[1]
    )
    for t in range(qpos.shape[0]):
        _tree.fk(tr, qpos[t], w)
        _tree.normal_equations(tr, target[t], wts[t], w)


def timed(fn: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Minimum and median wall time [s] of ``repeats`` calls of fn() (after one untimed)."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), statistics.median(times)


Case = tuple[str, Callable[[], Any], int, bool]


def cases(
    st: State, target: np.ndarray, w: np.ndarray, free: np.ndarray, sub: np.ndarray
) -> list[Case]:
    """(label, call, frames, parallel) of every kernel timed at one state (inputs as
    :func:`inputs`; sub: the coarse phase's subset rows)."""
    n = len(target)
    tr, kt, qpos = st.tree, st.kt, st.qpos
    nv = tr.dof_jnt.size
    solver = IKSolver(st.kin)
    n_par = kt.n_kappa + 3 * tr.site_body.size
    blocks = _schur.frame_blocks(tr, kt, target, w, qpos, free, 1e-6)
    y = blocks.y
    kernel_outs = (
        *y.kernel_args(),
        np.empty((n, nv)),
        np.empty((n, _schur.factor_size(tr))),
        np.empty((n, nv)),
        np.empty((n, nv)),
    )
    c_acc, gt_acc = np.zeros((n_par, n_par)), np.zeros(n_par)

    def schur_kernel() -> None:
        _schur._schur_range(
            tr, kt, target, w, qpos, free, 0, n, True, 1e-6, *kernel_outs, c_acc, gt_acc
        )

    return [
        ("Schur kernel alone (_schur_range)", schur_kernel, n, False),
        (
            "Schur pass (frame_blocks: kernel + Gram)",
            lambda: _schur.frame_blocks(tr, kt, target, w, qpos, free, 1e-6),
            n,
            True,
        ),
        (
            "information pass (frame_blocks, mu 0, no limits)",
            lambda: _schur.frame_blocks(tr, kt, target, w, qpos, free, 0.0, limits=False),
            n,
            True,
        ),
        ("Gram products of the packed Y", lambda: y.gram(0, n), n, False),
        (
            "reduced gradient",
            lambda: _schur.reduced_gradient(tr, kt, target, w, qpos),
            n,
            True,
        ),
        ("fk (_tree.forward)", lambda: _tree.forward(tr, qpos), n, True),
        ("fk + normal_equations", lambda: _fk_normal(tr, target, w, qpos), n, False),
        (
            "pose finish, 1 IK iteration",
            lambda: solver.solve_frames(target, qpos, w, max_iterations=1, prepared=(target, w)),
            n,
            True,
        ),
        (
            "pose finish, 2 IK iterations",
            lambda: solver.solve_frames(target, qpos, w, max_iterations=2, prepared=(target, w)),
            n,
            True,
        ),
        ("IK of every frame (solve_trial)", lambda: solver.solve_trial(target), n, True),
        (
            "cold IK of the 100-frame subset",
            lambda: solver.solve_trial(target[sub]),
            sub.size,
            True,
        ),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=40, help="timed calls per kernel")
    parser.add_argument("--only", help="only the kernels whose label contains this text")
    parser.add_argument("--threads", type=int, nargs="*", help="thread counts (default 1 and all)")
    args = parser.parse_args()
    target, w, states, free = inputs()
    n = len(target)
    threads = args.threads or sorted({1, numba.get_num_threads()})
    nv = states[0].tree.dof_jnt.size
    print(
        f"seed 0, {n} frames, nv {nv}, {w.shape[1]} markers, {free.size} free parameters; "
        f"minimum / median of {args.repeats} calls, us per frame (one BLAS thread)"
    )
    rows = coarse_rows([TrialData("rom", target, np.arange(n) / 100.0)], ParameterSet(), 100)
    assert rows is not None
    sub = rows[0]
    for st in states:
        print(f"\n{st.name}:")
        for label, fn, frames, parallel in cases(st, target, w, free, sub):
            if args.only and args.only not in label:
                continue
            for k in threads if parallel else [1]:
                numba.set_num_threads(k)
                with one_blas_thread():
                    lo, med = timed(fn, args.repeats)
                print(
                    f"  {label:48s} {k} thread{'s' if k > 1 else ' '}  "
                    f"{lo / frames * 1e6:7.2f} / {med / frames * 1e6:7.2f} us/frame  "
                    f"({lo * 1e3:.2f} ms)"
                )
        numba.set_num_threads(max(threads))


if __name__ == "__main__":
    main()
