"""load_markers: subjects, marker maps, units, vertical axis, and leaving inputs untouched."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.errors import InputFileError, MocapError, UnknownNameError
from mocap_mj.io import UP_AXES, load_markers, rotation_to_z_up

# Head, trunk, pelvis and feet of a standing subject, Z up, metres.
POSE = {
    "LFHD": (0.08, 0.07, 1.70), "RFHD": (0.08, -0.07, 1.70), "C7": (-0.08, 0.0, 1.50),
    "LASI": (0.10, 0.12, 1.00), "RASI": (0.10, -0.12, 1.00), "LFRA": (0.0, 0.22, 1.00),
    "LANK": (-0.02, 0.13, 0.08), "RANK": (-0.02, -0.13, 0.08), "LTOE": (0.12, 0.10, 0.05),
}  # fmt: skip


def pose(n_frames: int = 4) -> tuple[list[str], np.ndarray]:
    names = list(POSE)
    base = np.array([POSE[n] for n in names])
    drift = np.linspace(0.0, 0.03, n_frames)[:, None, None] * np.array([1.0, 0.0, 0.0])
    return names, base[None] + drift


def csv_text(
    labels: Sequence[str], positions_mm: np.ndarray, header: str = "units=mm rate=100"
) -> str:
    """A mocap-mj CSV (without an up= setting unless ``header`` has one)."""
    lines = [f"# mocap-mj markers v1 {header}".rstrip()]
    lines.append(",".join(["frame", "time", *[f"{n}_{a}" for n in labels for a in "XYZ"]]))
    for t, row in enumerate(positions_mm):
        cells = ["" if np.isnan(v) else f"{v:.6f}" for v in row.ravel()]
        lines.append(",".join([str(t), f"{t / 100:.6f}", *cells]))
    return "\n".join(lines) + "\n"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------------------ subjects


def test_several_subjects_need_subject_and_error_lists_them(tmp_path: Path) -> None:
    names, pos = pose()
    labels = [f"Ann:{n}" for n in names] + [f"Bob:{n}" for n in names]
    shift = np.array([1.0, 0.0, 0.0])
    both = np.concatenate([pos, pos + shift], axis=1) * 1000
    path = write(tmp_path, "two.csv", csv_text(labels, both))
    with pytest.raises(InputFileError, match=r"Ann, Bob") as info:
        load_markers(path)
    assert str(path) in str(info.value) and "--subject" in str(info.value)
    bob = load_markers(path, subject="bob")  # subject names match case-insensitively
    assert bob.names == tuple("LFRM" if n == "LFRA" else n for n in names)
    assert bob.source["subject"] == "Bob" and bob.source["subjects"] == ["Ann", "Bob"]
    np.testing.assert_allclose(bob.positions, pos + shift, atol=1e-9)
    assert len(bob.source["other_subjects_markers"]) == len(names)
    want = r"--subject: expected one of the file's subjects \(Ann, Bob\), got 'Cy'"
    with pytest.raises(InputFileError, match=want):
        load_markers(path, subject="Cy")


def test_single_prefix_is_stripped_without_subject(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "p.csv", csv_text([f"P01:{n}" for n in names], pos * 1000))
    traj = load_markers(path)
    assert traj.names == tuple("LFRM" if n == "LFRA" else n for n in names)  # built-in alias
    assert traj.source["subject"] == "P01" and traj.source["aliased"] == {"LFRA": "LFRM"}


def test_same_name_after_prefix_stripping_is_an_error(tmp_path: Path) -> None:
    names, pos = pose()
    labels = [f"P01:{n}" for n in names[:-1]] + ["LASI"]  # P01:LASI and LASI
    path = write(tmp_path, "dup.csv", csv_text(labels, pos * 1000))
    with pytest.raises(InputFileError, match=r"'LASI' twice") as info:
        load_markers(path)
    assert str(info.value).startswith(f"{path}: line 2:")


# ---------------------------------------------------------------------------- marker map


def test_marker_map_dict_renames_after_prefix(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "m.csv", csv_text([f"S:{n}" for n in names], pos * 1000))
    traj = load_markers(path, marker_map={"LFRA": "LFRM"})
    assert "LFRM" in traj.names and "LFRA" not in traj.names
    assert traj.source["renamed"] == {"LFRA": "LFRM"}
    np.testing.assert_allclose(traj.select(["LFRM"])[:, 0], pos[:, names.index("LFRA")])


@pytest.mark.parametrize(
    ("suffix", "text"), [(".yaml", "LFRA: LFRM\nRANK: RANKX\n"), (".json", '{"LFRA": "LFRM"}')]
)
def test_marker_map_from_file(tmp_path: Path, suffix: str, text: str) -> None:
    names, pos = pose()
    path = write(tmp_path, "m.csv", csv_text(names, pos * 1000))
    map_file = write(tmp_path, f"map{suffix}", text)
    traj = load_markers(path, marker_map=map_file)
    assert "LFRM" in traj.names
    assert traj.marker_report().fraction_present["LFRM"] == 1.0


def test_marker_map_keeps_a_name_that_would_be_dropped(tmp_path: Path) -> None:
    names, pos = pose()
    labels = [*names[:-1], "*12"]  # an unlabelled point the lab knows is LTOE
    path = write(tmp_path, "u.csv", csv_text(labels, pos * 1000))
    assert "*12" in load_markers(path).source["dropped"]
    assert "LTOE" in load_markers(path, marker_map={"*12": "LTOE"}).names


def test_marker_map_onto_an_existing_name_is_a_duplicate(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "d.csv", csv_text(names, pos * 1000))
    with pytest.raises(InputFileError, match=r"'LASI' twice"):
        load_markers(path, marker_map={"RASI": "LASI"})


@pytest.mark.parametrize("text", ["LFRA: [LFRM\n", "- LFRA\n- LFRM\n", "LFRA: 3\n", "LFRA: ''\n"])
def test_bad_marker_map_file_names_the_map(tmp_path: Path, text: str) -> None:
    names, pos = pose()
    path = write(tmp_path, "m.csv", csv_text(names, pos * 1000))
    map_file = write(tmp_path, "bad_map.yaml", text)
    with pytest.raises(InputFileError) as info:
        load_markers(path, marker_map=map_file)
    assert str(map_file) in str(info.value) and "\n" not in str(info.value)


def test_missing_marker_map_file(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "m.csv", csv_text(names, pos * 1000))
    with pytest.raises(InputFileError, match=r"nothere\.yaml"):
        load_markers(path, marker_map=tmp_path / "nothere.yaml")


# --------------------------------------------------------------------------------- units


@pytest.mark.parametrize(
    ("unit", "scale"), [("mm", 1e3), ("cm", 1e2), ("m", 1.0), ("Millimeters", 1e3)]
)
def test_units_convert_to_metres(tmp_path: Path, unit: str, scale: float) -> None:
    names, pos = pose()
    path = write(tmp_path, "u.csv", csv_text(names, pos * scale, f"units={unit} rate=100"))
    traj = load_markers(path)
    np.testing.assert_allclose(traj.positions, pos, atol=1e-9)
    assert traj.source["units"] == unit


def test_unknown_unit_names_file_and_unit(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "in.csv", csv_text(names, pos * 39.37, "units=inch rate=100"))
    with pytest.raises(InputFileError) as info:
        load_markers(path)
    assert str(info.value) == (
        f"{path}: line 1: expected length units mm, cm or m, got 'inch' (pass --units to say which)"
    )


# ---------------------------------------------------------------------------- up axis


def test_rotations_are_proper_and_map_up_to_z() -> None:
    for up in UP_AXES:
        rot = rotation_to_z_up(up)
        np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(rot) == pytest.approx(1.0)
        axis = np.zeros(3)
        axis["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
        np.testing.assert_allclose(rot @ axis, [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_array_equal(rotation_to_z_up("+Y"), rotation_to_z_up("y"))


@pytest.mark.parametrize("up", UP_AXES)
def test_detected_vertical_axis_ends_up_z(tmp_path: Path, up: str) -> None:
    names, pos = pose()
    in_file = pos @ rotation_to_z_up(up)  # the same subject, recorded with `up` vertical
    path = write(tmp_path, f"up{up}.csv", csv_text(names, in_file * 1000))
    traj = load_markers(path)
    assert traj.source["up"] == up and traj.source["up_detected"]
    np.testing.assert_allclose(traj.positions, pos, atol=1e-9)


def test_trunk_markers_stand_in_for_the_head(tmp_path: Path) -> None:
    names, pos = pose()
    keep = [i for i, n in enumerate(names) if n not in ("LFHD", "RFHD")]
    in_file = pos[:, keep] @ rotation_to_z_up("-y")
    path = write(tmp_path, "c7.csv", csv_text([names[i] for i in keep], in_file * 1000))
    traj = load_markers(path)
    assert traj.source["up"] == "-y" and "C7" in traj.source["up_how"]


def test_explicit_up_overrides_detection(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "z.csv", csv_text(names, pos * 1000))
    traj = load_markers(path, up="-z")
    assert traj.source["up"] == "-z" and not traj.source["up_detected"]
    np.testing.assert_allclose(traj.positions, pos * [1.0, -1.0, -1.0], atol=1e-9)


def test_header_up_setting_is_used(tmp_path: Path) -> None:
    names, pos = pose()
    in_file = pos @ rotation_to_z_up("x")
    path = write(tmp_path, "x.csv", csv_text(names, in_file * 1000, "units=mm rate=100 up=x"))
    traj = load_markers(path)
    assert traj.source["up"] == "x" and not traj.source["up_detected"]
    np.testing.assert_allclose(traj.positions, pos, atol=1e-9)


def test_without_head_and_feet_up_defaults_to_z(tmp_path: Path) -> None:
    names, pos = pose()
    keep = [i for i, n in enumerate(names) if n in ("LASI", "RASI", "LFRA")]
    path = write(tmp_path, "pelvis.csv", csv_text([names[i] for i in keep], pos[:, keep] * 1e3))
    traj = load_markers(path)
    assert traj.source["up"] == "z" and not traj.source["up_detected"]
    assert "assumed z" in traj.source["up_how"]


def test_lying_subject_is_not_guessed(tmp_path: Path) -> None:
    names, pos = pose()
    flat = pos.copy()
    flat[..., 2] *= 0.1  # head barely above the feet: no clear vertical
    path = write(tmp_path, "lying.csv", csv_text(names, flat * 1000))
    traj = load_markers(path)
    assert not traj.source["up_detected"] and traj.source["up"] == "z"


@pytest.mark.parametrize("bad", ["w", "up", "zz", ""])
def test_bad_up_argument(tmp_path: Path, bad: str) -> None:
    names, pos = pose()
    path = write(tmp_path, "a.csv", csv_text(names, pos * 1000))
    with pytest.raises(UnknownNameError, match="up axis"):
        load_markers(path, up=bad)


# ---------------------------------------------------------------------------- the file


def test_input_file_is_never_modified(tmp_path: Path) -> None:
    names, pos = pose()
    path = write(tmp_path, "ro.csv", csv_text(names, pos * 1000))
    path.chmod(0o444)
    before = (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns)
    load_markers(path, marker_map={"LFRA": "LFRM"}, up="y")
    after = (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns)
    assert before == after
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro.csv"]


def test_source_is_json_serialisable(tmp_path: Path) -> None:
    names, pos = pose()
    traj = load_markers(write(tmp_path, "s.csv", csv_text(names, pos * 1000)))
    text = json.dumps(traj.source)
    assert "mocap-mj csv" in text and str(tmp_path) in text


def test_every_error_is_a_mocap_error(tmp_path: Path) -> None:
    with pytest.raises(MocapError):
        load_markers(tmp_path / "absent.trc")


def test_cmu_and_vicon_template_names_get_plug_in_gait_names(tmp_path: Path) -> None:
    """The CMU 41-marker set's waist, shin and back markers (Vicon's labelling-template names)
    load as Plug-in Gait's; its fifth-metatarsal marker, which Plug-in Gait lacks, stays extra."""
    cmu = ["LFWT", "RFWT", "LBWT", "RBWT", "LSHN", "RSHN", "RBAC", "LMT5", "C7", "LKNE"]
    pos = np.arange(4 * len(cmu) * 3, dtype=float).reshape(4, len(cmu), 3) * 10.0 + 100.0
    traj = load_markers(write(tmp_path, "cmu.csv", csv_text(cmu, pos)))
    assert traj.source["aliased"] == {
        "LFWT": "LASI", "RFWT": "RASI", "LBWT": "LPSI", "RBWT": "RPSI",
        "LSHN": "LTIB", "RSHN": "RTIB", "RBAC": "RBAK",
    }  # fmt: skip
    pig = ("LASI", "RASI", "LPSI", "RPSI", "LTIB", "RTIB", "RBAK")
    assert traj.names == (*pig, "LMT5", "C7", "LKNE")
    np.testing.assert_allclose(traj.select(["LPSI"])[:, 0], pos[:, 2] / 1000.0)
