"""Marker data quality: injected mislabels, swaps and re-sticks found, named, with their frames;
clean synthetic trials with soft tissue and the shared real trials give no finding."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.marker_quality import (
    MOVED_MIN,
    between_trials,
    check_marker_quality,
    exclude_markers,
    marker_segments,
    parse_marker_list,
    quality_lines,
    suspects,
)
from mocap_mj.cli import main
from mocap_mj.errors import UnknownNameError
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_synth.config import SynthConfig
from mocap_synth.experiment import Experiment, synthesize
from mocap_synth.noise import apply_swaps

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
RATE = 100.0


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def _segments(pset: ParameterSet) -> list[str]:
    return marker_segments(pset.model)


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


def test_demo_data_have_no_finding(pset: ParameterSet) -> None:
    # mocap-mj demo's trials: the ROM it fits and the walk it holds out (its defaults).
    for motion, frames in (("rom", 500), ("walk", 200)):
        exp = synthesize(SynthConfig(frames=frames, noise_mm=1.0, seed=0, motion=motion), pset)
        found = check_marker_quality(
            "demo", pset.marker_names, np.asarray(exp.markers), exp.config.rate, _segments(pset)
        )
        assert found == [], [f.message for f in found]


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
    # wrist markers: docs/recordings.md.)
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
    assert 0.020 < steps[0].value < 0.040
    assert next(iter(suspects(found))) == "LFRM"


def _moved(pset: ParameterSet, exp: Experiment, name: str, toward: str, by: float) -> np.ndarray:
    """The trial's markers with ``name`` re-attached ``by`` [m] closer to ``toward`` (a marker
    of its segment) in the segment's frame, for the whole trial."""
    names = pset.marker_names
    i, j = names.index(name), names.index(toward)
    _, offsets = pset.split(exp.theta_true)
    off = offsets.reshape(-1, 3)
    along = (off[j] - off[i]) / np.linalg.norm(off[j] - off[i])
    kin = Kinematics(pset)
    kin.set_theta(exp.theta_true)
    xmat = kin.forward(np.asarray(exp.qpos)).xmat[:, int(pset.site_body[i])]  # (T, 3, 3)
    markers = np.array(exp.markers)
    markers[:, i] += xmat @ (by * along)
    return markers


def test_marker_moved_between_trials_is_named(pset: ParameterSet) -> None:
    # Two halves of a walk with soft tissue as two trials of one session; in the second,
    # LTHI re-attached 45 mm closer to the knee. Every trial alone is clean.
    exp = _trial(pset, "walk")
    moved = _moved(pset, exp, "LTHI", "LKNE", 0.045)
    first, second = np.asarray(exp.markers)[:300], moved[300:]
    segments = _segments(pset)
    assert _check(pset, first) == [] and _check(pset, second) == []
    clean = between_trials(["a.c3d", "b.c3d"], pset.marker_names, [first, exp.markers[300:]],
                           segments)  # fmt: skip
    assert clean == [], [f.message for f in clean]
    found = between_trials(["a.c3d", "b.c3d"], pset.marker_names, [first, second], segments)
    assert [f.kind for f in found] == ["moved"], [f.message for f in found]
    assert set(found[0].markers) == {"LTHI", "LKNE"}
    assert 0.040 < found[0].value < 0.050
    assert found[0].file == "a.c3d, b.c3d"  # two trials: either may be the one that moved
    assert "a.c3d" in found[0].message and "b.c3d" in found[0].message
    # Three trials: the odd one is named. 20 mm (below MOVED_MIN) is not a finding.
    thirds = [np.asarray(exp.markers)[:200], np.asarray(exp.markers)[200:400], moved[400:]]
    found = between_trials(["a", "b", "c"], pset.marker_names, thirds, segments)
    assert [f.file for f in found] == ["c"], [f.message for f in found]
    small = _moved(pset, exp, "LTHI", "LKNE", MOVED_MIN - 0.01)
    two = [np.asarray(exp.markers)[:300], small[300:]]
    assert between_trials(["a", "b"], pset.marker_names, two, segments) == []


def test_shared_sessions_have_no_moved_marker(pset: ParameterSet) -> None:
    # Trials of one session differ by posture only (up to 20 mm on the thorax's markers).
    for group in (REAL[:2], REAL[2:]):
        files = [SHARED / "real" / f"{n}.c3d" for n in group]
        if not all(f.is_file() for f in files):
            pytest.skip("the shared data are not in this checkout")
        x = [load_markers(f, model_names=pset.marker_names).select(pset.marker_names)
             for f in files]  # fmt: skip
        found = between_trials([str(f) for f in files], pset.marker_names, x, _segments(pset))
        assert found == [], [f.message for f in found]


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
    # RELB-RWRA 118 mm is a small child's forearm (the distance check spans 0.85-2.1 m):
    # against the left side's 278 mm it is an asymmetry.
    asym = {f.markers for f in found if f.kind == "asymmetry"}
    assert {("LELB", "LWRA", "RELB", "RWRA"), ("LELB", "LWRB", "RELB", "RWRB")} <= asym


@pytest.fixture(scope="module")
def swapped_csv(pset: ParameterSet, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 120-frame ROM with LWRA and LWRB swapped in frames 40-79, as a mocap-mj CSV."""
    exp = synthesize(SynthConfig(frames=120, rate=RATE, sta_mm=10.0, seed=3), pset)
    markers = apply_swaps(np.asarray(exp.markers), pset.marker_names, [("LWRA", "LWRB", 40, 79)])
    path = tmp_path_factory.mktemp("quality") / "swapped.csv"
    save_csv(path, MarkerTrajectory(exp.times, markers, pset.marker_names, RATE))
    return path


def _ik(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, list[str]]:
    code = main(["ik", *argv])
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("mocap-mj ik")]
    return code, err


@pytest.mark.slow
def test_ik_warns_records_and_strict_refuses(
    swapped_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "a"),
                    "--no-relabel")  # fmt: skip
    assert code == 0
    assert any(
        "warning: " in e and "LWRA and LWRB: labels swapped in frames 40-79" in e for e in err
    )
    quality = json.loads((tmp_path / "a" / "summary.json").read_text())["marker_quality"]
    found = [(f["kind"], f["frames"]) for f in quality["findings"]]
    assert found == [("swap", [40, 80])], found  # one finding: no step at the swap's edges
    assert quality["findings"][0]["file"] == str(swapped_csv)

    # By default the swap is corrected (mocap_mj.pipeline.relabel.track_swaps) and nothing is left.
    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "f"))
    assert code == 0 and len(err) == 1 and "relabelled: " in err[0], err
    assert "LWRA <-> LWRB in frames 40-79" in err[0]
    quality = json.loads((tmp_path / "f" / "summary.json").read_text())["marker_quality"]
    assert quality["findings"] == [] and quality["relabelled"][0]["frames"] == [40, 80]

    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "b"), "--strict")
    assert code == 2 and len(err) == 1 and "--strict" in err[0] and "LWRA <-> LWRB" in err[0]
    assert not (tmp_path / "b").exists()

    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "c"),
                    "--exclude-markers", "LWRA,LWRX")  # fmt: skip
    assert code == 2 and len(err) == 1 and "unknown marker (--exclude-markers) 'LWRX'" in err[0]

    # Without LWRA, LWRB's track still jumps; without both, nothing is left to find.
    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "d"),
                    "--exclude-markers", "LWRA")  # fmt: skip
    assert code == 0 and any("LWRB: 2 jump(s)" in e for e in err), err
    code, err = _ik(capsys, "--markers", str(swapped_csv), "--out", str(tmp_path / "e"),
                    "--exclude-markers", "LWRA,LWRB", "--strict")  # fmt: skip
    assert code == 0 and err == []
    summary = json.loads((tmp_path / "e" / "summary.json").read_text())
    assert summary["marker_quality"] == {
        "relabelled": [],
        "findings": [],
        "suspects": {},
        "excluded": ["LWRA", "LWRB"],
        "samples_dropped": 0,
    }
    assert set(summary["markers_without_data"]) == {"LWRA", "LWRB"}


def test_report_section() -> None:
    entry = {
        "findings": [{"message": "t.c3d: RELB-RWRA: median distance 118 mm ..."}],
        "suspects": {"RELB": 2, "RWRA": 1},
        "excluded": ["RFIN"],
    }
    text = "\n".join(quality_lines(entry))
    assert text.startswith("## Marker data quality")
    assert "excluded by --exclude-markers: RFIN" in text
    assert "- t.c3d: RELB-RWRA: median distance 118 mm" in text
    assert "RELB (2), RWRA (1)" in text
    assert "no finding" in "\n".join(quality_lines({"findings": [], "suspects": {}}))


def test_batch_column() -> None:
    from mocap_mj.commands.batch import _quality_cell
    from mocap_mj.outputs.batch_out import COLUMNS

    assert "marker_quality" in COLUMNS
    from mocap_mj.capture.marker_quality import Finding
    from mocap_mj.pipeline.report import MarkerQuality

    def found(file: str, kind: str, *markers: str) -> Finding:
        return Finding(file, kind, markers, None, 0.1, "", "")

    quality = MarkerQuality(findings=(
        found("a.c3d", "distance", "RELB", "RWRA"),
        found("a.c3d", "asymmetry", "LELB", "LWRA", "RELB", "RWRA"),
        found("b.c3d", "swap", "LASI", "RASI"),
    ))  # fmt: skip
    assert _quality_cell(quality, "a.c3d") == "2 finding(s): RELB RWRA"
    assert _quality_cell(quality, "b.c3d") == "1 finding(s): LASI RASI"
    assert _quality_cell(quality, "c.c3d") == "none"


@pytest.mark.slow
def test_identify_strict_refuses_a_marker_moved_between_trials(
    pset: ParameterSet, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    exp = _trial(pset, "walk")
    moved = _moved(pset, exp, "LTHI", "LKNE", 0.045)
    paths = [tmp_path / "a.csv", tmp_path / "b.csv"]
    for path, x, t in ((paths[0], np.asarray(exp.markers)[:300], exp.times[:300]),
                       (paths[1], moved[300:], exp.times[300:])):  # fmt: skip
        save_csv(path, MarkerTrajectory(t, x, pset.marker_names, RATE))
    code = main(["identify", "--markers", *map(str, paths), "--out", str(tmp_path / "out"),
                 "--strict"])  # fmt: skip
    err = [e for e in capsys.readouterr().err.splitlines() if e.startswith("mocap-mj identify")]
    assert code == 2 and len(err) == 1, err
    assert "LTHI-LKNE" in err[0] and "moved between trials" in err[0] and "--strict" in err[0]
    assert not (tmp_path / "out").exists()
