"""Benchmark: an hour-long recording, identified on a subset, refined on every frame, IK.

    python benchmarks/long.py                       # 360,000 frames (1 h at 100 Hz)
    python benchmarks/long.py --frames 60000 --count 500 --even

The recording is synthetic: a ROM trial (first half) then a walk (second half) of the same
subject (one seed: one truth model), 1 mm noise. It is synthesized once into ``--cache`` (in a
child process, so that its memory is not counted) as ``.npy`` files that the timed run reads
as memory maps. The timed part is :func:`mocap_mj.long.long.identify_long`: selection,
identification on the selection, the refinement (Gauss-Newton steps on a 20,000-frame
sample, then one step on every frame: IK of every frame and its reduced gradient, in
chunks), the IK of every frame with the refined model into a memory-mapped ``.npy``.

Then, untimed, the accuracy: the parameter error against the truth (aligned along the
directions the data cannot determine, as ``mocap-mj score`` does, but with the wrist's
hinges widened: :func:`mocap_mj.outputs.score.align_gauge_free`; also printed aligned within the
limits),
in the observable directions, of the subset's estimate and of the refined one, against the
Cramer-Rao bound of the selected frames and of all frames. The all-frames information is
summed over every ``--info-stride``-th frame and scaled by the stride (frames of an hour
repeat their poses, so the sample's mean information is the recording's). With ``--even``
the same number of evenly spaced frames is identified too, for comparison. Prints the
figures and a JSON line.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from numpy.lib.format import open_memmap

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.long.long import identify_long
from mocap_mj.outputs.score import align_gauge_free, align_truth
from mocap_mj.skeleton.mjcf import model_path
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMResult, LMSettings, TrialData, identify_lm
from mocap_mj.solve.problem import IdentificationProblem, ProblemOptions


def model_digest() -> str:
    """A fingerprint of the bundled model the cache's truth was synthesized with."""
    return hashlib.sha256(model_path().read_bytes()).hexdigest()[:16]


def cache_is_current(cache: Path) -> bool:
    """The cache is complete and made with today's bundled model (a truth from another model,
    e.g. before the knee's rolling, would score the estimator against a different skeleton)."""
    done = cache / "done"
    return done.exists() and json.loads(done.read_text()).get("model") == model_digest()


def synthesize_cache(cache: Path, frames: int, seed: int) -> None:
    from mocap_synth import SynthConfig, synthesize

    half = frames // 2
    parts = [
        synthesize(SynthConfig(frames=half, motion="rom", seed=seed)),
        synthesize(SynthConfig(frames=frames - half, motion="walk", seed=seed)),
    ]
    cache.mkdir(parents=True, exist_ok=True)
    rate = parts[0].config.rate
    np.save(cache / "markers.npy", np.concatenate([p.markers for p in parts]))
    np.save(cache / "clean.npy", np.concatenate([p.markers_clean for p in parts]))
    np.save(cache / "times.npy", np.arange(frames) / rate)
    np.save(cache / "theta_true.npy", parts[0].theta_true)
    done = {"frames": frames, "seed": seed, "sigma": 1e-3, "model": model_digest()}
    (cache / "done").write_text(json.dumps(done))


def observable_error(
    pset: ParameterSet,
    theta: np.ndarray,
    idf: Identifiability,
    frames: np.ndarray,
    clean: np.ndarray,
    times: np.ndarray,
    hand_zero_free: bool = True,
) -> np.ndarray:
    """The error (P,) [m] of theta against the truth aligned on the clean markers of
    ``frames``, in idf's observable directions: the hand's zero free
    (:func:`mocap_mj.outputs.score.align_gauge_free`) or, without ``hand_zero_free``, within pset's
    limits."""
    align = align_gauge_free if hand_zero_free else align_truth
    aligned = align(pset, theta, np.asarray(clean[frames]), times[frames])
    return idf.project(theta - aligned)[0]


def rms(pset: ParameterSet, e_obs: np.ndarray) -> tuple[float, float]:
    """RMS [m] of an error (P,) [m] over the kinematic parameters and over the offsets."""
    k = pset.n_kappa
    return float(np.sqrt(np.mean(e_obs[:k] ** 2))), float(np.sqrt(np.mean(e_obs[k:] ** 2)))


def worst_markers(
    pset: ParameterSet, idf: Identifiability, e_obs: np.ndarray, count: int = 6
) -> dict[str, list[float]]:
    """The ``count`` markers whose offset error e_obs (P,) [m] is largest: per marker its
    largest component in standard deviations of idf's bound and its error [mm]."""
    k = pset.n_kappa
    e = e_obs[k:].reshape(-1, 3)
    sd = np.abs(e) / np.maximum(idf.param_std[k:].reshape(-1, 3), 1e-300)
    order = np.argsort(-sd.max(axis=1))[:count]
    return {
        pset.marker_names[i]: [float(sd[i].max()), float(np.linalg.norm(e[i]) * 1e3)] for i in order
    }


def subset_errors(
    pset: ParameterSet, lm: LMResult, frames: np.ndarray, clean: np.ndarray, times: np.ndarray
) -> tuple[Identifiability, float, float]:
    """Identifiability of a subset's result and its observable kappa/offset RMS error [m]."""
    idf = Identifiability(
        pset, lm.reduced_information, lm.sigma, observable_std=0.005, theta=lm.theta
    )
    return idf, *rms(pset, observable_error(pset, lm.theta, idf, frames, clean, times))


def all_frames_bound(
    pset: ParameterSet, lm: LMResult, markers: np.ndarray, qpos: np.ndarray, stride: int
) -> Identifiability:
    """Identifiability of all frames, from every ``stride``-th frame's information x stride."""
    kin = Kinematics(pset)
    kin.set_theta(lm.theta)
    rows = np.arange(0, len(markers), stride)
    rows = rows[np.all(np.isfinite(qpos[rows]), axis=1)]
    m = np.asarray(markers[rows])
    options = ProblemOptions(theta0=lm.theta)
    prob = IdentificationProblem(
        kin, m, np.array(qpos[rows]), np.flatnonzero(lm.free), options=options
    )
    info = prob.information(prob.present.astype(float)) * stride
    return Identifiability(pset, info, lm.sigma, observable_std=0.005, theta=lm.theta)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=360_000)
    ap.add_argument("--count", type=int, default=1000, help="frames identified on")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default="/tmp/mocap-mj-long")
    ap.add_argument("--info-stride", type=int, default=10)
    ap.add_argument("--even", action="store_true", help="also identify on evenly spaced frames")
    ap.add_argument("--synth-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    cache = Path(args.cache) / f"{args.frames}-{args.seed}"
    if args.synth_only:
        synthesize_cache(cache, args.frames, args.seed)
        return
    if not cache_is_current(cache):
        t = time.perf_counter()
        cmd = [sys.executable, __file__, "--synth-only", "--frames", str(args.frames)]
        subprocess.run([*cmd, "--seed", str(args.seed), "--cache", args.cache], check=True)
        print(f"synthesized {args.frames} frames in {time.perf_counter() - t:.0f} s -> {cache}")

    pset = ParameterSet()
    kin = Kinematics(pset)
    markers = np.load(cache / "markers.npy", mmap_mode="r")
    times = np.load(cache / "times.npy")
    clean = np.load(cache / "clean.npy", mmap_mode="r")
    theta_true = np.load(cache / "theta_true.npy")
    qpos = open_memmap(cache / "qpos.npy", mode="w+", dtype=float, shape=(len(markers), kin.nq))
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    t0 = time.perf_counter()
    res = identify_long(markers, times, pset, qpos, count=args.count)
    qpos.flush()
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # GiB (Linux: KiB)

    lm = res.lm
    idf_sub, ek, eo = subset_errors(pset, lm, res.selection.frames, clean, times)
    t = time.perf_counter()
    idf_all = all_frames_bound(pset, lm, markers, qpos, args.info_stride)
    info_seconds = time.perf_counter() - t
    e1 = observable_error(pset, res.theta, idf_all, res.selection.frames, clean, times)
    ek1, eo1 = rms(pset, e1)
    worst = worst_markers(pset, idf_all, e1)
    # The same aligned within the model's own ranges (why not: gauge_free).
    e1_h = observable_error(pset, res.theta, idf_all, res.selection.frames, clean, times, False)
    ek1_h, eo1_h = rms(pset, e1_h)
    np.save(cache / "theta_refined.npy", res.theta)
    bk_s, bo_s = idf_sub.bound_rms()
    bk_a, bo_a = idf_all.bound_rms()
    n = len(markers)
    out = {
        "frames": n,
        "count": args.count,
        "pool": res.selection.pool,
        "cover_max_mm": res.selection.cover_max * 1e3,
        "cover_median_mm": res.selection.cover_median * 1e3,
        "selected_in_rom_half": int(np.sum(res.selection.frames < n // 2)),
        "seconds_total": wall,
        "seconds": res.seconds,
        "ik_frames_per_second": n / res.seconds["ik"],
        "identify_iterations": lm.iterations,
        "peak_rss_gib": peak,
        "rss_before_gib": rss0,
        "marker_rmse_mm": res.marker_rmse * 1e3,
        "frames_solved": res.frames_solved,
        "kappa_error_mm": ek * 1e3,
        "offset_error_mm": eo * 1e3,
        "kappa_crlb_subset_mm": bk_s * 1e3,
        "offset_crlb_subset_mm": bo_s * 1e3,
        "kappa_crlb_all_mm": bk_a * 1e3,
        "offset_crlb_all_mm": bo_a * 1e3,
        "kappa_error_over_all_bound": ek / bk_a,
        "refine_steps_std": res.steps,
        "refined_kappa_error_mm": ek1 * 1e3,
        "refined_offset_error_mm": eo1 * 1e3,
        "refined_kappa_error_over_all_bound": ek1 / bk_a,
        "refined_offset_error_over_all_bound": eo1 / bo_a,
        "kappa_error_over_subset_bound": ek / bk_s,
        "refined_worst_offsets_std_mm": worst,
        "refined_over_all_bound_aligned_within_limits": [ek1_h / bk_a, eo1_h / bo_a],
        "all_frames_information_seconds": info_seconds,
        "kappa_error_before_mm": float(
            np.sqrt(np.mean((pset.nominal - theta_true)[: pset.n_kappa] ** 2))
        )
        * 1e3,
    }
    if args.even:
        frames = np.linspace(0, n - 1, args.count).round().astype(int)
        sub = np.asarray(markers[frames])
        t = time.perf_counter()
        from mocap_mj.anatomy.initial import place_markers, scaled_theta, segment_scales

        th0 = place_markers(pset, scaled_theta(pset, [sub], scales=segment_scales(pset, [sub])),
                            [sub])  # fmt: skip
        lm_e = identify_lm([TrialData("even", sub, times[frames])], pset=pset, theta0=th0,
                           settings=LMSettings())  # fmt: skip
        idf_e, ek_e, eo_e = subset_errors(pset, lm_e, frames, clean, times)
        out.update(
            even_seconds=time.perf_counter() - t,
            even_kappa_error_mm=ek_e * 1e3,
            even_offset_error_mm=eo_e * 1e3,
            even_kappa_crlb_mm=idf_e.bound_rms()[0] * 1e3,
            even_offset_crlb_mm=idf_e.bound_rms()[1] * 1e3,
        )
    s = res.seconds
    print(
        f"{n} frames: {wall:.1f} s end to end (select {s['select']:.1f} s, identify on "
        f"{args.count} frames {s['identify']:.1f} s / {lm.iterations} iterations, refinement "
        f"{s['refine']:.1f} s (sample steps {s.get('refine_sample', 0.0):.1f} s, IK + reduced "
        f"gradient of every frame {s.get('refine_pass', 0.0):.1f} s), last IK "
        f"{s['ik']:.1f} s = {out['ik_frames_per_second']:,.0f} frames/s); peak RSS "
        f"{peak:.2f} GiB; IK marker RMSE {out['marker_rmse_mm']:.3f} mm\n"
        f"selection: {args.count} of a {res.selection.pool}-frame pool, "
        f"{out['selected_in_rom_half']} in the ROM half; cover max "
        f"{out['cover_max_mm']:.0f} mm, median {out['cover_median_mm']:.0f} mm\n"
        f"kinematic error {ek * 1e3:.3f} mm: {ek / bk_s:.2f}x the subset's bound "
        f"({bk_s * 1e3:.3f} mm), {ek / bk_a:.2f}x all frames' ({bk_a * 1e3:.3f} mm)\n"
        f"offset error {eo * 1e3:.3f} mm: {eo / bo_s:.2f}x the subset's bound "
        f"({bo_s * 1e3:.3f} mm), {eo / bo_a:.2f}x all frames' ({bo_a * 1e3:.3f} mm)\n"
        f"after the refinement on every frame: kinematic error {ek1 * 1e3:.3f} mm = "
        f"{ek1 / bk_a:.2f}x all frames' bound, offsets {eo1 * 1e3:.3f} mm = {eo1 / bo_a:.2f}x"
        f" (aligned within the model's own ranges: {ek1_h / bk_a:.2f}x, {eo1_h / bo_a:.2f}x)"
        "\nworst offsets (standard deviations, mm): "
        + ", ".join(f"{k} {v[0]:.1f} sd {v[1]:.3f}" for k, v in worst.items())
    )
    if args.even:
        print(
            f"evenly spaced {args.count} frames: kinematic error {out['even_kappa_error_mm']:.3f}"
            f" mm (bound {out['even_kappa_crlb_mm']:.3f}), offsets "
            f"{out['even_offset_error_mm']:.3f} mm (bound {out['even_offset_crlb_mm']:.3f})"
        )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
