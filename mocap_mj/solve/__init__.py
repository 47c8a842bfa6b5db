"""The identification problem (residuals, losses, priors, bounds) and its solvers: the joint
Levenberg-Marquardt, the per-frame IK, and what the data determine (identifiability, bounds).
"""
