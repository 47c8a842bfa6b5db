"""Marker sets as YAML data: the bundled Plug-in Gait set, round trips, refusals, and models
built from a set (so ParameterSet works on any marker set)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.marker_set import (
    MarkerSet,
    load_marker_set,
    marker_class,
    model_with_marker_set,
    plug_in_gait,
    save_marker_set,
    undetermined_segments,
)
from mocap_mj.errors import InputFileError, UnknownNameError
from mocap_mj.io.marker_names import MARKER_NAMES
from mocap_mj.skeleton.mjcf import load_model, model_path
from mocap_mj.skeleton.parameters import ParameterSet

LANDMARKS = ("ASI", "PSI", "KNE", "ANK", "HEE", "TOE", "C7", "T10", "CLAV", "STRN", "SHO",
             "ELB", "WRA", "WRB", "FIN", "FHD", "BHD")  # fmt: skip
CLUSTERS = ("THI", "TIB", "UPA", "FRM", "RBAK")


@pytest.mark.slow
def test_bundled_plug_in_gait_is_the_models_sites() -> None:
    pig = plug_in_gait()
    model = load_model()
    assert pig.names == MARKER_NAMES
    for i, marker in enumerate(pig.markers):
        assert model.site(i).name == marker.name
        assert model.body(model.site_bodyid[i]).name == marker.body
        np.testing.assert_allclose(marker.offset, model.site_pos[i], atol=1e-12)
        want = "cluster" if marker.name.endswith(CLUSTERS) else "landmark"
        assert marker.name.endswith(CLUSTERS + LANDMARKS)
        assert marker_class(marker.name) == want


def test_marker_class_of_an_unknown_marker_lists_the_set() -> None:
    with pytest.raises(UnknownNameError, match=r"unknown marker 'LFRA'; the model has: LASI"):
        marker_class("LFRA")


def test_round_trip(tmp_path: Path) -> None:
    pig = plug_in_gait()
    lower = pig.subset(["RTOE", "LASI", "RASI", "LPSI", "RPSI", "LKNE", "LTHI"])
    assert lower.names == ("LASI", "RASI", "LPSI", "RPSI", "LTHI", "LKNE", "RTOE")
    for marker_set in (pig, lower, MarkerSet("a: b", lower.markers)):
        path = tmp_path / "set.yaml"
        save_marker_set(path, marker_set)
        assert load_marker_set(path) == marker_set


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("markers: 3\n", "expected a mapping with a 'markers' list"),
        ("markers: [\n", "expected a YAML marker set"),
        ("markers: []\n", "expected at least one marker, got none"),
        ("markers: [LASI]\n", "marker 1: expected {name, body, offset, class}"),
        ("markers:\n  - {body: pelvis, offset: [0, 0, 0]}\n", "marker 1: expected a non-empty"),
        ("markers:\n  - {name: A, offset: [0, 0, 0]}\n", "marker 1 (A): expected a body name"),
        ("markers:\n  - {name: A, body: pelvis, offset: [0, 0]}\n", "marker 1 (A): expected off"),
        ("markers:\n  - {name: A, body: pelvis, offset: [0, .nan, 0]}\n", "expected offset"),
        ("markers:\n  - {name: A, body: pelvis, offset: [0, 0, 0], class: bony}\n",
         "marker 1 (A): expected class landmark / cluster / free, got 'bony'"),
        ("markers:\n  - {name: A, body: pelvis, offset: [0, 0, 0]}\n"
         "  - {name: A, body: pelvis, offset: [0, 0, 0]}\n", "expected unique marker names"),
    ],
)  # fmt: skip
def test_bad_marker_set_files_name_file_and_entry(tmp_path: Path, text: str, where: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputFileError) as info:
        load_marker_set(path)
    assert str(info.value).startswith(f"{path}: ") and where in str(info.value)


def test_parameter_set_on_a_model_built_from_a_marker_set(tmp_path: Path) -> None:
    default = ParameterSet()
    path = tmp_path / "pig.xml"
    path.write_text(model_with_marker_set(plug_in_gait()).to_xml())
    rebuilt = ParameterSet(path)
    assert rebuilt.marker_names == default.marker_names
    np.testing.assert_allclose(rebuilt.nominal, default.nominal, atol=1e-12)

    legs = plug_in_gait().subset([n for n in MARKER_NAMES if n[1:] in ("ASI", "PSI", "THI",
                                  "KNE", "TIB", "ANK", "HEE", "TOE")])  # fmt: skip
    moved = MarkerSet("legs", tuple(m if m.name != "LTHI" else type(m)(m.name, m.body,
                      (0.01, 0.09, -0.2), "cluster") for m in legs.markers))  # fmt: skip
    path = tmp_path / "legs.xml"
    path.write_text(model_with_marker_set(moved).to_xml())
    pset = ParameterSet(path)
    assert pset.marker_names == moved.names and pset.n_markers == 16
    assert pset.size == pset.n_kappa + 48
    np.testing.assert_allclose(pset.nominal[pset.index("LTHI.x") :][:3], [0.01, 0.09, -0.2])


def test_marker_on_an_unknown_body_lists_the_bodies() -> None:
    pig = plug_in_gait()
    bad = MarkerSet("bad", (type(pig.markers[0])("X", "femur", (0.0, 0.0, 0.0), "free"),))
    with pytest.raises(UnknownNameError, match=r"unknown body 'femur'; the model has: world"):
        model_with_marker_set(bad)


@pytest.mark.slow
def test_a_non_plug_in_gait_set_identifies_within_1_5x_its_bound(tmp_path: Path) -> None:
    """The bundled thigh/shank-cluster set: a synthetic trial (300 frames, 1 mm noise) is
    identified with kappa and offset errors (aligned along the null directions) within 1.5x
    their Cramer-Rao bounds, as for Plug-in Gait (tests/test_identify.py)."""
    from test_identify import errors

    from mocap_mj.solve.identifiability import Identifiability
    from mocap_mj.solve.lm import identify_lm
    from mocap_mj.solve.problem import TrialData
    from mocap_synth import SynthConfig, synthesize

    clusters = load_marker_set(model_path("marker_sets/pig_leg_clusters.yaml"))
    assert {"LTH1", "LSK3", "LKNM", "RMED"} <= set(clusters.names) and "LTHI" not in clusters.names
    assert (
        clusters.marker_class("LTH2") == "cluster" and clusters.marker_class("LKNM") == "landmark"
    )
    path = tmp_path / "clusters.xml"
    path.write_text(model_with_marker_set(clusters).to_xml())
    pset = ParameterSet(path)
    assert set(pset.marker_names) == set(clusters.names) and pset.n_markers == 51
    exp = synthesize(SynthConfig(frames=300, seed=0), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    result = identify_lm([trial], pset=pset)
    idf = Identifiability(pset, result.reduced_information, result.sigma, theta=result.theta)
    k_ratio, o_ratio, _ = errors(pset, result, exp, idf, 300)
    assert k_ratio <= 1.5, k_ratio
    assert o_ratio <= 1.5, o_ratio


def test_undetermined_segments_are_named() -> None:
    model = load_model()
    assert undetermined_segments(model, MARKER_NAMES) == ()
    no_hands = [n for n in MARKER_NAMES if n[1:] not in ("WRA", "WRB", "FIN", "FRM")]
    assert undetermined_segments(model, no_hands) == (
        "ulna_l", "radius_l", "hand_l", "ulna_r", "radius_r", "hand_r",
    )  # fmt: skip
    legs = [n for n in MARKER_NAMES if n[1:] in ("ASI", "PSI", "KNE", "ANK", "HEE", "TOE")]
    assert set(undetermined_segments(model, legs)) == {
        "lumbar", "thorax", "head", "clavicle_l", "upperarm_l", "ulna_l", "radius_l", "hand_l",
        "clavicle_r", "upperarm_r", "ulna_r", "radius_r", "hand_r",
    }  # fmt: skip


def test_cli_marker_report_names_undetermined_segments(tmp_path: Path) -> None:
    import argparse

    import mujoco

    from mocap_mj.commands._markers import load_trial
    from mocap_mj.io import MarkerTrajectory, save_csv

    model = load_model()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    pose = np.array(data.site_xpos)  # (39, 3) [m]: the nominal standing pose
    names = [n for n in MARKER_NAMES if n[1:] not in ("WRA", "WRB", "FIN", "FRM")]
    keep = [MARKER_NAMES.index(n) for n in names]
    rng = np.random.default_rng(0)
    pos = pose[keep][None] + np.array([0.0, 0.0, 1.0]) + rng.normal(0, 0.01, (3, len(keep), 3))
    path = tmp_path / "no_hands.csv"
    save_csv(path, MarkerTrajectory(np.arange(3) / 100.0, pos, tuple(names), 100.0, {}))
    args = argparse.Namespace(subject=None, marker_map=None, up="z", units=None, model=None)
    trial = load_trial(str(path), MARKER_NAMES, args)
    assert trial.report.undetermined == ("ulna_l", "radius_l", "hand_l", "ulna_r", "radius_r",
                                         "hand_r")  # fmt: skip
    assert "segments no marker found determines" in str(trial.report)


def test_marker_set_flag_builds_the_model_the_commands_use() -> None:
    import argparse

    from mocap_mj.commands._markers import model_for
    from mocap_mj.commands.options import add_input_options, add_model_options

    parser = argparse.ArgumentParser()
    add_input_options(parser)
    add_model_options(parser, model="MJCF model")
    yaml_path = str(model_path("marker_sets/pig_leg_clusters.yaml"))
    args = parser.parse_args(["--markers", "x.c3d", "--marker-set", yaml_path])
    path = model_for(args)
    assert path is not None and path == model_for(args)  # built once, named by content
    assert ParameterSet(path).marker_names == ParameterSet(path).marker_names
    assert set(ParameterSet(path).marker_names) == set(load_marker_set(yaml_path).names)
    args.marker_set = None
    assert model_for(args) is None
