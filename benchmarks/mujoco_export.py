"""Plain MuJoCo on a written result: does ``model.xml`` + ``motion.npz`` reproduce the tool?

    python benchmarks/mujoco_export.py RESULT_DIR [RESULT_DIR ...]

For each result folder (``mocap-mj identify`` / ``ik`` / ``demo`` output):

* kinematics: ``mujoco.MjModel.from_xml_path(model.xml)``, ``data.qpos[:] = motion.npz's
  qpos``, ``mj_kinematics`` in every solved frame; the largest distance [mm] of every marker
  site from the tool's own model markers (the compiled kinematics the solvers use, on the
  tool's reading of the same files) and of every joint-centre body from ``joint_centres.csv``.
  Target: 0.1 mm. A folder written before the knees' slide joints existed is measured as
  plain MuJoCo reads it (its qpos as written), which is what the slides fix;
* simulation: ``mj_step`` for 1 s under gravity from the frame of deepest knee flexion, at
  rest, with the free root (the body falls) and with the pelvis held (the legs swing, the
  knees hit their limits): the largest residual [mm] of the slide-hinge equalities. Target:
  1 mm;
* the quartic's fit: the largest distance [mm] over the hinge's range between each
  equality's polynomial and the tool's coupling (the slides' exact values).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.pipeline.motion import ResultDir
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.joint_centres import centre_bodies


def kinematics_errors(rd: ResultDir) -> tuple[float, float, int, float]:
    """Largest marker and centre distances [mm] of plain MuJoCo from the tool's, the frames
    compared and the deepest knee flexion [deg]."""
    plain = mujoco.MjModel.from_xml_path(str(rd.model))
    with np.load(rd.motion) as f:
        raw = np.array(f["qpos"], dtype=float)
    pset = ParameterSet(rd.model)
    kin = Kinematics(pset)
    layout = exported.Layout.of(pset.model)
    internal = layout.read(raw, str(rd.motion))
    ok = np.flatnonzero(np.all(np.isfinite(raw), axis=1))
    tool = kin.site_positions(internal[ok])
    centres = np.genfromtxt(rd.root / "joint_centres.csv", delimiter=",", skip_header=1)
    centres = centres[:, 2:].reshape(len(centres), -1, 3) * 1e-3
    bodies = centre_bodies(plain)
    data = mujoco.MjData(plain)
    worst_m = worst_c = 0.0
    for i, t in enumerate(ok):
        data.qpos[:] = raw[t]
        mujoco.mj_kinematics(plain, data)
        worst_m = max(worst_m, float(np.linalg.norm(data.site_xpos - tool[i], axis=1).max()))
        worst_c = max(worst_c, float(np.linalg.norm(data.xpos[bodies] - centres[t], axis=1).max()))
    knees = [pset.model.joint(n).qposadr[0] for n in ("knee_flex_l", "knee_flex_r")]
    flex = float(np.degrees(np.nanmax(internal[:, knees])))
    return worst_m * 1e3, worst_c * 1e3, len(ok), flex


def deepest_flexion(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """The solved frame (nq,) of ``qpos`` (T, nq) whose knees are most flexed together."""
    knees = [model.joint(n).qposadr[0] for n in ("knee_flex_l", "knee_flex_r")]
    flex = np.nan_to_num(qpos[:, knees].sum(axis=1), nan=-np.inf)
    return qpos[int(np.argmax(flex))]


def simulation(rd: ResultDir) -> tuple[float, float, float]:
    """Largest equality residuals [mm] over 1 s: free root, pelvis held; and the quartic fit."""
    plain = mujoco.MjModel.from_xml_path(str(rd.model))
    with np.load(rd.motion) as f:
        start = deepest_flexion(plain, np.array(f["qpos"], dtype=float))
    free, _ = exported.stepped_residual(plain, start)
    held, _ = exported.stepped_residual(exported.held_root(rd.model), start[7:])
    pset = ParameterSet(rd.model)
    layout = exported.Layout.of(pset.model)
    worst = 0.0
    assert layout.roll is not None
    for j in layout.roll.joints:
        lo, hi = pset.model.jnt_range[j]
        q = np.tile(np.array(pset.model.qpos0), (400, 1))
        q[:, pset.model.jnt_qposadr[j]] = np.linspace(lo, hi, 400)
        written = layout.written(q)
        res = np.array([exported.equality_residuals(plain, w) for w in written])
        worst = max(worst, float(np.abs(res).max()))
    return free * 1e3, held * 1e3, worst * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("folders", type=Path, nargs="+", help="result folders")
    args = ap.parse_args()
    for folder in args.folders:
        rd = ResultDir.open(folder)
        plain = mujoco.MjModel.from_xml_path(str(rd.model))
        marker, centre, frames, flex = kinematics_errors(rd)
        written = "slides" if exported.carried(plain) else "no slides (older version)"
        print(
            f"{folder} ({written}): plain mj_kinematics over {frames} frames (knee flexion up "
            f"to {flex:.0f} deg): markers <= {marker:.6f} mm from the tool's, joint centres "
            f"<= {centre:.6f} mm from joint_centres.csv"
        )
        if exported.carried(plain):
            free, held, fit = simulation(rd)
            print(
                f"  mj_step 1 s under gravity from the deepest flexion: equality residual "
                f"<= {free:.4f} mm (free root), <= {held:.4f} mm (pelvis held); quartic fit "
                f"<= {fit:.4f} mm from the coupling over the knee's range"
            )


if __name__ == "__main__":
    main()
