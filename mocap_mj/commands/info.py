"""``mocap-mj info``: what a model is made of (bodies, DOF, markers, parameters)."""

from __future__ import annotations

import argparse
from typing import Any

from mocap_mj.commands.common import finish
from mocap_mj.skeleton.parameters import ParameterSet


def describe(pset: ParameterSet) -> dict[str, Any]:
    m = pset.model
    return {
        "model": str(pset.path),
        "bodies": m.nbody - 1,
        "dof": m.nv,
        "nq": m.nq,
        "joints": [m.joint(j).name for j in range(m.njnt)],
        "markers": list(pset.marker_names),
        "kinematic_parameters": list(pset.kappa_names),
        "parameter_count": pset.size,
    }


def run(args: argparse.Namespace) -> int:
    pset = ParameterSet(args.model)
    info = describe(pset)
    lines = [
        f"model       {info['model']}",
        f"bodies      {info['bodies']} (besides the world)",
        f"dof         {info['dof']} (nq {info['nq']})",
        f"markers     {len(info['markers'])}: {' '.join(info['markers'])}",
        f"kinematic   {len(info['kinematic_parameters'])}: "
        + " ".join(info["kinematic_parameters"]),
        f"parameters  {info['parameter_count']} (kinematic + 3 x markers)",
    ]
    return finish(args, info, "\n".join(lines))
