"""Hip centres against their regression: synthetic trials with a known truth and the shared
real trials (docs/model.md#hip-centres-regression-and-data).

    python benchmarks/hip_centres.py [--shared ../shared/data] [--seeds 0 1]

Synthetic: walks with 10 and 30 mm/rad of soft-tissue artefact whose truth hips sit at
their Harrington regression, and a white-noise range-of-motion trial whose truth sits 15 mm
lateral of it (:func:`mocap_synth.centres.at_regression`), each identified three ways: by
the data alone (``data only``: the regression rows 1 m wide), without the soft-tissue floor
(``before``: the centre rows' width factors held at 1) and with it (``after``). The data
alone miss the lateral centre by several of their own standard deviations (as the solve
counts the data), by about the floor: that is why a walk moved the hips. Per trial: the
inter-hip distance and its error against the truth [mm], each hip's distance from the
regression with its reported standard deviation, and the error of the centre relative to
its pelvis markers against the truth's [mm]. Real: Movement_trial, Static_trial and the
three biobuddy trials (their Plug-in Gait markers), each identified alone, before and after:
inter-hip distance and each hip's distance from the regression. The shared files are only
read.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

import mocap_mj
from mocap_mj.anatomy import anatomy, ball_centres
from mocap_mj.capture.subject import from_c3d
from mocap_mj.io import load_markers
from mocap_synth import SynthConfig, synthesize
from mocap_synth.centres import at_regression

REAL = ["Movement_trial", "Static_trial", "Test_func_rhip", "Test_func_rknee",
        "anatomical_posture"]  # fmt: skip


@contextlib.contextmanager
def floor_off(off: bool, data_only: bool = False) -> Iterator[None]:
    """The identification without the soft-tissue floor (every width factor 1) when ``off``;
    with ``data_only`` also the hip regressions' rows 1 m wide (the data alone place them)."""
    saved, sigma = ball_centres.RowSpread.factor, anatomy.SIGMA_HJC
    if off:
        ball_centres.RowSpread.factor = property(lambda self: 1.0)  # type: ignore[assignment]
    if data_only:
        anatomy.SIGMA_HJC = 1.0
    try:
        yield
    finally:
        ball_centres.RowSpread.factor = saved  # type: ignore[method-assign]
        anatomy.SIGMA_HJC = sigma


def _at_100_hz(trial: mocap_mj.TrialData) -> mocap_mj.Recording:
    """``trial`` as a recording at 100 Hz (the synthetic trials' rate)."""
    return mocap_mj.Recording(trial.name, trial.markers, trial.times, 100.0)


def _data_line(tag: str, fit: mocap_mj.Fit, offsets: dict[str, float]) -> str:
    """The data alone: each hip's error against the truth (relative to its pelvis markers)
    beside the standard deviation of its lateral row as the solve counts the data and the
    soft-tissue floor of that row [mm]."""
    rep = fit.report.centres_vs_regression
    parts = [f"{tag:34s}"]
    for hip in ("hip_l", "hip_r"):
        rows = list(rep[hip].rows.values())
        d = np.array([r.distance * 1e3 for r in rows])
        err = np.linalg.norm(d - np.array([0.0, offsets.get(hip, 0.0), 0.0]))
        spread = rows[1].spread  # depth, width, height
        lateral = d[1] - offsets.get(hip, 0.0)
        sd = float("nan") if spread is None else spread.data_m * 1e3
        floor = float("nan") if spread is None else spread.floor_m * 1e3
        parts.append(f"{hip} error {err:5.1f} (lateral: error {lateral:+6.1f}, data sd "
                     f"{sd:4.1f}, floor {floor:5.1f})")  # fmt: skip
    return "  ".join(parts)


def _interhip(pset: mocap_mj.ParameterSet, theta: np.ndarray) -> float:
    pos = pset.body_pos(theta)
    return float(
        np.linalg.norm(pos[pset.model.body("thigh_l").id] - pos[pset.model.body("thigh_r").id])
    )


def _line(tag: str, fit: mocap_mj.Fit, truth_interhip: float | None = None,
          offsets: dict[str, float] | None = None) -> str:  # fmt: skip
    rep = fit.report.centres_vs_regression
    ih = _interhip(fit.pset, fit.theta) * 1e3
    parts = [f"{tag:34s} inter-hip {ih:6.1f} mm"]
    if truth_interhip is not None:
        parts.append(f"(error {ih - truth_interhip * 1e3:+5.1f})")
    for hip in ("hip_l", "hip_r"):
        e = rep[hip]
        s = f"{hip} {e.distance * 1e3:5.1f} +- {e.distance_sd * 1e3:4.1f} from regression"
        if offsets is not None:
            d = np.array([r.distance * 1e3 for r in e.rows.values()])
            want = np.array([0.0, offsets.get(hip, 0.0), 0.0])
            s += f" (error {np.linalg.norm(d - want):4.1f})"
        parts.append(s)
    return "  ".join(parts)


def synthetic(seeds: list[int]) -> None:
    cases = [("walk", 10.0, 0.0), ("walk", 30.0, 0.0), ("rom", 0.0, 15.0)]
    for motion, sta, shift in cases:
        for seed in seeds:
            exp = synthesize(SynthConfig(frames=500, motion=motion, noise_mm=1.0, sta_mm=sta,
                                         seed=seed))  # fmt: skip
            exp = at_regression(exp, {"hip_width_l": shift * 1e-3, "hip_width_r": shift * 1e-3})
            trial = mocap_mj.TrialData("synth", np.array(exp.markers), np.array(exp.times))
            truth = _interhip(exp.pset, np.asarray(exp.theta_true))
            offsets = {"hip_l": shift, "hip_r": shift}  # the width rows count outward
            for label, off in (("data only", True), ("before", True), ("after", False)):
                with floor_off(off, data_only=label == "data only"):
                    fit = mocap_mj.identify([_at_100_hz(trial)], mocap_mj.Recipe(), None)
                tag = f"{motion} sta {sta:.0f} shift {shift:.0f} seed {seed} {label}"
                if label == "data only":
                    print(_data_line(tag, fit, offsets), flush=True)
                else:
                    print(_line(tag, fit, truth, offsets), flush=True)


def real(shared: Path) -> None:
    folder = shared / "real"
    if not folder.is_dir():
        print(f"{folder} not present: real trials skipped")
        return
    for name in REAL:
        path = folder / f"{name}.c3d"
        if not path.exists():
            continue
        for label, off in (("before", True), ("after", False)):
            pset = mocap_mj.ParameterSet()
            traj = load_markers(path, model_names=pset.marker_names)
            rec = mocap_mj.Recording(str(path), traj.select(pset.marker_names), traj.times,
                                     traj.rate)  # fmt: skip
            with floor_off(off):
                fit = mocap_mj.identify([rec], mocap_mj.Recipe(), from_c3d(path))
            print(_line(f"{name} {label}", fit), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parents[1]
    parser.add_argument("--shared", type=Path, default=here.parent / "shared" / "data")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = parser.parse_args()
    synthetic(args.seeds)
    real(args.shared)


if __name__ == "__main__":
    main()
