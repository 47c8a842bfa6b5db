"""Ask ezc3d whether it reads a C3D file, in a separate process that may crash or hang.

The reader's own structural check (:mod:`mocap_mj.io.formats.c3d_check`) refuses some files
that ezc3d reads (unusual but valid layouts). ezc3d is the parser of record, so before such a
refusal stands, :func:`ezc3d_failure` lets ezc3d try the file where a crash cannot take the
caller down: a forked child on POSIX (a few milliseconds, ezc3d already imported), else a new
interpreter. The child's verdict is only "read" or "did not read"; the caller then reads the
file in-process, which is safe because ezc3d is deterministic.
"""

from __future__ import annotations

import faulthandler
import os
import signal
import subprocess
import sys
from pathlib import Path

__all__ = ["PROBE_TIMEOUT", "ezc3d_failure"]

#: Seconds ezc3d may take on one file in the probe before it counts as hung. Real files of
#: tens of megabytes read in about a second; the bound stops a corrupted header (on which
#: ezc3d can loop forever) from stalling the caller.
PROBE_TIMEOUT = 20
#: Memory the forked probe may add [bytes]: 1 GiB plus 64 bytes per byte of file. ezc3d keeps
#: each 4-byte value as an 8-byte double plus copies; a corrupted header can ask it for tens
#: of gigabytes, which the limit turns into a failed read instead of a machine out of memory.
PROBE_MEMORY = (1 << 30, 64)

_CHILD = (
    "import sys, ezc3d\n"
    "try:\n"
    "    ezc3d.c3d(sys.argv[1])\n"
    "except Exception as exc:\n"
    "    sys.stdout.write(' '.join(str(exc).split())[:200] or type(exc).__name__)\n"
    "    sys.exit(1)\n"
)


def ezc3d_failure(path: Path, timeout: int = PROBE_TIMEOUT) -> str | None:
    """None if ezc3d reads ``path`` in a separate process, else one line saying why not."""
    if hasattr(os, "fork"):
        return _forked(path, timeout)
    return _spawned(path, timeout)


def _forked(path: Path, timeout: int) -> str | None:
    import ezc3d

    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: never returns
        code = 1
        try:
            os.close(read_end)
            faulthandler.disable()  # a crash here is an answer, not a report
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(timeout)
            _limit_memory(path)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.dup2(null, 2)
            try:
                ezc3d.c3d(str(path))
                code = 0
            except Exception as exc:
                message = " ".join(str(exc).split())[:200] or type(exc).__name__
                os.write(write_end, message.encode("utf-8", "replace"))
        finally:
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as pipe:
        message = pipe.read().decode("utf-8", "replace")
    _, status = os.waitpid(pid, 0)
    return _verdict(status, message, timeout)


def _limit_memory(path: Path) -> None:
    """Cap the child's address space at its current size plus :data:`PROBE_MEMORY`."""
    import resource

    try:
        with open("/proc/self/statm") as statm:
            current = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return
    base, per_byte = PROBE_MEMORY
    limit = current + base + per_byte * path.stat().st_size
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file for an expected crash


def _verdict(status: int, message: str, timeout: int) -> str | None:
    if os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0:
        return None
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        if sig == signal.SIGALRM:
            return f"ezc3d did not finish within {timeout} s"
        return f"ezc3d crashed (signal {sig})"
    return f"ezc3d: {message}" if message else "ezc3d could not read it"


def _spawned(path: Path, timeout: int) -> str | None:
    try:
        done = subprocess.run(
            [sys.executable, "-c", _CHILD, str(path)],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return f"ezc3d did not finish within {timeout} s"
    if done.returncode == 0:
        return None
    if done.returncode < 0:
        return f"ezc3d crashed (signal {-done.returncode})"
    return f"ezc3d: {done.stdout.strip()}" if done.stdout.strip() else "ezc3d could not read it"
