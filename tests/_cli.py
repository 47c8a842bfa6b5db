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
