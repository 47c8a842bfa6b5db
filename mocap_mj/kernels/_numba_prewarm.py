"""The background compile as the kernels see it: :func:`wait`, called by the Python wrappers of
the kernels :func:`mocap_mj.skeleton.prewarm.start` compiles in a second process, before their
first call, waits for that process, so that they load from the cache instead of compiling. A
process still running at exit is stopped (numba writes its cache files atomically).
"""

from __future__ import annotations

import atexit
import subprocess

__all__ = ["follow", "started", "wait"]

_process: subprocess.Popen[bytes] | None = None


def follow(process: subprocess.Popen[bytes]) -> None:
    """Wait for ``process`` (the background compile) before the kernels' first call."""
    global _process
    _process = process
    atexit.register(_stop)


def started() -> bool:
    """Whether this process has started a background compile."""
    return _process is not None


def wait() -> None:
    """Wait for the background compile, if one was started and is still running."""
    if _process is not None:
        _process.wait()


def _stop() -> None:
    if _process is not None and _process.poll() is None:
        _process.terminate()
        _process.wait()
