"""Plug-in Gait's whole-body centre of mass (mocap_mj.clinical.centre_of_mass): a standing
configuration whose centre of mass is worked out by hand, its rigid motion, missing markers,
and the shared Movement trial against the ``CentreOfMass`` and ``CentreOfMassFloor`` Nexus
wrote into it (skipped without it)."""

from __future__ import annotations

from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.centre_of_mass import pig_centre_of_mass
from mocap_mj.clinical.segments import Segment
from mocap_mj.io.load import load_markers

SHARED = Path(__file__).resolve().parents[2] / "shared"
TRIAL = SHARED / "data" / "real" / "Movement_trial.c3d"
RADIUS = 0.007
#: Nexus' CentreOfMass on the Movement trial, ours against it [mm]: the residual is a constant
#: offset of about 1.3 mm (see docs/clinical.md), the bounds hold it with a margin.
COM_RMS_MM, COM_MAX_MM = 1.5, 1.6
FLOOR_RMS_MM, FLOOR_MAX_MM = 1.5, 1.6


def _standing() -> tuple[dict[str, Segment], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """One frame of a symmetric standing body, its segment frames the lab's axes but the
    thorax' (z down) and the foot's (z backwards): segments, joint centres and markers (3,)
    [m]."""
    eye = np.eye(3)
    thorax = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]]).T  # columns x fwd, y right, z down
    foot = np.array([[0, 0, 1.0], [0, 1, 0], [-1, 0, 0]]).T  # columns x up, y left, z back
    segs = {"pelvis": Segment(np.array([0.05, 0, 0.95]), eye),
            "thorax": Segment(np.array([0.1, 0, 1.4]), thorax),
            "head": Segment(np.array([0.1, 0, 1.65]), eye)}  # fmt: skip
    centres: dict[str, np.ndarray] = {}
    for s, y in (("l", 1.0), ("r", -1.0)):
        segs[f"foot_{s}"] = Segment(np.array([0.15, 0.1 * y, 0.08]), foot)  # the toe marker
        for joint, point in (("hip", (0, 0.08, 0.9)), ("knee", (0, 0.09, 0.5)),
                             ("ankle", (0, 0.1, 0.08)), ("shoulder", (0, 0.2, 1.45)),
                             ("elbow", (0, 0.22, 1.15)), ("wrist", (0, 0.23, 0.9)),
                             ("hand", (0, 0.23, 0.85))):  # fmt: skip
            centres[f"{joint}_{s}"] = np.array(point) * [1.0, y, 1.0]
    front = {"LFHD": np.array([0.1, 0.05, 1.65]), "RFHD": np.array([0.1, -0.05, 1.65])}
    markers = {"C7": np.array([-0.1, 0, 1.45]), **front}
    return segs, centres, markers


def _hand_worked() -> np.ndarray:
    """The standing body's centre of mass [m], segment by segment from the published
    definitions (both sides alike, so y is 0). The head length is 0.172 m: twice the 0.1 m
    between the front head markers less a 14 mm marker diameter; the head's origin lies 0.84
    of it behind and 0.3 below the front head markers' mid-point."""
    head = 0.172
    x = (2 * 0.0145 * 0.075  # feet: half-way from the tip (the toe, 0.15 ahead) to the ankle
         + 0.355 * (-0.093 + 0.63 * 0.093)  # thorax: C7 7 mm forward, 0.63 of it to L5
         + 0.081 * (0.1 + (0.52 - 0.84) * head))  # head: 0.52 ahead of its origin  # fmt: skip
    z = (2 * 0.0145 * 0.08
         + 2 * 0.0465 * (0.08 + 0.567 * 0.42)  # tibiae
         + 2 * 0.100 * (0.5 + 0.567 * 0.4)  # femora
         + 2 * 0.006 * (0.8 + 0.6205 * 0.1)  # hands, from the far end 0.1 below the wrist
         + 2 * 0.016 * (0.9 + 0.57 * 0.25)  # radii
         + 2 * 0.028 * (1.15 + 0.564 * 0.3)  # humeri
         + 0.142 * (0.9 + 0.895 * 0.925 * 0.16)  # pelvis: L5 0.925 x 0.16 m above the hips
         + 0.355 * (1.45 + 0.63 * (0.9 + 0.925 * 0.16 - 1.45))  # thorax
         + 0.081 * (1.65 - 0.3 * head))  # fmt: skip
    return np.array([x, 0.0, z])


def _moved(angles: np.ndarray, shifts: np.ndarray) -> tuple[dict, dict, dict, np.ndarray]:
    """The standing body turned about the vertical by ``angles`` (T,) [rad] and moved by
    ``shifts`` (T, 3) [m], frame by frame; the rotations (T, 3, 3)."""
    segs, centres, markers = _standing()
    c, s = np.cos(angles), np.sin(angles)
    rot = np.zeros((len(angles), 3, 3))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0

    def place(p: np.ndarray) -> np.ndarray:
        return np.einsum("tij,j->ti", rot, p) + shifts

    moved = {k: Segment(place(v.origin), rot @ v.axes) for k, v in segs.items()}
    return (
        moved,
        {k: place(v) for k, v in centres.items()},
        {k: place(v) for k, v in markers.items()},
        rot,
    )


def test_standing_body_centre_of_mass_worked_by_hand() -> None:
    """The standing body's centre of mass is the hand-worked one to 1e-12 m; turned and moved
    rigidly, it turns and moves with the body; the floor point drops its vertical only."""
    angles = np.array([0.0, 0.4, -1.1, 2.5])
    shifts = np.array([[0, 0, 0], [1.0, -2.0, 0.1], [0.3, 0.2, -0.05], [-4.0, 1.0, 0.0]])
    segs, centres, markers, rot = _moved(angles, shifts)
    out = pig_centre_of_mass(segs, centres, markers, marker_radius=RADIUS)
    expected = np.einsum("tij,j->ti", rot, _hand_worked()) + shifts
    np.testing.assert_allclose(out["CentreOfMass"], expected, rtol=0, atol=1e-12)
    floor = expected.copy()
    floor[:, 2] = 0.0
    np.testing.assert_allclose(out["CentreOfMassFloor"], floor, rtol=0, atol=1e-12)
    # the recording's lab with -Y up: the Z-up frame's vertical becomes the lab's -Y
    to_lab = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    lab = pig_centre_of_mass(segs, centres, markers, marker_radius=RADIUS, to_lab=to_lab)
    np.testing.assert_allclose(lab["CentreOfMass"], expected @ to_lab.T, atol=1e-12)
    assert np.allclose(lab["CentreOfMassFloor"][:, 1], 0.0)


def test_missing_markers_empty_only_their_frames() -> None:
    """A front head marker missing in one frame (plug_in_gait's head frame NaN there) empties
    that frame alone (no stale value); C7 missing in one frame leaves the thorax' trial-mean
    point, and so every other frame, unchanged; C7 never seen empties every frame."""
    angles, shifts = np.array([0.0, 0.3, 0.6, 0.9]), np.zeros((4, 3))
    segs, centres, markers, _ = _moved(angles, shifts)
    whole = pig_centre_of_mass(segs, centres, markers, marker_radius=RADIUS)["CentreOfMass"]
    gappy = {k: v.copy() for k, v in markers.items()}
    gappy["LFHD"][2] = np.nan
    gappy["C7"][1] = np.nan
    head = segs["head"]
    origin, axes = head.origin.copy(), head.axes.copy()
    origin[2], axes[2] = np.nan, np.nan
    segs = {**segs, "head": Segment(origin, axes)}
    out = pig_centre_of_mass(segs, centres, gappy, marker_radius=RADIUS)
    assert np.isnan(out["CentreOfMass"][2]).all() and np.isnan(out["CentreOfMassFloor"][2]).all()
    keep = [0, 1, 3]
    np.testing.assert_allclose(out["CentreOfMass"][keep], whole[keep], rtol=0, atol=1e-12)
    gappy["C7"][:] = np.nan
    assert np.isnan(pig_centre_of_mass(segs, centres, gappy, marker_radius=RADIUS)
                    ["CentreOfMass"]).all()  # fmt: skip


def _nexus(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Points of a C3D [m] by label (NaN where the residual says invalid)."""
    c3d = ezc3d.c3d(str(path))
    labels = [s.strip() for s in c3d["parameters"]["POINT"]["LABELS"]["value"]]
    pts = c3d["data"]["points"]
    out = {}
    for n in names:
        i = labels.index(n)
        out[n] = np.where((pts[3, i] < 0)[:, None], np.nan, pts[:3, i].T / 1e3)
    return out


def _error_mm(ours: np.ndarray, theirs: np.ndarray) -> tuple[float, float]:
    e = 1e3 * np.linalg.norm(ours - theirs, axis=1)
    return float(np.sqrt(np.mean(e**2))), float(e.max())


def test_movement_trial_against_nexus_centre_of_mass() -> None:
    """The Movement trial: CentreOfMass within COM_RMS_MM RMS and COM_MAX_MM in every frame of
    Nexus'; Nexus' floor point is its centre of mass at z = 0, and so is ours."""
    if not TRIAL.exists():
        pytest.skip(f"{TRIAL} (shared real recording) not present")
    traj = load_markers(TRIAL)
    result = plug_in_gait(traj, pig_from_c3d(TRIAL))
    markers = {n: traj.positions[:, i] for i, n in enumerate(traj.names)}
    ours = pig_centre_of_mass(result.segments, result.centres, markers,
                              marker_radius=result.subject.marker_radius)  # fmt: skip
    nexus = _nexus(TRIAL, ("CentreOfMass", "CentreOfMassFloor"))
    com, floor = nexus["CentreOfMass"], nexus["CentreOfMassFloor"]
    assert np.isfinite(com).all() and np.isfinite(ours["CentreOfMass"]).all()
    np.testing.assert_array_equal(floor[:, :2], com[:, :2])
    assert (floor[:, 2] == 0).all() and (ours["CentreOfMassFloor"][:, 2] == 0).all()
    rms, worst = _error_mm(ours["CentreOfMass"], com)
    assert rms < COM_RMS_MM and worst < COM_MAX_MM, (rms, worst)
    rms, worst = _error_mm(ours["CentreOfMassFloor"], floor)
    assert rms < FLOOR_RMS_MM and worst < FLOOR_MAX_MM, (rms, worst)


@pytest.mark.slow
def test_command_writes_centre_of_mass_without_plates(tmp_path: Path) -> None:
    """plug-in-gait --plates none writes the centre of mass alone into kinetics.csv [mm] and
    into result.c3d [mm], the two the same."""
    if not TRIAL.exists():
        pytest.skip(f"{TRIAL} (shared real recording) not present")
    from mocap_mj.cli import main

    out = tmp_path / "pig"
    argv = ["plug-in-gait", "--markers", str(TRIAL), "--plates", "none", "--out", str(out)]
    assert main(argv) == 0
    lines = (out / "kinetics.csv").read_text().splitlines()
    header = lines[0].split(",")
    axes = [f"{n}_{a}" for n in ("CentreOfMass", "CentreOfMassFloor") for a in "XYZ"]
    assert header == ["frame", "time_s", *axes] and len(lines) == 1 + 323
    table = np.array([[float(v) for v in row.split(",")[2:5]] for row in lines[1:]])
    written = _nexus(out / "result.c3d", ("CentreOfMass", "CentreOfMassFloor"))
    np.testing.assert_allclose(written["CentreOfMass"] * 1e3, table, atol=1e-3)
    nexus = _nexus(TRIAL, ("CentreOfMass",))["CentreOfMass"]
    assert _error_mm(written["CentreOfMass"], nexus)[1] < COM_MAX_MM
