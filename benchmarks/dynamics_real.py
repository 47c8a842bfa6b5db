"""Inverse dynamics of a real recording with force plates: root residuals, and the joint
moments against the Plug-in Gait kinetics Vicon Nexus stored in the same C3D.

    python benchmarks/dynamics_real.py RESULT_DIR [--c3d FILE] [--mass KG] [--sex male]

RESULT_DIR is ``mocap-mj identify --markers FILE`` of the C3D (default: the shared
Movement_trial.c3d). The plates are read with ezc3d's platform extraction (force [N], centre of
pressure [mm], free moment Tz [N mm], lab frame, analog rate), averaged over each marker frame's
samples, and each plate's load goes, frame by frame, to the foot whose origin (the ankle
centre) lies nearest its centre of pressure in the horizontal plane, above ``--threshold`` N.
Prints: the loads against Nexus's GroundReactionForce points (the assignment and signs), the
root's residual force in per cent of body weight and its moment, and for the sagittal ankle,
knee and hip moments the correlation with Nexus's LAnkleMoment ... (component X, N mm/kg).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ezc3d
import mujoco
import numpy as np

from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.outputs.dynamics_out import STANDARD_GRAVITY, dynamics_of_result
from mocap_mj.pipeline.dynamics import BodyLoad
from mocap_mj.pipeline.motion import ResultDir, load_motion

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_C3D = ROOT.parent / "shared" / "data" / "real" / "Movement_trial.c3d"
#: Our degree of freedom and Nexus's moment point for each sagittal moment compared.
MOMENTS = {
    "ankle": ("ankle_{s}", "{S}AnkleMoment"),
    "knee": ("knee_flex_{s}", "{S}KneeMoment"),
    "hip": ("hip_{s}_y", "{S}HipMoment"),
}


def plate_loads(c3d: ezc3d.c3d, frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per plate P: force (P, T, 3) [N], centre of pressure (P, T, 3) [m] and free moment
    (P, T, 3) [N m], lab frame, each marker frame the mean of its analog samples."""
    ratio = round(c3d["header"]["analogs"]["frame_rate"] / c3d["header"]["points"]["frame_rate"])
    out = []
    for plate in c3d["data"]["platform"]:
        scale = {"N": 1.0}[plate["unit_force"]], {"mm": 1e-3, "m": 1.0}[plate["unit_position"]]
        rows = []
        for key, unit in (("force", scale[0]), ("center_of_pressure", scale[1]),
                          ("Tz", scale[0] * scale[1])):  # fmt: skip
            x = np.asarray(plate[key], dtype=float).T[: frames * ratio] * unit
            rows.append(x.reshape(frames, ratio, 3).mean(axis=1))
        out.append(rows)
    force, cop, tz = (np.stack([p[i] for p in out]) for i in range(3))
    return force, cop, tz


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("result", type=Path)
    parser.add_argument("--c3d", type=Path, default=DEFAULT_C3D)
    parser.add_argument("--mass", type=float, help="body mass [kg] (default: PROCESSING)")
    parser.add_argument("--sex", choices=("male", "female"), default="male")
    parser.add_argument("--threshold", type=float, default=20.0, help="contact threshold [N]")
    args = parser.parse_args()

    c3d = ezc3d.c3d(str(args.c3d), extract_forceplat_data=True)
    mass = args.mass or float(c3d["parameters"]["PROCESSING"]["Bodymass"]["value"][0])
    rd = ResultDir.open(args.result)
    motion = load_motion(rd.motion)
    frames = len(motion.times)
    force, cop, tz = plate_loads(c3d, frames)
    contact = np.linalg.norm(force, axis=2) > args.threshold  # (P, T)
    up = float(np.sum(force[..., 2][contact]))
    sign = 1.0 if up > 0 else -1.0  # the loads act on the subject: upward in stance
    force, tz = sign * force, sign * tz

    model = inertial_model(rd.model, mass, sex=args.sex)
    data = mujoco.MjData(model)
    feet = {s: model.body(f"foot_{s}").id for s in "lr"}
    ankle = np.zeros((2, frames, 3))
    for t, q in enumerate(motion.qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        ankle[:, t] = data.xpos[feet["l"]], data.xpos[feet["r"]]
    loads = []
    per_foot = {s: np.zeros((frames, 3)) for s in "lr"}
    for p in range(len(force)):
        dist = np.linalg.norm((ankle - cop[p][None])[..., :2], axis=2)  # (2, T)
        nearest = np.argmin(dist, axis=0)
        for k, s in enumerate("lr"):
            on = contact[p] & (nearest == k)
            point = np.where(on[:, None], cop[p], np.nan)
            loads.append(BodyLoad(f"foot_{s}", force[p], point, tz[p]))
            per_foot[s][on] += force[p][on]
    dyn, _ = dynamics_of_result(rd.root, loads, mass, sex=args.sex)

    labels = list(c3d["parameters"]["POINT"]["LABELS"]["value"])
    points = np.asarray(c3d["data"]["points"][:3], dtype=float)  # (3, N, T)

    def nexus(name: str) -> np.ndarray:
        return points[:, labels.index(name), :frames].T  # (T, 3)

    print(f"{args.c3d.name}: {frames} frames, {len(force)} plates, body mass {mass:g} kg")
    for s, side in (("l", "L"), ("r", "R")):
        if f"{side}GroundReactionForce" in labels:
            theirs = nexus(f"{side}GroundReactionForce")[:, 2] * mass  # [N/kg] -> [N]
            ok = np.isfinite(theirs)
            diff = per_foot[s][ok, 2] - theirs[ok]
            print(f"  foot_{s} vertical load vs Nexus's {side}GroundReactionForce: "
                  f"RMS {np.sqrt(np.mean(diff**2)):.1f} N over {ok.sum()} frames, "
                  f"peak {np.abs(per_foot[s][:, 2]).max():.0f} N")  # fmt: skip
    weight = mass * STANDARD_GRAVITY
    pct = 100 * np.linalg.norm(dyn.root_force, axis=1) / weight
    moment = np.linalg.norm(dyn.root_moment, axis=1)
    loaded = contact.any(axis=0) & np.isfinite(pct)
    rest = ~loaded & np.isfinite(pct)
    for name, rows in (("frames with a load", loaded), ("frames without", rest)):
        if rows.any():
            print(
                f"  root residual force, {name} ({rows.sum()}): median "
                f"{np.median(pct[rows]):.1f} %BW, 95th percentile "
                f"{np.percentile(pct[rows], 95):.1f} %BW; moment median "
                f"{np.median(moment[rows]):.1f} N m"
            )
    for joint, (ours, theirs) in MOMENTS.items():
        for s, side in (("l", "L"), ("r", "R")):
            name = theirs.format(S=side)
            if name not in labels:
                continue
            a = dyn.tau[:, dyn.dof_names.index(ours.format(s=s))] / mass
            b = nexus(name)[:, 0] / 1000.0  # [N mm/kg] -> [N m/kg]
            # the frames Nexus computed kinetics with this foot on a plate it assigned
            stance = np.isfinite(nexus(f"{side}GroundReactionForce")[:, 2])
            ok = np.isfinite(a) & np.isfinite(b) & stance
            r = np.corrcoef(a[ok], b[ok])[0, 1]
            print(
                f"  {joint}_{s} ({ok.sum()} stance frames): ours {ours.format(s=s)} vs "
                f"Nexus's {name}_X: r {r:+.2f}, peak |ours| {np.abs(a[ok]).max():.2f}, "
                f"|Nexus| {np.abs(b[ok]).max():.2f} N m/kg"
            )


if __name__ == "__main__":
    main()
