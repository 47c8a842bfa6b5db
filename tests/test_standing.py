"""Knee axes in standing against the pelvis (mocap_mj.anatomy.standing): the identified and the
constructed axis's yaw on poses and markers whose truth is known, the note when a thigh wand
turns the construction, and no figure for a trial where the subject does not stand."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy.standing import STANDING_YAW, standing_knee_axes, standing_note
from mocap_mj.skeleton.kinematics import Kinematics

#: Width / 2 + marker radius [m] of the knees in these tests.
HALF = {"l": 0.064, "r": 0.064}
#: The yaws' tolerance [deg]: the poses are exact, the markers noise-free.
TOL = 0.5


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def _poses(pset: ParameterSet, hip_turn_deg: float = 0.0, knee_deg: float = 0.0) -> np.ndarray:
    """20 standing poses (20, nq): pelvis upright 1 m up, facing a heading that changes
    nothing, each hip turned internally by ``hip_turn_deg`` about the thigh's long axis,
    the knees flexed by ``knee_deg``."""
    model = pset.model
    q = np.tile(model.qpos0, (20, 1))
    heading = np.radians(70.0)
    q[:, 3:7] = [np.cos(heading / 2), 0.0, 0.0, np.sin(heading / 2)]
    for side, sign in (("l", -1.0), ("r", 1.0)):  # internal: about -z on the left, +z on the right
        a = np.radians(sign * hip_turn_deg)
        adr = int(model.jnt_qposadr[model.joint(f"hip_{side}").id])
        q[:, adr : adr + 4] = [np.cos(a / 2), 0.0, 0.0, np.sin(a / 2)]
        q[:, int(model.jnt_qposadr[model.joint(f"knee_flex_{side}").id])] = np.radians(knee_deg)
    return q


def _markers(pset: ParameterSet, q: np.ndarray) -> np.ndarray:
    kin = Kinematics(pset)
    kin.set_theta(pset.nominal)
    return kin.marker_positions(q)


def _deg(axes: dict, side: str, key: str) -> float:
    return float(np.degrees(axes[side][key]))


def test_a_straight_standing_knee_lies_along_the_pelvis(pset: ParameterSet) -> None:
    q = _poses(pset)
    axes = standing_knee_axes(pset, pset.nominal, q, _markers(pset, q), HALF)
    assert axes is not None
    for side in "lr":
        assert abs(_deg(axes, side, "identified")) < TOL
        assert abs(_deg(axes, side, "construction")) < TOL
    assert standing_note(axes, "static.c3d") is None


def test_an_internally_turned_hip_turns_both_axes_forward(pset: ParameterSet) -> None:
    q = _poses(pset, hip_turn_deg=30.0)
    axes = standing_knee_axes(pset, pset.nominal, q, _markers(pset, q), HALF)
    assert axes is not None
    for side in "lr":
        assert _deg(axes, side, "identified") == pytest.approx(30.0, abs=TOL)
        assert _deg(axes, side, "construction") == pytest.approx(30.0, abs=TOL)
    note = standing_note(axes, "static.c3d")
    assert note is not None and "cannot place them" in note


def test_a_turned_thigh_wand_turns_only_the_construction(pset: ParameterSet) -> None:
    q = _poses(pset)
    markers = _markers(pset, q)
    kin = Kinematics(pset)
    kin.set_theta(pset.nominal)
    frames = kin.forward(q)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        i = pset.marker_index(side.upper() + "THI")
        hip = frames.xpos[:, pset.model.body(f"thigh_{side}").id]
        a = np.radians(-sign * 40.0)  # the wand turned forward about the vertical thigh
        rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1]])
        markers[:, i] = hip + (markers[:, i] - hip) @ rot.T
    axes = standing_knee_axes(pset, pset.nominal, q, markers, HALF)
    assert axes is not None
    for side in "lr":
        assert abs(_deg(axes, side, "identified")) < TOL
        assert abs(_deg(axes, side, "construction")) > np.degrees(STANDING_YAW)
    note = standing_note(axes, "static.c3d")
    assert note is not None and "not theirs" in note and "static.c3d" in note


def test_flexed_knees_or_missing_markers_give_no_figure(pset: ParameterSet) -> None:
    q = _poses(pset, knee_deg=60.0)
    assert standing_knee_axes(pset, pset.nominal, q, _markers(pset, q), HALF) is None
    q = _poses(pset)
    markers = _markers(pset, q)
    markers[:, pset.marker_index("LKNE")] = np.nan
    axes = standing_knee_axes(pset, pset.nominal, q, markers, HALF)
    assert axes is not None and axes["l"]["construction"] is None
    assert axes["r"]["construction"] is not None
    q[:, 0] += np.linspace(0.0, 2.0, len(q))  # the pelvis walks 2 m: no calibration
    assert standing_knee_axes(pset, pset.nominal, q, _markers(pset, q), HALF) is None
