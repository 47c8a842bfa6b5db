"""OpenSim's inverse dynamics on the exported model against the tool's (mocap_mj/export/
opensim_id.py), the ground reactions as OpenSim's external loads (mocap_mj/export/grf.py) and
the exported coordinates' continuity.

The agreement test (skipped without the ``[opensim]`` extra): the bundled humanoid with de
Leva's parameters for 75 kg moving smoothly in every joint (the knees rolling), a force and a
free moment on each foot; the tool's generalised forces (MuJoCo, the model as written) in
OpenSim's coordinates by virtual work against OpenSim 4.6's InverseDynamicsTool on the
exported .osim, .mot and ExternalLoads: within 1 % of each coordinate's peak (the target 2 %;
measured 0.19 % at most). On Movement_trial (benchmarks/opensim_id.py) 1.6 % at most.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.inertia import inertial_model, segment_inertia
from mocap_mj.capture.contacts import FootLoads
from mocap_mj.errors import InputFileError
from mocap_mj.export.coordinates import model_coordinates
from mocap_mj.export.grf import (
    GroundReactions,
    external_loads_xml,
    grf_mot_text,
    read_grf_csv,
    write_grf,
)
from mocap_mj.export.mot import coordinates_in_degrees, read_mot
from mocap_mj.export.opensim_id import in_coordinates, run_opensim_id
from mocap_mj.export.osim import up_rotation
from mocap_mj.outputs.kinetics_out import grf_table
from mocap_mj.pipeline import dynamics as dy
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.mjcf import load_model

MASS = 75.0  # [kg]
FRAMES, RATE = 200, 100.0
EDGE = 5  # frames left out at each end: both programs' derivatives are one-sided there


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The models, the motion and the loads, and the tool's inverse dynamics of them."""
    pset = ParameterSet()
    path = tmp_path_factory.mktemp("osim_id") / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    internal, written = load_model(path), inertial_model(path, MASS)
    times = np.arange(FRAMES) / RATE
    qpos = exported.Layout.of(pset.model).written(smooth_motion(Kinematics(pset), FRAMES, seed=4))
    data = mujoco.MjData(written)
    force, cop, moment, loads = {}, {}, {}, []
    for k, (side, body) in enumerate((("left", "foot_l"), ("right", "foot_r"))):
        point = np.zeros((FRAMES, 3))
        for t in range(FRAMES):
            data.qpos[:] = qpos[t]
            mujoco.mj_kinematics(written, data)
            point[t] = data.xpos[written.body(body).id] + [0.05, 0.0, -0.07]
        w = 2 + k
        force[side] = np.stack([30 * np.sin(w * times), 20 * np.cos(w * times),
                                400 + 200 * np.sin(5 * times)], axis=1)  # fmt: skip
        moment[side] = np.zeros((FRAMES, 3))
        moment[side][:, 2] = 2 * np.sin(4 * times)
        cop[side] = point
        loads.append(dy.BodyLoad(body, force[side], point, moment[side]))
    dyn = dy.inverse_dynamics(written, qpos, times, loads, cutoff_hz=None)
    return {
        "internal": internal,
        "written": written,
        "dyn": dyn,
        "grf": GroundReactions(times, force, cop, moment),
    }


def test_opensim_inverse_dynamics_agrees_with_the_tool_s(case: dict, tmp_path: Path) -> None:
    pytest.importorskip("opensim", reason="the [opensim] extra is not installed")
    internal, written, dyn = case["internal"], case["written"], case["dyn"]
    ours = in_coordinates(internal, written, dyn.qpos, dyn.tau)
    names, times, theirs = run_opensim_id(
        internal,
        exported.Layout.of(internal).internal(dyn.qpos),
        dyn.times,
        tmp_path,
        inertia=segment_inertia(internal, MASS),
        loads=case["grf"],
    )
    assert len(times) == FRAMES and names == [c.name for c in model_coordinates(internal)]
    checked = 0
    for i, name in enumerate(names):
        a, b = ours[EDGE:-EDGE, i], theirs[EDGE:-EDGE, i]
        peak = np.max(np.abs(a))
        if peak < 0.01:  # the toes: no load to speak of
            continue
        assert np.max(np.abs(a - b)) < 0.01 * peak, (name, peak, np.max(np.abs(a - b)))
        checked += 1
    assert checked >= 40


def test_a_hinge_s_coordinate_force_is_its_own_and_a_knee_gains_its_slides(case: dict) -> None:
    """Virtual work: an elbow's OpenSim generalised force is its MuJoCo one; a knee's
    flexion adds its two slides' forces times the slides' slope over the flexion."""
    internal, written, dyn = case["internal"], case["written"], case["dyn"]
    ours = in_coordinates(internal, written, dyn.qpos, dyn.tau)
    names = [c.name for c in model_coordinates(internal)]
    elbow = written.joint("elbow_l").dofadr[0]
    np.testing.assert_allclose(ours[:, names.index("elbow_l")], dyn.tau[:, elbow], rtol=1e-6,
                               atol=1e-6)  # fmt: skip
    layout = exported.Layout.of(internal)
    knee = internal.joint("knee_flex_l")
    adr = layout.columns[knee.qposadr[0]]  # the flexion's written column
    slides = next(s for s in layout.slides if s[1] + 1 == adr)
    t = FRAMES // 2
    q = layout.internal(dyn.qpos[t : t + 1])
    up, down = q.copy(), q.copy()
    up[0, knee.qposadr[0]] += 1e-6
    down[0, knee.qposadr[0]] -= 1e-6
    slope = (layout.written(up)[0, slides] - layout.written(down)[0, slides]) / 2e-6
    dof = written.jnt_dofadr[written.jnt_qposadr == slides[0]][0]
    hinge = written.jnt_dofadr[written.jnt_qposadr == adr][0]
    expected = dyn.tau[t, hinge] + dyn.tau[t, dof : dof + 2] @ slope
    assert ours[t, names.index("knee_flex_l")] == pytest.approx(expected, rel=1e-6)


def test_ground_reactions_become_opensim_s_external_loads(tmp_path: Path) -> None:
    """grf.csv (as ik writes it) to the .mot: the force, point and torque rotated into OpenSim's
    y-up ground; off the plates zero; the ExternalLoads names the .mot and the foot bodies."""
    times = np.arange(6) / 100.0
    on = np.array([False, True, True, True, True, False])
    feet = []
    for k, side in enumerate(("left", "right")):
        force = np.where(on[:, None], [10.0 * k, 20.0, 700.0], 0.0)
        cop = np.where(on[:, None], [0.3, 0.1 + k, 0.0], np.nan)
        free = np.where(on[:, None], [0.0, 0.0, 1.5], 0.0)
        feet.append(FootLoads(side, force, cop, free, on, ()))
    csv = tmp_path / "grf.csv"
    csv.write_text(grf_table(times, feet))
    loads = read_grf_csv(csv)
    mot, xml = write_grf(tmp_path / "walk.mot", loads)
    names, t, values = read_mot(mot)
    np.testing.assert_allclose(t, times, atol=1e-6)
    rot = up_rotation("y")
    col = {n: values[:, i] for i, n in enumerate(names)}
    for k, s in enumerate("lr"):
        v = np.stack([col[f"ground_force_{s}_v{a}"] for a in "xyz"], axis=1)
        np.testing.assert_allclose(v[on], np.tile(rot @ [10.0 * k, 20.0, 700.0], (4, 1)))
        np.testing.assert_allclose(v[~on], 0.0)
        p = np.stack([col[f"ground_force_{s}_p{a}"] for a in "xyz"], axis=1)
        np.testing.assert_allclose(p[on], np.tile(rot @ [0.3, 0.1 + k, 0.0], (4, 1)), atol=1e-9)
        torque = np.stack([col[f"ground_torque_{s}_{a}"] for a in "xyz"], axis=1)
        np.testing.assert_allclose(torque[on], np.tile(rot @ [0, 0, 1.5], (4, 1)), atol=1e-12)
    text = xml.read_text()
    assert xml.name == "walk_loads.xml" and "<datafile>walk.mot</datafile>" in text
    assert "<applied_to_body>foot_l</applied_to_body>" in text
    assert "<torque_identifier>ground_torque_r_</torque_identifier>" in text
    assert text == external_loads_xml("walk.mot") and grf_mot_text(loads).startswith("grf\n")


def test_a_file_that_is_not_grf_csv_is_refused_in_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "grf.csv"
    bad.write_text("time_s,force\n0,1\n")
    with pytest.raises(InputFileError, match=r"expected grf\.csv.s columns"):
        read_grf_csv(bad)


def test_exported_angles_stay_continuous_past_180_degrees() -> None:
    """The root turning from 170 to 190 deg about the vertical: its coordinate goes on past
    180 (unwrapped), not back to -170, so that OpenSim's splines see no jump."""
    pset = ParameterSet()
    model = pset.model
    yaw = np.radians(np.linspace(170.0, 190.0, 21))
    qpos = np.tile(model.qpos0, (len(yaw), 1))
    qpos[:, 3:7] = np.stack([np.cos(yaw / 2), 0 * yaw, 0 * yaw, np.sin(yaw / 2)], axis=1)
    values = coordinates_in_degrees(model, qpos)
    names = [c.name for c in model_coordinates(model)]
    rz = values[:, names.index("root_rz")]
    np.testing.assert_allclose(np.diff(rz), 1.0, atol=1e-9)
    assert rz[-1] == pytest.approx(190.0) or rz[-1] == pytest.approx(-170.0 + 360.0)
