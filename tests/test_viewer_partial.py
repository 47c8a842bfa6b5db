"""Partial recordings in render and view: a frame not solved is "no data" (refused as a PNG,
an empty labelled image in a video, the body hidden in the viewer), a segment no recorded
marker measures is drawn grey and translucent, and the label gives the recording's frame."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_viewer.playback import UNMEASURED_RGBA, frame_label, load_playback

LOWER = "LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB RANK RHEE RTOE".split()
UNSOLVED = (2, 3)  # rows without a pose
FIRST = 700  # the recording's number of row 0


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A result of 8 frames: lower-body markers only, rows 2 and 3 not solved."""
    root = tmp_path_factory.mktemp("partial")
    kin = Kinematics()
    qpos = np.tile(np.array(kin.model.qpos0), (8, 1))
    qpos[:, 0] = np.linspace(0.0, 0.1, 8)
    markers = kin.marker_positions(qpos)
    markers[:, [n not in LOWER for n in kin.pset.marker_names]] = np.nan
    qpos[list(UNSOLVED)] = np.nan
    ParameterSet().export_mjcf(root / "model.xml", ParameterSet().nominal)
    motion = Motion(qpos, np.arange(8) / 100.0, markers, kin.pset.marker_names, None, FIRST)
    save_motion(root / "motion.npz", motion)
    return root


def test_unrecorded_segments_are_grey_and_unsolved_frames_no_data(result: Path) -> None:
    pb = load_playback(result)
    assert {"head", "hand_l", "thorax"} <= set(pb.unmeasured_bodies)
    assert not {"pelvis", "thigh_l", "shank_r"} & set(pb.unmeasured_bodies)
    for g in range(pb.model.ngeom):
        body = pb.model.body(int(pb.model.geom_bodyid[g])).name
        grey = np.allclose(pb.model.geom_rgba[g], UNMEASURED_RGBA)
        assert grey == (body in pb.unmeasured_bodies), body
    assert pb.solved.tolist() == [k not in UNSOLVED for k in range(8)]
    assert np.isnan(pb.predicted[2]).all() and np.isfinite(pb.predicted[1, 0]).all()
    assert frame_label(pb, 2) == "frame 702 (row 2)  t = 0.020 s  no data (not solved)"
    assert frame_label(pb, 1).startswith("frame 701 (row 1)  t = 0.010 s  RMSE")
    pb.show_body(False)
    assert (pb.model.geom_rgba[pb.model.geom_bodyid > 0, 3] == 0).all()
    pb.show_body(True)
    assert pb.model.geom_rgba[pb.model.geom_bodyid > 0, 3].min() == UNMEASURED_RGBA[3]


def _render(*args: str | Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", "render", *map(str, args)],
        env=env, capture_output=True, text=True, timeout=240, check=False,
    )  # fmt: skip


@pytest.mark.slow
def test_render_refuses_an_unsolved_png_and_draws_no_data_in_a_video(
    result: Path, tmp_path: Path
) -> None:
    png = tmp_path / "f.png"
    proc = _render(result, "--out", png, "--frame", "2", "--fast", "--size", "80x60")
    if "cannot render" in proc.stderr:
        pytest.skip(f"offscreen rendering unavailable: {proc.stderr.strip()}")
    assert proc.returncode == 2 and not png.exists()
    assert "frame 2 (the recording's 702) was not solved" in proc.stderr
    assert "nearest solved rows: 1, 4" in proc.stderr and "Traceback" not in proc.stderr
    gif = tmp_path / "f.gif"
    proc = _render(result, "--out", gif, "--fast", "--size", "80x60", "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["frames_without_data"] == len(UNSOLVED)
    from PIL import Image, ImageSequence

    with Image.open(gif) as im:
        frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
    grey = np.median(frames[2].reshape(-1, 3), axis=0)
    assert len(frames) == 8 and 80 < grey.mean() < 110  # the "no data" grey, not black
    assert not np.array_equal(frames[1], frames[2])
