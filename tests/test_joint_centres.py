import mujoco
import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories


def test_joint_centres_are_the_child_body_origins() -> None:
    pset = ParameterSet()
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_l")] += 0.03
    model = pset.model_for(theta)
    rng = np.random.default_rng(0)
    qpos = np.tile(model.qpos0, (4, 1))
    qpos[:, 7:] += rng.normal(0, 0.2, (4, model.nq - 7))
    qpos[1, 0] = np.nan  # an unsolved frame
    c = joint_centre_trajectories(model, qpos)
    assert c.shape == (4, len(JOINT_CENTRE_NAMES), 3)
    assert np.all(np.isnan(c[1]))
    data = mujoco.MjData(model)
    data.qpos[:] = qpos[2]
    rolling.kinematics(model, data)  # the knee rolling placed (mocap_mj.skeleton.rolling)
    knee = JOINT_CENTRE_NAMES.index("knee_l")
    np.testing.assert_allclose(c[2, knee], data.xpos[model.body("shank_l").id], atol=1e-12)
    hip = JOINT_CENTRE_NAMES.index("hip_l")
    # The hip-knee distance is the thigh length moved by the knee's rolling t(q).
    roll = rolling.read(model)
    t, _ = roll.translation(qpos[[0, 2, 3]][:, roll.qposadr])
    np.testing.assert_allclose(
        np.linalg.norm(c[[0, 2, 3], knee] - c[[0, 2, 3], hip], axis=1),
        np.linalg.norm(t[:, 0] + [0.0, 0.0, -(0.43 + 0.03)], axis=1),
        atol=1e-12,
    )
