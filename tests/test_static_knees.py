"""A static trial whose knees stand hyperextended: Plug-in Gait's chord plane places the knee
axes (no motion does) and the identified knees keep the subject's hyperextension, inside
the model's range (healthy adults extend 5-6 degrees beyond straight on average)."""

from __future__ import annotations

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.axes import pig_angle
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.anatomical import AnatomyPriors
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData

HYPEREXTENSION = -8.0  # deg: beyond the former -5 degree limit, inside the normal range


@pytest.mark.slow
def test_static_hyperextended_knees_keep_their_angle() -> None:
    """One pose held for 80 frames, both knees at -8 degrees, wands in the chord plane: the
    knee axes stay by Plug-in Gait's construction, the identified knee flexion is the
    truth's within 2 degrees and no knee sits at its limit."""
    pset = ParameterSet()
    kin = Kinematics(pset)
    q = smooth_motion(kin, 1, seed=2)[0]
    knees = [pset.model.joint(f"knee_flex_{s}").qposadr[0] for s in "lr"]
    for i in knees:
        q[i] = np.radians(HYPEREXTENSION)
    qpos = np.tile(q, (80, 1))
    kin.set_theta(pset.nominal)
    rng = np.random.default_rng(4)
    markers = kin.marker_positions(qpos) + rng.normal(0.0, 1e-3, (80, pset.n_markers, 3))
    subject = Subject()
    subject.set("height", 1.75, "test")
    for side in "lr":  # the nominal model's widths (KNE 57 mm, ANK 43 mm lateral, r 7 mm)
        subject.set(f"knee_width_{side}", 0.100, "test")
        subject.set(f"ankle_width_{side}", 0.072, "test")
    trial = TrialData("static", markers, np.arange(80) / 100.0)
    result, weighting = solve_anatomical([trial], pset=pset, theta0=None, settings=LMSettings(),
                                         anatomy=AnatomyPriors(subject))  # fmt: skip
    lower = np.degrees(pset.model.jnt_range[pset.model.joint("knee_flex_l").id][0])
    for side, i in zip("lr", knees, strict=True):
        d = weighting.joint_axes[f"knee_{side}"]
        # Plug-in Gait's row, or the data (the leg's plane at -8 deg and the alignment rows)
        # about as uncertain as it (7.7 against 8 deg): either way the axis stays by the
        # construction, which the next assertion checks.
        assert d["source"] == "plug-in-gait" or d["data_sd_deg"] > 0.9 * d["row_sd_deg"], d
        p = side.upper()
        angle = pig_angle(pset, result.theta, p + "THI", p + "KNE", f"knee_{side}")
        assert abs(angle) < 2.0 * d["row_sd_deg"], (side, angle)
        got = np.degrees(np.median(result.qpos[0][:, i]))
        # within 2 deg: an axis that the rows hold to 7.7 deg turns the flexion by 1.5 of them
        assert abs(got - HYPEREXTENSION) < 2.0, (side, got)
        assert got > lower + 0.5, (side, got, lower)
