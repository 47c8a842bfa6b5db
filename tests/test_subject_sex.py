"""The subject's sex (a subject file's ``sex``): de Leva's women's or men's table for the
segments' masses and inertias in identify's model.xml and kinetics, recorded in summary.json
and report.md, and taken by ik from the identified model's folder."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.anatomy.inertia import segment_inertia
from mocap_mj.capture.subject import Subject, from_yaml
from mocap_mj.errors import MocapError
from mocap_mj.skeleton.mjcf import load_model

MASS = 68.0  # [kg]


def test_a_subject_file_gives_the_sex_and_a_bad_one_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "s.yaml").write_text("mass: 68\nsex: F\n")
    subject = from_yaml(tmp_path / "s.yaml")
    assert subject.sex == ("female", f"{tmp_path / 's.yaml'}: sex")
    assert subject.table == "female" and Subject().table == "male"
    assert Subject().update(subject).sex == subject.sex  # a later source's sex wins
    assert subject.update(Subject()).sex == subject.sex  # and none leaves it
    assert subject.with_stature_estimate(None).sex == subject.sex
    summary = {"measurements": subject.to_dict(),
               "sex": {"value": "female", "source": subject.sex[1]}}  # fmt: skip
    assert Subject.from_summary(summary).sex == subject.sex
    (tmp_path / "bad.yaml").write_text("sex: 2\n")
    with pytest.raises(MocapError) as info:
        from_yaml(tmp_path / "bad.yaml")
    assert str(info.value) == f"{tmp_path / 'bad.yaml'}: sex: expected female or male, got 2"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True, timeout=600
    )


@pytest.mark.slow
def test_identify_and_ik_take_the_womens_table(tmp_path: Path) -> None:
    synth = tmp_path / "synth"
    proc = run("synth", "--out", str(synth), "--movement", "static", "--noise-mm", "0",
               "--frame-count", "120", "--seed", "5", "--with-plate", f"{MASS:g}")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    (tmp_path / "s.yaml").write_text(f"mass: {MASS}\nsex: female\n")
    out = tmp_path / "identify"
    proc = run("identify", "--markers", str(synth / "plates.c3d"), "--subject-file",
               str(tmp_path / "s.yaml"), "--out", str(out))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sex"] == {"value": "female", "source": f"{tmp_path / 's.yaml'}: sex"}
    assert "- sex: female" in (out / "report.md").read_text()
    model = load_model(out / "model.xml")
    women, men = (segment_inertia(model, MASS, sex=s).mass for s in ("female", "male"))
    np.testing.assert_allclose(model.body_mass[1:], women)
    assert np.abs(women - men).max() > 0.3  # [kg]: the tables differ
    assert [t["sex"] for t in summary["kinetics"]["trials"]] == ["female"]
    again = tmp_path / "ik"
    proc = run("ik", "--markers", str(synth / "plates.c3d"), "--model", str(out / "model.xml"),
               "--out", str(again))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    ik = json.loads((again / "summary.json").read_text())["kinetics"]
    assert [t["sex"] for t in ik["trials"]] == ["female"]  # from the model's folder


def test_plug_in_gait_reads_the_same_subject_file(tmp_path: Path) -> None:
    """Plug-in Gait's Dempster table has one sex: the key is checked and not used."""
    from mocap_mj.clinical.subject import pig_from_yaml

    (tmp_path / "s.yaml").write_text("knee_width_l: 100 mm\nsex: female\n")
    assert pig_from_yaml(tmp_path / "s.yaml").get("knee_width_l") == pytest.approx(0.1)
    (tmp_path / "bad.yaml").write_text("sex: x\n")
    with pytest.raises(MocapError, match="sex: expected female or male"):
        pig_from_yaml(tmp_path / "bad.yaml")
