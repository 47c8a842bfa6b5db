"""Our joint centres against Vicon Nexus's bone points (clinical/nexus_centres.py,
clinical/centre_causes.py, outputs/nexus_out.py).

Synthetic arrays: a known offset in a known Nexus segment frame gives its distance and its
anterior / lateral / proximal components back, the frame of a turned recording is found
from the markers, the explanation rules; a C3D without bone points gives nothing. On the
shared Movement_trial.c3d (skipped without ../shared/data): identify's report.md has the
section, every centre over 10 mm an explanation, and Davis's hip regression on our pelvis
reproduces Nexus's hip centres.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mocap_mj.cli import main
from mocap_mj.clinical.centre_causes import explanation
from mocap_mj.clinical.nexus_centres import (
    CentreGap,
    NexusOutput,
    centre_gaps,
    lab_from_ours,
    read_nexus,
    rows_for,
)
from mocap_mj.errors import MocapError
from mocap_mj.io.formats.c3d_write import write_markers_c3d
from mocap_mj.outputs.nexus_out import centres_vs_nexus

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: the Nexus comparison needs the shared folder"
T = 40
#: Lab axes of a subject facing +x, left +y, up +z.
ANT, LEFT, UP = np.eye(3)


def _turning(seed: int = 0) -> np.ndarray:
    """Rotations (T, 3, 3) about the vertical, a different heading every frame."""
    a = np.random.default_rng(seed).uniform(-np.pi, np.pi, T)
    c, s = np.cos(a), np.sin(a)
    r = np.zeros((T, 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    return r


def _segment(points: dict[str, np.ndarray], code: str, origin: np.ndarray,
             axes: np.ndarray, turn: np.ndarray) -> None:  # fmt: skip
    """Nexus's O, A, L, P points of ``code`` at ``origin`` (T, 3) with the columns of
    ``axes`` (3, 3) (lab directions of the subject facing +x) turned by ``turn``."""
    points[code + "O"] = origin
    for k, letter in enumerate("ALP"):
        points[code + letter] = origin + 0.1 * (turn @ axes[:, k])


def _nexus(points: dict[str, np.ndarray]) -> NexusOutput:
    return NexusOutput(np.arange(1, T + 1), points, {}, None, "synthetic.c3d")


def test_known_offset_in_known_frames() -> None:
    """Ours = Nexus's + 30 mm anterior, 10 mm lateral, 5 mm distal, in the left femur
    (Plug-in Gait: x anterior, y left, z up) and the right humerus (x posterior, y to the
    right, z up): the distance and the components come back, for either side's table."""
    turn = _turning()
    rng = np.random.default_rng(1)
    knee, elbow = rng.normal(0, 0.5, (T, 3)), rng.normal(0, 0.5, (T, 3))
    pts: dict[str, np.ndarray] = {"LFEO": knee, "RHUO": elbow}
    _segment(pts, "LFE", knee, np.stack([ANT, LEFT, UP], axis=1), turn)
    _segment(pts, "RHU", elbow, np.stack([-ANT, -LEFT, UP], axis=1), turn)
    pts["LKNE"] = knee + turn @ (0.08 * LEFT)  # the knee marker lateral of Nexus's centre
    offset_l = 0.030 * ANT + 0.010 * LEFT - 0.005 * UP  # lateral is +y on the left
    offset_r = 0.030 * ANT - 0.010 * LEFT - 0.005 * UP  # and -y on the right
    ours = {"knee_l": knee + turn @ offset_l, "elbow_r": elbow + turn @ offset_r}
    gaps = {g.joint: g for g in centre_gaps(_nexus(pts), np.arange(T), ours)}
    assert set(gaps) == {"knee_l", "elbow_r"}
    for g in gaps.values():
        assert g.frames == T
        assert g.distance == pytest.approx(np.sqrt(0.03**2 + 0.01**2 + 0.005**2), abs=1e-9)
        np.testing.assert_allclose(g.components, [0.030, 0.010, -0.005], atol=1e-9)
        np.testing.assert_allclose(g.components_sd, 0.0, atol=1e-9)
    k = gaps["knee_l"]
    assert k.marker == "LKNE" and k.from_marker is not None and k.marker_angle is not None
    assert k.from_marker[1] == pytest.approx(0.08)
    mine = np.array([0.030, -0.07, -0.005])  # ours - KNE: anterior, medial, distal
    assert k.from_marker[0] == pytest.approx(np.linalg.norm(mine))
    cos = mine @ np.array([0.0, -0.08, 0.0]) / (np.linalg.norm(mine) * 0.08)
    assert k.marker_angle == pytest.approx(np.arccos(cos))
    assert k.marker_anterior == pytest.approx((0.030, 0.0), abs=1e-9)


def test_lab_frame_of_a_turned_recording() -> None:
    """Markers read turned (a Y-up file made Z-up) and shifted: the rigid map back to the
    file's frame is found; a marker set that does not match the file is refused."""
    rng = np.random.default_rng(2)
    names = ("A", "B", "C", "D")
    lab = rng.normal(0, 1, (T, 4, 3))
    rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    ours = (lab - 0.2) @ rot  # lab = ours @ rot.T + 0.2
    nexus = _nexus({n: lab[:, i] for i, n in enumerate(names)})
    r, t = lab_from_ours(nexus, np.arange(T), names, ours)
    np.testing.assert_allclose(r, rot, atol=1e-9)
    np.testing.assert_allclose(t, 0.2, atol=1e-9)
    with pytest.raises(MocapError, match="not the recording fitted"):
        lab_from_ours(nexus, np.arange(T), names, ours + rng.normal(0, 0.01, ours.shape))
    with pytest.raises(MocapError, match="fewer than three of our markers"):
        lab_from_ours(nexus, np.arange(T), ("X", "Y", "Z", "W"), ours)


def test_rows_by_number_or_position() -> None:
    nexus = _nexus({})
    np.testing.assert_array_equal(rows_for(np.array([5, 6, 41]), nexus), [4, 5, -1])
    np.testing.assert_array_equal(rows_for(np.array([0]), nexus), [0])  # counted from 0


def _gap(distance: float, **figures: object) -> CentreGap:
    return CentreGap("elbow_l", "LHUO", T, distance, np.zeros(3), np.full(3, 0.01),
                     **figures)  # type: ignore[arg-type]  # fmt: skip


def test_explanations() -> None:
    """Within 10 mm: none; without figures: the tool says it measures no cause; the
    construction on our proximal centre near Nexus's and far from ours names our placement,
    the reverse the proximal centre; both at one distance from the marker but apart seen
    from it: a direction (a different distance alone shows no cause)."""
    assert explanation(_gap(0.009)) is None
    assert "measures no cause" in str(explanation(_gap(0.02)))
    near_nexus = explanation(_gap(0.02, proximal="shoulder", construction=(0.004, 0.02)))
    assert "its placement about the marker moves it, not the shoulder centre" in str(near_nexus)
    near_ours = explanation(_gap(0.02, proximal="shoulder", construction=(0.02, 0.004)))
    assert "the shoulder centre it hangs from moves it" in str(near_ours)
    both = explanation(_gap(0.02, proximal="shoulder", construction=(0.012, 0.012)))
    assert "measures no cause" in str(both)
    turned = explanation(_gap(0.02, marker="LELB", from_marker=(0.055, 0.055),
                              marker_angle=np.radians(21.0)))  # fmt: skip
    assert "ours lies 55 mm, nexus's 55 mm from lelb, 21 deg apart" in str(turned).lower()
    assert "no cause" not in str(turned)
    deeper = explanation(_gap(0.02, marker="LELB", from_marker=(0.075, 0.055),
                              marker_angle=np.radians(21.0)))  # fmt: skip
    assert "measures no cause" in str(deeper)


def test_c3d_with_and_without_bone_points(tmp_path: Path) -> None:
    """A C3D holding only markers gives None, and identify's outputs no section and no
    summary key; one holding LFEO gives its points in metres."""
    xyz = np.random.default_rng(3).normal(0, 1, (5, 2, 3))
    write_markers_c3d(tmp_path / "markers.c3d", xyz, ["LKNE", "LANK"], 100.0)
    assert read_nexus(tmp_path / "markers.c3d") is None
    fit = SimpleNamespace(trials=[SimpleNamespace(name=str(tmp_path / "markers.c3d"))])
    assert centres_vs_nexus(fit, {}) == ([], None)  # type: ignore[arg-type]
    write_markers_c3d(tmp_path / "nexus.c3d", xyz, ["LKNE", "Sub:LFEO"], 100.0)
    nexus = read_nexus(tmp_path / "nexus.c3d")
    assert nexus is not None
    np.testing.assert_allclose(nexus.points["LFEO"], xyz[:, 1], atol=1e-6)


@pytest.fixture(scope="module")
def movement(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:  # type: ignore[type-arg]
    path = REAL / "Movement_trial.c3d"
    if not path.is_file():
        pytest.skip(SKIP)
    out = tmp_path_factory.mktemp("nexus") / "result"
    assert main(["identify", "--markers", str(path), "--out", str(out), "--json"]) == 0
    return out, json.loads((out / "summary.json").read_text())


def test_movement_trial_report(movement: tuple[Path, dict]) -> None:  # type: ignore[type-arg]
    """Every centre of both sides compared, every one over 10 mm explained by a measured
    cause, and Davis's regression on our pelvis within 10 mm of Nexus's hips (Plug-in
    Gait's hip centre is Davis's: the ground truth of the hips' explanation)."""
    out, summary = movement
    report = (out / "report.md").read_text()
    assert "## Joint centres against Plug-in Gait" in report
    centres = summary["joint_centres_vs_plug_in_gait"]["centres"]
    joints = ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")
    assert set(centres) == {f"{j}_{s}" for j in joints for s in "lr"}
    for name, c in centres.items():
        if c["distance_mm"] > 10:
            assert c["explanation"], name
            assert "no cause" not in c["explanation"], name
            assert f"| {name} | {c['nexus_point']} |" in report
        else:
            assert c["explanation"] is None
    for hip in ("hip_l", "hip_r"):
        assert centres[hip]["alternative"]["to_nexus_mm"] < 10.0
        assert centres[hip]["distance_mm"] > centres[hip]["alternative"]["to_nexus_mm"]
