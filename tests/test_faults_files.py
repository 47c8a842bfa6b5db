"""File-system and input-naming faults, driven through the command line as a user would.

Every case asserts the promises: the exit status, one line on stderr without a traceback,
nothing left that looks like a result (and no hidden staging folder), and the inputs byte for
byte as they were. The inputs are one small synthetic trial (30 frames) and its identification,
shared by the module; the commands run in this process (``mocap_mj.cli.main``) except where a
second process is the point (concurrent runs, kill -9).
"""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import pytest
from _cli import cli, hashes, identified_trial

from mocap_mj.errors import OutputFolderError
from mocap_mj.io.atomic import atomic_folder, atomic_path
from mocap_mj.io.ownership import MARKER
from mocap_mj.skeleton.mjcf import model_path

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

FRAMES = 30


# ------------------------------------------------------------------------------ helpers
def refused(code: int, lines: list[str], status: int, *needles: str | Path) -> str:
    """Exit ``status`` with exactly one stderr line holding every needle."""
    assert code == status, lines
    assert len(lines) == 1, lines
    for needle in needles:
        assert str(needle) in lines[0], lines[0]
    return lines[0]


def staging_left(out: Path) -> list[str]:
    """Hidden temporaries of ``out`` beside it (``.<name>.partial-...``, ``.old-``)."""
    return [p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


def no_result(out: Path) -> None:
    assert not out.exists(), sorted(p.name for p in out.iterdir())
    assert staging_left(out) == []


def wait_for_staging(proc: subprocess.Popen[str], out: Path) -> bool:
    """Until ``proc``'s hidden folder of ``out`` exists (its checks passed, its work began);
    False if it exited first."""
    deadline = time.monotonic() + 300
    while not any(p.startswith(f".{out.name}.partial-") for p in os.listdir(out.parent)):
        if proc.poll() is not None:
            return False
        assert time.monotonic() < deadline, "the command never began its work"
        time.sleep(0.005)
    return True


def start(*argv: str | Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "mocap_mj", *map(str, argv)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


# ------------------------------------------------------------------------------ inputs
@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A synthetic trial (``synth``, its ``markers.csv``) and its identification (``result``)."""
    return identified_trial(tmp_path_factory.mktemp("faults"), FRAMES, seed=3)


def copy_of(src: Path, dest: Path) -> Path:
    if src.is_dir():
        shutil.copytree(src, dest)
    else:
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest)
    return dest


# ------------------------------------------------------ an --out that holds an input
def _holding_case(case: str, data: dict[str, Path], tmp: Path) -> tuple[list[str], Path, Path]:
    """(argv, the input named, the folder whose bytes must not change) of one case."""
    d = tmp / "d"
    if case in ("identify", "ik"):
        markers = copy_of(data["markers"], d / "markers.csv")
        return [case, "--markers", str(markers), "--out", str(d), "--force"], markers, d
    if case == "ik-out-above":  # the input two folders down
        markers = copy_of(data["markers"], d / "trial" / "markers.csv")
        return ["ik", "--markers", str(markers), "--out", str(tmp), "--force"], markers, tmp
    if case == "ik-out-a-link":
        markers = copy_of(data["markers"], d / "markers.csv")
        (tmp / "link").symlink_to(d, target_is_directory=True)
        argv = ["ik", "--markers", str(markers), "--out", str(tmp / "link"), "--force"]
        return argv, markers, d
    if case == "ik-model":
        model = copy_of(data["result"] / "model.xml", d / "model.xml")
        argv = ["ik", "--markers", str(data["markers"]), "--model", str(model),
                "--out", str(d), "--force"]  # fmt: skip
        return argv, model, d
    result = copy_of(data["result"], d)
    if case == "export-all":
        return ["export", str(result), "--to", "all", "--out", str(result), "--force"], result, d
    if case == "export-file":
        argv = ["export", str(result), "--to", "trc", "--out", str(result / "model.xml")]
        return argv, result / "model.xml", d
    if case == "batch":
        return ["batch", str(result), "--out", str(result), "--serial"], result, d
    raise AssertionError(case)


@pytest.mark.parametrize(
    "case",
    ["identify", "ik", "ik-out-above", "ik-out-a-link", "ik-model", "export-all",
     "export-file", "batch"],
)  # fmt: skip
def test_out_holding_an_input_is_refused_before_any_work(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str
) -> None:
    argv, named, folder = _holding_case(case, data, tmp_path)
    before = hashes(folder)
    code, lines = cli(capsys, *argv)
    line = refused(code, lines, 2, "--out", named)
    whats = ("is the input", "holds the input", "is a file of the input")
    assert any(what in line for what in whats)
    assert hashes(folder) == before
    assert not (folder / "summary.json").exists() or case.startswith(("export", "batch"))
    assert staging_left(folder) == []


# ------------------------------------------------------------------ what --force deletes
def test_force_replaces_only_an_empty_folder_or_a_result(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine = tmp_path / "mine"  # the user's own files: never deleted
    (mine / "sub").mkdir(parents=True)
    (mine / "notes.txt").write_text("the user's own notes")
    (mine / "sub" / "data.bin").write_bytes(b"\x00\x01")
    before = hashes(mine)
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", mine, "--force")
    refused(code, lines, 2, mine, "not a folder mocap-mj wrote", "--force")
    assert hashes(mine) == before
    assert staging_left(mine) == []
    out = tmp_path / "out"  # empty, then an earlier result: replaced
    out.mkdir()
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")[0] == 0
    (out / "summary.json").write_text('{"earlier": true}\n')
    assert cli(capsys, "ik", "--markers", data["markers"], "--out", out, "--force")[0] == 0
    assert "earlier" not in (out / "summary.json").read_text()
    assert {"motion.npz", "model.xml", "summary.json"} <= {p.name for p in out.iterdir()}
    assert staging_left(out) == []


@pytest.mark.parametrize("fmt", ["trc", "angles"])
def test_an_existing_output_file_is_replaced_only_with_force(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], fmt: str
) -> None:
    result = data["result"]
    mine = tmp_path / "mine.txt"  # a file of the user's, named as --out by mistake
    mine.write_text("the user's own table")
    code, lines = cli(capsys, "export", result, "--to", fmt, "--out", mine)
    refused(code, lines, 2, mine, "exists", "--force")
    assert mine.read_text() == "the user's own table"
    assert cli(capsys, "export", result, "--to", fmt, "--out", mine, "--force")[0] == 0
    assert mine.read_text() != "the user's own table"


# ------------------------------------------------------------ a result written meanwhile
@pytest.mark.parametrize("existing", ["absent", "empty"])
def test_a_result_renamed_into_place_meanwhile_is_kept(tmp_path: Path, existing: str) -> None:
    """The race, deterministically: a second run finishes inside the first run's block."""
    out = tmp_path / "out"
    if existing == "empty":
        out.mkdir()
    with pytest.raises(OutputFolderError, match="written by another run meanwhile"):
        with atomic_folder(out) as slow:
            (slow / "summary.json").write_text("slow\n")
            with atomic_folder(out) as fast:  # checked now: still new or empty
                (fast / "summary.json").write_text("fast\n")
    assert (out / "summary.json").read_text() == "fast\n"
    assert sorted(p.name for p in out.iterdir()) == sorted([MARKER, "summary.json"])
    assert staging_left(out) == []


@pytest.mark.skipif(not hasattr(signal, "SIGSTOP"), reason="holds a process with SIGSTOP (POSIX)")
def test_concurrent_runs_keep_the_first_result(data: dict[str, Path], tmp_path: Path) -> None:
    """Two real processes into one --out: the slow one (held stopped after its checks) is
    refused when it ends; the fast one's result stays byte for byte."""
    out = tmp_path / "out"
    slow = start("identify", "--markers", data["markers"], "--out", out, "--json")
    try:
        if not wait_for_staging(slow, out):
            pytest.skip("identify ended before its work could be held")
        slow.send_signal(signal.SIGSTOP)
        if out.exists():
            pytest.skip("identify finished before it could be held")
        fast = subprocess.run(
            [sys.executable, "-m", "mocap_mj", "ik", "--markers", str(data["markers"]),
             "--out", str(out), "--json"],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert fast.returncode == 0, fast.stderr
        first = hashes(out)
    finally:
        slow.send_signal(signal.SIGCONT)
    _, stderr = slow.communicate(timeout=600)
    assert slow.returncode == 2, stderr
    assert "Traceback" not in stderr
    last = stderr.strip().splitlines()[-1]
    assert str(out) in last and "another run" in last, stderr
    assert hashes(out) == first
    assert staging_left(out) == []


# -------------------------------------------------------------------- export is atomic
def test_export_on_a_full_disk_leaves_no_folder_and_names_the_file(
    data: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import mocap_mj.commands.export as export

    def full_disk(path: Path, *args: object, **kwargs: object) -> None:
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"half a mot")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    out = tmp_path / "all"
    before = hashes(data["result"])
    monkeypatch.setattr(export, "write_mot", full_disk)
    code, lines = cli(capsys, "export", data["result"], "--to", "all", "--out", out)
    refused(code, lines, 1, out / "coordinates.mot", os.strerror(errno.ENOSPC))
    no_result(out)
    monkeypatch.undo()
    # The rerun is not refused as "not empty": there is nothing there.
    assert cli(capsys, "export", data["result"], "--to", "all", "--out", out)[0] == 0
    assert {"coordinates.mot", "subject.osim", "summary.json"} <= {p.name for p in out.iterdir()}
    assert hashes(data["result"]) == before


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="kill -9 is POSIX")
def test_killed_export_leaves_no_folder_and_does_not_block_the_rerun(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """kill -9 as soon as the export writes anything (its folder or a hidden one)."""
    out = tmp_path / "all"
    for _ in range(3):  # the export may finish between two looks
        proc = start("export", data["result"], "--to", "all", "--out", out, "--json")
        while proc.poll() is None and not os.listdir(tmp_path):
            time.sleep(0.002)
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=60)
        if proc.returncode == -signal.SIGKILL:
            break
        shutil.rmtree(out)
    else:
        pytest.skip("the export always finished before it could be killed")
    assert not out.exists()  # at most the dead process's hidden folder
    assert cli(capsys, "export", data["result"], "--to", "all", "--out", out)[0] == 0
    assert staging_left(out) == []  # the stale one is gone


# ------------------------------------------------------------- damaged result files
def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2] if how == "truncated" else b"\xff\xfe\x00garbage")


@pytest.mark.parametrize(
    ("name", "how", "command"),
    [
        ("motion.npz", "truncated", "export-all"),
        ("motion.npz", "truncated", "export-trc"),
        ("motion.npz", "truncated", "render"),
        ("motion.npz", "truncated", "view"),
        ("motion.npz", "truncated", "score"),
        ("motion.npz", "garbage", "export-all"),
        ("theta.json", "garbage", "score"),
        ("theta.json", "truncated", "score"),
        ("summary.json", "garbage", "export-all"),
        ("summary.json", "garbage", "score"),
    ],
)
def test_a_damaged_result_file_is_one_line_naming_it(
    data: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    how: str,
    command: str,
) -> None:
    result = copy_of(data["result"], tmp_path / "result")
    _damage(result / name, how)
    before = hashes(result)
    out = tmp_path / "out"
    argv: list[str | Path] = {
        "export-all": ["export", result, "--to", "all", "--out", out],
        "export-trc": ["export", result, "--to", "trc", "--out", out],
        "render": ["render", result, "--out", tmp_path / "out.png"],
        "view": ["view", result, "--duration", "0.1"],
        "score": ["score", "--truth", data["synth"], "--result", result],
    }[command]
    code, lines = cli(capsys, *argv)
    line = refused(code, lines, 2, result / name)
    assert "expected" in line or "not a complete" in line, line
    assert hashes(result) == before
    no_result(out)
    assert not (tmp_path / "out.png").exists()


# ----------------------------------------------------------------------- messages
def test_a_model_without_a_body_names_the_model_file(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = mujoco.MjSpec.from_file(str(model_path()))
    spec.delete(spec.body("toes_l"))
    model = tmp_path / "no_toes.xml"
    model.write_text(spec.to_xml())
    out = tmp_path / "out"
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--model", model, "--out", out)
    refused(code, lines, 2, model, "toes_l")
    no_result(out)


@pytest.mark.parametrize(("kind", "said"), [("folder", "is a folder"),
                                            ("fifo", "is not a regular file")])  # fmt: skip
def test_a_marker_file_that_is_a_folder_or_a_fifo_is_named_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, said: str
) -> None:
    markers = tmp_path / "markers.trc"
    if kind == "folder":
        markers.mkdir()
    elif hasattr(os, "mkfifo"):
        os.mkfifo(markers)
    else:
        pytest.skip("no FIFOs on this platform")
    out = tmp_path / "out"
    for command in ("ik", "identify"):
        code, lines = cli(capsys, command, "--markers", markers, "--out", out)
        line = refused(code, lines, 2, markers, said)
        assert "no such file" not in line
        no_result(out)


@pytest.mark.parametrize(("command", "frames"), [("ik", "0:500"), ("identify", "40:50"),
                                                 ("ik", "-31:")])  # fmt: skip
def test_frames_past_the_end_are_refused_naming_the_frame_count(
    data: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: str,
    frames: str,
) -> None:
    out = tmp_path / "out"
    code, lines = cli(capsys, command, "--markers", data["markers"], f"--frames={frames}",
                      "--out", out)  # fmt: skip
    refused(code, lines, 2, data["markers"], f"--frames {frames}", f"has {FRAMES} frames")
    no_result(out)


def test_a_symlinked_out_stays_a_link_to_the_result(
    data: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "target"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target, target_is_directory=True)
    for force in ([], ["--force"]):  # new, then replacing the result where the link points
        code, _ = cli(capsys, "ik", "--markers", data["markers"], "--out", link, *force)
        assert code == 0
        assert link.is_symlink() and link.resolve() == target.resolve()
        assert {"motion.npz", "model.xml", "summary.json"} <= {p.name for p in target.iterdir()}
        assert staging_left(target) == [] and staging_left(link) == []
    code, lines = cli(capsys, "ik", "--markers", data["markers"], "--out", link)
    refused(code, lines, 2, link, "not empty")


def test_batch_replaces_only_its_own_subject_folders(tmp_path: Path) -> None:
    """A subject folder of ``batch --out`` is replaced only if a batch wrote it (its marker,
    or an earlier batch's subject.json with nothing but the batch's folders beside it); a
    folder of the user's that bears a subject's name is kept and the subject fails."""
    from mocap_mj.batch.dataset import Entry
    from mocap_mj.batch.run import RECORD, execute

    def job(subject: Entry, folder: Path) -> dict[str, object]:
        (folder / "result.txt").write_text("new")
        return {"rows": []}

    (tmp_path / "S1").mkdir()
    (tmp_path / "S1" / "notes.txt").write_text("the user's")
    before = hashes(tmp_path / "S1")
    record = execute(job, Entry("S1", ("t.csv",)), str(tmp_path), "h")
    assert record["status"] == "failed"
    assert str(tmp_path / "S1") in record["error"] and MARKER in record["error"]
    assert hashes(tmp_path / "S1") == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["S1"]
    (tmp_path / "S1" / RECORD).write_text("{}")  # a subject.json beside the user's notes
    before = hashes(tmp_path / "S1")
    assert execute(job, Entry("S1", ("t.csv",)), str(tmp_path), "h")["status"] == "failed"
    assert hashes(tmp_path / "S1") == before
    (tmp_path / "S1" / "notes.txt").unlink()  # now an earlier batch's subject folder
    assert execute(job, Entry("S1", ("t.csv",)), str(tmp_path), "h")["status"] == "ok"
    assert sorted(p.name for p in (tmp_path / "S1").iterdir()) == sorted(
        [MARKER, RECORD, "result.txt"]
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["S1"]
