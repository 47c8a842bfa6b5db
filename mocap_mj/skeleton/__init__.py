"""The parametrised humanoid: theta (:class:`~mocap_mj.skeleton.parameters.ParameterSet`), its MJCF,
forward kinematics, the knee's rolling, joint centres and named joint coordinates.
"""
