"""Plug-in Gait (mocap_mj.clinical): conventions on synthetic poses, missing markers, and
Vicon Nexus' own output in the shared recordings."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.subject import Subject, from_values
from mocap_mj.clinical import calibrate, pig_from_c3d, plug_in_gait
from mocap_mj.clinical.centres import davis_hip
from mocap_mj.io.trajectory import MarkerTrajectory

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: the Nexus comparison needs the shared folder"


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _subject() -> Subject:
    values = [(f"{n}_{s}", v) for n, v in (("leg_length", 0.88), ("knee_width", 0.10),
              ("ankle_width", 0.07)) for s in "lr"]  # fmt: skip
    return from_values([*values, ("asis_distance", 0.24)], "test")


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _pose(
    tilt: float,
    hip: float,
    knee: float,
    dorsi: float,
    n: int = 20,
    torsion: float = 0.0,
    walk: float = 1.0,
    pelvis_turn: tuple[float, float] = (0.0, 0.0),
    hip_abd: float = 0.0,
) -> dict[str, np.ndarray]:
    """Lower-body markers (n, 3) [m] of a subject facing +x, walking ``walk`` m along +x, in a
    known pose [deg]: pelvis anterior tilt, hip and knee flexion, ankle dorsiflexion; the
    TIB and ANK markers turned ``torsion`` [deg] externally about the tibia (a tibial
    torsion); the pelvis rolled and turned by ``pelvis_turn`` [deg] about the direction of
    walking and the vertical; both thighs swung ``hip_abd`` [deg] out to the side."""
    subj = _subject()
    r = subj.marker_radius
    roll, turn = np.radians(pelvis_turn)
    c, s = np.cos(roll), np.sin(roll)
    rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    p_axes = _rz(turn) @ _ry(np.radians(tilt)) @ rx
    origin = np.array([0.0, 0.0, 1.0])
    x, y = p_axes[:, 0], p_axes[:, 1]
    m = {"LASI": origin + 0.12 * y, "RASI": origin - 0.12 * y,
         "LPSI": origin - 0.15 * x + 0.05 * y, "RPSI": origin - 0.15 * x - 0.05 * y}  # fmt: skip
    for side, lat in (("l", 1.0), ("r", -1.0)):
        p = side.upper()
        hjc = davis_hip(p_axes[None], origin[None], leg_length=0.88, asis_trochanter=0.88 * 0.1288
                        - 0.04856, inter_asis=0.24, marker_radius=r, side=side)[0]  # fmt: skip
        c, s = np.cos(np.radians(hip_abd)), np.sin(np.radians(hip_abd))
        swing = np.array([[1, 0, 0], [0, c, -lat * s], [0, lat * s, c]])  # knee out to the side
        femur = p_axes @ _ry(-np.radians(hip)) @ swing
        kjc = hjc - 0.42 * femur[:, 2]
        dk = 0.05 + r
        m[p + "KNE"] = kjc + lat * dk * femur[:, 1]
        m[p + "THI"] = kjc + 0.2 * femur[:, 2] + lat * (dk + 0.03) * femur[:, 1]
        tibia = femur @ _ry(np.radians(knee))
        ajc = kjc - 0.40 * tibia[:, 2]
        da = 0.035 + r
        wand = tibia @ _rz(lat * np.radians(torsion))
        m[p + "ANK"] = ajc + lat * da * wand[:, 1]
        m[p + "TIB"] = ajc + 0.2 * wand[:, 2] + lat * (da + 0.03) * wand[:, 1]
        foot = tibia @ _ry(-np.radians(90 + dorsi))
        m[p + "TOE"] = ajc - 0.15 * foot[:, 2]
        m[p + "HEE"] = m[p + "TOE"] + 0.22 * foot[:, 2]
    path = np.linspace(0.0, walk, n)[:, None] * np.array([1.0, 0.0, 0.0])
    return {k: v[None] + path for k, v in m.items()}


def _trajectory(markers: dict[str, np.ndarray]) -> MarkerTrajectory:
    names = tuple(markers)
    pos = np.stack([markers[k] for k in names], axis=1)
    n = pos.shape[0]
    return MarkerTrajectory(np.arange(n) / 100.0, pos, names, 100.0, {"path": "synthetic"})


def _moved(markers: dict[str, np.ndarray], degrees: float, shift: float) -> dict[str, np.ndarray]:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return {k: v @ rz.T + np.array([shift, shift, 0.0]) for k, v in markers.items()}


def test_known_pose_reads_its_angles():
    res = plug_in_gait(_trajectory(_pose(12, 30, 40, 10)), _subject())
    deg = {k: np.degrees(v) for k, v in res.angles.items()}
    for p in "LR":
        np.testing.assert_allclose(deg[p + "PelvisAngles"][:, 0], 12, atol=1e-6)
        np.testing.assert_allclose(deg[p + "HipAngles"][:, 0], 30, atol=1e-6)
        np.testing.assert_allclose(deg[p + "KneeAngles"][:, 0], 40, atol=1e-6)
        np.testing.assert_allclose(deg[p + "AnkleAngles"][:, 0], 10, atol=1e-6)
        for name in ("HipAngles", "KneeAngles", "AnkleAngles"):  # no out-of-plane motion
            np.testing.assert_allclose(deg[p + name][:, 1:], 0, atol=1e-6)
        np.testing.assert_allclose(deg[p + "FootProgressAngles"][:, 2], 0, atol=1e-6)


def test_pelvis_and_hip_signs_follow_the_markers():
    """Left side up, right side forward, knees out: the signs clinicians read."""
    pose = _pose(0, 0, 0, 0, pelvis_turn=(8, 10), hip_abd=12)
    assert np.all(pose["LASI"][:, 2] > pose["RASI"][:, 2])  # the left side is up
    assert np.all(pose["RASI"][:, 0] > pose["LASI"][:, 0])  # the right side is forward
    res = plug_in_gait(_trajectory(pose), _subject())
    deg = {k: np.degrees(v) for k, v in res.angles.items()}
    assert np.all(deg["LPelvisAngles"][:, 1] > 7) and np.all(deg["RPelvisAngles"][:, 1] < -7)
    assert np.all(deg["RPelvisAngles"][:, 2] > 9) and np.all(deg["LPelvisAngles"][:, 2] < -9)
    flat = _pose(0, 0, 0, 0, hip_abd=12)
    assert flat["LKNE"][0, 1] > _pose(0, 0, 0, 0)["LKNE"][0, 1]  # the left knee went out
    res = plug_in_gait(_trajectory(flat), _subject())
    for p in "LR":  # abduction reads negative on both sides
        np.testing.assert_allclose(np.degrees(res.angles[p + "HipAngles"][:, 1]), -12, atol=1e-6)


def test_flexed_knee_positive_extended_knee_negative():
    flexed = plug_in_gait(_trajectory(_pose(0, 0, 25, 0)), _subject())
    hyper = plug_in_gait(_trajectory(_pose(0, 0, -5, 0)), _subject())
    assert np.all(np.degrees(flexed.angles["LKneeAngles"][:, 0]) > 24)
    assert np.all(np.degrees(hyper.angles["RKneeAngles"][:, 0]) < -4)


@pytest.mark.parametrize("degrees", [90.0, 180.0, -90.0])
def test_heading_and_lab_translation_change_no_angle(degrees):
    pose = _pose(15, 20, 35, -5)
    base = plug_in_gait(_trajectory(pose), _subject())
    turned = plug_in_gait(_trajectory(_moved(pose, degrees, 10.0)), _subject())
    for name, a in base.angles.items():
        d = np.degrees(np.angle(np.exp(1j * (turned.angles[name] - a))))
        assert np.max(np.abs(d)) < 0.5, name


def test_missing_marker_gives_nan_only_where_it_is_needed():
    pose = _pose(10, 20, 30, 5)
    pose["LKNE"] = pose["LKNE"].copy()
    pose["LKNE"][5] = np.nan
    res = plug_in_gait(_trajectory(pose), _subject())
    for name in ("LKneeAngles", "LHipAngles", "LAnkleAngles"):
        assert np.all(np.isnan(res.angles[name][5])), name
        assert np.all(np.isfinite(res.angles[name][4])), name
    for name in ("RKneeAngles", "LPelvisAngles", "RAnkleAngles"):
        assert np.all(np.isfinite(res.angles[name][5])), name
    assert np.all(np.isnan(res.points["LFEO"][5])) and np.all(np.isfinite(res.points["RFEO"][5]))


def test_standing_still_is_a_static_trial_unless_told():
    still = _trajectory(_pose(5, 10, 15, 5, walk=0.0))
    auto = plug_in_gait(still, _subject())
    dynamic = plug_in_gait(still, _subject(), trial_type="dynamic")
    assert auto.static and not dynamic.static
    assert not plug_in_gait(_trajectory(_pose(5, 10, 15, 5)), _subject()).static
    # the measurements of a subject file serve the static calibration too
    assert plug_in_gait(still, Subject(), override=_subject()).static
    for res in (auto, dynamic):  # the heel lies on the toe-ankle line: no offsets either way
        np.testing.assert_allclose(np.degrees(res.angles["LAnkleAngles"][:, 0]), 5, atol=1e-6)


def test_tibial_torsion_is_taken_out_of_the_knee():
    pose = _trajectory(_pose(0, 10, 30, 0, torsion=15))
    plain = plug_in_gait(pose, _subject())
    given = _subject().with_pig(
        {"tibial_torsion_l": np.radians(15), "tibial_torsion_r": np.radians(15)}, "test"
    )
    corrected = plug_in_gait(pose, given)
    for p in "LR":
        # the wand's external turn reads as external knee rotation (negative) unless given
        np.testing.assert_allclose(np.degrees(plain.angles[p + "KneeAngles"][:, 2]), -15, atol=1e-6)
        np.testing.assert_allclose(
            np.degrees(corrected.angles[p + "KneeAngles"])[:, 1:], 0, atol=1e-6
        )
        np.testing.assert_allclose(
            np.degrees(corrected.angles[p + "KneeAngles"][:, 0]), 30, atol=1e-6
        )


def test_command_writes_tables_in_the_lab_frame(tmp_path):
    from mocap_mj.cli import main
    from mocap_mj.export.trc import write_trc

    pose = _pose(12, 30, 40, 10)
    names = list(pose)
    trc = tmp_path / "walk.trc"
    write_trc(trc, names, np.arange(20) / 100.0, np.stack([pose[k] for k in names], 1), up="y")
    yaml_file = tmp_path / "subject.yaml"
    yaml_file.write_text(
        "leg_length_l: 880 mm\nleg_length_r: 880 mm\nknee_width_l: 100 mm\n"
        "knee_width_r: 100 mm\nankle_width_l: 70 mm\nankle_width_r: 70 mm\n"
        "asis_distance: 240 mm\nstatic_plantar_flex_l: 0 deg\n"
    )
    out = tmp_path / "pig"
    args = ["plug-in-gait", "--markers", str(trc), "--subject-file", str(yaml_file)]
    assert main([*args, "--out", str(out)]) == 0
    rows = np.genfromtxt(out / "angles.csv", delimiter=",", names=True)
    np.testing.assert_allclose(rows["LKneeAngles_X"], 40, atol=1e-3)
    np.testing.assert_allclose(rows["RHipAngles_X"], 30, atol=1e-3)
    centres = np.genfromtxt(out / "joint_centres.csv", delimiter=",", names=True)
    res = plug_in_gait(_trajectory(pose), _subject())
    # the TRC's lab is Y up: the centres come back in it, in mm
    np.testing.assert_allclose(centres["LFEO_Y"], res.points["LFEO"][:, 2] * 1e3, atol=0.01)
    np.testing.assert_allclose(centres["LFEO_Z"], -res.points["LFEO"][:, 1] * 1e3, atol=0.01)
    # every bone's origin and proximal point that result.c3d holds
    written = {n[:-2] for n in centres.dtype.names if n.endswith("_X")}
    assert {"PELP", "LFOP", "RTOP", "LFEP", "LTIP"} <= written
    assert {n for n in res.points if n[-1] in "OP"} == written
    assert {"summary.json", "report.md", "result.c3d"} <= {p.name for p in out.iterdir()}
    # a missing measurement is one line and exit status 2, with no folder left behind
    yaml_file.write_text("leg_length_l: 880 mm\n")
    assert main([*args, "--out", str(tmp_path / "bad")]) == 2
    assert not (tmp_path / "bad").exists()


def _nexus(path: Path) -> tuple[list[str], np.ndarray]:
    """The file's point labels and positions (T, N, 3) [mm], Nexus' outputs included."""
    from mocap_mj.io.formats.c3d import read

    raw = read(path)
    xyz = raw.positions.copy()
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan
    return list(raw.labels), xyz


@pytest.mark.skipif(not REAL.is_dir(), reason=SKIP)
@pytest.mark.parametrize("trial", ["Movement_trial", "Static_trial"])
def test_shared_trials_match_nexus(trial):
    from mocap_mj.io.load import load_markers

    path = REAL / f"{trial}.c3d"
    res = plug_in_gait(load_markers(path), pig_from_c3d(path))
    labels, xyz = _nexus(path)
    checked = 0
    for name, ours in res.angles.items():
        nexus = xyz[:, labels.index(name)]
        d = np.degrees(np.angle(np.exp(1j * (ours - np.radians(nexus)))))
        assert np.nanmax(np.abs(d)) < 0.01, name  # deg, every frame
        checked += 1
    assert checked == 26  # 24 joint and segment angles, and the two AbsAnkleAngle
    points = [n for n in res.points if n in labels]
    assert len(points) == 76  # every bone point Nexus wrote, the head's and thorax's too
    for name in points:
        dist = np.linalg.norm(res.points[name] * 1e3 - xyz[:, labels.index(name)], axis=1)
        assert np.nanmax(dist) < 0.1, name  # mm, every frame


@pytest.mark.skipif(not REAL.is_dir(), reason=SKIP)
@pytest.mark.parametrize("degrees", [90.0, 180.0])
def test_shared_trial_heading_changes_no_angle(degrees):
    from mocap_mj.io.load import load_markers

    path = REAL / "Movement_trial.c3d"
    traj = load_markers(path)
    base = plug_in_gait(traj, pig_from_c3d(path))
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    moved = MarkerTrajectory(
        traj.times, traj.positions @ rz.T + np.array([10.0, 10.0, 0.0]), traj.names, traj.rate
    )
    turned = plug_in_gait(moved, pig_from_c3d(path))
    assert len(base.angles) == 26
    for name, a in base.angles.items():
        d = np.degrees(np.angle(np.exp(1j * (turned.angles[name] - a))))
        assert np.nanmax(np.abs(d)) < 0.5, name


@pytest.mark.skipif(not REAL.is_dir(), reason=SKIP)
def test_shared_trial_missing_elbow_marker_gives_nan_in_that_arm_only():
    from mocap_mj.io.load import load_markers

    path = REAL / "Movement_trial.c3d"
    traj = load_markers(path)
    pos = traj.positions.copy()
    pos[10, traj.names.index("LELB")] = np.nan
    res = plug_in_gait(MarkerTrajectory(traj.times, pos, traj.names, traj.rate), pig_from_c3d(path))
    for name in ("LElbowAngles", "LShoulderAngles", "LWristAngles"):
        assert np.all(np.isnan(res.angles[name][10])) and np.all(np.isfinite(res.angles[name][11]))
    for name in ("RElbowAngles", "LKneeAngles", "LThoraxAngles"):
        assert np.all(np.isfinite(res.angles[name][10])), name


@pytest.mark.skipif(not REAL.is_dir(), reason=SKIP)
def test_static_calibration_reproduces_nexus_offsets():
    from mocap_mj.io.load import load_markers

    path = REAL / "Static_trial.c3d"
    given = pig_from_c3d(path)
    ours = calibrate(load_markers(path), given)
    for name in ("static_plantar_flex_l", "static_plantar_flex_r", "static_rot_off_l",
                 "static_rot_off_r"):  # fmt: skip
        assert abs(ours.pig(name) - given.pig(name)) < 1e-3, name


@pytest.mark.skipif(not REAL.is_dir(), reason=SKIP)
def test_command_keeps_the_recordings_frames(tmp_path):
    import ezc3d

    from mocap_mj.cli import main

    path = REAL / "Movement_trial.c3d"
    out = tmp_path / "pig"
    assert main(["plug-in-gait", "--markers", str(path), "--out", str(out)]) == 0
    rows = np.genfromtxt(out / "angles.csv", delimiter=",", names=True)
    given = ezc3d.c3d(str(path))
    first = int(given["header"]["points"]["first_frame"]) + 1  # ezc3d counts from 0
    assert first == 695  # the C3D header's first frame
    np.testing.assert_array_equal(rows["frame"], first + np.arange(len(rows)))
    np.testing.assert_allclose(rows["time_s"], (rows["frame"] - 1) / 120.0, atol=1e-6)
    written = ezc3d.c3d(str(out / "result.c3d"))
    assert int(written["header"]["points"]["first_frame"]) + 1 == first
    labels = list(written["parameters"]["POINT"]["LABELS"]["value"])
    ours = written["data"]["points"][:3, labels.index("LKneeAngles")]
    nexus = given["data"]["points"][
        :3, list(given["parameters"]["POINT"]["LABELS"]["value"]).index("LKneeAngles")
    ]
    np.testing.assert_allclose(ours, nexus, atol=1e-3)
