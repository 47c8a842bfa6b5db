"""Our model's angles in Plug-in Gait's conventions (mocap_mj.clinical.from_model): known
poses of the bundled model give their known angles on both sides, the heading and the lab
position change nothing, and on Vicon's own trial the moving components keep Nexus' sign."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocap_mj.cli import main
from mocap_mj.clinical.angles import ANGLES
from mocap_mj.clinical.compare import c3d_angles, compare, folder_angles
from mocap_mj.clinical.from_model import model_angles
from mocap_mj.export.read_result import load_result
from mocap_mj.outputs.clinical_out import write_model_angles
from mocap_mj.pipeline.motion import Motion
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.mjcf import load_model, model_path

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
MOVEMENT = SHARED / "Movement_trial.c3d"


def _pose(
    model: mujoco.MjModel, root: tuple[float, ...] | None = None, **joints: object
) -> np.ndarray:
    """qpos0 with hinges at a degree value, balls (and the root, ``root``) turned by
    (axis x, y, z, degrees); ``root`` may carry a translation (dx, dy, dz) [m] after it."""
    q = model.qpos0.copy()
    for name, value in joints.items():
        adr = int(model.jnt_qposadr[model.joint(name).id])
        if isinstance(value, tuple):
            mujoco.mju_axisAngle2Quat(q[adr : adr + 4], np.array(value[:3]), np.radians(value[3]))
        else:
            q[adr] = np.radians(float(value))  # type: ignore[arg-type]
    if root is not None:
        mujoco.mju_axisAngle2Quat(q[3:7], np.array(root[:3], float), np.radians(root[3]))
        q[:3] += np.array(root[4:7] if len(root) > 4 else (0.0, 0.0, 0.0))
    return q


def _deg(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, np.ndarray]:
    return {k: np.degrees(v) for k, v in model_angles(model, np.atleast_2d(qpos)).items()}


def _sites(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Marker site positions (3,) [m] in the reference pose."""
    data = mujoco.MjData(model)
    rolling.kinematics(model, data)
    return {model.site(i).name: data.site_xpos[i].copy() for i in range(model.nsite)}


def _pelvic_tilt(model: mujoco.MjModel) -> float:
    """The anterior tilt [deg] of the model's ASIS-PSIS line in the reference pose, from the
    marker sites directly."""
    site = _sites(model)
    v = 0.5 * (site["LASI"] + site["RASI"]) - 0.5 * (site["LPSI"] + site["RPSI"])
    return float(np.degrees(np.arctan2(-v[2], v[0])))


def _toe_up(model: mujoco.MjModel, side: str) -> float:
    """The rise [deg] of the heel-to-toe site line in the reference pose (the foot's long
    axis, as Plug-in Gait's static foot)."""
    site = _sites(model)
    v = site[side + "TOE"] - site[side + "HEE"]
    return float(np.degrees(np.arctan2(v[2], np.hypot(v[0], v[1]))))


def test_the_table_has_plug_in_gaits_names_in_its_order() -> None:
    model = load_model()
    got = list(model_angles(model, model.qpos0[None]))
    assert got == [s + n for n in ANGLES for s in "LR"]


def test_the_reference_pose_reads_its_known_angles() -> None:
    model = load_model()
    a = _deg(model, model.qpos0)
    for name in ("Knee", "Elbow", "Wrist"):
        for s in "LR":
            np.testing.assert_allclose(a[f"{s}{name}Angles"][0], 0.0, atol=1e-6, err_msg=name)
    tilt = _pelvic_tilt(model)
    for s in "LR":  # a vertical femur reads the pelvis' anterior tilt as hip flexion
        np.testing.assert_allclose(a[f"{s}PelvisAngles"][0], [tilt, 0, 0], atol=1e-6)
        np.testing.assert_allclose(a[f"{s}HipAngles"][0], [tilt, 0, 0], atol=1e-6)
        up = _toe_up(model, s)  # a vertical shank: the toe's rise is dorsiflexion
        np.testing.assert_allclose(a[f"{s}AnkleAngles"][0], [up, 0, 0], atol=1e-6)
        np.testing.assert_allclose(a[f"{s}FootProgressAngles"][0], [-90 - up, 0, 0], atol=1e-6)


#: (joints, {angle (side letter added): (component, expected change [deg])}); the foot's
#: pitch in the progression frame (FootProgressAngles X) follows the leg.
KNOWN = [
    ({"knee_flex_{s}": 40.0}, {"KneeAngles": (0, 40.0), "FootProgressAngles": (0, 40.0)}),
    ({"hip_{s}": (0, -1, 0, 30)}, {"HipAngles": (0, 30.0), "FootProgressAngles": (0, -30.0)}),
    ({"ankle_{s}": 10.0}, {"AnkleAngles": (0, 10.0), "FootProgressAngles": (0, -10.0)}),
    ({"ankle_{s}": -25.0}, {"AnkleAngles": (0, -25.0), "FootProgressAngles": (0, 25.0)}),
    ({"elbow_{s}": 60.0}, {"ElbowAngles": (0, 60.0)}),
]


@pytest.mark.parametrize(("joints", "expected"), KNOWN)
@pytest.mark.parametrize("side", ["l", "r"])
def test_a_known_pose_gives_its_known_angles(joints: dict, expected: dict, side: str) -> None:
    model = load_model()
    named = {k.format(s=side): v for k, v in joints.items()}
    base = _deg(model, model.qpos0)
    posed = _deg(model, _pose(model, **named))
    changed = {f"{side.upper()}{n}": c for n, c in expected.items()}
    for name in base:
        want = base[name][0].copy()
        if name in changed:
            k, delta = changed[name]
            want[k] += delta
        np.testing.assert_allclose(posed[name][0], want, atol=1e-6, err_msg=name)


@pytest.mark.parametrize("side", ["l", "r"])
def test_internal_rotation_reads_positive_on_both_sides(side: str) -> None:
    """The thigh turned toe-in by 15 deg: hip internal rotation +15 and the foot 15 deg more
    toe-in; the shank turned toe-out by 15 deg at the knee: knee rotation -15."""
    model = load_model()
    base = _deg(model, model.qpos0)
    sign = -1.0 if side == "l" else 1.0  # toe-in: clockwise from above for the left leg
    hip = _deg(model, _pose(model, **{f"hip_{side}": (0, 0, sign, 15)}))
    knee = _deg(model, _pose(model, **{f"knee_rot_{side}": 15.0}))  # the model's + is toe-out
    p = side.upper()
    for got, angle, delta in ((hip, "HipAngles", 15.0), (knee, "KneeAngles", -15.0)):
        want = base[p + angle][0] + [0, 0, delta]
        np.testing.assert_allclose(got[p + angle][0], want, atol=1e-6, err_msg=angle)
        # the foot, pitched by its heel-toe line, turns within 0.1 deg of as much
        foot = got[p + "FootProgressAngles"][0, 2] - base[p + "FootProgressAngles"][0, 2]
        assert foot == pytest.approx(delta, abs=0.1)


def test_a_tilted_pelvis_reads_anterior_tilt_and_leaves_the_joints() -> None:
    model = load_model()
    base = _deg(model, model.qpos0)
    tilted = _deg(model, _pose(model, root=(0, 1, 0, 12)))
    for name in base:
        want = base[name][0] + ([12.0, 0, 0] if "Pelvis" in name else 0.0)
        if "FootProgress" in name or "Thorax" in name or "Head" in name:
            continue  # segments in the progression frame turn with the body
        np.testing.assert_allclose(tilted[name][0], want, atol=1e-6, err_msg=name)


@pytest.mark.parametrize("heading", [90.0, 180.0, 270.0])
def test_heading_and_lab_position_change_nothing(heading: float) -> None:
    model = load_model()
    q = _pose(model, knee_flex_l=40.0, hip_r=(0, -1, 0, 25), ankle_l=10.0, elbow_r=30.0)
    turned = q.copy()
    mujoco.mju_axisAngle2Quat(turned[3:7], np.array([0.0, 0.0, 1.0]), np.radians(heading))
    turned[:3] += [10.0, -7.0, 0.0]
    a, b = _deg(model, q), _deg(model, turned)
    for name in a:
        np.testing.assert_allclose(b[name], a[name], atol=1e-6, err_msg=name)


def test_turning_within_the_progression_frame_reads_pelvic_rotation() -> None:
    """Facing 30 deg to the left of +x: the right side is forward (Plug-in Gait's sign); the
    rotation is the third of the tilt-obliquity-rotation Cardan angles (scipy's)."""
    model = load_model()
    a = _deg(model, _pose(model, root=(0, 0, 1, 30)))
    pelvis = Rotation.from_euler("ZY", [30.0, _pelvic_tilt(model)], degrees=True)
    tilt, obliquity, rotation = pelvis.as_euler("YXZ", degrees=True)
    np.testing.assert_allclose(a["LPelvisAngles"][0], [tilt, obliquity, -rotation], atol=1e-6)
    np.testing.assert_allclose(a["RPelvisAngles"][0], [tilt, -obliquity, rotation], atol=1e-6)
    assert rotation == pytest.approx(30.0, abs=0.5)


def test_a_model_without_some_sites_and_hinges_falls_back_or_gives_nan() -> None:
    """Without the pelvis, trunk and heel sites the body frames stand in; without a wrist
    hinge that wrist's angles are NaN, every component (never half a frame)."""
    spec = mujoco.MjSpec.from_file(str(model_path()))
    for name in ("C7", "LASI", "LHEE"):
        spec.delete(spec.site(name))
    spec.delete(spec.joint("wrist_flex_l"))
    model = spec.compile()
    a = _deg(model, model.qpos0)
    assert np.isnan(a["LWristAngles"]).all()
    assert all(np.isfinite(v).all() for k, v in a.items() if k != "LWristAngles")
    np.testing.assert_allclose(a["LPelvisAngles"][0], 0.0, atol=1e-9)  # the body frame
    np.testing.assert_allclose(a["LKneeAngles"][0], 0.0, atol=1e-9)


@pytest.mark.slow
@pytest.mark.skipif(not MOVEMENT.is_file(), reason=f"shared recording absent: {MOVEMENT}")
def test_movement_trial_keeps_nexus_signs(tmp_path: Path) -> None:
    """identify on Vicon's jump; the table of identify's folder against the Nexus angles of
    the same file: the components that move most (flexions, pelvis, trunk, head) keep
    Nexus' sign (correlation >= 0.9); report.md carries the comparison."""
    out = tmp_path / "r"
    assert main(["identify", "--markers", str(MOVEMENT), "--out", str(out)]) == 0
    ours = folder_angles(out).angles
    ref = c3d_angles(MOVEMENT)
    rows = {r.name: r for r in compare(ours, ref.angles)}
    for s in "LR":
        for name in ("Hip", "Knee", "Ankle", "Neck", "Head"):
            assert rows[f"{s}{name}Angles_X"].correlation >= 0.9, (name, rows)
        for k in "XYZ":
            assert rows[f"{s}PelvisAngles_{k}"].correlation >= 0.9
            assert rows[f"{s}PelvisAngles_{k}"].rms < 2.0
            assert rows[f"{s}ThoraxAngles_{k}"].correlation >= 0.9
    report = (out / "report.md").read_text()
    assert "## Angles against Plug-in Gait" in report
    assert "323 frames in common" in report  # matched by the recording's frame numbers
    assert (out / "angles_vs_plug_in_gait.png").is_file()
    # a part of the trial (identify --frames 100:300) is compared with Nexus' same frames
    src = load_result(out)
    m = src.motion
    part = Motion(m.qpos[100:300], m.times[100:300], m.markers[100:300], m.marker_names)
    (tmp_path / "part").mkdir()
    lines, entry = write_model_angles(tmp_path / "part", src.model, [part], str(MOVEMENT), 100)
    assert entry is not None and "200 frames in common" in "\n".join(lines)
    knee = entry["components"]["LKneeAngles_X"]
    assert knee["offset_deg"] == pytest.approx(rows["LKneeAngles_X"].offset, abs=3.0)
