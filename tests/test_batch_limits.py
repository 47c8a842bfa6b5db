"""``mocap-mj batch``: a per-subject time limit, stdout that is the JSON alone, one-line
manifest errors.

The subjects' job is replaced by a stand-in (a subject that sleeps, one that prints on file
descriptor 1 as Ray's processes do): what is checked is the batch around it.
"""

from __future__ import annotations

import csv
import json
import os
import time
from pathlib import Path
from typing import Any

import pytest

from mocap_mj.batch.dataset import Entry
from mocap_mj.cli import main


def _dataset(root: Path, names: tuple[str, ...]) -> Path:
    for name in names:
        (root / name).mkdir(parents=True)
        (root / name / "walk.csv").write_text("stand-in\n")
    return root


def _job(subject: Entry, folder: Path) -> dict[str, Any]:
    if subject.name == "slow":
        time.sleep(60)  # a subject that hangs
    os.write(1, b"(raylet) a log line of a process the batch started\n")
    return {
        "identify": {"marker_rmse_mm": 1.0},
        "rows": [{"subject": subject.name, "trial": "walk.csv", "status": "ok", "error": ""}],
    }


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with open(out / "summary.csv", newline="") as handle:
        return {r["subject"]: r for r in csv.DictReader(handle)}


def test_a_subject_past_the_time_limit_is_recorded_and_the_batch_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("mocap_mj.commands.batch.process_subject", _job)
    ds = _dataset(tmp_path / "ds", ("fast", "slow", "zlast"))
    out = tmp_path / "out"
    t0 = time.monotonic()
    code = main(["batch", str(ds), "--out", str(out), "--serial", "--timeout", "0.5", "--json"])
    assert time.monotonic() - t0 < 30  # the sleeping subject was stopped
    assert code == 1
    captured = capfd.readouterr()
    summary = json.loads(captured.out)  # stdout is the JSON alone
    assert summary["subjects_failed"] == ["slow"] and summary["exit_status"] == 1
    rows = _rows(out)
    assert {n: r["status"] for n, r in rows.items()} == {
        "fast": "ok",
        "slow": "timed out",
        "zlast": "ok",
    }
    assert rows["slow"]["error"] == "timed out after 0.5 s (batch --timeout)"
    assert "timed out after 0.5 s" in (out / "report.md").read_text()
    assert "(raylet)" in captured.err and "Traceback" not in captured.err
    assert not (out / "slow").exists()


@pytest.mark.parametrize("value", ["0", "-3", "nan"])
def test_timeout_must_be_positive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    with pytest.raises(SystemExit) as info:
        main(["batch", str(tmp_path), "--out", str(tmp_path / "o"), "--timeout", value])
    assert info.value.code == 2
    assert f"argument --timeout: expected a number > 0, got '{value}'" in capsys.readouterr().err


def test_a_broken_yaml_manifest_is_one_line_naming_the_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = tmp_path / "m.yaml"
    manifest.write_text("subjects:\n  - name: A\n    trials: [a.c3d\n  - name: B\n")
    assert main(["batch", str(manifest), "--out", str(tmp_path / "o"), "--serial"]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"mocap-mj batch: error: {manifest}: expected a YAML manifest: line 4, column 9: "
        "expected ',' or ']', but got ':' (while parsing a flow sequence)\n"
    )


def test_an_implausible_identification_makes_the_batch_exit_3(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    def job(subject: Entry, folder: Path) -> dict[str, Any]:
        record = _job(subject, folder)
        if subject.name == "odd":
            record["identify"]["implausible"] = ["marker RMSE 111 mm, above the 30 mm"]
        return record

    monkeypatch.setattr("mocap_mj.commands.batch.process_subject", job)
    ds = _dataset(tmp_path / "ds", ("fine", "odd"))
    code = main(["batch", str(ds), "--out", str(tmp_path / "out"), "--serial", "--json"])
    assert code == 3
    captured = capfd.readouterr()
    summary = json.loads(captured.out)
    assert summary["subjects_implausible"] == ["odd"] and summary["exit_status"] == 3
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["exit_status"] == 3
    assert "mocap-mj batch: implausible identification of odd (exit status 3" in captured.err
