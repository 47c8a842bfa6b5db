"""Helpers of the fault tests: the command line run in this process, file hashes, a dead pid."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mocap_mj.cli import main

#: stderr notices that precede any work (an add-on that failed to load, the kernels compiling).
NOTICES = ("mocap-mj: command ", "mocap-mj: compiling")


def cli(
    capsys: pytest.CaptureFixture[str], *argv: str | Path, drop: tuple[str, ...] = ()
) -> tuple[int, list[str]]:
    """Run ``mocap-mj ARGV`` in this process: its exit status and its stderr lines, the
    notices and lines holding any of ``drop`` aside; a traceback fails the test."""
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [
        line
        for line in err.splitlines()
        if line.strip() and not line.startswith(NOTICES) and not any(d in line for d in drop)
    ]
    return code, lines


def hashes(path: Path) -> dict[str, str]:
    """SHA-256 of every file under ``path`` (or of the file), by relative path."""
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    return {str(f.relative_to(path)): hashlib.sha256(f.read_bytes()).hexdigest() for f in files}


def dead_pid() -> int:
    """The pid of a process that has ended (skips the test if it was reused meanwhile)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    try:
        os.kill(proc.pid, 0)
    except ProcessLookupError:
        return proc.pid
    pytest.skip("could not find a pid that is not running")
    raise AssertionError  # unreachable


def identified_trial(root: Path, frames: int, seed: int) -> dict[str, Path]:
    """A synthetic trial of ``frames`` frames in ``root/synth`` and its identification in
    ``root/result`` (``mocap-mj identify`` in a process of its own): the paths by name
    (``root``, ``synth``, ``markers``, ``result``)."""
    from mocap_synth import SynthConfig, synthesize, write_experiment

    write_experiment(synthesize(SynthConfig(frames=frames, seed=seed)), root / "synth")
    markers, result = root / "synth" / "markers.csv", root / "result"
    proc = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(markers),
         "--out", str(result), "--json"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return {"root": root, "synth": root / "synth", "markers": markers, "result": result}
