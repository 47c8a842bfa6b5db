"""The dynamics of a result folder (mocap_mj/outputs/dynamics_out.py): ``mocap-mj synth`` and
``mocap-mj ik`` make the folder, ``dynamics_of_result`` reads it through the project's readers,
and dynamics.csv and root_residuals.csv read back to the figures computed."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.cli import main
from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.outputs import dynamics_out as out
from mocap_mj.pipeline.dynamics import BodyLoad, inverse_dynamics, translational
from mocap_synth import SynthConfig, synthesize, write_experiment

MASS = 68.0  # [kg]


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mocap-mj ik`` of a synthetic walk: a result folder as the tool writes it."""
    root = tmp_path_factory.mktemp("dynamics_out")
    write_experiment(synthesize(SynthConfig(frames=60, motion="walk", seed=5)), root / "synth")
    argv = ["ik", "--markers", str(root / "synth" / "markers.csv"), "--out", str(root / "result")]
    assert main([*argv, "--json"]) == 0
    return root / "result"


def _weight_under_com(model: mujoco.MjModel, qpos: np.ndarray) -> BodyLoad:
    """The body's weight, upward, on the left foot under the centre of mass every frame."""
    data = mujoco.MjData(model)
    point = np.zeros((len(qpos), 3))
    for t, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        point[t] = data.subtree_com[1] * (1, 1, 0)
    force = np.tile(-model.body_mass.sum() * model.opt.gravity, (len(qpos), 1))
    return BodyLoad("foot_l", force, point, np.zeros_like(point))


def test_dynamics_of_an_ik_result_and_its_tables(result: Path, tmp_path: Path) -> None:
    model = inertial_model(result / "model.xml", MASS)
    with np.load(result / "motion.npz") as npz:
        qpos, times = npz["qpos"], npz["times"]
    load = _weight_under_com(model, qpos)
    dyn, force_dofs = out.dynamics_of_result(result, [load], MASS)
    assert model.nq == qpos.shape[1] == 59 and dyn.tau.shape == (len(times), 52)
    # the same as the dynamics of the folder's files computed directly
    direct = inverse_dynamics(model, qpos, times, [load])
    np.testing.assert_array_equal(dyn.tau, direct.tau)
    np.testing.assert_array_equal(force_dofs, translational(model))
    assert force_dofs.sum() == 3 + 4  # the root's translations and the knees' slides

    paths = out.write_dynamics(tmp_path, dyn, MASS, force_dofs)
    assert [p.name for p in paths] == ["dynamics.csv", "root_residuals.csv"]
    table = np.genfromtxt(paths[0], delimiter=",", names=True)
    np.testing.assert_allclose(table["time_s"], times, atol=1e-6)
    knee = dyn.dof_names.index("knee_flex_l")
    np.testing.assert_allclose(table["knee_flex_l_Nm"], dyn.tau[:, knee], rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(
        table["knee_flex_l_Nm_per_kg"], dyn.tau[:, knee] / MASS, rtol=1e-5, atol=1e-9
    )
    np.testing.assert_allclose(table["knee_flex_l_W"], dyn.power[:, knee], rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(table["root_x_N"], dyn.tau[:, 0], rtol=1e-5, atol=1e-9)
    assert "knee_flex_l_t1_N" in table.dtype.names  # a slide's force

    res = np.genfromtxt(paths[1], delimiter=",", names=True)
    weight = MASS * out.STANDARD_GRAVITY
    np.testing.assert_allclose(res["force_Z_N"], dyn.root_force[:, 2], rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(
        res["force_Z_pct_bw"], 100 * dyn.root_force[:, 2] / weight, rtol=1e-5, atol=1e-9
    )
    norm = 100 * np.linalg.norm(dyn.root_force, axis=1) / weight
    np.testing.assert_allclose(res["force_norm_pct_bw"], norm, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(res["moment_Y_Nm"], dyn.root_moment[:, 1], rtol=1e-5, atol=1e-9)
    # a walk is no still stance: the weight alone leaves the accelerations as the residual
    assert 0.1 < np.nanmax(norm) < 100.0


def test_a_folder_that_is_not_a_result_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="not a result folder"):
        out.dynamics_of_result(tmp_path, [], MASS)
    with pytest.raises(MocapError, match="positive number of kilograms"):
        out.dynamics_of_result(tmp_path, [], 0.0)
