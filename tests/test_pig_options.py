"""Nexus's static options and the outputs Plug-in Gait writes beside its angles: the head
offset (read from PROCESSING and Vicon's subject files, computed for a level head), the flat
foot with its sole delta, the absolute ankle angle, the head and thorax bone points, and a
trial whose measurements live in its subject's .vsk only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_plug_in_gait import _pose, _subject, _trajectory

from mocap_mj.capture.subject import Subject, from_values
from mocap_mj.clinical import calibrate, pig_from_c3d, pig_from_file, plug_in_gait
from mocap_mj.clinical.angles import abs_ankle_angles, all_angles, progression_frame
from mocap_mj.clinical.geometry import rotate_about
from mocap_mj.clinical.segments import Markers, Segment, static_foot, trunk_frames
from mocap_mj.clinical.static import head_offset
from mocap_mj.clinical.subject import pig_from_numbers
from mocap_mj.errors import MocapError

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
STATIC, MOVEMENT = REAL / "Static_trial.c3d", REAL / "Movement_trial.c3d"
needs_shared = pytest.mark.skipif(
    not STATIC.is_file(), reason="shared data absent: ../shared/data/real/Static_trial.c3d"
)


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _head_markers(pitch: float, n: int = 5) -> dict[str, np.ndarray]:
    """Thorax and head markers (n, 3) [m] of a subject facing +x, the head pitched ``pitch``
    [rad] about its left-right axis (positive: the front goes down), the thorax upright."""
    rot = _ry(pitch)
    centre = np.array([0.0, 0.0, 1.6])
    head = {"LFHD": (0.08, 0.05, 0.0), "RFHD": (0.08, -0.05, 0.0),
            "LBHD": (-0.08, 0.06, 0.0), "RBHD": (-0.08, -0.06, 0.0)}  # fmt: skip
    m = {k: centre + rot @ np.array(v) for k, v in head.items()}
    m |= {"C7": np.array([-0.08, 0.0, 1.45]), "T10": np.array([-0.1, 0.0, 1.2]),
          "CLAV": np.array([0.07, 0.0, 1.42]), "STRN": np.array([0.09, 0.0, 1.25])}  # fmt: skip
    return {k: np.tile(v, (n, 1)) for k, v in m.items()}


def _head(pitch: float, n: int = 5) -> Markers:
    return Markers(_head_markers(pitch, n), n)


def _head_angles(m: Markers, offset: float) -> dict[str, np.ndarray]:
    segs = trunk_frames(m, 0.007, offset)
    pelvis = np.tile(np.eye(3), (m.n_frames, 1, 1))
    segs["pelvis"] = Segment(np.zeros((m.n_frames, 3)), pelvis)
    prog = progression_frame(pelvis, np.zeros((m.n_frames, 3)))
    return all_angles(segs, prog)


def test_head_offset_turns_the_head_about_its_own_y_by_exactly_the_offset():
    m = _head(0.0)
    plain, turned = trunk_frames(m, 0.007, 0.0)["head"], trunk_frames(m, 0.007, 0.3)["head"]
    np.testing.assert_allclose(turned.axes, plain.axes @ _ry(0.3), atol=1e-12)
    np.testing.assert_allclose(turned.origin, plain.origin)
    a, b = _head_angles(m, 0.0), _head_angles(m, 0.3)
    for name in ("LHeadAngles", "RHeadAngles"):  # tilt (X) by the offset, nothing else
        np.testing.assert_allclose(b[name][:, 0] - a[name][:, 0], -0.3, atol=1e-12)
        np.testing.assert_allclose(b[name][:, 1:], a[name][:, 1:], atol=1e-12)
    np.testing.assert_allclose(b["LNeckAngles"][:, 0] - a["LNeckAngles"][:, 0], 0.3, atol=1e-12)


def test_head_level_gives_the_offset_that_levels_the_static_head():
    m = _head(0.25)
    off = head_offset(trunk_frames(m, 0.0, 0.0)["head"].axes)
    assert off == pytest.approx(-0.25, abs=1e-12)
    level = rotate_about(trunk_frames(m, 0.0, 0.0)["head"].axes, 1, off)
    np.testing.assert_allclose(level[:, 2, 0], 0.0, atol=1e-12)  # x horizontal
    np.testing.assert_allclose(_head_angles(m, off)["LHeadAngles"], 0.0, atol=1e-12)


def test_head_offset_and_sole_delta_are_read_in_nexus_names_and_units(tmp_path):
    numbers = [("PROCESSING", "HeadOffset", 0.29), ("PROCESSING", "LSoleDelta", 12.0),
               ("PROCESSING", "RSoleDelta", 0.0)]  # fmt: skip
    subj = pig_from_numbers(numbers, "trial.c3d")
    assert subj.pig("head_offset") == 0.29  # rad, as Nexus stores it
    assert subj.pig("sole_delta_l") == pytest.approx(0.012)  # mm in the file
    assert subj.pig_values["head_offset"].source == "trial.c3d: PROCESSING:HeadOffset"
    mp = tmp_path / "s.mp"
    mp.write_text("$HeadOffset = -0.1\n$RightSoleDelta = 8\n")
    from_mp = pig_from_file(mp)
    assert from_mp.pig("head_offset") == -0.1 and from_mp.pig("sole_delta_r") == pytest.approx(
        0.008
    )
    yaml = tmp_path / "s.yaml"
    yaml.write_text("flat_foot_l: true\nhead_level: false\nsole_delta_l: 9 mm\n")
    from_yaml = pig_from_file(yaml)
    assert from_yaml.flag("flat_foot_l") is True and from_yaml.flag("head_level") is False
    assert from_yaml.flag("flat_foot_r") is None and from_yaml.pig("sole_delta_l") == pytest.approx(
        0.009
    )
    with pytest.raises(MocapError, match=r"expected a .* within -50\.\.50 mm"):
        pig_from_numbers([("PROCESSING", "LSoleDelta", 120.0)], "trial.c3d")
    yaml.write_text("flat_foot_l: 2\n")
    with pytest.raises(MocapError, match="flat_foot_l: expected true or false"):
        pig_from_file(yaml)


def test_flat_foot_puts_the_heel_at_the_toes_height_plus_the_sole_delta():
    m = _markers(_pose(0, 0, 0, 10, walk=0.0, n=3))
    tibia = np.tile(np.eye(3), (3, 1, 1))
    toe, hee = m["LTOE"], m["LHEE"]
    for delta in (0.0, 0.015):
        z = static_foot(m, "l", tibia, flat=True, sole_delta=delta)[..., 2]
        expected = np.concatenate([hee[:, :2] - toe[:, :2], np.full((3, 1), delta)], axis=1)
        np.testing.assert_allclose(z, expected / np.linalg.norm(expected, axis=1)[:, None])
    plain = static_foot(m, "l", tibia)[..., 2]
    np.testing.assert_allclose(plain, (hee - toe) / np.linalg.norm(hee - toe, axis=1)[:, None])


def _markers(pose: dict[str, np.ndarray]) -> Markers:
    return Markers(pose, len(next(iter(pose.values()))))


def _flagged(**flags: float) -> Subject:
    return _subject().with_pig(flags, "test")


def test_flat_foot_offsets_differ_by_the_heel_rise_less_the_sole_delta():
    still = _trajectory(_pose(0, 0, 0, 10, walk=0.0))
    m = _markers(_pose(0, 0, 0, 10, walk=0.0))
    rise = m["LHEE"][0, 2] - m["LTOE"][0, 2]
    run = np.linalg.norm(m["LHEE"][0, :2] - m["LTOE"][0, :2])
    plain = calibrate(still, _flagged(flat_foot_l=0.0, flat_foot_r=0.0))
    assert plain.pig("static_plantar_flex_l") == pytest.approx(0.0, abs=1e-12)  # heel on the line
    for delta in (0.0, 0.01):
        flat = calibrate(still, _flagged(flat_foot_l=1.0, flat_foot_r=0.0, sole_delta_l=delta))
        turn = np.arctan2(rise, run) - np.arctan2(delta, run)
        assert flat.pig("static_plantar_flex_l") == pytest.approx(turn, abs=1e-12)
        assert flat.pig("static_rot_off_l") == pytest.approx(0.0, abs=1e-12)
        assert flat.pig("static_plantar_flex_r") == pytest.approx(0.0, abs=1e-12)
    level = calibrate(still, _flagged(flat_foot_l=1.0, sole_delta_l=float(rise)))
    assert level.pig("static_plantar_flex_l") == pytest.approx(0.0, abs=1e-12)


def test_given_offsets_tell_a_flat_calibration_and_the_static_foot_follows():
    still = _trajectory(_pose(0, 0, 0, 10, walk=0.0))
    flat = calibrate(still, _flagged(flat_foot_l=1.0, flat_foot_r=1.0))
    given = {k: flat.pig(k) for k in ("static_plantar_flex_l", "static_rot_off_l",
                                      "static_plantar_flex_r", "static_rot_off_r")}  # fmt: skip
    told = calibrate(still, _subject().with_pig(given, "PROCESSING"))
    assert told.flag("flat_foot_l") is True and told.flag("flat_foot_r") is True
    assert calibrate(still, _subject()).flag("flat_foot_l") is False  # nothing given: plain
    res = plug_in_gait(still, _subject().with_pig(given, "PROCESSING"))
    assert res.static and res.subject.flag("flat_foot_l") is True
    # the static output's foot lies along the floor: its progression pitch reads -90 deg
    np.testing.assert_allclose(np.degrees(res.angles["LFootProgressAngles"][:, 0]), -90, atol=1e-9)
    plain = plug_in_gait(still, _subject())  # the heel-toe line, 10 deg off the floor
    np.testing.assert_allclose(
        np.degrees(plain.angles["LFootProgressAngles"][:, 0]), -100, atol=1e-9
    )


def test_abs_ankle_angle_is_the_long_axes_angle_whatever_the_foot_rotation():
    n = 4
    tibia = Segment(np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
    base = _ry(-np.radians(90 + 12.0))  # the foot's z 12 deg above the tibia's perpendicular
    for turn in (0.0, 25.0):
        c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
        rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        foot = Segment(np.zeros((n, 3)), np.tile(rz @ base, (n, 1, 1)))
        out = abs_ankle_angles({"tibia_torsioned_l": tibia, "foot_l": foot})
        assert set(out) == {"LAbsAnkleAngle"}
        np.testing.assert_allclose(np.degrees(out["LAbsAnkleAngle"][:, 0]), 12.0, atol=1e-12)
        np.testing.assert_allclose(out["LAbsAnkleAngle"][:, 1:], 0.0)
    res = plug_in_gait(_trajectory(_pose(5, 10, 15, 7)), _subject())
    np.testing.assert_allclose(np.degrees(res.angles["RAbsAnkleAngle"][:, 0]), 7, atol=1e-9)


def test_head_and_thorax_bone_points_follow_their_construction():
    pose = _pose(0, 0, 0, 5, n=4) | _head_markers(0.1, n=4)
    upper = {f"{p}{k}": pose["C7"] + np.array(v) for p, lat in (("L", 1), ("R", -1))
             for k, v in (("SHO", (0, lat * 0.18, -0.02)), ("ELB", (-0.02, lat * 0.2, -0.3)),
                          ("WRA", (0.02, lat * 0.2, -0.55)), ("WRB", (-0.02, lat * 0.18, -0.55)),
                          ("FIN", (0.0, lat * 0.2, -0.65)))}  # fmt: skip
    widths = (("shoulder_offset", 0.05), ("elbow_width", 0.07), ("wrist_width", 0.05),
              ("hand_thickness", 0.03))  # fmt: skip
    measures = [(f"{n}_{s}", v) for s in "lr" for n, v in widths]
    subj = _subject().update(from_values(measures, "test"))
    res = plug_in_gait(_trajectory(pose | upper), subj, trial_type="dynamic")
    head, thorax = res.segments["head"], res.segments["thorax"]
    size = 2 * (0.10 - 0.014)  # the front head markers 0.10 m apart, 14 mm markers
    origin = head.origin + size * (head.axes @ np.array([-0.84, 0.0, -0.3]))
    np.testing.assert_allclose(res.points["HEDO"], origin, atol=1e-12)
    for k, letter in enumerate("ALP"):
        np.testing.assert_allclose(res.points["HED" + letter], origin + size * head.axes[..., k])
    sho = [np.linalg.norm(res.centres[f"shoulder_{s}"] - thorax.origin, axis=1) for s in "lr"]
    length = 0.5 * (sho[0] + sho[1])
    np.testing.assert_allclose(res.points["TRXO"], thorax.origin)
    np.testing.assert_allclose(
        res.points["TRXP"], thorax.origin + length[:, None] * thorax.axes[..., 2]
    )


@needs_shared
@pytest.mark.parametrize("path", [STATIC, MOVEMENT], ids=lambda p: p.stem)
def test_shared_trials_abs_ankle_and_head_thorax_points_are_nexus(path):
    from mocap_mj.clinical.nexus_centres import read_nexus
    from mocap_mj.io.load import load_markers

    res = plug_in_gait(load_markers(path), pig_from_c3d(path))
    nexus = read_nexus(path)
    assert nexus is not None
    for name in ("LAbsAnkleAngle", "RAbsAnkleAngle"):
        d = np.degrees(res.angles[name]) - nexus.angles[name]
        assert np.nanmax(np.abs(d)) < 0.01, name
    for code in ("HED", "TRX"):
        for letter in "OALP":
            dist = np.linalg.norm(res.points[code + letter] - nexus.points[code + letter], axis=1)
            assert np.nanmax(dist) < 1e-4, code + letter  # 0.1 mm


@pytest.mark.slow
@needs_shared
def test_a_trial_whose_measurements_live_in_the_vsk_only(tmp_path):
    import ezc3d
    from test_vicon_subject import _processing, _write_vsk

    from mocap_mj.cli import main

    bare = tmp_path / "bare.c3d"
    c = ezc3d.c3d(str(STATIC))
    del c["parameters"]["PROCESSING"]
    c.write(str(bare))
    vsk = _write_vsk(tmp_path / "subject.vsk", {k: repr(v) for k, v in _processing(STATIC).items()})
    assert main(["plug-in-gait", "--markers", str(bare), "--out", str(tmp_path / "no")]) == 2
    args = ["plug-in-gait", "--markers", str(bare), "--subject-file", str(vsk), "--json"]
    assert main([*args, "--out", str(tmp_path / "vsk")]) == 0
    assert main(["plug-in-gait", "--markers", str(STATIC), "--out", str(tmp_path / "c3d")]) == 0
    ours = (tmp_path / "vsk" / "angles.csv").read_text()
    assert ours == (tmp_path / "c3d" / "angles.csv").read_text()


def test_a_kad_offset_is_read_and_said_not_applied():
    given = pig_from_numbers([("PROCESSING", "LThighRotation", 0.1)], "kad.c3d")
    assert given.pig("thigh_rotation_l") == 0.1
    res = plug_in_gait(_trajectory(_pose(5, 10, 15, 5)), _subject().update(given))
    (note,) = [n for n in res.notes if "thigh_rotation_l" in n]
    assert "5.73 deg (kad.c3d: PROCESSING:LThighRotation) is not applied" in note
    plain = plug_in_gait(_trajectory(_pose(5, 10, 15, 5)), _subject())
    assert not any("not applied" in n for n in plain.notes)


@needs_shared
def test_a_statics_processing_head_offset_turns_its_head(tmp_path):
    import ezc3d

    from mocap_mj.io.load import load_markers

    copy = tmp_path / "head_offset.c3d"
    c = ezc3d.c3d(str(STATIC))
    c.add_parameter("PROCESSING", "HeadOffset", [0.29])
    c.write(str(copy))
    subject = pig_from_c3d(copy)
    assert subject.pig("head_offset") == pytest.approx(0.29)
    traj = load_markers(STATIC)
    base, turned = plug_in_gait(traj, pig_from_c3d(STATIC)), plug_in_gait(traj, subject)
    a, b = base.segments["head"].axes, turned.segments["head"].axes
    np.testing.assert_allclose(b, a @ _ry(subject.pig("head_offset")), atol=1e-12)  # float32
    tilt = np.degrees(
        np.nanmean(turned.angles["LHeadAngles"][:, 0] - base.angles["LHeadAngles"][:, 0])
    )
    assert tilt == pytest.approx(-np.degrees(0.29), abs=0.5)  # the head stands nearly level
    for name in ("LKneeAngles", "LThoraxAngles", "LShoulderAngles"):
        np.testing.assert_array_equal(turned.angles[name], base.angles[name])


def test_head_offset_turns_the_head_as_pycgm_does():
    """pyCGM's ``headJC`` (cadop/pyCGM, its docstring's example: Sample_SM.vsk's HeadOffset on
    four head markers [mm]) gives these axis points; pyCGM reproduces Nexus's head angles."""
    head = {"RFHD": (325.82983398, 402.55450439, 1722.49816895),
            "LFHD": (184.55158997, 409.68713379, 1721.34289551),
            "RBHD": (304.39898682, 242.91339111, 1694.97497559),
            "LBHD": (197.8621521, 251.28889465, 1696.90197754)}  # fmt: skip
    m = Markers({k: np.array([v]) for k, v in head.items()}, 1)
    seg = trunk_frames(m, 7.0, 0.2571990469310653)["head"]
    pycgm = np.array([[255.21685583, 407.11593888, 1721.82538439],
                      [254.19105385, 406.14680918, 1721.91767712],
                      [255.1903437, 406.21600904, 1722.91599129]])  # fmt: skip
    np.testing.assert_allclose(seg.origin[0], [255.19071198, 406.12081909, 1721.92053223])
    np.testing.assert_allclose(seg.origin[0] + seg.axes[0].T, pycgm, atol=1e-7)
