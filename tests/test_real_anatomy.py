"""Issue #14 targets on the shared real trials (skip without ../shared): parameters within
their anatomical ranges, left/right lengths within 10 mm, knee/ankle/elbow/wrist centres at
width/2 + marker radius from their lateral marker within 5 mm where the file records the
widths, marker RMSE within 10 mm. Frame subsets keep them to a few seconds each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.plausibility import kappa_outside_bounds, left_right_differences, width_errors
from mocap_mj.anatomy.ranges import kappa_ranges
from mocap_mj.capture.subject import from_c3d, from_values, from_yaml
from mocap_mj.cli import main
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.solve.consistency import joint_centre_lengths

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: real-data checks need the shared folder beside the repo"


#: Static_trial's first 300 frames: with the nominal proportions' L5/S1 row the lumbar rows
#: conflicted there and a knee centre sat 5.9 mm off its width (6.3 on the whole trial); the
#: first 150 frames did not show it (docs/model.md#prior-rows).
@pytest.mark.parametrize(("name", "frames"), [("Static_trial.c3d", "0:300"),
                                              ("anatomical_posture.c3d", "0:122")])  # fmt: skip
@pytest.mark.slow
def test_real_skeleton_targets(tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str,
                               frames: str) -> None:  # fmt: skip
    path = REAL / name
    if not path.is_file():
        pytest.skip(SKIP)
    out = tmp_path / "out"
    # Plug-in Gait's model (the biobuddy trials' medial markers would detect the medial set)
    args = ["identify", "--markers", str(path), "--out", str(out), "--frames", frames,
            "--marker-set", "plug_in_gait"]  # fmt: skip
    subject = from_c3d(path)
    if not subject.values:  # no measurements in the file: give some by YAML file and flag
        (tmp_path / "s.yaml").write_text("knee_width_l: 100 mm\nknee_width_r: 0.1\n")
        args += ["--subject-file", str(tmp_path / "s.yaml"), "--height", "1750"]
        subject = from_yaml(tmp_path / "s.yaml").update(from_values([("height", 1.75)], "--height"))
    assert main([*args, "--json", "--force"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    pset = ParameterSet()
    theta = pset.load_json(out / "theta.json")
    assert summary["marker_rmse_mm"] <= 10.0
    assert kappa_outside_bounds(pset, theta, *kappa_ranges(pset, subject)) == {}
    lr = left_right_differences(pset, theta)
    assert max(lr.values()) <= 0.010, lr
    # The measurements reach the summary with their source.
    assert {n: m["source"] for n, m in summary["measurements"].items()} == {
        n: m.source for n, m in subject.values.items()
    }
    motion = load_motion(out / "motion.npz", pset.model)
    widths = width_errors(pset, theta, motion.qpos, motion.markers, subject)
    assert len(widths) == sum(
        subject.get(f"{w}_{s}") is not None
        for w in ("knee_width", "ankle_width", "elbow_width", "wrist_width")
        for s in "lr"
    )
    assert all(abs(v) <= 0.005 for v in widths.values()), widths
    assert np.isfinite(summary["prior_weighting"]["noise_mm"])
    # The hip centres where Harrington's rows put them, within 1 sd (8 mm): a knee without
    # frontal-plane alignment pulled them 18-22 mm medially on Static_trial (2.3 / 2.7 sd;
    # docs/model.md#frontal-plane-alignment-26-29).
    prior = landmark_prior(pset, subject)
    hjc = [i for i, lab in enumerate(prior.labels) if lab.endswith("(Harrington 2007)")]
    assert len(hjc) == 6
    z = prior.residuals(theta)[hjc]
    assert np.all(np.abs(z) < 1.0), dict(zip(np.array(prior.labels)[hjc], z, strict=True))


def _identify(tmp_path: Path, name: str, *paths: Path) -> Path:
    out = tmp_path / name
    args = ["identify", "--markers", *map(str, paths), "--out", str(out), "--force",
            "--marker-set", "plug_in_gait"]  # fmt: skip
    assert main(args) == 0
    return out


#: Joint-centre distances through the joints the model defines from the trunk and shoulder
#: markers (C7/T1, T12/L1, L5/S1, SC joints, the glenohumeral centres under SHO:
#: SIGMA_CONVENTION rows), docs/model.md.
CONVENTION = ("pelvis:lumbar", "lumbar:thorax", "thorax:head", "thorax:clavicle_l",
              "thorax:clavicle_r", "clavicle_l:clavicle_r", "clavicle_l:upperarm_l",
              "clavicle_r:upperarm_r")  # fmt: skip


@pytest.mark.slow
def test_convention_joints_agree_across_trials(tmp_path: Path) -> None:
    """Two trials of one subject (a knee functional trial and a near-static posture): the
    joints that stand in for a chain (spine, shoulder girdle, the glenoid on the scapula) sit
    at the same place relative to the trunk and shoulder markers, within 10 mm (issue #14's
    cross-trial target), whatever motion each trial holds."""
    paths = [REAL / "Test_func_rknee.c3d", REAL / "anatomical_posture.c3d"]
    if not all(p.is_file() for p in paths):
        pytest.skip(SKIP)
    pset = ParameterSet()
    lengths = [
        joint_centre_lengths(pset, pset.load_json(_identify(tmp_path, p.stem, p) / "theta.json"))
        for p in paths
    ]
    diff = {n: abs(lengths[0][n] - lengths[1][n]) for n in CONVENTION}
    assert max(diff.values()) <= 0.010, diff


@pytest.mark.slow
def test_multi_trial_wrist_and_elbow_centres_at_width(tmp_path: Path) -> None:
    """Movement + Static (a jump and an arms-abducted static pose, one set of wrist-bar
    offsets): the wrist centres sit wrist_width/2 + r from the bar's midpoint within 5 mm.
    The static pose needs the forearm pronated past 60 degrees from palms forward, which
    the model's range (-160..30 degrees) allows. The elbow centres sit elbow_width/2 + r
    from ELB within 5 mm: ELB's level and depth define the elbow (a convention joint), so
    the jump's elbow at 15-25 degrees and the pose's at 90 do not move it off ELB (at 10 mm
    they did: 4.6-7.7 mm off the width, docs/model.md#convention-joints)."""
    paths = [REAL / "Movement_trial.c3d", REAL / "Static_trial.c3d"]
    if not all(p.is_file() for p in paths):
        pytest.skip(SKIP)
    out = _identify(tmp_path, "both", *paths)
    pset = ParameterSet()
    theta = pset.load_json(out / "theta.json")
    subject = from_c3d(paths[0])
    for motion_file in ("motion.npz", "trials/Static_trial/motion.npz"):
        motion = load_motion(out / motion_file, pset.model)
        widths = width_errors(pset, theta, motion.qpos, motion.markers, subject)
        arms = {k: v for k, v in widths.items() if k.startswith(("wrist", "elbow"))}
        assert len(arms) == 4 and all(abs(v) <= 0.005 for v in arms.values()), widths
    # The jump places the knee axes (docs/model.md#knee-axes-in-standing): standing in the
    # static, they lie within 15 deg of the pelvis's lateral axis (-7 / -7 measured), where
    # Plug-in Gait's thigh wands put them 37-41 deg forward, and a note says so.
    summary = json.loads((out / "summary.json").read_text())
    (axes,) = summary["standing_knee_axes_deg"].values()
    for side in "lr":
        assert abs(axes[side]["identified"]) < 15.0, axes
        assert axes[side]["construction"] > 30.0, axes
    (note,) = summary["standing_notes"]
    assert "not theirs" in note
