"""Compile the identification kernels in a second process while this one compiles the IK's.

Numba compiles one kernel at a time per process (a global compiler lock), and the first run of
an install spends most of its time compiling (docs/validation.md#first-run). A command that will
identify a model needs the IK kernel first and the Schur-complement and forward-kinematics
kernels after it; :func:`start` launches a Python process running :func:`_compile`, which compiles
the latter into the shared on-disk cache (:mod:`mocap_mj.kernels._kernel_cache`) on the other core,
and :func:`mocap_mj.kernels._numba_prewarm.wait` (called by those kernels' Python wrappers
before their first call) waits for it, so the kernels then load from the cache instead of
compiling.

The second process pays off only with a core to spare: on a machine whose load average
already fills all but one core the two processes share the cores and the first run gets
slower (the second process also compiles the helpers both kernels call). So it starts only
when the kernels are not cached yet and the 1-minute load average is below (cores - 1) + 0.5;
``MOCAP_MJ_PREWARM=1`` starts it regardless, ``=0`` never (the background process itself runs
with 0). A background process still running at exit is stopped (numba writes its cache files
atomically).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from mocap_mj.kernels import _numba_prewarm

__all__ = ["start"]

_ENV = "MOCAP_MJ_PREWARM"


def _cached(kernel: object) -> bool:
    """Whether numba's on-disk index for ``kernel`` (a cached dispatcher) exists."""
    try:
        return Path(kernel._cache._cache_file._index_path).exists()  # type: ignore[attr-defined]
    except AttributeError:  # another numba's cache layout: assume cached, start nothing
        return True


def _kernels() -> tuple[object, ...]:
    from mocap_mj.kernels import _schur, _tree

    return (_schur._schur_range, _schur._back_range, _tree._forward_range)


def start() -> None:
    """Start the background compile if the kernels are not cached yet (once per process)."""
    setting = os.environ.get(_ENV, "")
    if _numba_prewarm.started() or setting == "0" or all(_cached(k) for k in _kernels()):
        return
    if setting != "1" and not _core_to_spare():
        return
    env = dict(os.environ, **{_ENV: "0"})
    try:
        process = subprocess.Popen(
            [sys.executable, "-c", f"from {__name__} import _compile; _compile()"],
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:  # cannot start a process: compile in this one when needed
        return
    _numba_prewarm.follow(process)


def _core_to_spare() -> bool:
    """Whether the 1-minute load average leaves a core idle (see the module docstring)."""
    try:
        load = os.getloadavg()[0]
    except OSError:  # not available on this platform
        return False
    return load < (os.cpu_count() or 1) - 0.5


def _compile() -> None:
    """Compile the kernels of :func:`_kernels` by running them on two frames of the bundled
    model, with the argument types the library passes them."""
    from mocap_mj.kernels import _schur, _tree
    from mocap_mj.skeleton.kinematics import Kinematics

    kin = Kinematics()
    tr = kin.tree()
    qpos = np.tile(kin.model.qpos0, (2, 1))
    target = _tree.forward(tr, qpos)
    wts = np.ones(target.shape[:2])
    free = np.arange(kin.pset.size, dtype=np.int64)
    blocks = _schur.frame_blocks(tr, kin.kappa_tables(), target, wts, qpos, free, 1e-3)
    _schur.back_substitute(tr, blocks, np.zeros(free.size))
