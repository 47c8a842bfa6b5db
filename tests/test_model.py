"""The bundled humanoid: counts, names, marker placement, and the CLI's description of it."""

from __future__ import annotations

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import mocap_mj
from mocap_mj import MARKER_NAMES, ParameterSet, load_model

PIG_39 = (
    "LFHD RFHD LBHD RBHD C7 T10 CLAV STRN RBAK LSHO LUPA LELB LFRM LWRA LWRB LFIN RSHO RUPA "
    "RELB RFRM RWRA RWRB RFIN LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB "
    "RANK RHEE RTOE"
).split()

# Plug-in Gait segment of every marker (the body that must carry it in our model).
SEGMENT = {
    "LFHD": "head", "RFHD": "head", "LBHD": "head", "RBHD": "head",
    "C7": "thorax", "T10": "thorax", "CLAV": "thorax", "STRN": "thorax", "RBAK": "thorax",
    "LASI": "pelvis", "RASI": "pelvis", "LPSI": "pelvis", "RPSI": "pelvis",
    "LSHO": "clavicle_l", "LUPA": "upperarm_l", "LELB": "upperarm_l", "LFRM": "radius_l",
    "LWRA": "radius_l", "LWRB": "radius_l", "LFIN": "hand_l",
    "RSHO": "clavicle_r", "RUPA": "upperarm_r", "RELB": "upperarm_r", "RFRM": "radius_r",
    "RWRA": "radius_r", "RWRB": "radius_r", "RFIN": "hand_r",
    "LTHI": "thigh_l", "LKNE": "thigh_l", "LTIB": "shank_l", "LANK": "shank_l",
    "LHEE": "foot_l", "LTOE": "foot_l",
    "RTHI": "thigh_r", "RKNE": "thigh_r", "RTIB": "shank_r", "RANK": "shank_r",
    "RHEE": "foot_r", "RTOE": "foot_r",
}  # fmt: skip


def test_counts() -> None:
    m = load_model()
    assert m.nbody - 1 == 22
    assert m.nv == 48
    assert m.nsite == 39
    assert sorted(MARKER_NAMES) == sorted(PIG_39)
    assert [m.site(i).name for i in range(m.nsite)] == list(MARKER_NAMES)
    kinds = {int(t) for t in m.jnt_type}
    assert kinds <= {
        int(mujoco.mjtJoint.mjJNT_FREE),
        int(mujoco.mjtJoint.mjJNT_BALL),
        int(mujoco.mjtJoint.mjJNT_HINGE),
    }
    assert m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE and m.jnt_bodyid[0] == m.body("pelvis").id


def test_markers_on_plug_in_gait_segments() -> None:
    m = load_model()
    for name, body in SEGMENT.items():
        assert m.body(m.site(name).bodyid[0]).name == body, name


def test_reference_pose_is_anatomical() -> None:
    """Standing at qpos0: head above shoulders above pelvis above knees above feet; L is +y."""
    m = load_model()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)

    def z(n: str) -> float:
        return float(d.site(n).xpos[2])

    assert z("LFHD") > z("C7") > z("LASI") > z("LKNE") > z("LANK") > z("LHEE") > 0
    assert 1.6 < z("LFHD") < 1.75  # a 1.75 m adult
    for name in MARKER_NAMES:
        if name[0] in "LR" and name not in ("RBAK",):
            side = 1 if name[0] == "L" else -1
            assert side * d.site(name).xpos[1] > 0, name
    # Left and right are mirror images.
    for name in MARKER_NAMES:
        if name.startswith("L") and "R" + name[1:] in MARKER_NAMES:
            left, right = d.site(name).xpos, d.site("R" + name[1:]).xpos
            np.testing.assert_allclose(left * [1, -1, 1], right, atol=1e-12)


def test_joint_ranges_physiological() -> None:
    m = load_model()
    for j in range(1, m.njnt):
        assert m.jnt_limited[j], m.joint(j).name
        lo, hi = np.degrees(m.jnt_range[j])
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            # Pronation is measured from palms forward (full supination): it turns up to
            # 160 degrees one way; every other hinge at most 90 degrees below its zero.
            least = -160 if m.joint(j).name.startswith("pronation") else -90
            assert least <= lo < 0 < hi <= 160, m.joint(j).name
        else:
            assert lo == 0 and 30 <= hi <= 170, m.joint(j).name


def test_all_names_resolve() -> None:
    for name in mocap_mj.__all__:
        assert hasattr(mocap_mj, name), name


@pytest.mark.slow
def test_cli_info_json() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "info", "--json"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    info = json.loads(out.stdout)
    assert info["bodies"] == 22
    assert info["dof"] == 48
    assert info["markers"] == list(MARKER_NAMES)
    assert info["kinematic_parameters"] == list(ParameterSet().kappa_names)
    assert len(info["kinematic_parameters"]) == 34
    assert info["parameter_count"] == 151


@pytest.mark.slow
def test_cli_bad_model_is_one_line(tmp_path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body></mujoco>")
    out = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "info", "--model", str(bad)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert str(bad) in out.stderr


def test_bundled_model_found_from_any_directory(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The MJCF ships as package data: found from a folder that is not the checkout."""
    out = subprocess.run(
        [sys.executable, "-c", "from mocap_mj import model_path, load_model; "
         "p = model_path(); load_model(); print(p)"],
        capture_output=True, text=True, check=True, cwd=tmp_path,
    )  # fmt: skip
    from pathlib import Path

    assert Path(out.stdout.strip()).is_file()
    assert out.stdout.strip().endswith("humanoid.xml")
