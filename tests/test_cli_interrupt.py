"""Interrupted runs leave no folder that looks like a result, and do not block the next run.

``identify`` is started in a subprocess and sent SIGINT (Ctrl-C) or SIGKILL at a random
moment (seeded) after its work began; afterwards ``--out`` is either absent or a complete
result (the run finished first), and after SIGINT nothing of the run is left beside it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.errors import OutputFolderError
from mocap_mj.io.atomic import atomic_folder
from mocap_mj.pipeline.motion import ResultDir
from mocap_synth import SynthConfig, synthesize, write_experiment

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

#: What a complete identify folder holds.
RESULT_FILES = {"model.xml", "theta.json", "motion.npz", "identifiability.json", "summary.json"}


@pytest.fixture(scope="module")
def markers(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("interrupt")
    write_experiment(synthesize(SynthConfig(frames=40, seed=5)), root / "synth")
    return root / "synth" / "markers.csv"


def looks_like_a_result(folder: Path) -> bool:
    try:
        ResultDir.open(folder)
    except Exception:
        return (folder / "summary.json").exists()
    return True


def start_identify(markers: Path, out: Path) -> tuple[subprocess.Popen[str], float]:
    """Start ``identify``; return it and the moment its work began (its hidden folder exists)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(markers),
         "--out", str(out), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    deadline = time.monotonic() + 600
    while not any(p.name.startswith(f".{out.name}.partial-") for p in out.parent.iterdir()):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.02)
    return proc, time.monotonic()


@pytest.fixture(scope="module")
def work_seconds(markers: Path, tmp_path_factory: pytest.TempPathFactory) -> float:
    """How long an uninterrupted identify of the trial works (from its hidden folder to exit)."""
    proc, began = start_identify(markers, tmp_path_factory.mktemp("full") / "out")
    proc.communicate(timeout=600)
    assert proc.returncode == 0
    return time.monotonic() - began


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
@pytest.mark.parametrize("seed", [0, 1])
def test_interrupted_identify_leaves_no_partial_result(
    markers: Path, work_seconds: float, tmp_path: Path, sig: signal.Signals, seed: int
) -> None:
    out = tmp_path / "out"
    # A random moment of the work (fit or writing), from a seed.
    delay = float(np.random.default_rng(seed).uniform(0.0, 0.9)) * work_seconds
    proc, began = start_identify(markers, out)
    time.sleep(max(0.0, began + delay - time.monotonic()))
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=600)
    assert "Traceback" not in stderr
    if out.exists():  # the signal came after the rename: then the result is complete
        assert RESULT_FILES <= {p.name for p in out.iterdir()}
    else:
        assert not looks_like_a_result(out)
        # Ctrl-C: the CLI's 130, or death by the signal itself (-2, which a shell also reports
        # as 130) when it lands where Python's handler is not in charge (a native library's
        # own handler during in-process JIT compilation, the interpreter's start-up or
        # shutdown): seen once in a CI run, not reproduced in six local runs of this file.
        interrupted = (130, -signal.SIGINT) if sig == signal.SIGINT else (-signal.SIGKILL,)
        assert proc.returncode in interrupted
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".out.")]
    if sig == signal.SIGINT:
        assert leftovers == []
    # Whatever a kill left is no obstacle: the next folder is created and the stale one goes.
    with atomic_folder(out, force=True) as staging:
        (staging / "x").write_text("")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out.")] == []


def _stale_staging(folder: Path, pid: int) -> None:
    """``folder`` as a run of process ``pid`` leaves it when killed: marked ``staging``."""
    import json
    import socket

    from mocap_mj.io.ownership import FORMAT, MARKER

    folder.mkdir()
    record = {"format": FORMAT, "kind": "staging", "pid": pid, "host": socket.gethostname()}
    (folder / MARKER).write_text(json.dumps(record))


def test_stale_staging_is_removed_and_look_alikes_are_kept(tmp_path: Path) -> None:
    """A killed run's staging folder (the tool's marker, its process gone) is removed; a file
    or folder that merely bears a staging name is the user's: kept, byte for byte."""
    dead = _dead_pid()
    out = tmp_path / "out"
    stale_dir = tmp_path / f".out.partial-{dead}-abcd1234"
    _stale_staging(stale_dir, dead)
    (stale_dir / "model.xml").write_text("<mujoco/>")
    alike = tmp_path / f".out.partial-{dead}-00000000"  # the user's, no marker
    alike.mkdir()
    (alike / "notes.txt").write_text("mine")
    (tmp_path / f".out.old-{dead}-abcd1234").write_text("mine too")
    half = tmp_path / f".out.partial-{dead}-0000beef"  # killed while writing its marker
    half.mkdir()
    (half / f".mocap-mj-folder.json.{dead}.new").write_text('{"form')
    with atomic_folder(out) as staging:
        (staging / "summary.json").write_text("{}")
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["out", alike.name, f".out.old-{dead}-abcd1234"])
    assert (alike / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == [".mocap-mj-folder.json", "summary.json"]
    # Inside --out: a stale staging folder does not make it "not empty"; a file named like a
    # killed write's temporary does, and is kept.
    inner = tmp_path / "inner"
    inner.mkdir()
    _stale_staging(inner / f".x.partial-{dead}-abcd1234", dead)
    with atomic_folder(inner) as staging:
        (staging / "summary.json").write_text("{}")
    assert sorted(p.name for p in inner.iterdir()) == [".mocap-mj-folder.json", "summary.json"]
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / f".summary.tmp-{dead}-abcd1234.json").write_text("{")
    with pytest.raises(OutputFolderError, match="not empty"), atomic_folder(mine):
        pass
    assert [p.name for p in mine.iterdir()] == [f".summary.tmp-{dead}-abcd1234.json"]


def test_failed_block_leaves_the_old_folder(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with atomic_folder(out) as staging:  # a result, which --force may replace
        (staging / "summary.json").write_text("{}")
        (staging / "old.txt").write_text("old")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(KeyboardInterrupt), atomic_folder(out, force=True) as staging:
        (staging / "new.txt").write_text("new")
        raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    with pytest.raises(OutputFolderError, match="not empty"), atomic_folder(out):
        pass


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    pid = proc.pid
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return pid
    pytest.skip("could not find a pid that is not running")
    raise AssertionError  # unreachable


def test_ctrl_c_during_shutdown_keeps_the_exit_status() -> None:
    """A Ctrl-C that arrives while the interpreter shuts down, after the command finished,
    neither kills the process by the signal nor changes its exit status (the interpreter
    restores the default SIGINT action during shutdown unless the signal is ignored)."""
    code = (
        "import atexit, os, signal, sys\n"
        # Registered before main: exit handlers run last-in first-out, so this one runs
        # after the command's own and stands for a Ctrl-C late in the shutdown.
        "atexit.register(lambda: os.kill(os.getpid(), signal.SIGINT))\n"
        "from mocap_mj.cli import main\n"
        "sys.exit(main(['info']))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
