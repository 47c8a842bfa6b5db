"""Forward kinematics and Jacobian throughput of the bundled humanoid (frames per second).

Compares, in one process on the same random poses: a plain ``mj_kinematics`` loop (what
``Kinematics.marker_positions`` does), ``mujoco.batch.Batch`` (1 and 2 threads), and the
vectorised analytic Jacobians (joints: (T, 39, 3, 48); kappa: (T, 39, 3, 30)).
Also times a large NumPy matmul before and after the Batch runs, because a thread pool that
spins can starve OpenBLAS in the same process.

Run: python benchmarks/kinematics.py [--frames 500 50000]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import mujoco.batch
import numpy as np

from mocap_mj import Kinematics


def best_of(fn, repeat: int = 3) -> float:  # type: ignore[no-untyped-def]
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def random_poses(kin: Kinematics, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return kin.integrate(np.tile(kin.model.qpos0, (n, 1)), rng.normal(0, 0.4, (n, kin.nv)))


def matmul_ms() -> float:
    a = np.random.default_rng(0).normal(size=(600, 600))
    return 1e3 * best_of(lambda: a @ a, repeat=5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, nargs="+", default=[500, 50_000])
    parser.add_argument("--chunk", type=int, default=2000, help="frames per Jacobian chunk")
    args = parser.parse_args()

    kin = Kinematics()
    print(f"matmul 600x600 before Batch: {matmul_ms():.2f} ms")
    print(f"{'T':>7} {'method':<34} {'frames/s':>12} {'ratio':>7}")
    for n in args.frames:
        qpos = random_poses(kin, n)
        loop = best_of(lambda q=qpos: kin.marker_positions(q))
        rows = [("FK: mj_kinematics loop", loop)]
        for threads in (1, 2):
            batch = mujoco.batch.Batch(kin.model, nsim=n, nthread=threads)
            batch.bind("qpos")[:] = qpos
            site = batch.bind("site_xpos")

            def run(b=batch) -> None:  # type: ignore[no-untyped-def]
                b.forward(stage=int(mujoco.mjtStage.mjSTAGE_POS))

            run()
            assert np.array_equal(np.asarray(site), kin.marker_positions(qpos))
            rows.append((f"FK: mujoco.batch.Batch, {threads} thr", best_of(run)))
            del batch

        def jac(q=qpos) -> None:  # type: ignore[no-untyped-def]
            for s in range(0, len(q), args.chunk):
                frames = kin.forward(q[s : s + args.chunk])
                kin.jac_q(frames)
                kin.jac_kappa(frames)

        sub = qpos[: min(n, 2000)]

        def jac_site(q=sub) -> None:  # type: ignore[no-untyped-def]
            data, jacp = mujoco.MjData(kin.model), np.zeros((3, kin.nv))
            for qq in q:
                data.qpos[:] = qq
                mujoco.mj_kinematics(kin.model, data)
                mujoco.mj_comPos(kin.model, data)
                for s in range(kin.n_markers):
                    mujoco.mj_jacSite(kin.model, data, jacp, None, s)

        rows.append(("FK + Jacobians (q, kappa), NumPy", best_of(jac, repeat=2)))
        t_site = best_of(jac_site, repeat=2) * n / min(n, 2000)
        rows.append(("FK + mj_jacSite loop (q only)", t_site))
        for label, seconds in rows:
            print(f"{n:>7} {label:<34} {n / seconds:>12,.0f} {loop / seconds:>7.2f}")
    print(f"matmul 600x600 after Batch:  {matmul_ms():.2f} ms")


if __name__ == "__main__":
    main()
