"""The compiled (numba) kernels: the joint tree's kinematics, the per-frame IK, the
joint LM's blocks, and how they are compiled and cached. They import nothing of the library
above them.
"""
