"""angles.csv of a long recording, written chunk by chunk (mocap_mj.long.angles_out): the
same table as the whole motion's (export --to angles), whatever the chunk."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.cli import main
from mocap_mj.export.clinical import angles_table_text
from mocap_mj.long.angles_out import write_angle_chunks
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.skeleton.exported import Layout


def test_chunked_angles_are_the_whole_motions(tmp_path: Path) -> None:
    """A walk-like motion (the pelvis moves more than 0.5 m, so the progression frame comes
    from its first and last frames) written in chunks of 37 frames: the text of
    angles.csv is the whole motion's, byte for byte, frame numbers from the first frame."""
    pset = ParameterSet()
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 250, seed=11)
    qpos[:, 0] += np.linspace(0.0, -2.0, len(qpos))  # walks 2 m towards -x
    model = pset.model_for(pset.nominal)
    times = np.arange(len(qpos)) / 100.0
    layout = Layout.of(model)
    markers = np.zeros((len(qpos), pset.n_markers, 3))
    motion = Motion(layout.written(qpos), times, markers, pset.marker_names, first_frame=694)
    save_motion(tmp_path / "motion.npz", motion)
    write_angle_chunks(tmp_path / "angles.csv", model, tmp_path / "motion.npz", 694, 37)
    want = angles_table_text(model, times, qpos, 694)
    got = (tmp_path / "angles.csv").read_text()
    assert got == want
    assert got.splitlines()[1].startswith("694,") and got.splitlines()[-1].startswith("943,")


@pytest.mark.slow
def test_identify_select_writes_the_angles_of_every_frame(tmp_path: Path) -> None:
    """``identify`` with ``select`` (every frame's motion chunk by chunk) writes angles.csv of
    every frame, the table ``export --to angles`` computes from its motion.npz."""
    truth, out = tmp_path / "truth", tmp_path / "sel"
    assert main(["synth", "--out", str(truth), "--frame-count", "200", "--movement", "walk",
                 "--seed", "3"]) == 0  # fmt: skip
    (tmp_path / "select.yaml").write_text("select: 80\n")
    code = main(["identify", "--markers", str(truth / "markers.trc"), "--recipe",
                 str(tmp_path / "select.yaml"), "--out", str(out), "--json"])  # fmt: skip
    assert code == 0
    assert json.loads((out / "summary.json").read_text())["motion_frames"] == [200]
    got = (out / "angles.csv").read_text()
    assert len(got.splitlines()) == 201
    again = tmp_path / "again.csv"
    assert main(["export", str(out), "--to", "angles", "--out", str(again)]) == 0
    assert got == again.read_text()
