"""The shoulder rows of a Plug-in Gait subject (shoulder offset measured) encode Plug-in
Gait's shoulder centre: a model whose SHO sits where the rows put it gives, through the
chord construction of mocap_mj.clinical on its own marker sites, its own glenohumeral centre."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.shoulders import pig_shoulder_offsets
from mocap_mj.capture.subject import Subject
from mocap_mj.clinical.centres import shoulder
from mocap_mj.clinical.segments import Markers, trunk_frames

RADIUS = 0.007


@pytest.mark.parametrize("offset", [0.04, 0.05, 0.065])
def test_rows_put_the_centre_where_plug_in_gait_does(offset: float) -> None:
    pset = ParameterSet()
    subject = Subject()
    subject.set("height", 1.75, "test")
    for side in "lr":
        subject.set(f"shoulder_offset_{side}", offset, "test")
    prior = landmark_prior(pset, subject)
    theta = pset.nominal.copy()
    for p in "LR":
        # SHO where the rows put it: each row's mean, solved for the SHO offset.
        i = pset.n_kappa + 3 * pset.marker_index(p + "SHO")
        for k, c in enumerate("xyz"):
            (r,) = [j for j, lab in enumerate(prior.labels) if lab.startswith(f"{p}SHO.{c} = GH")]
            assert "Plug-in Gait" in prior.labels[r]
            theta[i + k] = prior.b[r] - (prior.a[r] @ theta - prior.a[r][i + k] * theta[i + k])
    kin = Kinematics(pset)
    kin.set_theta(theta)
    frames = kin.forward(pset.model.qpos0[None].copy())
    site = {n: frames.site_xpos[0, k][None] for k, n in enumerate(pset.marker_names)}
    thorax = trunk_frames(Markers(site, 1), RADIUS, 0.0)["thorax"]
    for side, p in (("l", "L"), ("r", "R")):
        pig = shoulder(thorax.axes, thorax.origin, site[p + "SHO"], offset, RADIUS, side)[0]
        gh = frames.xpos[0, pset.model.body(f"upperarm_{side}").id]
        # The rows are linearised on the nominal model: 1 mm for this model's own geometry.
        assert np.linalg.norm(pig - gh) < 1e-3, (side, pig - gh)


def test_without_the_thorax_markers_no_plug_in_gait_rows() -> None:
    pset = ParameterSet()
    got = pig_shoulder_offsets(pset, lambda r: "absent" if r == "STRN" else r, {"l": 0.057}, 1.0,
                               RADIUS)  # fmt: skip
    assert got == {}
