"""A user's files are never lost: one fault test per way a command could delete or replace one.

Each case puts files of the user's where a command writes (a folder that merely holds a
``summary.json``, names that look like the tool's temporaries, the files of a result being
read, the recording a result was made from, a batch's output names, the dataset itself) and
asserts that they are byte for byte as they were, that the refusal is one line with exit
status 2, and, after a kill at a random moment, that a rerun succeeds and leaves nothing of
the killed run behind (beside ``--out`` or in the temporary folder).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _cli import cli as run_cli
from _cli import dead_pid, hashes, identified_trial

from mocap_mj.io.ownership import FORMAT, MARKER, folder_mark

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

FRAMES = 30


def cli(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, list[str]]:
    return run_cli(capsys, *argv, drop=("marker set",))


def refused(code: int, lines: list[str], *needles: str | Path) -> None:
    assert code == 2, lines
    assert len(lines) == 1, lines
    for needle in needles:
        assert str(needle) in lines[0], lines[0]


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A synthetic trial (``markers``) and its identification (``result``)."""
    return identified_trial(tmp_path_factory.mktemp("user_files"), FRAMES, seed=5)


def users_folder(where: Path) -> Path:
    """A folder of the user's that happens to hold a file named like the tool's summary."""
    where.mkdir(parents=True)
    (where / "summary.json").write_text('{"my": "own summary"}\n')
    (where / "notes.txt").write_text("the user's notes\n")
    return where


# ------------------------------------------------------------ a folder that only looks like ours
@pytest.mark.parametrize("command", ["identify", "ik"])
def test_force_keeps_a_users_folder_holding_a_summary_json(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    mine = users_folder(tmp_path / "mine")
    before = hashes(mine)
    code, lines = cli(capsys, command, "--markers", data["markers"], "--out", mine, "--force")
    refused(code, lines, mine, "not a folder mocap-mj wrote", "--force")
    assert hashes(mine) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_force_keeps_a_result_the_user_added_a_file_to(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out)[0] == 0
    assert folder_mark(out) is not None and folder_mark(out)["kind"] == "result"  # type: ignore[index]
    (out / "notes.txt").write_text("what I saw in this trial\n")
    before = hashes(out)
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")
    refused(code, lines, out, "'notes.txt'", "mocap-mj did not write")
    assert hashes(out) == before
    (out / "notes.txt").unlink()  # wholly the tool's again: replaced
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")[0] == 0


def test_a_result_written_before_the_marker_is_replaced_only_if_nothing_else_is_in_it(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out)[0] == 0
    (out / MARKER).unlink()  # as an older version wrote it
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")[0] == 0
    (out / MARKER).unlink()
    (out / "photo.jpg").write_bytes(b"\xff\xd8 the user's")
    before = hashes(out)
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")
    refused(code, lines, out, "not a folder mocap-mj wrote")
    assert hashes(out) == before


# ------------------------------------------------------------------- names like our temporaries
def test_files_named_like_staging_are_never_removed(
    data: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Look-alikes of staging folders, moved-aside folders, file temporaries and scratch
    folders, of a process that no longer runs, beside --out, inside it and in the temporary
    folder: all kept."""
    import tempfile

    dead = dead_pid()
    tmp = tmp_path / "tmpdir"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    work = tmp_path / "work"
    work.mkdir()
    for parent in (work, tmp):
        names = (f".out.partial-{dead}-abcd1234", f".out.old-{dead}-abcd1234",
                 f".mocap-mj-motion-{dead}", f"mocap-mj-identify-{dead}", "mocap-mj-x")  # fmt: skip
        for name in names:
            (parent / name).mkdir()
            (parent / name / "notes.txt").write_text(f"mine, in {name}\n")
        (parent / f".report.tmp-{dead}-abcd1234.md").write_text("a draft of mine\n")
    before = {p: hashes(p) for p in (work, tmp)}
    out = work / "out"
    assert cli(capsys, "identify", "--markers", data["markers"], "--out", out)[0] == 0
    assert cli(capsys, "identify", "--markers", data["markers"], "--out", out, "--force")[0] == 0
    for parent, was in before.items():
        now = {k: v for k, v in hashes(parent).items() if not k.startswith("out/")}
        assert now == was
    # Inside --out: a file named like a killed write's temporary is the user's, so the folder
    # is not empty (and not the tool's).
    inner = work / "inner"
    inner.mkdir()
    (inner / f".summary.tmp-{dead}-abcd1234.json").write_text("mine\n")
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", inner)
    refused(code, lines, inner, "not empty")
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", inner, "--force")
    refused(code, lines, inner, "not a folder mocap-mj wrote")
    assert (inner / f".summary.tmp-{dead}-abcd1234.json").read_text() == "mine\n"


# ---------------------------------------------------------------- export onto what it reads
def test_export_never_replaces_a_file_of_the_result_or_its_recording(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    result = tmp_path / "result"
    shutil.copytree(data["result"], result)
    recording = tmp_path / "rec.csv"
    shutil.copy2(data["markers"], recording)
    summary = json.loads((result / "summary.json").read_text())
    summary["markers_files"] = [str(recording)]  # the recording this result was made from
    (result / "summary.json").write_text(json.dumps(summary))
    before = {p: hashes(p) for p in (result, recording)}
    for name in ("report.md", "segments.csv", "joint_centres.csv"):
        code, lines = cli(
            capsys, "export", result, "--to", "mot", "--out", result / name, "--force"
        )
        refused(code, lines, result / name, "is a file of the input folder")
    code, lines = cli(capsys, "export", result, "--to", "trc", "--out", recording, "--force")
    refused(code, lines, recording, "is the input")
    assert {p: hashes(p) for p in (result, recording)} == before
    # A new file inside the result is fine: it replaces nothing.
    assert cli(capsys, "export", result, "--to", "mot", "--out", result / "new.mot")[0] == 0


# ------------------------------------------------------------------------------------- batch
def _dataset(root: Path, markers: Path, names: tuple[str, ...] = ("S01",)) -> Path:
    for name in names:
        (root / name).mkdir(parents=True)
        shutil.copy2(markers, root / name / "walk.csv")
    return root


def test_batch_out_is_refused_onto_users_files_and_inside_the_dataset(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ds = _dataset(tmp_path / "ds", data["markers"])
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "summary.csv").write_text("subject,my,own,table\n")
    (mine / "report.md").write_text("# my report\n")
    cases = [
        (mine, "not a folder a batch wrote"),
        (data["result"], "not a folder a batch wrote"),  # an identify result
        (ds / "S01" / "results", "inside the dataset"),
        (ds / "results", "inside the dataset"),
    ]
    before = {p: hashes(p) for p in (ds, mine, data["result"])}
    for out, why in cases:
        code, lines = cli(capsys, "batch", ds, "--out", out, "--serial")
        refused(code, lines, why)
    assert {p: hashes(p) for p in (ds, mine, data["result"])} == before
    assert not (ds / "results").exists() and not (ds / "S01" / "results").exists()


def test_batch_subject_names_never_collide_with_its_files(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("summary.csv", "REPORT.md"):
        ds = _dataset(tmp_path / f"ds-{name}", data["markers"], (name,))
        code, lines = cli(capsys, "batch", ds, "--out", tmp_path / f"out-{name}", "--serial")
        refused(code, lines, repr(name), "rename the subject")
        assert not (tmp_path / f"out-{name}").exists()


def test_batch_resumes_only_into_its_own_folder(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ds = _dataset(tmp_path / "ds", data["markers"])
    out = tmp_path / "out"
    assert cli(capsys, "batch", ds, "--out", out, "--serial")[0] == 0
    assert folder_mark(out)["kind"] == "batch"  # type: ignore[index]
    assert folder_mark(out / "S01")["kind"] == "subject"  # type: ignore[index]
    code, _ = cli(capsys, "batch", ds, "--out", out, "--serial")  # resumed, not refused
    assert code == 0


def test_an_empty_out_is_refused_everywhere(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    here = tmp_path / "here"
    shutil.copytree(data["result"], here)
    monkeypatch.chdir(here)  # --out '' would otherwise mean this folder
    before = hashes(here)
    ds = _dataset(tmp_path / "ds", data["markers"])
    for argv in (
        ["identify", "--markers", data["markers"], "--out", "", "--force"],
        ["ik", "--markers", data["markers"], "--out", " ", "--force"],
        ["export", here, "--to", "all", "--out", "", "--force"],
        ["batch", ds, "--out", "", "--serial"],
    ):
        code, lines = cli(capsys, *argv)
        refused(code, lines, "--out", "empty")
    assert hashes(here) == before


# ------------------------------------------------------------------- killed while staging
def _start(argv: list[str | Path], tmp: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "TMPDIR": str(tmp)}
    return subprocess.Popen(
        [sys.executable, "-m", "mocap_mj", *map(str, argv)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip


def _ours(folder: Path) -> list[str]:
    """Entries of ``folder`` that hold the tool's marker (a run's staging or scratch)."""
    found = []
    for p in folder.iterdir():
        if p.is_dir() and (p / MARKER).is_file():
            record = json.loads((p / MARKER).read_text())
            if record.get("format") == FORMAT and record.get("kind") in ("staging", "scratch"):
                found.append(p.name)
    return found


def users(work: Path) -> dict[str, str]:
    """The hashes of the files in ``work`` that are not the tool's (its result, its runs')."""
    ours = {"out", *_ours(work)}
    return {k: v for k, v in hashes(work).items() if k.split("/")[0] not in ours}


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="kill -9 and SIGHUP are POSIX")
@pytest.mark.parametrize(("sig", "seed"), [("SIGKILL", 0), ("SIGKILL", 1), ("SIGHUP", 2)])
def test_killed_while_staging_then_rerun(
    data: dict[str, Path], tmp_path: Path, sig: str, seed: int
) -> None:
    """A kill at a random moment after the staging folder appears: the user's files beside
    --out (with look-alike names) are untouched; the rerun succeeds and removes what the
    killed run left, beside --out and in the temporary folder. SIGHUP (a closed terminal)
    cleans up at once and exits 129."""
    dead = dead_pid()
    work, tmp = tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    tmp.mkdir()
    (work / f".out.partial-{dead}-00000000").mkdir()
    (work / f".out.partial-{dead}-00000000" / "mine.txt").write_text("mine\n")
    (work / "notes.txt").write_text("mine\n")
    before = hashes(work)
    out = work / "out"
    argv: list[str | Path] = ["identify", "--markers", data["markers"], "--out", out, "--json"]
    proc = _start(argv, tmp)
    deadline = time.monotonic() + 300
    while not any(p.name.startswith(".out.partial-") and (p / MARKER).exists()
                  for p in work.iterdir()):  # fmt: skip
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.communicate()
            pytest.skip("identify ended before its staging could be seen")
        time.sleep(0.005)
    time.sleep(float(np.random.default_rng(seed).uniform(0.0, 1.5)))
    proc.send_signal(getattr(signal, sig))
    _, err = proc.communicate(timeout=300)
    assert "Traceback" not in err
    if proc.returncode == 0:
        pytest.skip("identify finished before the signal")
    if sig == "SIGHUP":
        assert proc.returncode == 129, err
        assert _ours(work) == [] and _ours(tmp) == []
    assert not out.exists()
    assert users(work) == before
    rerun = _start(argv, tmp)
    _, err = rerun.communicate(timeout=600)
    assert rerun.returncode == 0, err
    assert (out / "summary.json").is_file()
    assert _ours(work) == [] and _ours(tmp) == []
    assert users(work) == before
