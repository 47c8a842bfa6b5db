"""Synthetic subjects whose hip centres sit where their regression puts them, or off it.

:func:`at_regression` moves an experiment's truth hip centres onto the Harrington et al.
(2007) regression of its own pelvis markers (``mocap_mj.anatomy.anatomy``'s rows, the
prior the identification uses), optionally shifted by a given amount per parameter, and
moves the measured markers with them (the soft-tissue artefact and the noise unchanged: the
artefact depends on the motion's rotations alone). The tests and
``benchmarks/hip_centres.py`` score against it how far the data move an identified centre.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.ball_centres import centre_rows
from mocap_mj.skeleton.kinematics import Kinematics

from .experiment import Experiment


def at_regression(exp: Experiment, shift: Mapping[str, float] | None = None) -> Experiment:
    """``exp`` with every regression-placed centre parameter (``hip_depth_l``, ...) set to its
    regression at the truth's own marker offsets plus ``shift`` (name -> [m], default none),
    and the clean and measured markers (T, M, 3) [m] moved by the change of the rigid model."""
    pset = exp.pset
    prior = landmark_prior(pset)
    theta = np.array(exp.theta_true, dtype=float)
    for c in centre_rows(pset, prior):
        a, b = np.asarray(prior.a)[c.row], float(prior.b[c.row])
        j = int(np.flatnonzero(a[: pset.n_kappa])[0])
        rest = a.copy()
        rest[j] = 0.0
        theta[j] = (b - rest @ theta) / a[j] + (shift or {}).get(pset.names[j], 0.0)
    kin = Kinematics(pset)
    kin.set_theta(theta)
    clean = np.array(kin.forward(np.asarray(exp.qpos)).site_xpos)
    moved = np.asarray(exp.markers) + clean - np.asarray(exp.markers_clean)
    return replace(exp, theta_true=theta, markers_clean=clean, markers=moved)


__all__ = ["at_regression"]
