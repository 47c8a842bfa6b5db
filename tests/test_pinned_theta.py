"""The theta of ``mocap-mj demo`` (seed 0, its defaults) and of benchmarks/identify.py's first
solve (the joint LM on the 500-frame synthetic trial, seed 0), pinned by the SHA-256 of their
float64 bytes: a change of the code's structure that is meant to keep the arithmetic must
keep them bit for bit. The hashes are those of the initial model the bundled humanoid gives
today (``anatomy/initial.py``); a change of that model, or of the solver's arithmetic, changes
them legitimately, and the new hashes are then computed and written here with the change."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

import mocap_mj
from mocap_mj import cli

DEMO_THETA_SHA256 = "be142e856c27ca713f0eaf6f5f522b096fb5a653988b533de94d9cbd5d5fc6c2"
BENCHMARK_THETA_SHA256 = "182464e0527f0c44319fe23deba0981cf186d11b479f2eddee9a3e707d434642"


def _digest(theta: np.ndarray) -> str:
    return hashlib.sha256(np.asarray(theta, dtype=np.float64).tobytes()).hexdigest()


@pytest.mark.slow
def test_the_demo_gives_its_pinned_theta(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(["demo", "--out", str(tmp_path / "demo"), "--json"]) == 0
    json.loads(capsys.readouterr().out)  # the summary is one JSON object
    theta = mocap_mj.ParameterSet().load_json(tmp_path / "demo" / "result" / "theta.json")
    assert _digest(theta) == DEMO_THETA_SHA256


@pytest.mark.slow
def test_the_identify_benchmark_gives_its_pinned_theta() -> None:
    from mocap_mj.solve.lm import identify_lm
    from mocap_mj.solve.problem import TrialData
    from mocap_synth import SynthConfig, synthesize

    pset = mocap_mj.ParameterSet()
    exp = synthesize(SynthConfig(frames=500, seed=0), pset)
    data = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    assert _digest(identify_lm([data], pset=pset).theta) == BENCHMARK_THETA_SHA256
