"""The theta of ``mocap-mj demo`` (seed 0, its defaults) and of benchmarks/identify.py's first
solve (the joint LM on the 500-frame synthetic trial, seed 0), pinned by the SHA-256 of their
float64 bytes: a change of the code's structure that is meant to keep the arithmetic must
keep them bit for bit. The hashes are those of the initial model the bundled humanoid gives
today (``anatomy/initial.py``); a change of that model, or of the solver's arithmetic, changes
them legitimately, and the new hashes are then computed and written here with the change.
Each runs in a fresh process on one numba thread: the last bits of the LM's sums over frames
follow the thread count, and a process that ran other work first may reach them otherwise."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mocap_mj

DEMO_THETA_SHA256 = "5093480ac5790c3c66b2f2e5c815f715b28751f13a3aa1c99bff22356e716ca3"
BENCHMARK_THETA_SHA256 = "326462d7f6a79c202d776ab404f84c6657de88967f3bb4f0116b375d6e57d246"
_ENV = {**os.environ, "NUMBA_NUM_THREADS": "1"}
_BENCHMARK = """
import hashlib, numpy as np, mocap_mj
from mocap_mj.solve.lm import identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize
pset = mocap_mj.ParameterSet()
exp = synthesize(SynthConfig(frames=500, seed=0), pset)
data = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
theta = np.asarray(identify_lm([data], pset=pset).theta, dtype=np.float64)
print(hashlib.sha256(theta.tobytes()).hexdigest())
"""


def _digest(theta: np.ndarray) -> str:
    return hashlib.sha256(np.asarray(theta, dtype=np.float64).tobytes()).hexdigest()


@pytest.mark.slow
def test_the_demo_gives_its_pinned_theta(tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "mocap_mj", "demo", "--out", str(tmp_path / "demo"), "--json"]
    proc = subprocess.run(argv, capture_output=True, text=True, env=_ENV, check=False)
    assert proc.returncode == 0, proc.stderr
    json.loads(proc.stdout)  # the summary is one JSON object
    theta = mocap_mj.ParameterSet().load_json(tmp_path / "demo" / "result" / "theta.json")
    assert _digest(theta) == DEMO_THETA_SHA256


@pytest.mark.slow
def test_the_identify_benchmark_gives_its_pinned_theta() -> None:
    proc = subprocess.run([sys.executable, "-c", _BENCHMARK], capture_output=True, text=True,
                          env=_ENV, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == BENCHMARK_THETA_SHA256
