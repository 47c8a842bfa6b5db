"""Hinge centres against their construction (mocap_mj.anatomy.hinge_centres): the move is
measured in the frame of the parent segment's markers, with the standard deviation of the
fit's covariance."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy.hinge_centres import MOVED_SD, hinge_report
from mocap_mj.outputs.fit_tables import hinge_lines
from mocap_mj.pipeline.summary import hinge_fields

SOURCES = {"knee_l": "Plug-in Gait's chord", "ankle_r": "on the knee's flexion axis",
           "elbow_l": "Plug-in Gait's elbow centre", "hip_l": "Harrington 2007"}  # fmt: skip


def _result(
    pset: ParameterSet, theta0: np.ndarray, theta: np.ndarray, info: float
) -> SimpleNamespace:
    """A fit's fields hinge_report reads: the reduced information ``info`` (unit weights)
    times the identity on every free parameter, 1 mm noise."""
    return SimpleNamespace(theta0=theta0, theta=theta, sigma=1e-3, free=~np.asarray(pset.frozen),
                           reduced_information=info * np.eye(pset.size))  # fmt: skip


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def test_a_centre_moved_against_its_markers_is_measured(pset: ParameterSet) -> None:
    """knee_lateral_l moved 10 mm (the shank's origin along the knee axis, the thigh's markers
    kept): the left knee centre moved 10 mm from its construction; a turn of KNE and THI
    together about the thigh's long axis (its frame's z, the centre on it) moves nothing;
    the hip (a ball joint) is not reported here."""
    theta0 = pset.nominal.copy()
    theta = theta0.copy()
    theta[pset.index("knee_lateral_l")] += 0.010
    prior = 1e6 * np.eye(pset.size)  # 1 mm sd on every parameter
    out = hinge_report(pset, _result(pset, theta0, theta, 0.0), prior, 1.0, SOURCES)
    assert set(out) == {"knee_l", "ankle_r", "elbow_l"}
    assert out["knee_l"].distance == pytest.approx(0.010, abs=1e-9)
    assert out["knee_l"].construction == SOURCES["knee_l"]
    assert out["ankle_r"].distance == pytest.approx(0.0, abs=1e-12)
    # sd of the move's length: the knee_lateral parameter and the two markers' offsets
    # enter it, each with 1 mm; the move is larger than MOVED_SD of them
    assert 1.0e-3 < out["knee_l"].distance_sd < 3.0e-3
    assert out["knee_l"].moved_by_data == (0.010 > MOVED_SD * out["knee_l"].distance_sd)

    turned = theta0.copy()
    k = pset.n_kappa
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    for name in ("LKNE", "LTHI"):
        i = k + 3 * pset.marker_index(name)
        turned[i : i + 3] = rot @ turned[i : i + 3]
    centre = pset.body_pos(theta0)[pset.model.body("shank_l").id]
    assert np.hypot(centre[0], centre[1]) < 1e-9  # on the thigh frame's z axis
    out = hinge_report(pset, _result(pset, theta0, turned, 0.0), prior, 1.0, SOURCES)
    assert out["knee_l"].distance == pytest.approx(0.0, abs=1e-12)


def test_more_information_narrows_the_sd_and_the_table_says_so(pset: ParameterSet) -> None:
    """The data's information (inflated by the correlation time) narrows the sd; report.md's
    table has one row per entry with its figures."""
    theta0 = pset.nominal.copy()
    theta = theta0.copy()
    theta[pset.index("knee_lateral_l")] += 0.010
    prior = 1e6 * np.eye(pset.size)
    wide = hinge_report(pset, _result(pset, theta0, theta, 0.0), prior, 1.0, SOURCES)
    narrow = hinge_report(pset, _result(pset, theta0, theta, 3.0), prior, 1.0, SOURCES)
    slow = hinge_report(pset, _result(pset, theta0, theta, 3.0), prior, 100.0, SOURCES)
    sd = [r["knee_l"].distance_sd for r in (wide, narrow, slow)]
    assert sd[1] == pytest.approx(sd[0] / 2.0, rel=1e-6)  # information 1 + 3 = 4 x the prior's
    assert sd[1] < sd[2] < sd[0]
    lines = hinge_lines(hinge_fields(narrow))
    assert len(lines) == 5 + len(narrow)
    assert any(line.startswith("| knee_l | Plug-in Gait's chord |") and "| 10.0 |" in line
               for line in lines)  # fmt: skip
    assert hinge_lines({}) == []
