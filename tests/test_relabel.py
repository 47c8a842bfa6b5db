"""Label errors put into synthetic trials on purpose (soft tissue and noise at the levels of
real captures), each found with its markers and frames and corrected to the truth's labels;
clean trials give no correction; the commands say so and obey --no-relabel and --strict."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.marker_quality import check_marker_quality, marker_segments, quality_lines
from mocap_mj.cli import main
from mocap_mj.io import MarkerTrajectory, save_csv
from mocap_mj.pipeline.relabel import (
    Relabel,
    apply_relabels,
    candidates,
    find_label_errors,
    reference_theta,
    track_swaps,
)
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_synth.config import SynthConfig
from mocap_synth.experiment import synthesize

RATE = 100.0
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def _markers(pset: ParameterSet, motion: str = "rom", seed: int = 3, **kw: float) -> np.ndarray:
    # sta_mm 10: about 6 mm RMS of soft-tissue displacement over the ROM (docs/synth.md),
    # 1 mm white noise; the subject's skeleton and marker placement perturbed (10 %, 20 mm).
    cfg = SynthConfig(frames=600, rate=RATE, motion=motion, sta_mm=10.0, seed=seed, **kw)
    return np.array(synthesize(cfg, pset).markers)


def _find(pset: ParameterSet, x: np.ndarray, path: str = "trial.c3d") -> list[Relabel]:
    kin = Kinematics(pset)
    kin.set_theta(reference_theta(pset, x))
    return find_label_errors(path, x, RATE, kin)


def _exchange(
    pset: ParameterSet, x: np.ndarray, pairs: list[tuple[str, str]], frames: slice = slice(None)
) -> np.ndarray:
    y = np.array(x)
    col = {n: i for i, n in enumerate(pset.marker_names)}
    for a, b in pairs:
        y[frames, [col[a], col[b]]] = y[frames, [col[b], col[a]]]
    return y


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal where present, missing in the same samples."""
    return bool(
        np.array_equal(np.isnan(a), np.isnan(b))
        and np.array_equal(a[~np.isnan(a)], b[~np.isnan(b)])
    )


def _assert_fixed(
    pset: ParameterSet,
    x: np.ndarray,
    y: np.ndarray,
    pairs: list[tuple[str, str]],
    frames: tuple[int, int],
) -> None:
    found = _find(pset, y)
    assert len(found) == 1, [r.message for r in found]
    r = found[0]
    assert sorted(r.markers) == sorted(n for p in pairs for n in p)
    assert r.frames == frames
    assert r.before > r.after + 0.030
    assert r.message.startswith("trial.c3d: labels exchanged")
    assert _same(apply_relabels(y, pset.marker_names, found, "trial.c3d"), x)


@pytest.mark.slow
@pytest.mark.parametrize("motion,seed", [("rom", 0), ("rom", 1), ("walk", 2), ("walk", 3)])
def test_no_correction_on_clean_trials(pset: ParameterSet, motion: str, seed: int) -> None:
    assert _find(pset, _markers(pset, motion, seed)) == []


def test_no_correction_when_the_recording_is_no_person_sized(pset: ParameterSet) -> None:
    """Millimetres read as centimetres' worth (a tenth of a person) fit no reference model: no
    labeling is judged, even with a real exchange in the data (the fit's checks name the
    unit instead)."""
    x = _exchange(pset, _markers(pset), [("RKNE", "RTIB")]) / 10.0
    assert _find(pset, x) == []


@pytest.mark.slow
def test_no_correction_with_occlusion_gaps(pset: ParameterSet) -> None:
    # 5 % of the samples in gaps: every gap edge is a breakpoint, no span is mislabelled.
    assert _find(pset, _markers(pset, "walk", 4, gaps=0.05)) == []


@pytest.mark.parametrize(
    "pairs",
    [
        [("LTHI", "LKNE")],  # two markers of one segment
        [("RWRA", "RFRM")],  # two of a three-marker segment
        [("LASI", "RASI")],  # left for right on one segment: the pelvis mirrored
        [("RKNE", "LKNE")],  # left for right across the body
        [("RKNE", "RTIB")],  # across neighbouring segments
        [("LFHD", "LBHD"), ("RFHD", "RBHD")],  # front pair for back pair: every distance kept
        [("LASI", "LPSI"), ("RASI", "RPSI")],  # the pelvis plate reversed front to back
    ],
)
@pytest.mark.slow
def test_whole_trial_exchange_found_and_corrected(
    pset: ParameterSet, pairs: list[tuple[str, str]]
) -> None:
    x = _markers(pset)
    _assert_fixed(pset, x, _exchange(pset, x, pairs), pairs, (0, len(x)))


@pytest.mark.slow
def test_exchange_between_two_gaps_found_for_its_span(pset: ParameterSet) -> None:
    # LTHI lost for 5 frames, then carrying LKNE's label (and LKNE LTHI's) until LKNE is lost.
    x = _markers(pset, "walk")
    col = pset.marker_names.index
    x[195:200, col("LTHI")] = np.nan
    x[400:405, col("LKNE")] = np.nan
    y = _exchange(pset, x, [("LTHI", "LKNE")], slice(200, 400))
    _assert_fixed(pset, x, y, [("LTHI", "LKNE")], (200, 400))


@pytest.mark.slow
def test_exchange_between_gaps_without_a_jump(pset: ParameterSet) -> None:
    # Both markers lost around the swap's ends: no track jumps, only the gaps bound it.
    x = _markers(pset, "rom")
    col = pset.marker_names.index
    for a, b in ((150, 160), (450, 460)):
        x[a:b, [col("RASI"), col("LASI")]] = np.nan
    y = _exchange(pset, x, [("LASI", "RASI")], slice(160, 450))
    _assert_fixed(pset, x, y, [("LASI", "RASI")], (160, 450))


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_mocap_synth_left_right_windows(pset: ParameterSet, seed: int) -> None:
    # mocap_synth's own corruption: two left/right pairs exchanged over a window each.
    cfg = SynthConfig(frames=600, rate=RATE, motion="walk", sta_mm=10.0, seed=seed)
    exp = synthesize(replace(cfg, swaps=2), pset)
    found = _find(pset, np.array(exp.markers))
    want = {(*sorted((a, b)), first, last + 1) for a, b, first, last in exp.swapped}
    assert {(*sorted(r.markers), *r.frames) for r in found} == want
    fixed = apply_relabels(np.array(exp.markers), pset.marker_names, found, "trial.c3d")
    assert _same(fixed, np.array(synthesize(cfg, pset).markers))


@pytest.mark.slow
def test_track_swap_of_close_markers(pset: ParameterSet) -> None:
    # LWRA and LWRB, about 50 mm apart: too close for the model's margin, found by their
    # tracks (each jumps onto the other's) and corrected from the quality check's finding.
    x = _markers(pset)
    y = _exchange(pset, x, [("LWRA", "LWRB")], slice(200, 320))
    assert _find(pset, y) == []
    found = check_marker_quality(
        "trial.c3d", pset.marker_names, y, RATE, marker_segments(pset.model)
    )
    fixes = track_swaps("trial.c3d", pset.marker_names, y, found)
    assert [(r.kind, sorted(r.markers), r.frames) for r in fixes] == [
        ("tracks", ["LWRA", "LWRB"], (200, 320))
    ]
    assert fixes[0].before > 0.030 > fixes[0].after
    assert _same(apply_relabels(y, pset.marker_names, fixes, "trial.c3d"), x)


@pytest.fixture(scope="module")
def clusters(tmp_path_factory: pytest.TempPathFactory) -> ParameterSet:
    """The bundled thigh/shank-cluster marker set (three-marker plates, medial knee and
    ankle markers) on the humanoid."""
    from mocap_mj.capture.marker_set import load_marker_set, model_with_marker_set
    from mocap_mj.skeleton.mjcf import model_path

    path = tmp_path_factory.mktemp("clusters") / "clusters.xml"
    path.write_text(
        model_with_marker_set(
            load_marker_set(model_path("marker_sets/pig_leg_clusters.yaml"))
        ).to_xml()
    )
    return ParameterSet(path)


@pytest.mark.parametrize(
    "pairs",
    [
        [],  # no false alarm
        [("LTH1", "LTH2")],  # a thigh plate front for back (60 mm apart)
        [("LTH1", "LTH2"), ("LKNE", "LKNM")],  # and the knee's lateral for medial
        [("RTH1", "RSK1")],  # a thigh plate marker for a shank plate marker
    ],
)
@pytest.mark.slow
def test_cluster_marker_set(clusters: ParameterSet, pairs: list[tuple[str, str]]) -> None:
    x = _markers(clusters, "walk", seed=1)
    y = _exchange(clusters, x, pairs)
    found = _find(clusters, y)
    assert len(found) == (1 if pairs else 0), [r.message for r in found]
    assert _same(apply_relabels(y, clusters.marker_names, found, "trial.c3d"), x)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["clusters", "pig"])
def test_three_markers_turned_by_one_place(
    clusters: ParameterSet, pset: ParameterSet, which: str
) -> None:
    # A triangular plate read rotated: each label on the next marker of the three.
    model, turned = (
        (clusters, ["LTH1", "LTH2", "LTH3"])
        if which == "clusters"
        else (pset, ["RFRM", "RWRA", "RWRB"])
    )
    x = _markers(model, "walk", seed=2)
    col = [model.marker_names.index(n) for n in turned]
    y = np.array(x)
    y[:, col] = x[:, col[1:] + col[:1]]
    found = _find(model, y)
    assert [(sorted(r.markers), r.frames) for r in found] == [(sorted(turned), (0, len(x)))]
    assert " <- " in found[0].message
    assert _same(apply_relabels(y, model.marker_names, found, "trial.c3d"), x)


@pytest.mark.slow
def test_one_trial_of_several(pset: ParameterSet) -> None:
    trials = [_markers(pset, m, seed=5) for m in ("rom", "walk", "static")]
    trials[1] = _exchange(pset, trials[1], [("RTHI", "RKNE")])
    kin = Kinematics(pset)
    kin.set_theta(reference_theta(pset, trials))
    found = [find_label_errors(f"t{k}.c3d", x, RATE, kin) for k, x in enumerate(trials)]
    assert [len(f) for f in found] == [0, 1, 0], [r.message for f in found for r in f]
    assert sorted(found[1][0].markers) == ["RKNE", "RTHI"]


def test_candidates_cover_the_kinds(pset: ParameterSet) -> None:
    names = pset.marker_names
    got = {(c.kind, tuple(sorted(names[i] for i in c.slots))) for c in candidates(pset)}
    assert ("across segments", ("RKNE", "RTIB")) in got
    assert ("left/right", ("LASI", "RASI")) in got
    assert ("within segment", ("LBHD", "LFHD", "RBHD", "RFHD")) in got
    assert ("left/right", ("LKNE", "LTHI", "RKNE", "RTHI")) in got  # a thigh for the other
    assert all(len(set(c.slots)) == len(c.slots) == len(c.sources) for c in candidates(pset))
    assert all(sorted(c.slots) == sorted(c.sources) for c in candidates(pset))


# ---------------------------------------------------------------------------------- commands
def _csv(pset: ParameterSet, x: np.ndarray, path: Path) -> Path:
    save_csv(path, MarkerTrajectory(np.arange(len(x)) / RATE, x, pset.marker_names, RATE))
    return path


@pytest.mark.slow
def test_ik_corrects_says_and_records(
    pset: ParameterSet, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    x = _markers(pset, "walk")[:300]
    f = _csv(pset, _exchange(pset, x, [("LASI", "RASI")]), tmp_path / "walk.csv")
    before = f.read_bytes()
    assert main(["ik", "--markers", str(f), "--out", str(tmp_path / "fixed")]) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "relabelled" in ln]
    assert len(lines) == 1 and "LASI <-> RASI in frames 0-299" in lines[0], err
    summary = json.loads((tmp_path / "fixed" / "summary.json").read_text())
    (entry,) = summary["marker_quality"]["relabelled"]
    assert entry["applied"] and entry["frames"] == [0, 300]
    assert "labels corrected" in "\n".join(quality_lines(summary["marker_quality"]))
    assert f.read_bytes() == before  # the input is never touched

    assert main(["ik", "--markers", str(f), "--out", str(tmp_path / "as_is"), "--no-relabel"]) == 0
    err = capsys.readouterr().err
    assert "warning: not relabelled (--no-relabel)" in err
    as_is = json.loads((tmp_path / "as_is" / "summary.json").read_text())
    assert not as_is["marker_quality"]["relabelled"][0]["applied"]
    assert as_is["marker_rmse_mm"] > summary["marker_rmse_mm"] + 10.0

    code = main(["ik", "--markers", str(f), "--out", str(tmp_path / "strict"), "--strict"])
    assert code == 2
    assert "--strict refuses" in capsys.readouterr().err
    assert not (tmp_path / "strict").exists()


@pytest.mark.slow
@pytest.mark.skipif(not (SHARED / "Movement_trial.c3d").is_file(), reason="shared data absent")
@pytest.mark.parametrize("name", ["Movement_trial", "Static_trial"])
def test_shared_trials_exchanges_found_none_on_the_files(pset: ParameterSet, name: str) -> None:
    from mocap_mj.io import load_markers

    tr = load_markers(str(SHARED / f"{name}.c3d"), model_names=pset.marker_names)
    x = tr.select(pset.marker_names)
    kin = Kinematics(pset)
    kin.set_theta(reference_theta(pset, x))
    assert find_label_errors(name, x, tr.rate, kin) == []
    n = len(x)
    y = _exchange(pset, x, [("RKNE", "RTIB"), ("LASI", "RASI"), ("LFHD", "LBHD"), ("RFHD", "RBHD")])
    y = _exchange(pset, y, [("LTHI", "LKNE")], slice(n // 3, 2 * n // 3))
    found = find_label_errors(name, y, tr.rate, kin)
    assert len(found) == 4, [r.message for r in found]
    assert _same(apply_relabels(y, pset.marker_names, found, name), x)


@pytest.mark.slow
def test_identify_corrects_one_trial_of_two_and_fits_the_corrected_copy(
    pset: ParameterSet, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    walk, rom = _markers(pset, "walk", seed=6)[:300], _markers(pset, "rom", seed=6)[:300]
    fw = _csv(pset, _exchange(pset, walk, [("RTHI", "RKNE")]), tmp_path / "walk.csv")
    fr = _csv(pset, rom, tmp_path / "rom.csv")
    out = tmp_path / "out"
    assert main(["identify", "--markers", str(fw), str(fr), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("relabelled:") == 1 and "RTHI <-> RKNE in frames 0-299" in err, err
    (entry,) = json.loads((out / "summary.json").read_text())["marker_quality"]["relabelled"]
    assert entry["file"] == str(fw) and entry["applied"]
    assert "labels corrected: " in (out / "report.md").read_text()
    # motion.npz holds the markers fitted (and exported): the corrected labels, the truth's
    motion = np.load(out / "motion.npz")
    assert np.allclose(motion["markers"], walk, rtol=0, atol=1e-6, equal_nan=True)  # CSV digits

    code = main(
        ["identify", "--markers", str(fw), str(fr), "--out", str(tmp_path / "s"), "--strict"]
    )
    assert code == 2 and not (tmp_path / "s").exists()
    assert "walk.csv" in capsys.readouterr().err
