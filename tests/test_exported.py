"""The written model in plain MuJoCo (mocap_mj/skeleton/exported.py, docs/mujoco.md): the knees'
slide joints reproduce the tool's kinematics, keep the coupling under mj_step, and a model written
before them is read alike."""

from __future__ import annotations

import os
import re
from pathlib import Path
from xml.etree import ElementTree

import mujoco
import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.cli import main
from mocap_mj.errors import InputFileError
from mocap_mj.export.read_result import load_result
from mocap_mj.pipeline.motion import Motion, load_motion, save_motion
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.mjcf import load_model
from mocap_synth import SynthConfig, synthesize, write_experiment

DOC = Path(__file__).resolve().parent.parent / "docs" / "mujoco.md"
#: The agreement target between plain MuJoCo and the tool [m].
TOLERANCE = 1e-4


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mocap-mj ik`` of a synthetic range-of-motion trial (knees flexed up to ~140 deg):
    a result folder as the tool writes it."""
    root = tmp_path_factory.mktemp("exported")
    write_experiment(synthesize(SynthConfig(frames=60, motion="rom", seed=3)), root / "synth")
    argv = ["ik", "--markers", str(root / "synth" / "markers.csv"), "--out", str(root / "result")]
    assert main([*argv, "--json"]) == 0
    return root


def _tool(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tool's reading of a result: internal qpos (T, nq), model markers (T, M, 3) [m] by
    the solvers' compiled kinematics, and joint_centres.csv (T, J, 3) [m]."""
    pset = ParameterSet(folder / "model.xml")
    qpos = load_motion(folder / "motion.npz", pset.model).qpos
    markers = Kinematics(pset).site_positions(qpos)
    table = np.genfromtxt(folder / "joint_centres.csv", delimiter=",", skip_header=1)
    return qpos, markers, table[:, 2:].reshape(len(table), -1, 3) * 1e-3


def test_doc_example_reproduces_the_tool_on_flexed_knees(result: Path) -> None:
    code = re.search(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert code is not None, f"{DOC}: no python example"
    assert len(code.group(1).strip().splitlines()) <= 16
    cwd = os.getcwd()
    os.chdir(result)
    try:
        scope: dict = {}
        exec(code.group(1), scope)  # the documented example, as a user runs it
    finally:
        os.chdir(cwd)
    model, sites = scope["model"], scope["sites"]
    assert model.nq == 59 and model.nv == 52 and model.neq == 4
    qpos, markers, centres = _tool(result / "result")
    knees = [ParameterSet().model.joint(n).qposadr[0] for n in ("knee_flex_l", "knee_flex_r")]
    assert np.degrees(qpos[:, knees].max()) > 100.0  # the coupling is far from zero
    np.testing.assert_allclose(sites, markers, rtol=0, atol=TOLERANCE)
    # Joint centres: plain MuJoCo's bodies against the tool's joint_centres.csv.
    from mocap_mj.skeleton.joint_centres import centre_bodies

    data = mujoco.MjData(model)
    bodies = centre_bodies(model)
    for t, q in enumerate(scope["qpos"]):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.xpos[bodies], centres[t], rtol=0, atol=TOLERANCE)


def test_synthetic_truth_is_plain_mujoco(result: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(result / "synth" / "truth_model.xml"))
    qpos = np.load(result / "synth" / "truth_motion.npz")["qpos"]
    pset = ParameterSet(result / "synth" / "truth_model.xml")
    markers = Kinematics(pset).site_positions(exported.Layout.of(pset.model).internal(qpos))
    data = mujoco.MjData(model)
    for t in range(0, len(qpos), 7):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site_xpos, markers[t], rtol=0, atol=TOLERANCE)


@pytest.mark.parametrize("hold", [False, True])
def test_mj_step_keeps_the_coupling(result: Path, hold: bool) -> None:
    path = result / "result" / "model.xml"
    qpos = np.load(result / "result" / "motion.npz")["qpos"]
    model = exported.held_root(path) if hold else mujoco.MjModel.from_xml_path(str(path))
    knee = model.joint("knee_flex_l").qposadr[0] + (7 if hold else 0)
    start = qpos[int(np.nanargmax(qpos[:, knee]))]
    assert np.degrees(start[knee]) > 100.0
    worst, end = exported.stepped_residual(model, start[7:] if hold else start, seconds=1.0)
    assert worst < 1e-3  # [m]
    if hold:  # the legs did swing under gravity: the coupling was exercised
        assert abs(end[knee - 7] - start[knee]) > np.radians(30)


def test_quartic_follows_the_coupling() -> None:
    model = load_model()
    layout = exported.Layout.of(model)
    plain = mujoco.MjModel.from_xml_string(ParameterSet().to_xml(ParameterSet().nominal))
    assert layout.nq_written == plain.nq
    q = np.tile(np.array(model.qpos0), (200, 1))
    for j in ("knee_flex_l", "knee_flex_r"):
        lo, hi = model.jnt_range[model.joint(j).id]
        q[:, model.joint(j).qposadr[0]] = np.linspace(lo, hi, 200)
    written = layout.written(q)
    np.testing.assert_array_equal(layout.internal(written), q)
    res = np.array([exported.equality_residuals(plain, w) for w in written])
    assert res.shape == (200, 4) and np.abs(res).max() < 1e-3  # 0.6 mm beyond 120 deg
    below = np.degrees(q[:, model.joint("knee_flex_l").qposadr[0]]) < 100
    assert np.abs(res[below]).max() < 5e-4


def _older(folder: Path, out: Path) -> Path:
    """``folder`` as a version without the slides wrote it: model.xml without the slide joints
    and their equalities (the <custom> record only), motion.npz of nq = 55."""
    out.mkdir()
    root = ElementTree.parse(folder / "model.xml").getroot()
    for parent in root.iter():
        for child in list(parent):
            if child.get("name", "").endswith(exported.SLIDE_SUFFIXES):
                parent.remove(child)
    (out / "model.xml").write_text(ElementTree.tostring(root, encoding="unicode"))
    motion = load_motion(folder / "motion.npz", load_model(folder / "model.xml"))
    save_motion(out / "motion.npz", motion)
    (out / "joint_centres.csv").write_bytes((folder / "joint_centres.csv").read_bytes())
    return out


def test_older_model_is_read_alike(result: Path, tmp_path: Path) -> None:
    from mocap_viewer.playback import load_playback

    new, old = result / "result", _older(result / "result", tmp_path / "old")
    assert exported.carried(mujoco.MjModel.from_xml_path(str(new / "model.xml")))
    assert not exported.carried(mujoco.MjModel.from_xml_path(str(old / "model.xml")))
    assert np.load(old / "motion.npz")["qpos"].shape[1] == 55
    a, b = load_result(new), load_result(old)
    np.testing.assert_array_equal(a.motion.qpos, b.motion.qpos)
    for f in ("body_pos", "site_pos", "jnt_range", "numeric_data"):
        np.testing.assert_array_equal(getattr(a.model, f), getattr(b.model, f))
    np.testing.assert_array_equal(load_playback(new).qpos, load_playback(old).qpos)
    for left, right in zip(_tool(new), _tool(old), strict=True):
        np.testing.assert_array_equal(left, right)
    # ik --model on the older model writes the current layout.
    markers = result / "synth" / "markers.csv"
    argv = ["ik", "--markers", str(markers), "--model", str(old / "model.xml")]
    assert main([*argv, "--out", str(tmp_path / "ik"), "--json", "--frames", "0:5"]) == 0
    assert np.load(tmp_path / "ik" / "motion.npz")["qpos"].shape == (5, 59)
    header = (tmp_path / "ik" / "motion.csv").read_text().splitlines()[0].split(",")
    assert "knee_flex_l_t1_mm" in header and len(header) == 2 + 52


def test_motion_of_another_width_is_refused(result: Path, tmp_path: Path) -> None:
    motion = load_motion(result / "result" / "motion.npz")
    bad = tmp_path / "motion.npz"
    save_motion(bad, Motion(motion.qpos[:, :-1], motion.times, motion.markers, motion.marker_names))
    with pytest.raises(InputFileError, match=rf"{re.escape(str(bad))}: qpos has 58 columns"):
        load_motion(bad, load_model(result / "result" / "model.xml"))


def test_fixed_hinges_of_a_written_model() -> None:
    from mocap_mj.skeleton import rolling

    pset = ParameterSet()
    plain = mujoco.MjModel.from_xml_string(rolling.without(pset.to_xml(pset.nominal)))
    assert (plain.nq, plain.neq, rolling.read(plain)) == (55, 0, None)
