"""The theta of ``mocap-mj demo`` (seed 0, its defaults) and of benchmarks/identify.py's first
solve (the joint LM on the 500-frame synthetic trial, seed 0), pinned by the SHA-256 of their
float64 bytes: a change of the code's structure that is meant to keep the arithmetic must
keep them bit for bit. The hashes are those of the initial model the bundled humanoid gives
today (``anatomy/initial.py``); a change of that model, or of the solver's arithmetic, changes
them legitimately, and the new hashes are then computed and written here with the change.
Each runs in a fresh process on one numba thread: the last bits of the LM's sums over frames
follow the thread count, and a process that ran other work first may reach them otherwise.

The last bits also follow the CPU (numba compiles for the host's vector units, and BLAS picks
its kernels by it): each pin holds the hashes of the hosts it was computed on, and
``pinned_theta.json`` the theta itself (float64, exact through JSON). On a host whose hash is
not pinned, theta must agree with the stored one within :data:`OTHER_HOST_ATOL` (a thread
count's or a host's reordering of the sums moves it by about 1e-13 m; a changed solve by far
more)."""

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

DEMO_THETA_SHA256 = (
    "5093480ac5790c3c66b2f2e5c815f715b28751f13a3aa1c99bff22356e716ca3",
    "efdbf9598787f536c81a47d289a1fc9f5b70fda82e23f33fec71fd6b9b2d1770",
)
BENCHMARK_THETA_SHA256 = (
    "326462d7f6a79c202d776ab404f84c6657de88967f3bb4f0116b375d6e57d246",
    "3ef8e3e63612ef9650a46397765810b3371cfc1848327b290e75f52a99b30616",
)
#: Largest difference [m] from the stored theta allowed on a host whose hash is not pinned.
OTHER_HOST_ATOL = 1e-9
_STORED = Path(__file__).with_name("pinned_theta.json")
_ENV = {**os.environ, "NUMBA_NUM_THREADS": "1"}
_BENCHMARK = """
import json, numpy as np, mocap_mj
from mocap_mj.solve.lm import identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize
pset = mocap_mj.ParameterSet()
exp = synthesize(SynthConfig(frames=500, seed=0), pset)
data = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
theta = np.asarray(identify_lm([data], pset=pset).theta, dtype=np.float64)
print(json.dumps(theta.tolist()))
"""


def _digest(theta: np.ndarray) -> str:
    return hashlib.sha256(np.asarray(theta, dtype=np.float64).tobytes()).hexdigest()


def _assert_pinned(theta: np.ndarray, pins: tuple[str, ...], key: str) -> None:
    """theta (P,) [m] is bit for bit a pinned host's, else within OTHER_HOST_ATOL of the
    stored one."""
    if _digest(theta) in pins:
        return
    stored = np.asarray(json.loads(_STORED.read_text())[key], dtype=np.float64)
    assert _digest(stored) in pins, f"{_STORED}: {key} is not the pinned theta"
    off = float(np.max(np.abs(np.asarray(theta, dtype=np.float64) - stored)))
    assert off <= OTHER_HOST_ATOL, f"{key}: theta {off:.3g} m from the pinned one"


@pytest.mark.slow
def test_the_demo_gives_its_pinned_theta(tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "mocap_mj", "demo", "--out", str(tmp_path / "demo"), "--json"]
    proc = subprocess.run(argv, capture_output=True, text=True, env=_ENV, check=False)
    assert proc.returncode == 0, proc.stderr
    json.loads(proc.stdout)  # the summary is one JSON object
    theta = mocap_mj.ParameterSet().load_json(tmp_path / "demo" / "result" / "theta.json")
    _assert_pinned(theta, DEMO_THETA_SHA256, "demo")


@pytest.mark.slow
def test_the_identify_benchmark_gives_its_pinned_theta() -> None:
    proc = subprocess.run([sys.executable, "-c", _BENCHMARK], capture_output=True, text=True,
                          env=_ENV, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    _assert_pinned(np.asarray(json.loads(proc.stdout)), BENCHMARK_THETA_SHA256, "benchmark")
