"""Kinetics against a synthetic ground truth: ``synth --plates`` and ``ik`` with the truth model.

The truth: a quiet stance leant onto the right foot (mocap_synth/plates.py), whose ground
reaction is the wrench the truth motion needs (its root residual without loads); ``synth
--plates`` writes it as a type-2 plate under the right foot of plates.c3d. The commands then
read the plate (offsets, sign, axes, centre of pressure), give it to the right foot (the
contact rules), apply it to the model's foot and run the inverse dynamics. With the truth
model and noiseless markers the root residual is below 0.5 % of body weight and every joint
moment within 2 % of its peak in the truth (0.01 N m where it carries next to nothing); the
truth is MuJoCo's inverse dynamics of the truth motion under the needed wrench, both
unfiltered, computed here. ik filters the markers and the plate with one filter, whose
padding reshapes the ends: the moments are compared off the first and last :data:`EDGE`
frames.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.pipeline.dynamics import BodyLoad, inverse_dynamics, translational
from mocap_mj.pipeline.motion import load_motion

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

MASS = 68.0  # [kg]
G = 9.80665  # [m/s^2]
#: Frames at each end left out of the joint moments' comparison: there the filter's padding
#: (odd extension), not the data, shapes the filtered motion and plate (0.25 s at 100 Hz).
EDGE = 25


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    base = tmp_path_factory.mktemp("synth_plates")
    synth, result = base / "synth", base / "ik"
    proc = run("synth", "--out", str(synth), "--movement", "static", "--noise-mm", "0",
               "--frame-count", "300", "--seed", "5", "--with-plate",
               str(MASS))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "plates.c3d" in json.loads((synth / "summary.json").read_text())["files"]
    proc = run("ik", "--markers", str(synth / "plates.c3d"), "--model",
               str(synth / "truth_model.xml"), "--out", str(result))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return synth, result


def test_ik_with_the_truth_model_leaves_no_residual(folders: tuple[Path, Path]) -> None:
    _, result = folders
    (entry,) = json.loads((result / "summary.json").read_text())["kinetics"]["trials"]
    assert entry["body_mass_kg"] == MASS  # PROCESSING:Bodymass
    assert entry["plates_per_foot"] == {"left": [], "right": ["plate 1"]}
    residuals = np.genfromtxt(result / "root_residuals.csv", delimiter=",", names=True)
    pct = residuals["force_norm_pct_bw"]
    assert np.isfinite(pct).sum() == 300
    assert np.nanmax(pct) < 0.5
    moment = np.stack([residuals[f"moment_{a}_Nm"] for a in "XYZ"], axis=1)
    assert np.nanmax(np.abs(moment)) < 0.005 * MASS * G  # [N m], a 1 m lever


def test_joint_moments_are_the_truths(folders: tuple[Path, Path]) -> None:
    synth, result = folders
    model = inertial_model(synth / "truth_model.xml", MASS)
    truth_motion = load_motion(synth / "truth_motion.npz")
    free = inverse_dynamics(model, truth_motion.qpos, truth_motion.times, cutoff_hz=None)
    force = free.root_force  # the wrench the motion needs, at the world origin
    moment = free.root_moment + np.cross(free.qpos[:, :3], force)
    load = BodyLoad("foot_r", force, np.zeros_like(force), moment)
    # the truth unfiltered; ik filters the markers and the plate alike
    truth = inverse_dynamics(model, truth_motion.qpos, truth_motion.times, [load], cutoff_hz=None)
    assert np.abs(truth.root_force).max() < 1e-6 * MASS * G
    table = np.genfromtxt(result / "dynamics.csv", delimiter=",", names=True)
    forces = translational(model)
    checked = 0
    for k, name in enumerate(truth.dof_names):
        if name.startswith("root"):
            continue
        ours = table[f"{name}_{'N' if forces[k] else 'Nm'}"]
        peak = np.abs(truth.tau[:, k]).max()
        # 2 % of the joint's peak; 0.01 N m (N) for the joints that carry next to nothing
        err = np.abs(ours - truth.tau[:, k])[EDGE:-EDGE]
        assert err.max() <= max(0.02 * peak, 0.01), name
        checked += 1
    assert checked == model.nv - 6
    # the stance knee passes the weight of the body above it along the shank, the other
    # carries its shank and foot: the load is on the right foot alone
    right, left = (truth.dof_names.index(f"knee_flex_{s}_t2") for s in "rl")
    assert np.abs(truth.tau[:, right]).max() > 0.8 * MASS * G
    assert np.abs(truth.tau[:, left]).max() < 0.1 * MASS * G
