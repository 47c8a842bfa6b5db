"""Landmarks in marker-set files and the joint widths a landmark pair measures
(mocap_mj.capture.landmarks), on a synthetic subject in the bundled Plug-in Gait set with medial
knee and ankle markers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import InputFileError, Kinematics, ParameterSet
from mocap_mj.capture.landmarks import disagreements, measured_widths
from mocap_mj.capture.marker_set import load_marker_set, model_with_marker_set, save_marker_set
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.anatomical import AnatomyPriors
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.skeleton.mjcf import model_path
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData

#: The synthetic subject's epicondyles: 144 mm apart (a 130 mm knee, 14 mm markers), where
#: the nominal model's regression gives 100 mm.
HALF = 0.072


@pytest.fixture(scope="module")
def medial(tmp_path_factory: pytest.TempPathFactory) -> tuple[ParameterSet, dict, dict]:
    marker_set = load_marker_set(model_path("marker_sets/plug_in_gait_medial.yaml"))
    path = tmp_path_factory.mktemp("medial") / "medial.xml"
    path.write_text(model_with_marker_set(marker_set).to_xml())
    landmarks = {m.name: m.landmark for m in marker_set.markers if m.landmark}
    bodies = {m.name: m.body for m in marker_set.markers}
    return ParameterSet(path), landmarks, bodies


def _subject_trial(pset: ParameterSet, static: bool = False) -> tuple[np.ndarray, TrialData]:
    """The nominal subject with wide knees (epicondyles at +-HALF on the knee axis), 200
    frames of smooth motion (``static``: its first pose held) with 1 mm noise."""
    truth = pset.nominal.copy()
    for name, y in (("LKNE", HALF), ("LKNEM", -HALF), ("RKNE", -HALF), ("RKNEM", HALF)):
        truth[pset.n_kappa + 3 * pset.marker_index(name) + 1] = y
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 200, seed=6)
    if static:
        qpos = np.tile(qpos[0], (200, 1))
    kin.set_theta(truth)
    rng = np.random.default_rng(7)
    markers = kin.marker_positions(qpos) + rng.normal(0.0, 1e-3, (200, pset.n_markers, 3))
    return truth, TrialData("medial", markers, np.arange(200) / 100.0)


def test_landmarks_round_trip_and_unknown_ones_are_refused(tmp_path: Path) -> None:
    marker_set = load_marker_set(model_path("marker_sets/plug_in_gait_medial.yaml"))
    assert marker_set.marker("LKNEM").landmark == "medial_femoral_epicondyle"
    assert marker_set.marker("LTHI").landmark == "technical"
    save_marker_set(tmp_path / "s.yaml", marker_set)
    assert load_marker_set(tmp_path / "s.yaml") == marker_set
    bad = tmp_path / "bad.yaml"
    bad.write_text("markers:\n  - {name: LK, body: thigh_l, offset: [0, 0, 0], landmark: knee}\n")
    with pytest.raises(InputFileError, match=r"bad.yaml: marker 1 \(LK\): expected a landmark"):
        load_marker_set(bad)


def test_knee_width_measured_from_the_epicondyles(medial: tuple) -> None:
    """The median distance of the two epicondyle markers less a diameter is the subject's
    knee width (130 mm) within 0.5 mm; a given width 40 mm off is warned about."""
    pset, landmarks, bodies = medial
    _, trial = _subject_trial(pset)
    found = {m.name: m for m in measured_widths(landmarks, bodies, pset.marker_names,
                                                [trial.markers], 0.014)}  # fmt: skip
    assert set(found) == {"knee_width_l", "knee_width_r", "ankle_width_l", "ankle_width_r"}
    for side in "lr":
        assert abs(found[f"knee_width_{side}"].value - (2 * HALF - 0.014)) < 5e-4
        assert abs(found[f"ankle_width_{side}"].value - (0.086 - 0.014)) < 5e-4
    lines = disagreements(list(found.values()), {"knee_width_l": 0.076, "knee_width_r": 0.12})
    assert len(lines) == 1 and "LKNE-LKNEM" in lines[0]


@pytest.mark.slow
def test_measured_width_puts_the_knee_centre_between_the_epicondyles(medial: tuple) -> None:
    """A static trial (no motion places the knee centre along its axis): identified with the
    measured widths, each knee centre is within 1 mm of the midpoint of its fitted
    epicondyle markers (the truth's) along the axis; with the widths regressed from the
    thigh (100 mm for the subject's 130) the worse knee lands more than 2 mm and three times
    as far away, so the measurement is what places it."""
    pset, landmarks, bodies = medial
    _, trial = _subject_trial(pset, static=True)
    subject = Subject()
    for m in measured_widths(landmarks, bodies, pset.marker_names, [trial.markers], 0.014):
        subject.set(m.name, m.value, m.source)
    gaps = []
    for given in (subject, Subject()):
        result, _ = solve_anatomical([trial], pset=pset, theta0=None, settings=LMSettings(),
                                     anatomy=AnatomyPriors(given))  # fmt: skip
        offsets, centres = pset.split(result.theta)[1], pset.body_pos(result.theta)
        gaps.append([
            abs(centres[pset.model.body(f"shank_{side}").id][1]
                - 0.5 * sum(offsets[pset.marker_index(p + n)][1] for n in ("KNE", "KNEM")))
            for side, p in (("l", "L"), ("r", "R"))
        ])  # fmt: skip
    assert max(gaps[0]) < 0.001, gaps
    assert max(gaps[1]) > max(0.002, 3 * max(gaps[0])), gaps


def test_epicondyle_pair_places_the_knee_centre_at_its_midpoint(medial: tuple) -> None:
    """With the set's landmarks (the pair's rows: the centre at the epicondyles' midpoint,
    in place of Plug-in Gait's chord plane, which the measured widths would otherwise
    build), a wide-kneed subject's static trial puts each knee centre within 1.5 mm of the
    midpoint of its fitted epicondyle markers, in every direction."""
    pset, landmarks, _ = medial
    _, trial = _subject_trial(pset, static=True)
    subject = Subject()
    for side in "lr":
        subject.set(f"knee_width_{side}", 2 * HALF - 0.014, "test")
        subject.set(f"ankle_width_{side}", 0.086 - 0.014, "test")
    anatomy = AnatomyPriors(subject, landmarks=landmarks)
    result, weighting = solve_anatomical([trial], pset=pset, theta0=None,
                                         settings=LMSettings(), anatomy=anatomy)  # fmt: skip
    decided = weighting.joint_axes
    assert not [j for j in decided if j.startswith(("knee", "ankle"))]  # the pairs give those
    offsets, centres = pset.split(result.theta)[1], pset.body_pos(result.theta)
    for side, p in (("l", "L"), ("r", "R")):
        mid = 0.5 * sum(offsets[pset.marker_index(p + n)] for n in ("KNE", "KNEM"))
        gap = np.linalg.norm(centres[pset.model.body(f"shank_{side}").id] - mid)
        assert gap < 0.0015, (side, gap)
