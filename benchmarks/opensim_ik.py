"""OpenSim's InverseKinematicsTool against `mocap-mj ik`, on the same model and markers.

For each trial: the model is exported to .osim (`mocap_mj.export.osim`, Y up) and the markers
to TRC; OpenSim 4.6's InverseKinematicsTool (every marker weight 1, accuracy 1e-5 = OpenSim's
default unless --accuracy) and this project's IK (`IKSolver` with the settings of `mocap-mj ik`)
solve every frame. Printed per trial:

- marker RMSE [mm] of each solution, both evaluated with MuJoCo's forward kinematics of the
  same model over the present samples (3D distance, as everywhere in mocap-mj);
- joint-angle differences between the two solutions [deg]: per rotational degree of freedom
  (hinges, and the three components of each ball joint's relative rotation vector), the
  median, 95th percentile and maximum over frames and DOF, all DOF and the hips, knee
  flexion and ankles alone; the root position difference [mm];
- frames/s of each (wall time of the solve alone; OpenSim's includes its file reading).

Trials: a synthetic range-of-motion trial (`mocap_synth`, seed 0, 1 mm noise) with its true
model, and the real recordings in ../shared/data/real with the bundled nominal model, or with
the identified model of a result folder given by --model-from NAME=RESULT_DIR (e.g.
`--model-from Movement_trial=out/id`).

Needs the [opensim] extra. Run: python benchmarks/opensim_ik.py [--frames N] [--synthetic-only]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.export.opensim_ik import run_opensim_ik
from mocap_mj.export.read_result import load_result
from mocap_mj.io import load_markers
from mocap_mj.solve.ik import IKSettings, IKSolver
from mocap_synth import SynthConfig, synthesize

REAL = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "real"
REAL_TRIALS = (
    "Movement_trial.c3d",
    "Static_trial.c3d",
    "Test_func_rknee.c3d",
    "Test_func_rhip.c3d",
    "anatomical_posture.c3d",
)


def marker_rmse(kin: Kinematics, qpos: np.ndarray, markers: np.ndarray) -> float:
    """RMSE [m] of the 3D marker distance over present samples of solved frames."""
    ok = np.all(np.isfinite(qpos), axis=1)
    d = np.linalg.norm(kin.marker_positions(qpos[ok]) - markers[ok], axis=2)
    return float(np.sqrt(np.nanmean(d**2)))


def compare(
    name: str,
    pset: ParameterSet,
    times: np.ndarray,
    markers: np.ndarray,
    accuracy: float,
) -> dict[str, float]:
    kin = Kinematics(pset)
    solver = IKSolver(kin, IKSettings())
    solver.solve_trial(markers[:3])  # compile the kernels outside the timing
    t0 = time.perf_counter()
    ours = solver.solve_trial(markers).qpos
    t_ours = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as work:
        osim = run_opensim_ik(kin.model, pset.marker_names, times, markers, work, accuracy=accuracy)
    ok = np.all(np.isfinite(ours), axis=1) & np.all(np.isfinite(osim.qpos), axis=1)
    dv = kin.difference(ours[ok], osim.qpos[ok])
    rot = np.degrees(np.abs(dv[:, 3:]))
    row = {
        "frames": float(len(times)),
        "rmse_ours_mm": marker_rmse(kin, ours, markers) * 1e3,
        "rmse_opensim_mm": marker_rmse(kin, osim.qpos, markers) * 1e3,
        "angle_median_deg": float(np.median(rot)),
        "angle_p95_deg": float(np.percentile(rot, 95)),
        "angle_max_deg": float(np.max(rot)),
        "root_max_mm": float(np.max(np.abs(dv[:, :3])) * 1e3),
        "fps_ours": len(times) / t_ours,
        "fps_opensim": len(times) / osim.seconds,
    }
    legs = [
        d - 3
        for d in range(3, kin.model.nv)
        if kin.model.joint(int(kin.model.dof_jntid[d])).name.startswith(
            ("hip_", "knee_flex_", "ankle_")
        )
    ]
    row["legs_median_deg"] = float(np.median(rot[:, legs]))
    row["legs_p95_deg"] = float(np.percentile(rot[:, legs], 95))
    row["legs_max_deg"] = float(np.max(rot[:, legs]))
    row["legs_frames_over_2deg"] = float(np.mean(rot[:, legs].max(axis=1) > 2.0))
    worst = int(np.argmax(rot.max(axis=0))) + 3
    row["worst_dof"] = worst  # type: ignore[assignment]
    dof_joint = kin.model.joint(int(kin.model.dof_jntid[worst])).name
    print(
        f"{name:24s} {len(times):5d}  RMSE ours {row['rmse_ours_mm']:7.3f} mm  "
        f"OpenSim {row['rmse_opensim_mm']:7.3f} mm  |  angle diff median "
        f"{row['angle_median_deg']:.3f}  p95 {row['angle_p95_deg']:.3f}  max "
        f"{row['angle_max_deg']:.2f} deg ({dof_joint}); hips, knees, ankles median "
        f"{row['legs_median_deg']:.3f} p95 {row['legs_p95_deg']:.3f} max "
        f"{row['legs_max_deg']:.2f} deg, {row['legs_frames_over_2deg']:.0%} of frames > 2 deg"
        f"  root {row['root_max_mm']:.2f} mm  |  "
        f"frames/s ours {row['fps_ours']:,.0f}  OpenSim {row['fps_opensim']:,.1f}",
        flush=True,
    )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=500, help="synthetic frames (500)")
    parser.add_argument("--max-frames", type=int, help="cut every real trial to N frames")
    parser.add_argument("--accuracy", type=float, default=1e-5, help="OpenSim IK accuracy")
    parser.add_argument("--synthetic-only", action="store_true")
    parser.add_argument("--no-synthetic", action="store_true")
    parser.add_argument("--trials", nargs="*", help="real trials to run (file stems; all)")
    parser.add_argument(
        "--model-from",
        action="append",
        default=[],
        metavar="TRIAL=RESULT_DIR",
        help="use the model.xml of RESULT_DIR for the real trial TRIAL (file stem)",
    )
    args = parser.parse_args()
    models = dict(item.split("=", 1) for item in args.model_from)

    print(f"OpenSim IK accuracy {args.accuracy:g}; angle differences over rotational DOF")
    if not args.no_synthetic:
        exp = synthesize(SynthConfig(frames=args.frames, noise_mm=1.0, seed=0))
        with tempfile.TemporaryDirectory() as tmp:
            truth = Path(tmp) / "truth.xml"
            exp.pset.export_mjcf(truth, exp.theta_true)
            markers = exp.markers
            compare("synthetic rom (truth)", ParameterSet(truth), exp.times, markers, args.accuracy)
    if args.synthetic_only:
        return
    if not REAL.is_dir():
        print(f"{REAL}: not found, real trials skipped")
        return
    for trial in REAL_TRIALS:
        stem = Path(trial).stem
        if args.trials and stem not in args.trials:
            continue
        if stem in models:
            pset, label = ParameterSet(load_result(models[stem]).model_path), "identified"
        else:
            pset, label = ParameterSet(), "nominal"
        traj = load_markers(REAL / trial)
        markers = traj.select(pset.marker_names)[: args.max_frames]
        times = np.asarray(traj.times)[: args.max_frames]
        compare(f"{stem} ({label})", pset, times, markers, args.accuracy)


if __name__ == "__main__":
    main()
