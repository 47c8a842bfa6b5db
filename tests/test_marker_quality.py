"""Marker data quality: injected mislabels, swaps and re-sticks found, named, with their frames;
clean synthetic trials with soft tissue and the shared real trials give no finding."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mocap_mj.errors import UnknownNameError
from mocap_mj.io import load_markers
from mocap_mj.kinematics import Kinematics
from mocap_mj.marker_quality import (
    check_marker_quality,
    exclude_markers,
    parse_marker_list,
    suspects,
)
from mocap_mj.parameters import ParameterSet
from mocap_synth.config import SynthConfig
from mocap_synth.experiment import Experiment, synthesize
from mocap_synth.noise import apply_swaps

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
RATE = 100.0


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def _segments(pset: ParameterSet) -> list[str]:
    return [
        str(mujoco.mj_id2name(pset.model, mujoco.mjtObj.mjOBJ_BODY, int(b))) for b in pset.site_body
    ]


def _trial(pset: ParameterSet, motion: str = "rom", sta_mm: float = 10.0, **kw: int) -> Experiment:
    cfg = SynthConfig(frames=600, rate=RATE, motion=motion, sta_mm=sta_mm, seed=3, **kw)
    return synthesize(cfg, pset)


def _check(pset: ParameterSet, markers: np.ndarray) -> list:
    return check_marker_quality("trial.c3d", pset.marker_names, markers, RATE, _segments(pset))


@pytest.mark.parametrize("motion", ["rom", "walk"])
def test_clean_trial_with_soft_tissue_has_no_finding(pset: ParameterSet, motion: str) -> None:
    # sta_mm 10: about 6 mm RMS of soft-tissue displacement over the ROM (docs/synth.md: 5
    # gives about 3 mm), with 1 mm white noise.
    exp = _trial(pset, motion)
    assert _check(pset, np.asarray(exp.markers)) == []


def test_left_right_swaps_found_with_their_frames(pset: ParameterSet) -> None:
    exp = _trial(pset, "walk", swaps=2)
    found = [f for f in _check(pset, np.asarray(exp.markers)) if f.kind == "swap"]
    want = {(a, b, first, last + 1) for a, b, first, last in exp.swapped}
    got = {(*sorted(f.markers), *f.frames) for f in found}
    assert got == {(*sorted((a, b)), s, e) for a, b, s, e in want}
    assert all(f.message.startswith("trial.c3d: ") for f in found)


def test_neighbour_swap_found(pset: ParameterSet) -> None:
    # The two wrist markers, about 50 mm apart, swapped for frames 200-319.
    exp = _trial(pset, "rom")
    names = pset.marker_names
    markers = apply_swaps(np.asarray(exp.markers), names, [("LWRA", "LWRB", 200, 319)])
    found = _check(pset, markers)
    swaps = [f for f in found if f.kind == "swap"]
    assert len(swaps) == 1, [f.message for f in found]
    assert set(swaps[0].markers) == {"LWRA", "LWRB"}
    assert swaps[0].frames == (200, 320)


def test_mislabel_for_the_whole_trial_names_the_marker(pset: ParameterSet) -> None:
    # RELB carries the forearm marker's track (RFRM) all along: an elbow that moves with the
    # forearm, on the upper arm segment.
    exp = _trial(pset, "rom")
    names = pset.marker_names
    markers = np.array(exp.markers)
    markers[:, names.index("RELB")] = markers[:, names.index("RFRM")]
    found = _check(pset, markers)
    assert found, "a mislabelled RELB went unnoticed"
    assert next(iter(suspects(found))) == "RELB", [f.message for f in found]
    assert all(f.frames is None for f in found if f.kind in ("spread", "distance"))


def test_marker_restuck_30mm_away_halfway(pset: ParameterSet) -> None:
    # LFRM re-stuck 30 mm further from the wrist markers from frame 300 on, fixed on the
    # forearm afterwards. (Distances alone cannot see a move around the line through the two
    # wrist markers: docs/real-data.md.)
    exp = _trial(pset, "rom")
    names = pset.marker_names
    i, j, k = (names.index(n) for n in ("LFRM", "LWRA", "LWRB"))
    _, offsets = pset.split(exp.theta_true)
    away = offsets.reshape(-1, 3)[i] - (offsets.reshape(-1, 3)[j] + offsets.reshape(-1, 3)[k]) / 2
    kin = Kinematics(pset)
    kin.set_theta(exp.theta_true)
    xmat = kin.forward(np.asarray(exp.qpos)).xmat[:, int(pset.site_body[i])]  # (T, 3, 3)
    markers = np.array(exp.markers)
    markers[300:, i] += xmat[300:] @ (0.03 * away / np.linalg.norm(away))
    found = _check(pset, markers)
    steps = [f for f in found if f.kind == "step"]
    assert len(steps) == 1, [f.message for f in found]
    assert steps[0].markers[0] == "LFRM"
    assert abs(steps[0].frames[0] - 300) <= 3  # within a block of the step search
    assert 20.0 < steps[0].value_mm < 40.0
    assert next(iter(suspects(found))) == "LFRM"


def test_exclude_markers(pset: ParameterSet) -> None:
    names = pset.marker_names
    assert parse_marker_list("RELB, RWRA", names) == ("RELB", "RWRA")
    with pytest.raises(UnknownNameError, match=r"unknown marker .*'RELBOW'"):
        parse_marker_list("RELBOW", names)
    x = np.ones((4, len(names), 3))
    out = exclude_markers(x, names, ("RELB",))
    assert np.isnan(out[:, names.index("RELB")]).all()
    assert np.isfinite(np.delete(out, names.index("RELB"), axis=1)).all()


REAL = ["Movement_trial", "Static_trial", "Test_func_rhip", "Test_func_rknee", "anatomical_posture"]


@pytest.mark.parametrize("path", [f"real/{n}.c3d" for n in REAL] + ["vendors/Qualisys.c3d"])
def test_shared_trials_have_no_finding(pset: ParameterSet, path: str) -> None:
    file = SHARED / path
    if not file.is_file():
        pytest.skip(f"{file} absent (the shared data are not in this checkout)")
    t = load_markers(file, model_names=pset.marker_names)
    found = check_marker_quality(
        str(file), pset.marker_names, t.select(pset.marker_names), t.rate, _segments(pset)
    )
    assert found == [], [f.message for f in found]


def test_read_notworking2_names_the_right_elbow(pset: ParameterSet) -> None:
    file = SHARED / "vendors" / "read_NOTworking2.c3d"
    if not file.is_file():
        pytest.skip(f"{file} absent (the shared data are not in this checkout)")
    t = load_markers(file, model_names=pset.marker_names)
    found = check_marker_quality(
        str(file), pset.marker_names, t.select(pset.marker_names), t.rate, _segments(pset)
    )
    assert next(iter(suspects(found))) == "RELB", [f.message for f in found]
    distance = [f for f in found if f.kind == "distance"]
    assert {f.markers for f in distance} == {("RELB", "RWRA"), ("RELB", "RWRB")}
