"""``mocap-mj gait-report`` and ``plug-in-gait --report``: the files on a synthetic walk
(its own events, a normative file made here), the page rendered in headless Chromium with
every plot (asserted from the page's DOM, not from the file's text), bad input refused, and
the kinetics page on the shared Movement trial.

The render test skips when Chromium is absent, unless ``RENDER_REQUIRED=1`` (CI), which
makes it fail."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import cli
from mocap_mj.clinical.gait_scores import GPS_VARIABLES

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
RENDER_REQUIRED = os.environ.get("RENDER_REQUIRED") == "1"
SUBJECT = (
    "knee_width_l: 105 mm\nknee_width_r: 105 mm\nankle_width_l: 70 mm\n"
    "ankle_width_r: 70 mm\nleg_length_l: 900 mm\nleg_length_r: 900 mm\n"
)


@pytest.fixture(scope="module")
def walk(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic walk (300 frames at 100 Hz) with its truth events, a subject file and a
    normative file: every GPS variable's mean 0, sd 5 deg, on every 2 %."""
    from mocap_synth import SynthConfig, synthesize, write_experiment
    from mocap_synth.gait_truth import write_gait_truth

    folder = tmp_path_factory.mktemp("gait")
    exp = synthesize(SynthConfig(motion="walk", frames=300, rate=100.0, seed=5))
    write_experiment(exp, folder / "synth", extra=lambda out: write_gait_truth(exp, out))
    (folder / "subject.yaml").write_text(SUBJECT)
    rows = ["variable,percent,mean,sd"]
    rows += [f"{v},{p},0,5" for v, _ in GPS_VARIABLES for p in range(0, 101, 2)]
    (folder / "normative.csv").write_text("\n".join(rows) + "\n")
    return folder


def _report(walk: Path, out: Path, *extra: str) -> int:
    synth = walk / "synth"
    return cli.main([
        "gait-report", "--markers", str(synth / "markers.trc"),
        "--events", str(synth / "truth_events.csv"),
        "--subject-file", str(walk / "subject.yaml"), "--out", str(out), *extra,
    ])  # fmt: skip


@pytest.fixture(scope="module")
def report(walk: Path) -> Path:
    out = walk / "report"
    assert _report(walk, out, "--normative", str(walk / "normative.csv")) == 0
    return out


@pytest.mark.slow
def test_gait_report_files(report: Path, walk: Path) -> None:
    names = {p.name for p in report.iterdir()}
    assert {"cycles.csv", "spatiotemporal.csv", "scores.csv", "report.html",
            "summary.json"} <= names  # fmt: skip
    summary = json.loads((report / "summary.json").read_text())
    entry = summary["gait_report"]
    assert entry["cycles"]["markers"] == {"left": 2, "right": 2}
    lines = (report / "cycles.csv").read_text().splitlines()
    assert lines[0] == "trial,side,cycle,variable,percent,value"
    knee = [r.split(",") for r in lines if ",left,1,KneeAngles_X," in r]
    assert [float(r[4]) for r in knee] == list(range(101))
    flexion = np.array([float(r[5]) for r in knee])
    assert flexion.max() - flexion.min() > 40  # deg: the walk's knee swings some 60 deg
    # the scores: each GVS the RMS of the mean cycle's curve against 0 (the normative mean)
    rows = [r.split(",") for r in (report / "scores.csv").read_text().splitlines()[1:]]
    gvs = {(r[0], r[2].split(" ")[0]): float(r[3]) for r in rows if r[1] == "GVS"}
    got = {}
    for side in ("left", "right"):
        values = [[float(r.split(",")[5]) for r in lines if f",{side},{n},KneeAngles_X," in r]
                  for n in (1, 2)]  # fmt: skip
        got[side] = np.mean([np.sqrt(np.mean(np.square(v))) for v in values])
        assert gvs[(side, "KneeAngles_X")] == pytest.approx(got[side], rel=1e-4)
    gps = {r[0]: float(r[3]) for r in rows if r[1] == "GPS"}
    left = [v for (s, _), v in gvs.items() if s == "left"]
    assert gps["left"] == pytest.approx(np.sqrt(np.mean(np.square(left))), rel=1e-4)
    assert entry["gps_deg"]["left"] == pytest.approx(gps["left"], rel=1e-4)


@pytest.mark.slow
def test_without_normative_the_scores_are_omitted(walk: Path) -> None:
    out = walk / "plain"
    assert _report(walk, out) == 0
    assert not (out / "scores.csv").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert "no --normative file" in summary["gait_report"]["scores_omitted"]
    assert "Scores omitted: no --normative file" in (out / "report.html").read_text()


def test_bad_normative_file_refused_before_any_output(
    walk: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "norm.csv"
    bad.write_text("variable,percent,mean,sd\nKneeAngles_X,0,1\n")
    out = tmp_path / "out"
    assert _report(walk, out, "--normative", str(bad)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{bad}: line 2: expected a variable" in err[0]
    assert not out.exists()


#: Instrumentation the test adds to a copy of the page: each image's natural size and each
#: SVG's box, written into the DOM once the page has loaded.
_PROBE = """<script>window.addEventListener('load', () => {
  for (const im of document.images) {
    im.setAttribute('data-natural', im.complete ? im.naturalWidth + 'x' + im.naturalHeight : '0x0');
  }
  document.body.setAttribute('data-loaded', String(document.images.length));
});</script>"""


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if found := shutil.which(name):
            return found
    if RENDER_REQUIRED:
        pytest.fail("RENDER_REQUIRED=1 and no chromium on PATH (apt-get install chromium)")
    pytest.skip("chromium not installed: the report's rendering is not checked")


def _headless(browser: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--virtual-time-budget=10000", *args],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip


def _rendered(browser: str, page: Path, tmp: Path) -> tuple[int, list[tuple[str, int, int]]]:
    """The images the page has once Chromium has loaded it, and each one's (alt, natural
    width, natural height) [px], read back from the DOM it dumps."""
    probed = tmp / "report.html"
    probed.write_text(page.read_text().replace("</body>", _PROBE + "</body>"))
    done = _headless(browser, "--dump-dom", probed.as_uri())
    assert done.returncode == 0, done.stderr[-500:]
    loaded = re.search(r'data-loaded="(\d+)"', done.stdout)
    assert loaded, "the page's load event never came"
    sizes = re.findall(
        r'<img class="plot" alt="([a-z]+)"[^>]*data-natural="(\d+)x(\d+)"', done.stdout
    )
    return int(loaded[1]), [(a, int(w), int(h)) for a, w, h in sizes]


@pytest.mark.slow
def test_report_renders_in_chromium_with_every_plot(report: Path, tmp_path: Path) -> None:
    browser = _chromium()
    count, sizes = _rendered(browser, report / "report.html", tmp_path)
    assert count == 1  # the kinematics page (no plates: no kinetics page)
    assert [(a, w > 300 and h > 300) for a, w, h in sizes] == [("kinematics", True)]
    shot = tmp_path / "shot.png"
    uri = (tmp_path / "report.html").as_uri()
    done = _headless(browser, "--window-size=1000,900", f"--screenshot={shot}", uri)
    assert done.returncode == 0 and shot.stat().st_size > 10_000


@pytest.mark.slow
def test_plug_in_gait_report_with_kinetics_on_the_movement_trial(tmp_path: Path) -> None:
    movement, static = SHARED / "Movement_trial.c3d", SHARED / "Static_trial.c3d"
    if not movement.is_file():
        pytest.skip("../shared/data not present: the Movement trial's report needs it")
    out = tmp_path / "pig"
    argv = ["plug-in-gait", "--markers", str(movement), "--static", str(static), "--report",
            "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["gait_report"]["cycles"]["Movement_trial"] == {"left": 1, "right": 1}
    lines = (out / "cycles.csv").read_text().splitlines()
    assert any(",right,1,KneeMoment_X," in r for r in lines)
    assert {"angles.csv", "kinetics.csv", "report.md"} <= {p.name for p in out.iterdir()}
    count, sizes = _rendered(_chromium(), out / "report.html", tmp_path)
    assert count == 2 and [a for a, w, h in sizes if w > 300 and h > 300] == [
        "kinematics",
        "kinetics",
    ]


def test_marker_sets_told_apart_and_mixed_trials_refused(
    walk: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A Plug-in Gait trial's angles come from its markers, another set's from an identified
    model; trials of both in one report are refused before any output."""
    from mocap_mj.commands._gait import is_plug_in_gait
    from mocap_mj.io import load_markers, save_csv

    pig = load_markers(walk / "synth" / "markers.trc")
    assert is_plug_in_gait(pig)
    keep = [i for i, n in enumerate(pig.names) if n not in ("LTHI", "SACR", "LPSI")]
    other = pig.__class__(
        pig.times, pig.positions[:, keep], tuple(pig.names[i] for i in keep), pig.rate
    )
    assert not is_plug_in_gait(other)
    save_csv(tmp_path / "other.csv", other)
    out = tmp_path / "out"
    argv = ["gait-report", "--markers", str(walk / "synth" / "markers.trc"),
            str(tmp_path / "other.csv"), "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected trials of one marker set" in err[0]
    assert not out.exists()


def test_events_files_one_per_trial(
    walk: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    synth = walk / "synth"
    out = tmp_path / "out"
    events = str(synth / "truth_events.csv")
    argv = ["gait-report", "--markers", str(synth / "markers.trc"), "--events", events,
            events, "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 2
    assert "--events: expected one events.csv per marker file (1), got 2" in capsys.readouterr().err
    assert not out.exists()
