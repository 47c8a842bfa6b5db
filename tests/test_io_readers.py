"""Each marker-file reader on small files written here, and the CSV/TRC writers."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.errors import MocapError
from mocap_mj.io import MarkerTrajectory, load_markers, rotation_to_z_up, save_csv, save_trc
from mocap_mj.io.marker_names import MARKER_NAMES

# A standing Plug-in Gait subject, Z up, metres: (x forward, y left, z up).
_LEFT = {
    "LASI": (0.10, 0.12, 1.00), "LPSI": (-0.10, 0.05, 1.02), "LFHD": (0.08, 0.07, 1.70),
    "LBHD": (-0.08, 0.07, 1.68), "LSHO": (0.00, 0.18, 1.45), "LUPA": (-0.02, 0.20, 1.30),
    "LELB": (-0.03, 0.20, 1.15), "LFRM": (0.00, 0.22, 1.00), "LWRA": (0.02, 0.20, 0.85),
    "LWRB": (-0.02, 0.22, 0.85), "LFIN": (0.00, 0.21, 0.75), "LTHI": (0.05, 0.15, 0.70),
    "LKNE": (0.00, 0.14, 0.50), "LTIB": (0.03, 0.13, 0.30), "LANK": (-0.02, 0.13, 0.08),
    "LHEE": (-0.07, 0.10, 0.05), "LTOE": (0.12, 0.10, 0.05),
}  # fmt: skip
_MIDDLE = {
    "C7": (-0.08, 0.0, 1.50), "T10": (-0.12, 0.0, 1.25), "CLAV": (0.05, 0.0, 1.45),
    "STRN": (0.10, 0.0, 1.30), "RBAK": (-0.12, -0.08, 1.35),
}  # fmt: skip


def standing(n_frames: int = 6, seed: int = 0) -> np.ndarray:
    """(T, 39, 3) [m] positions of MARKER_NAMES for a subject standing and swaying."""
    base = dict(_MIDDLE)
    for name, (x, y, z) in _LEFT.items():
        base[name] = (x, y, z)
        base["R" + name[1:]] = (x, -y, z)
    pose = np.array([base[n] for n in MARKER_NAMES])
    rng = np.random.default_rng(seed)
    sway = 0.02 * np.sin(np.arange(n_frames) / 3.0)[:, None, None] * np.array([1.0, 0.5, 0.0])
    return pose[None] + sway + rng.normal(scale=0.002, size=(n_frames, len(MARKER_NAMES), 3))


def to_file_axes(positions: np.ndarray, up: str) -> np.ndarray:
    """Z-up positions (..., 3) expressed in a frame whose vertical axis is ``up``."""
    return positions @ rotation_to_z_up(up)  # inverse of the loader's positions @ R.T


def write_c3d(
    path: Path,
    labels: Sequence[str],
    positions: np.ndarray,
    rate: float = 100.0,
    units: str = "mm",
    residuals: np.ndarray | None = None,
    extra_point_params: dict[str, list[str]] | None = None,
) -> Path:
    """Write (T, M, 3) ``positions`` (in ``units``) as a C3D file with ezc3d."""
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [rate]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(labels)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [units]
    n_frames, n_points, _ = positions.shape
    points = np.ones((4, n_points, n_frames))
    points[:3] = positions.transpose(2, 1, 0)
    c3d["data"]["points"] = points
    if residuals is not None:
        c3d["data"]["meta_points"] = {
            "residuals": residuals.T[None].astype(float),
            "camera_masks": np.zeros((7, n_points, n_frames), dtype=bool),
        }
    for name, value in (extra_point_params or {}).items():
        c3d.add_parameter("POINT", name, value)
    c3d.write(str(path))
    return path


def _cells(values: np.ndarray) -> list[str]:
    return ["" if np.isnan(v) else f"{v:.6f}" for v in values]


def trc_text(names: Sequence[str], pos: np.ndarray, rate: float, units: str | None) -> str:
    n_frames, n_markers, _ = pos.shape
    keys = "DataRate\tCameraRate\tNumFrames\tNumMarkers" + ("\tUnits" if units else "")
    vals = f"{rate}\t{rate}\t{n_frames}\t{n_markers}" + (f"\t{units}" if units else "")
    lines = [
        "PathFileType\t4\t(X/Y/Z)\tx.trc",
        keys,
        vals,
        "Frame#\tTime\t" + "\t".join(f"{n}\t\t" for n in names),
        "\t\t" + "\t".join(f"X{k}\tY{k}\tZ{k}" for k in range(1, n_markers + 1)),
        "",
    ]
    for t in range(n_frames):
        lines.append("\t".join([str(t + 1), f"{t / rate:.6f}", *_cells(pos[t].ravel())]))
    return "\n".join(lines) + "\n"


def nexus_text(labels: Sequence[str], pos: np.ndarray, rate: float, units: str = "mm") -> str:
    n_frames = pos.shape[0]
    lines = [
        "Devices",
        "1000",
        ",,Imported AMTI Force Plate #1 - Force,,",
        "Frame,Sub Frame,Fx,Fy,Fz",
        ",,N,N,N",
        "1,0,0.1,0.2,700.5",
        "1,1,0.1,0.2,701.5",
        "",
        "Trajectories",
        f"{rate:g}",
        ",," + ",".join(f"{lab},," for lab in labels),
        "Frame,Sub Frame," + ",".join("X,Y,Z" for _ in labels),
        ",," + ",".join(f"{units},{units},{units}" for _ in labels),
    ]
    for t in range(n_frames):
        lines.append(",".join([str(t + 101), "0", *_cells(pos[t].ravel())]))
    lines += ["", "Model Outputs", f"{rate:g}", ",,Derrick:LKneeAngles,,", "Frame,Sub Frame,X,Y,Z"]
    return "\n".join(lines) + "\n"


def motive_text(
    labels: Sequence[str], pos: np.ndarray, rate: float, units: str | None = "Millimeters"
) -> str:
    """Motive export with a rigid body (7 columns) and an unlabelled marker around the data."""
    n_frames = pos.shape[0]
    meta = f"Format Version,1.23,Take Name,Take 1,Capture Frame Rate,{rate:f},"
    meta += f"Export Frame Rate,{rate:f},Rotation Type,Quaternion"
    meta += f",Length Units,{units}" if units else ""
    meta += ",Coordinate Space,Global"
    n_cols = 3 * len(labels)
    types = ["Rigid Body"] * 7 + ["Marker"] * (n_cols + 3)
    names = ["RB1"] * 7 + [lab for lab in labels for _ in "xyz"] + ["Unlabeled 1000"] * 3
    ids = ["1"] * 7 + [str(10 + k) for k in range(len(labels)) for _ in "xyz"] + ["9"] * 3
    kinds = ["Rotation"] * 4 + ["Position"] * (3 + n_cols + 3)
    axes = ["X", "Y", "Z", "W", "X", "Y", "Z"] + ["X", "Y", "Z"] * (len(labels) + 1)
    lines = [
        meta,
        "",
        ",Type," + ",".join(types),
        ",Name," + ",".join(names),
        ",ID," + ",".join(ids),
        ",," + ",".join(kinds),
        "Frame,Time (Seconds)," + ",".join(axes),
    ]
    rigid = ["0", "0", "0", "1", "1.0", "2.0", "3.0"]
    for t in range(n_frames):
        cells = [str(t), f"{t / rate:.6f}", *rigid, *_cells(pos[t].ravel()), "5", "", "7"]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------- C3D


def test_c3d_markers_units_missing_samples_and_dropped_points(tmp_path: Path) -> None:
    truth = standing(8)
    extra_names = ["PELO", "LKneeAngles", "*12", "CentreOfMass", "LHipPower", "MYOUTPUT"]
    labels = [*MARKER_NAMES, *extra_names]
    pos = np.concatenate([truth, np.full((8, len(extra_names), 3), 7.0)], axis=1) * 1000.0
    residuals = np.zeros(pos.shape[:2])
    residuals[2, 0] = -1.0  # LASI not seen in frame 2
    pos[4, 1] = 0.0  # RASI all-zero in frame 4: missing
    path = write_c3d(
        tmp_path / "trial.c3d", labels, pos, rate=120.0, residuals=residuals,
        extra_point_params={"ANGLES": ["LKneeAngles"], "SCALARS": ["MYOUTPUT"]},
    )  # fmt: skip
    traj = load_markers(path)
    assert traj.names == MARKER_NAMES
    assert traj.rate == 120.0
    assert traj.source["format"] == "c3d" and traj.source["units"] == "mm"
    assert traj.source["up"] == "z" and traj.source["up_detected"]
    assert sorted(traj.source["dropped"]) == sorted(extra_names)
    expect = truth.copy()
    expect[2, 0] = np.nan
    expect[4, 1] = np.nan
    np.testing.assert_allclose(traj.positions, expect, atol=1e-6)  # float32 storage
    np.testing.assert_allclose(traj.times, np.arange(8) / 120.0)


@pytest.mark.parametrize(("units", "scale"), [("mm", 1000.0), ("m", 1.0), ("cm", 100.0)])
def test_c3d_units_give_the_same_metres(tmp_path: Path, units: str, scale: float) -> None:
    truth = standing(3)
    path = write_c3d(tmp_path / f"u_{units}.c3d", MARKER_NAMES, truth * scale, units=units)
    traj = load_markers(path)
    assert traj.source["units"] == units
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)


def test_c3d_more_than_255_points_reads_labels2(tmp_path: Path) -> None:
    truth = standing(2)
    filler = [f"EXTRA{k:03d}" for k in range(261)]
    pos = np.concatenate([np.full((2, 261, 3), 500.0), truth * 1000.0], axis=1)
    path = write_c3d(tmp_path / "many.c3d", [*filler, *MARKER_NAMES], pos)
    traj = load_markers(path)
    assert traj.n_markers == 300
    assert traj.names[-39:] == MARKER_NAMES
    assert traj.marker_report().missing == ()
    np.testing.assert_allclose(traj.select(MARKER_NAMES), truth, atol=1e-6)
    assert traj.source["extras"] == filler


def test_c3d_minus_z_file_ends_up_z_up(tmp_path: Path) -> None:
    truth = standing(4)
    path = write_c3d(tmp_path / "minus_z.c3d", MARKER_NAMES, to_file_axes(truth, "-z") * 1000)
    traj = load_markers(path)
    assert traj.source["up"] == "-z" and traj.source["up_detected"]
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)


def test_c3d_subject_prefix_is_stripped(tmp_path: Path) -> None:
    truth = standing(2)
    labels = [f"Derrick:{n}" for n in MARKER_NAMES]
    traj = load_markers(write_c3d(tmp_path / "p.c3d", labels, truth * 1000))
    assert traj.names == MARKER_NAMES
    assert traj.source["subject"] == "Derrick"


# --------------------------------------------------------------------------------------- TRC


def test_trc_reader_metres_and_gaps(tmp_path: Path) -> None:
    truth = standing(5)
    truth[1, 3] = np.nan
    path = tmp_path / "walk.trc"
    path.write_text(trc_text(MARKER_NAMES, truth, 50.0, "m"))
    traj = load_markers(path)
    assert traj.source["format"] == "trc" and traj.rate == 50.0
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)
    assert np.isnan(traj.positions[1, 3]).all()


def test_trc_without_units_assumes_mm_and_says_so(tmp_path: Path) -> None:
    truth = standing(2)
    path = tmp_path / "nounits.trc"
    path.write_text(trc_text(MARKER_NAMES, truth * 1000, 100.0, None))
    traj = load_markers(path)
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)
    assert "assumed mm" in traj.source["units_note"]


def test_trc_whitespace_separated(tmp_path: Path) -> None:
    lines = [
        "PathFileType 4 (X/Y/Z) a.trc",
        "DataRate CameraRate NumFrames NumMarkers Units",
        "10 10 2 2 mm",
        "Frame# Time A B",
        "X1 Y1 Z1 X2 Y2 Z2",
        "1 0.0 1 2 3 4 5 1600",
        "2 0.1 1 2 3 4 5 1700",
    ]
    path = tmp_path / "ws.trc"
    path.write_text("\n".join(lines) + "\n")
    traj = load_markers(path, up="z")
    assert traj.names == ("A", "B")
    np.testing.assert_allclose(traj.positions[1, 1], [0.004, 0.005, 1.7])


# ------------------------------------------------------------------------------ Vicon Nexus


def test_nexus_csv_skips_devices_and_strips_prefix(tmp_path: Path) -> None:
    truth = standing(4)
    truth[2, 5] = np.nan
    labels = [f"Derrick:{n}" for n in MARKER_NAMES] + ["Derrick:*7"]
    pos = np.concatenate([truth, np.ones((4, 1, 3))], axis=1) * 1000.0
    path = tmp_path / "nexus.csv"
    path.write_text(nexus_text(labels, pos, 100.0))
    traj = load_markers(path)
    assert traj.source["format"] == "vicon nexus csv"
    assert traj.names == MARKER_NAMES and traj.rate == 100.0
    assert traj.source["dropped"] == ["Derrick:*7"]
    assert traj.source["first_frame"] == 101
    # frame f of the recording at (f - 1) / rate, as its own software counts it
    np.testing.assert_allclose(traj.times, (101 + np.arange(4) - 1) / 100.0)
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)


# --------------------------------------------------------------------------- OptiTrack Motive


def test_motive_csv_y_up_ends_up_z_up(tmp_path: Path) -> None:
    truth = standing(5)
    truth[3, 0] = np.nan
    labels = [f"Skeleton:{n}" for n in MARKER_NAMES]
    path = tmp_path / "take.csv"
    path.write_text(motive_text(labels, to_file_axes(truth, "y"), 120.0, "Meters"))
    traj = load_markers(path)
    assert traj.source["format"] == "optitrack motive csv"
    assert traj.source["up"] == "y" and traj.source["up_detected"]
    assert traj.names == MARKER_NAMES and traj.rate == 120.0
    assert "RB1 (Rigid Body)" in traj.source["dropped"]
    assert "Unlabeled 1000" in traj.source["dropped"]
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)


def test_motive_without_head_or_feet_uses_its_y_up_default(tmp_path: Path) -> None:
    truth = standing(3)[:, :4]  # pelvis only: detection cannot decide
    path = tmp_path / "pelvis.csv"
    path.write_text(motive_text(MARKER_NAMES[:4], to_file_axes(truth, "y") * 1000, 100.0))
    traj = load_markers(path)
    assert traj.source["up"] == "y" and not traj.source["up_detected"]
    np.testing.assert_allclose(traj.positions, truth, atol=1e-6)


# ---------------------------------------------------------------------- mocap-mj CSV and TRC


def _with_gaps(n_frames: int = 7) -> MarkerTrajectory:
    pos = standing(n_frames, seed=3)
    pos[0, 2] = np.nan
    pos[4, 10:13] = np.nan
    pos[:, 20] = np.nan  # never seen
    return MarkerTrajectory(np.arange(n_frames) / 120.0 + 0.5, pos, MARKER_NAMES, 120.0, {})


@pytest.mark.parametrize(("save", "suffix"), [(save_csv, ".csv"), (save_trc, ".trc")])
def test_round_trip_to_a_micrometre_with_nans(tmp_path: Path, save, suffix: str) -> None:
    traj = _with_gaps()
    path = tmp_path / f"rt{suffix}"
    save(path, traj)
    back = load_markers(path)
    assert back.names == traj.names
    assert back.rate == traj.rate
    np.testing.assert_array_equal(np.isnan(back.positions), np.isnan(traj.positions))
    np.testing.assert_allclose(back.positions, traj.positions, atol=1e-6, rtol=0)
    np.testing.assert_allclose(back.times, traj.times, atol=1e-8, rtol=0)
    first = path.read_bytes()
    save(path, back)  # deterministic text: same trajectory, same bytes
    assert path.read_bytes() == first


def test_csv_round_trip_keeps_arbitrary_axes_via_up_setting(tmp_path: Path) -> None:
    # Data with feet above the head would be flipped by detection; the up=z line prevents it.
    # (Turned 180 degrees about x: negating all three axes would mirror the subject, which
    # the loader refuses.)
    traj = _with_gaps()
    turned = traj.positions * np.array([1.0, -1.0, -1.0])
    flipped = MarkerTrajectory(traj.times, turned, traj.names, traj.rate, {})
    path = tmp_path / "flip.csv"
    save_csv(path, flipped)
    back = load_markers(path)
    assert back.source["up"] == "z" and not back.source["up_detected"]
    np.testing.assert_allclose(back.positions, flipped.positions, atol=1e-6)


def test_csv_without_comment_defaults_to_mm_and_rate_from_times(tmp_path: Path) -> None:
    path = tmp_path / "plain.csv"
    path.write_text("frame,time,A_X,A_Y,A_Z\n0,0.0,1,2,3\n1,0.004,1,2,\n2,0.008,4,5,6\n")
    traj = load_markers(path)
    assert traj.rate == pytest.approx(250.0)
    np.testing.assert_allclose(traj.positions[2, 0], [0.004, 0.005, 0.006])
    assert np.isnan(traj.positions[1, 0]).all()  # one empty coordinate: the sample is missing


def test_csv_written_file_layout(tmp_path: Path) -> None:
    pos = np.array([[[0.001, -0.002, 1.5]], [[np.nan] * 3]])
    traj = MarkerTrajectory(np.array([0.0, 0.01]), pos, ("C7",), 100.0)
    path = tmp_path / "small.csv"
    save_csv(path, traj)
    assert path.read_text().splitlines() == [
        "# mocap-mj markers v1 units=mm rate=100.0 up=z",
        "frame,time,C7_X,C7_Y,C7_Z",
        "0,0.000000000,1.000000,-2.000000,1500.000000",
        "1,0.010000000,,,",
    ]


def test_format_comes_from_content_not_extension(tmp_path: Path) -> None:
    traj = _with_gaps(5)
    odd = tmp_path / "markers.dat"
    save_trc(odd, traj)
    assert load_markers(odd).source["format"] == "trc"
    csv_as_c3d = tmp_path / "really_csv.c3d"
    save_csv(csv_as_c3d, traj)
    assert load_markers(csv_as_c3d).source["format"] == "mocap-mj csv"
    nexus_txt = tmp_path / "nexus.txt"
    nexus_txt.write_text(nexus_text(MARKER_NAMES, standing(2) * 1000, 100.0))
    assert load_markers(nexus_txt).source["format"] == "vicon nexus csv"
    c3d_bin = tmp_path / "c3d.bin"  # ezc3d insists on writing *.c3d: rename after
    write_c3d(tmp_path / "tmp.c3d", MARKER_NAMES, standing(2) * 1000).rename(c3d_bin)
    assert load_markers(c3d_bin).source["format"] == "c3d"


def test_writers_refuse_names_they_cannot_represent(tmp_path: Path) -> None:
    traj = MarkerTrajectory(np.zeros(1), np.zeros((1, 1, 3)), ("bad,name",), 100.0)
    with pytest.raises(MocapError, match="bad,name"):
        save_csv(tmp_path / "x.csv", traj)
    traj = MarkerTrajectory(np.zeros(1), np.zeros((1, 1, 3)), ("bad name",), 100.0)
    with pytest.raises(MocapError, match="bad name"):
        save_trc(tmp_path / "x.trc", traj)
    assert list(tmp_path.iterdir()) == []


def test_c3d_metadata_never_drops_model_markers_or_mapped_names(tmp_path: Path) -> None:
    truth = standing(2)
    labels = [*MARKER_NAMES, "LKJC"]
    pos = np.concatenate([truth, np.full((2, 1, 3), 0.5)], axis=1) * 1000
    params = {"MODELED_MARKERS": ["LKJC"], "ANGLES": ["LASI"]}  # the second is a lie
    path = write_c3d(tmp_path / "meta.c3d", labels, pos, extra_point_params=params)
    traj = load_markers(path)
    assert traj.names == MARKER_NAMES and traj.source["dropped"] == ["LKJC"]
    mapped = load_markers(path, marker_map={"LKJC": "LKNEE_CENTRE"})
    assert mapped.names == (*MARKER_NAMES, "LKNEE_CENTRE")
    assert mapped.source["extras"] == ["LKNEE_CENTRE"] and mapped.source["dropped"] == []
