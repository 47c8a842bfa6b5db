"""``mocap-mj synth`` in a subprocess: files, JSON summary, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mocap_mj.io.ownership import MARKER
from mocap_synth import FILES


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", "synth", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def error_lines(stderr: str) -> list[str]:
    # Skip notices about other, unrelated add-on commands failing to load.
    return [line for line in stderr.splitlines() if not line.startswith("mocap-mj: command ")]


@pytest.mark.slow
def test_cli_writes_folder_and_json(tmp_path: Path) -> None:
    out = tmp_path / "s"
    proc = run("--out", str(out), "--frame-count", "60", "--movement", "walk", "--gaps", "0.05",
               "--swaps", "2", "--seed", "4", "--json")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary == json.loads((out / "summary.json").read_text())
    walk_truth = ["truth_events.csv", "truth_gait.json"]  # a walk's gait truth
    assert sorted(p.name for p in out.iterdir()) == sorted([*FILES, *walk_truth, MARKER])
    assert summary["frames"] == 60 and summary["motion"] == "walk" and summary["seed"] == 4
    assert len(summary["swapped"]) == 2 and summary["gap_fraction"] == pytest.approx(0.05, abs=1e-3)
    # Refused the second time (not empty), accepted with --force.
    again = run("--out", str(out), "--frame-count", "60")
    assert again.returncode == 2 and "not empty" in again.stderr
    assert run("--out", str(out), "--frame-count", "60", "--force").returncode == 0


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["--noise-mm", "-1"], "--noise-mm"),
        (["--frame-count", "0"], "--frame-count"),
        (["--frame-count", "ten"], "--frame-count"),
        (["--gaps", "1"], "--gaps"),
        (["--outliers", "-0.2"], "--outliers"),
        (["--movement", "dance"], "--movement"),
        (["--rate", "0"], "--rate"),
        (["--swaps", "40"], "swaps"),
    ],
)
@pytest.mark.slow
def test_cli_bad_arguments(tmp_path: Path, args: list[str], flag: str) -> None:
    out = tmp_path / "bad"
    proc = run("--out", str(out), *args)
    assert proc.returncode == 2
    lines = error_lines(proc.stderr)
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"mocap-mj synth: error: {flag}")
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    assert not out.exists()
