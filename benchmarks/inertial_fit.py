"""The segments' masses fitted to the measured loads (mocap_mj/pipeline/inertial_fit.py): on a
synthetic truth and on a real trial.

    python benchmarks/inertial_fit.py [--result DIR] [--trial PATH] [--identified [DIR]]

Synthetic: the bundled humanoid with de Leva's parameters for 75 kg as the regression, a truth
whose 16 segment masses are scaled by 0.8-1.25 (seed 0), a smooth 3 s motion of every joint
(tests/_motion.py), the truth's needed root wrench put on the right foot with a 1 % body-weight
noise on its force; prints per body the truth's scale, the fit's, its sd and whether the data
determine it, and the root residual before and after. Real (``--result``: an ``ik`` or
``identify`` result of a trial with plates, default ``ik`` run on Movement_trial.c3d into a
temporary folder): the fit over the stance frames (a foot on a counted plate, and no foot still
off them), the residual force RMS before and after in N, % body weight and % of the peak
ground reaction. Identified (``--identified``): ``mocap-mj identify --markers TRIAL STATIC
--recipe R`` with ``inertia: fit`` in R (STATIC: the Static_trial.c3d beside the trial), into
DIR or a temporary folder, and summary.json's ``inertia``: per segment the regression's and
the fitted mass, its sd, determined or not, the singular values, and the root residual over
the stance frames before and after (% body weight, % of the peak ground reaction, moment).
"""

from __future__ import annotations

import argparse
import copy
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.inertia import inertial_model, segment_inertia
from mocap_mj.capture.contacts import STILL_SPEED, pivot_speeds
from mocap_mj.export.grf import read_grf_csv
from mocap_mj.io.load import load_markers
from mocap_mj.outputs.kinetics_out import FOOT_BODIES
from mocap_mj.pipeline import dynamics as dy
from mocap_mj.pipeline.inertial_fit import MassFit, Trial, fit_masses
from mocap_mj.pipeline.motion import ResultDir, load_motion
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.mjcf import load_model

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared"
sys.path.insert(0, str(HERE.parent / "tests"))
from _motion import smooth_motion  # noqa: E402


def fitted_bodies(model_path: Path, mass: float) -> list[str]:
    """The segment bodies (carriers left out: they hold no segment of their own)."""
    inertia = segment_inertia(load_model(model_path), mass)
    return [b for b, length in zip(inertia.bodies, inertia.length, strict=True) if length > 0]


def show(fit: MassFit, truth: dict[str, float] | None = None) -> None:
    for k, b in enumerate(fit.bodies):
        ref = f"truth {truth[b]:.3f} " if truth else ""
        err = f" error {100 * (fit.scale[k] / truth[b] - 1):+5.1f} %" if truth else ""
        print(f"  {b:12s} {ref}fit {fit.scale[k]:.3f} sd {fit.sd[k]:.3f} "
              f"{'determined' if fit.determined[k] else 'undetermined'}"
              f"{' (at the bound)' if fit.at_bound[k] else ''}{err}")  # fmt: skip
    print("  singular values:", np.round(fit.singular_values, 1))


def synthetic(work: Path) -> None:
    mass, frames = 75.0, 300
    pset = ParameterSet()
    path = work / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    reg = inertial_model(path, mass)
    bodies = fitted_bodies(path, mass)
    rng = np.random.default_rng(0)
    truth_scale = dict(zip(bodies, rng.uniform(0.8, 1.25, len(bodies)), strict=True))
    truth = copy.deepcopy(reg)
    for b, s in truth_scale.items():
        truth.body_mass[truth.body(b).id] *= s
        truth.body_inertia[truth.body(b).id] *= s
    qpos = exported.Layout.of(pset.model).written(smooth_motion(Kinematics(pset), frames, seed=4))
    times = np.arange(frames) / 100.0
    need = dy.inverse_dynamics(truth, qpos, times, cutoff_hz=None)
    data, root = mujoco.MjData(truth), int(truth.jnt_bodyid[0])
    point = np.zeros((frames, 3))
    for t in range(frames):
        data.qpos[:] = need.qpos[t]
        mujoco.mj_kinematics(truth, data)
        point[t] = data.xpos[root]
    noise = rng.normal(0.0, 0.01 * mass * 9.80665, (frames, 3))
    load = dy.BodyLoad("foot_r", need.root_force + noise, point, need.root_moment)
    fit = fit_masses(reg, [Trial(qpos, times, [load], np.ones(frames, bool))], bodies,
                     cutoff_hz=None)  # fmt: skip
    print(f"synthetic, 75 kg, {frames} frames: residual force RMS {fit.residual_before[0]:.1f} N"
          f" before, {fit.residual_after[0]:.1f} N after (the load's noise: 7.4 N)")  # fmt: skip
    show(fit, truth_scale)


def real(result: Path, trial: Path) -> None:
    entry = json.loads((result / "summary.json").read_text())["kinetics"]["trials"][0]
    mass, sex = float(entry["body_mass_kg"]), entry["sex"]
    rd = ResultDir.open(result)
    model = inertial_model(rd.model, mass, sex=sex)
    motion = load_motion(rd.motion)
    grf = read_grf_csv(result / "grf.csv")
    loads = [
        dy.BodyLoad(FOOT_BODIES[s], grf.force[s], grf.cop[s], grf.moment[s]) for s in grf.force
    ]
    on = {s: np.isfinite(grf.cop[s]).all(axis=1) for s in grf.force}
    speeds = pivot_speeds(load_markers(trial))
    stance = np.any(list(on.values()), axis=0)
    for s in on:  # a still foot off the counted plates stands on something unmeasured
        stance &= on[s] | ~(speeds[s][: len(stance)] < STILL_SPEED)
    bodies = fitted_bodies(rd.model, mass)
    fit = fit_masses(model, [Trial(motion.qpos, motion.times, loads, stance)], bodies)
    peak = float(np.max(np.linalg.norm(sum(grf.force.values()), axis=1)))
    weight = mass * 9.80665
    print(f"\n{trial.name} ({result}), {mass:g} kg, {int(stance.sum())} stance frames:")
    for label, r in (("before", fit.residual_before), ("after", fit.residual_after)):
        print(f"  residual force RMS {label}: {r[0]:.1f} N = {100 * r[0] / weight:.1f} % body "
              f"weight = {100 * r[0] / peak:.1f} % of the peak ground reaction; moment "
              f"{r[1]:.1f} N m")  # fmt: skip
    show(fit)


def identified(trial: Path, out: Path) -> None:
    """identify with ``inertia: fit`` on ``trial`` and its static into ``out``; its figures."""
    recipe = out.with_name(out.name + "_recipe.yaml")
    recipe.write_text("inertia: fit\n")
    static = trial.with_name("Static_trial.c3d")
    cmd = [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(trial)]
    cmd += [str(static)] if static.is_file() else []
    proc = subprocess.run([*cmd, "--recipe", str(recipe), "--out", str(out), "--force"],
                          capture_output=True, text=True)  # fmt: skip
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    summary = json.loads((out / "summary.json").read_text())
    section = summary["inertia"]
    print(f"\nidentify {' '.join(Path(c).name for c in cmd[5:])} with inertia: fit ({out}); "
          f"marker RMSE {summary['marker_rmse_mm']:.1f} mm")  # fmt: skip
    if section["source"] != "fit":
        print(f"  no fit: {section['note']}")
        return
    print(f"  {section['stance_frames']} stance frames, {section['combinations_determined']} "
          f"combinations determined")  # fmt: skip
    for label in ("before", "after"):
        r = section["residuals"]["pooled"][label]
        print(f"  residual force RMS {label}: {r['force_rms_n']:.1f} N = "
              f"{r['force_rms_pct_bw']:.1f} % body weight = {r['force_rms_pct_peak_grf']:.1f} % "
              f"of the peak ground reaction; moment {r['moment_rms_nm']:.1f} N m")  # fmt: skip
    for b, s in section["segments"].items():
        print(f"  {b:12s} regression {s['regression_mass_kg']:6.2f} kg fitted "
              f"{s['fitted_mass_kg']:6.2f} +- {s['sd_kg']:.2f} kg "
              f"{'determined' if s['determined'] else 'undetermined'}"
              f"{' (at the bound)' if s['at_bound'] else ''}")  # fmt: skip
    print("  singular values:", np.round(section["singular_values"], 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--result", type=Path, help="an ik or identify result with grf.csv")
    ap.add_argument("--trial", type=Path, default=SHARED / "data/real/Movement_trial.c3d")
    ap.add_argument(
        "--identified",
        type=Path,
        nargs="?",
        const=Path(""),
        metavar="DIR",
        help="also identify with inertia: fit (into DIR, default a temporary one)",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.identified is not None:
            identified(args.trial, args.identified if args.identified.name else Path(tmp) / "id")
        synthetic(Path(tmp))
        result = args.result
        if result is None:
            result = Path(tmp) / "ik"
            subprocess.run([sys.executable, "-m", "mocap_mj", "ik", "--markers",
                            str(args.trial), "--out", str(result)], check=True,
                           capture_output=True)  # fmt: skip
        real(result, args.trial)


if __name__ == "__main__":
    main()
