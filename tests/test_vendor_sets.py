"""The bundled vendor marker sets (models/marker_sets/) and the landmark roles that give
their markers Plug-in Gait's anatomical rows (mocap_mj.capture.roles): a lateral and a
medial landmark place their joint centre at their midpoint on both sides; each set
identifies its shared recording (skip without ../shared) with the joint centres within
3 mm of their landmark pairs' midpoint and, for the lateral-only Davis sets, left and
right lengths within 10 mm (benchmarks/marker_sets.py prints the figures)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.plausibility import (
    kappa_outside_bounds,
    left_right_differences,
    pair_centre_gaps,
)
from mocap_mj.anatomy.ranges import kappa_ranges
from mocap_mj.capture.landmarks import measured_widths
from mocap_mj.capture.marker_set import load_marker_set, model_with_marker_set
from mocap_mj.capture.roles import roles
from mocap_mj.capture.subject import Subject
from mocap_mj.cli import main
from mocap_mj.pipeline.anatomical import AnatomyPriors
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData

ROOT = Path(__file__).resolve().parents[1]
SETS = ROOT / "models" / "marker_sets"
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SKIP = "../shared/data not present: the vendor-set checks need the shared folder beside the repo"


def _pset(path: Path, tmp: Path) -> tuple[ParameterSet, dict[str, str]]:
    marker_set = load_marker_set(path)
    xml = tmp / f"{path.stem}.xml"
    xml.write_text(model_with_marker_set(marker_set).to_xml())
    return ParameterSet(xml), {m.name: m.landmark for m in marker_set.markers if m.landmark}


def test_roles_fill_plug_in_gait_rows(tmp_path: Path) -> None:
    """The ISB names fill Plug-in Gait's roles by their landmarks and sides, the pairs'
    lateral markers keep only their width rows (the pair's midpoint rows place the centre);
    a sacrum stands in for both posterior spines; Plug-in Gait maps onto itself."""
    pset, landmarks = _pset(SETS / "qualisys_isb.yaml", tmp_path)
    alias = roles(pset, landmarks)
    expected = {"LKNE": "L_FLE", "RANK": "R_FAL", "RASI": "R_IAS", "LPSI": "L_IPS", "C7": "CV7",
                "CLAV": "SNJ", "STRN": "SXS", "RELB": "R_HLE"}  # fmt: skip
    assert {k: alias[k] for k in expected} == expected
    labels = landmark_prior(pset, landmarks=landmarks).labels
    assert "joint centre at the R_FAL-R_TAM midpoint (z)" in labels
    assert "hip_width_r = 0.33 PW + 7.3 mm (Harrington 2007)" in labels
    assert not any(label.startswith(("R_FAL.z", "R_FAL.x", "L_FLE.x")) for label in labels)
    davis, marks = _pset(SETS / "davis.yaml", tmp_path)
    assert roles(davis, marks)["LPSI"] == roles(davis, marks)["RPSI"] == "sacrum"
    pig = ParameterSet()
    assert roles(pig, {n: "asis" for n in ("LASI", "RASI")}) == {}


@pytest.mark.parametrize("static", [False, True])
def test_pairs_place_both_sides_centres_at_their_midpoints(tmp_path: Path, static: bool) -> None:
    """A subject whose knee and ankle centres sit off the segments' axes (knee_lateral
    +8 mm, ankle_lateral -6 mm on both sides) and whose lateral malleolus reaches 15 mm
    below the medial one, the pair's midpoint at the ankle centre. Moving, where the data
    see the centres: every knee and ankle centre within 1.5 mm of its pair's fitted
    midpoint (the right side's centre row had the left's sign: 7.5 mm off here, 9.8 mm on
    Qualisys.c3d). Static, where the rows place them: within 0.5 mm (the lateral
    malleolus's own level row pulled the ankle centre toward it: 5-6 mm on the biobuddy
    trials)."""
    pset, landmarks = _pset(SETS / "plug_in_gait_medial.yaml", tmp_path)
    truth = pset.nominal.copy()
    for side, p, sign in (("l", "L", 1.0), ("r", "R", -1.0)):
        for name, value in (("knee_lateral", 0.008), ("ankle_lateral", -0.006)):
            truth[pset.index(f"{name}_{side}")] = value
        centre = pset.body_pos(truth)
        for lat, med, body, half, dz in (("KNE", "KNEM", "shank", 0.058, 0.0),
                                         ("ANK", "ANKM", "foot", 0.04, 0.0075)):  # fmt: skip
            c = centre[pset.model.body(f"{body}_{side}").id]
            for marker, s in ((p + lat, 1.0), (p + med, -1.0)):
                i = pset.n_kappa + 3 * pset.marker_index(marker)
                truth[i : i + 3] = c + np.array([0.0, s * sign * half, -s * dz])
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 50, seed=3)
    if static:
        qpos = np.tile(qpos[0], (50, 1))
    kin.set_theta(truth)
    noise = np.random.default_rng(4).normal(0.0, 1e-3, (50, pset.n_markers, 3))
    markers = kin.marker_positions(qpos) + noise
    trial = TrialData("pairs", markers, np.arange(50) / 100.0)
    bodies = {n: pset.model.body(int(pset.model.site_bodyid[pset.model.site(n).id])).name
              for n in pset.marker_names}  # fmt: skip
    subject = Subject()
    for w in measured_widths(landmarks, bodies, pset.marker_names, [markers], 0.014):
        subject.set(w.name, w.value, w.source)
    result, _ = solve_anatomical([trial], pset=pset, theta0=None, settings=LMSettings(),
                                 anatomy=AnatomyPriors(subject, landmarks=landmarks))  # fmt: skip
    gaps = pair_centre_gaps(pset, result.theta, landmarks, pset.marker_names)
    assert set(gaps) == {"knee_l", "knee_r", "ankle_l", "ankle_r"}
    assert max(gaps.values()) < (0.0005 if static else 0.0015), gaps


#: (recording under ../shared/data, set, frames, the joints whose pairs it holds, whether the
#: left/right target applies, whether the anatomical ranges are checked).
CASES = [
    ("vendors/Qualisys.c3d", SETS / "qualisys_isb.yaml", "0:120", 6, False, True),
    ("vendors/FP_Type3.c3d", SETS / "qualisys_clusters.yaml", "0:2", 4, False, True),
    ("vendors/FP_Type1.c3d", SETS / "davis.yaml", "0:60", 0, True, False),
    ("vendors/BTS.c3d", SETS / "davis_bts.yaml", "200:500", 0, True, False),
    ("real/Test_func_rknee.c3d", SETS / "plug_in_gait_medial.yaml", "0:217", 4, False, True),
    ("real/Test_func_rhip.c3d", SETS / "plug_in_gait_medial.yaml", "0:260", 4, False, True),
    ("real/anatomical_posture.c3d", SETS / "plug_in_gait_medial.yaml", "0:122", 4, False,
     True),
]  # fmt: skip


@pytest.mark.parametrize(("name", "marker_set", "frames", "pairs", "lr", "ranges"), CASES,
                         ids=[Path(c[0]).stem for c in CASES])  # fmt: skip
@pytest.mark.slow
def test_vendor_set_identifies_its_recording(
    tmp_path: Path, name: str, marker_set: Path, frames: str, pairs: int, lr: bool, ranges: bool
) -> None:
    """The recording with its set and no other flag: every knee, ankle and elbow centre
    whose two landmarks the set marks within 3 mm of their fitted midpoint (the knee
    extended), the widths measured from the pairs, no kinematic parameter outside its
    anatomical range (the ISB / CAST sets and the biobuddy trials) and, with lateral
    landmarks only (Davis), left and right lengths within 10 mm."""
    path = DATA / name
    if not path.is_file():
        pytest.skip(SKIP)
    out = tmp_path / "out"
    args = ["identify", "--markers", str(path), "--marker-set", str(marker_set), "--out",
            str(out), "--frames", frames, "--force"]  # fmt: skip
    assert main(args) == 0
    pset, landmarks = _pset(Path(marker_set), tmp_path)
    theta = pset.load_json(out / "theta.json")
    motion = load_motion(out / "motion.npz", pset.model)
    seen = [n for i, n in enumerate(pset.marker_names) if np.isfinite(motion.markers[:, i]).any()]
    gaps = pair_centre_gaps(pset, theta, landmarks, seen)
    assert len(gaps) == pairs and all(v <= 0.003 for v in gaps.values()), gaps
    summary = json.loads((out / "summary.json").read_text())
    measured = [n for n, m in summary["measurements"].items() if m["source"].startswith("markers")]
    assert len(measured) == pairs
    if lr:
        diff = left_right_differences(pset, theta)
        assert max(diff.values()) <= 0.010, diff
    if ranges:
        ranges_of = kappa_ranges(pset, Subject.from_summary(summary))
        assert kappa_outside_bounds(pset, theta, *ranges_of) == {}
