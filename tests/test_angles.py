"""Joint-angle table: one named column per degree of freedom, in mm and degrees."""

from __future__ import annotations

import numpy as np
from _motion import smooth_motion

from mocap_mj import Kinematics
from mocap_mj.outputs.ik_out import angle_columns, joint_angle_table


def test_one_column_per_dof_with_units() -> None:
    kin = Kinematics()
    qpos = smooth_motion(kin, 20, seed=1)
    table = joint_angle_table(kin.model, qpos)
    names = angle_columns(kin.model)
    assert table.shape == (20, kin.nv) and len(names) == kin.nv
    assert names[:6] == ["root_x_mm", "root_y_mm", "root_z_mm", "root_rx_deg", "root_ry_deg",
                         "root_rz_deg"]  # fmt: skip
    assert names[names.index("thorax_x_deg") : names.index("thorax_x_deg") + 3] == [
        "thorax_x_deg", "thorax_y_deg", "thorax_z_deg"]  # fmt: skip
    np.testing.assert_allclose(table[:, :3], qpos[:, :3] * 1e3)
    knee = names.index("knee_flex_l_deg")
    adr = kin.model.jnt_qposadr[kin.model.joint("knee_flex_l").id]
    np.testing.assert_allclose(table[:, knee], np.degrees(qpos[:, adr]))
    # A ball joint's three Cardan angles rebuild its rotation.
    from scipy.spatial.transform import Rotation

    i = names.index("hip_l_x_deg")
    rot = Rotation.from_euler("XYZ", table[:, i : i + 3], degrees=True)
    a = kin.model.jnt_qposadr[kin.model.joint("hip_l").id]
    wxyz = qpos[:, a : a + 4]
    truth = Rotation.from_quat(np.column_stack([wxyz[:, 1:], wxyz[:, :1]]))
    assert np.all((rot.inv() * truth).magnitude() < 1e-9)
