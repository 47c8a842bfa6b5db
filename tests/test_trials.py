"""Every trial of a multi-trial result has its own files, report section and summary entry,
and export, render and view take any trial (``--trial NAME|INDEX``); a one-trial result's
layout is unchanged. report.md's numbers are summary.json's, and its tables list only what
a lower-body recording measures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.cli import main
from mocap_mj.errors import MocapError
from mocap_mj.export.read_result import frame_rate, load_result
from mocap_mj.outputs.trial_out import streamed_name
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.trials import open_trial, trial_folders, trial_names
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

#: per trial: the layout's files
FILES = ("motion.npz", "joint_centres.csv", "angles.csv", "marker_error.png")
#: Plug-in Gait's lower-body markers: the fixture's recording has no others
LOWER = "LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB RANK RHEE RTOE".split()


def test_names_are_the_stems_made_unique() -> None:
    assert trial_names(["lab/CAL.c3d", "lab/WALK.c3d"]) == ["CAL", "WALK"]
    assert trial_names(["cal/markers.csv", "walk/markers.csv"]) == ["cal_markers", "walk_markers"]
    assert trial_names(["a/x.c3d", "a/x.trc"]) == ["a_x_0", "a_x_1"]
    assert trial_folders(["CAL.c3d", "WALK.c3d", "RUN.c3d"]) == ["", "trials/WALK", "trials/RUN"]
    assert trial_folders(["ONLY.c3d"]) == [""]
    folders = ["", "trials/WALK"]  # a long recording's streamed files, moved in
    assert streamed_name("motion_1.npz", folders) == "trials/WALK/motion.npz"
    assert streamed_name("joint_centres_1.csv", folders) == "trials/WALK/joint_centres.csv"
    assert streamed_name("motion.npz", folders) == "motion.npz"
    assert streamed_name("angles.csv", folders) == "angles.csv"


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A static (30 frames) then a walk (60 frames) of one synthetic subject, lower-body
    markers only, identified together and written as a result folder."""
    from mocap_mj.outputs.write_fit import write_result

    root = tmp_path_factory.mktemp("trials")
    pset = ParameterSet()
    trials = []
    for name, motion, frames in (("CAL", "static", 30), ("WALK", "walk", 60)):
        exp = synthesize(SynthConfig(frames=frames, seed=3, motion=motion), pset)
        markers = np.asarray(exp.markers).copy()
        markers[:, [n not in LOWER for n in pset.marker_names]] = np.nan
        path = root / f"{name}.trc"
        trials.append(TrialData(str(path), markers, np.asarray(exp.times)))
    fit = identify(trials, pset=pset)
    write_result(fit, root / "result", inputs={"markers_files": [t.name for t in trials]})
    return root / "result"


def test_every_trial_has_its_files_section_and_entry(result: Path) -> None:
    for name in FILES:  # the first trial's where a one-trial result has them
        assert (result / name).is_file(), name
        assert (result / "trials" / "WALK" / name).is_file(), name
    assert not list(result.glob("motion_*.npz"))
    summary = json.loads((result / "summary.json").read_text())
    entries = summary["trials"]
    assert [(e["name"], e["folder"], e["frames"]) for e in entries] == [
        ("CAL", ".", 30),
        ("WALK", "trials/WALK", 60),
    ]
    for e in entries:
        assert e["files"] == list(FILES)
        assert 0 < e["fitted_marker_rmse_mm"] < 5  # 1 mm noise per axis
    # each table holds its own trial's frames: 30 and 60 rows after the header
    assert len((result / "angles.csv").read_text().splitlines()) == 31
    assert len((result / "trials/WALK/angles.csv").read_text().splitlines()) == 61
    assert len((result / "trials/WALK/joint_centres.csv").read_text().splitlines()) >= 61
    report = (result / "report.md").read_text()
    assert "## Trial 0: CAL (" in report and "## Trial 1: WALK (" in report
    assert "![marker error](trials/WALK/marker_error.png)" in report
    rmse = f"{entries[1]['fitted_marker_rmse_mm']:.3f} mm"
    assert rmse in report.split("## Trial 1: WALK")[1]


def test_export_and_render_take_any_trial(
    result: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert len(load_result(result).motion.times) == 30  # default: the first trial
    for trial in ("WALK", "1", "-1", "WALK.trc"):
        assert len(load_result(result, trial=trial).motion.times) == 60, trial
    assert len(load_result(result, trial="CAL").motion.times) == 30
    with pytest.raises(MocapError, match=r"no such trial.*0 CAL, 1 WALK"):
        open_trial(result, "RUN")
    with pytest.raises(MocapError, match="no such trial"):
        open_trial(result, "2")
    out = tmp_path / "walk.mot"
    assert main(["export", str(result), "--trial", "WALK", "--to", "mot", "--out", str(out)]) == 0
    rows = [line for line in out.read_text().splitlines() if line[:1].isdigit()]
    assert len(rows) == 60
    assert main(["export", str(result), "--trial", "RUN", "--out", str(tmp_path / "x.mot")]) == 2
    assert "0 CAL, 1 WALK" in capsys.readouterr().err
    pytest.importorskip("mocap_viewer")
    from mocap_viewer.playback import load_playback

    assert load_playback(result, trial="WALK").n_frames == 60


def test_an_index_finds_an_older_results_motion_files(result: Path, tmp_path: Path) -> None:
    """Results written before trials had folders hold motion_<i>.npz."""
    old = tmp_path / "old"
    old.mkdir()
    for name in ("model.xml", "motion.npz"):
        (old / name).write_bytes((result / name).read_bytes())
    (old / "motion_1.npz").write_bytes((result / "trials/WALK/motion.npz").read_bytes())
    assert open_trial(old, "1").motion == old / "motion_1.npz"
    with pytest.raises(MocapError, match="no such trial"):
        open_trial(old, "WALK")


def test_rates_of_float_clocks_are_round() -> None:
    times = np.cumsum(np.full(200, 0.01)) - 0.01
    assert frame_rate(times) == 100.0
    assert frame_rate(np.arange(10) / 119.88) == pytest.approx(119.88, rel=1e-12)


def test_report_numbers_are_the_summarys(result: Path) -> None:
    """Every figure report.md states is summary.json's, in the same words, and its tables
    list only the parameters the lower-body recording measures."""
    from mocap_mj.outputs.write_fit import iterations_text, weighting_text

    s = json.loads((result / "summary.json").read_text())
    report = (result / "report.md").read_text()
    pset = ParameterSet()
    assert f"- frames used: {s['frames_used']} of {s['frames']}" in report
    assert iterations_text(s) in report
    assert f"marker RMSE: {s['marker_rmse_mm']:.3f} mm" in report
    assert f"noise sigma of {s['sigma_mm']:.3f} mm" in report
    assert f"{s['observable_directions']} of {pset.size} directions" in report
    assert f"{s['kappa_crlb_rms_mm']:.3f} mm RMS for the kinematic" in report
    w = s["prior_weighting"]
    assert weighting_text(w) in report and f"{w['noise_mm']:.2f} mm" in weighting_text(w)
    for name, tau in zip(("CAL.trc", "WALK.trc"), w["trial_tau_frames"], strict=True):
        assert f"{name} " in report and f"(correlation time {tau:.1f} frames)" in report
    kappa = report.split("## Kinematic parameters")[1].split("\n## ")[0]
    rows = {r.split("|")[1].strip(): r.split("|")[5] for r in kappa.splitlines() if r[:2] == "| "}
    held = set(s["parameters_not_measured"])
    assert held and "upperarm_length_l" in held and "thigh_length_l" not in held
    assert not held & set(rows) and "thigh_length_l" in rows
    for name, cell in rows.items():
        if name == "parameter":
            continue
        white = s["segments"][name]["std_white_mm"]  # segments.csv's std_white_mm
        assert cell.strip().startswith(f"{white:.2f}"), (name, cell)
    lengths = report.split("## Segment lengths")[1].split("\n## ")[0]
    for name, r in s["segments"].items():
        if r["kind"] == "length":
            listed = f"| {name} | {r['value_mm']:.1f} |" in lengths
            assert listed == (r["flag"] != "not_measured"), name
    identifiability = report.split("## Identifiability")[1].split("\n## ")[0]
    for marker in ("C7", "RFHD", "LELB"):  # never recorded: no row of their own
        assert f"| {marker} offset" not in identifiability
    assert f"The {len(held)} parameters not measured" in identifiability
