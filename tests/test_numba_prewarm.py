"""The background compile of the identification kernels (mocap_mj.skeleton.prewarm, and
mocap_mj.kernels._numba_prewarm, which the kernels wait on)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mocap_mj.kernels import _numba_prewarm
from mocap_mj.skeleton import prewarm

#: Run with the background process's cache: the LM's elimination and back-substitution and the
#: forward kinematics as the library calls them; prints each kernel's cache hits and misses.
_USE = """
import numpy as np
from mocap_mj import Kinematics, ParameterSet
from mocap_mj.kernels import _schur, _tree
from mocap_mj.solve.problem import IdentificationProblem
from mocap_synth import SynthConfig, synthesize

exp = synthesize(SynthConfig(frames=6, seed=1), ParameterSet())
kin = Kinematics(exp.pset)
free = np.flatnonzero(~exp.pset.frozen)
prob = IdentificationProblem(kin, np.asarray(exp.markers), np.asarray(exp.qpos).copy(), free)
chunk = prob.reduce(slice(0, prob.n), prob.present.astype(float), 1e-3)
chunk.step(np.zeros(free.size))
kin.site_positions(np.asarray(exp.qpos))
for k in (_schur._schur_range, _schur._back_range, _tree._forward_range):
    print(k.py_func.__name__, sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values()))
"""


def test_off_starts_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MOCAP_MJ_PREWARM", "0")
    monkeypatch.setattr(_numba_prewarm, "_process", None)
    prewarm.start()
    assert _numba_prewarm._process is None
    _numba_prewarm.wait()  # nothing to wait for


@pytest.mark.slow
def test_background_compile_serves_the_identification(tmp_path: Path) -> None:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), MOCAP_MJ_PREWARM="0")
    subprocess.run(
        [sys.executable, "-c", "from mocap_mj.skeleton.prewarm import _compile; _compile()"],
        env=env,
        check=True,
        timeout=900,
    )
    out = subprocess.run(
        [sys.executable, "-c", _USE], env=env, check=True, capture_output=True, text=True
    ).stdout.split()
    stats = {out[i]: (int(out[i + 1]), int(out[i + 2])) for i in range(0, len(out), 3)}
    # Every kernel loaded from the cache the background process wrote: none compiled again.
    assert stats == {"_schur_range": (1, 0), "_back_range": (1, 0), "_forward_range": (1, 0)}
