"""Where the bundled humanoid lives, and loading MJCF files with clear errors."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import mujoco

from mocap_mj.arguments import instance, optional, path_like, validated
from mocap_mj.errors import MocapError
from mocap_mj.skeleton import exported

#: File name of the bundled 22-body, 48-DOF humanoid with 39 Plug-in Gait marker sites.
HUMANOID = "humanoid.xml"


@validated(name=instance(str, "a bundled model's file name"))
def model_path(name: str = HUMANOID) -> Path:
    """Path of a bundled MJCF file.

    Installed, the top-level ``models/`` folder ships as package data ``mocap_mj.models``; run
    from a source checkout without installing, it is found beside the package.
    """
    try:
        path = Path(str(resources.files("mocap_mj.models") / name))
    except ModuleNotFoundError:
        path = Path(__file__).resolve().parents[2] / "models" / name
    if not path.is_file():
        raise MocapError(f"bundled model {name!r} not found at {path}")
    return path


@validated(path=optional(path_like))
def load_model(path: str | Path | None = None) -> mujoco.MjModel:
    """Compile an MJCF file (the bundled humanoid by default) into the ``MjModel`` the tool
    works on: a model as the tool writes it carries the knee's rolling as slide joints for
    plain MuJoCo, which are removed here (the exact coupling is its ``<custom>`` record,
    :mod:`mocap_mj.skeleton.exported`); a model without them (the bundled humanoid, or written
    before they existed) compiles as it is."""
    path = model_path() if path is None else Path(path)
    model = load_written(path)
    if not exported.carried(model):
        return model
    try:
        return exported.internal_spec(path).compile()
    except ValueError as exc:
        raise MocapError(f"{path}: not a valid MJCF model: {_one_line(exc)}") from None


def load_written(path: str | Path) -> mujoco.MjModel:
    """Compile an MJCF file as plain MuJoCo does (``MjModel.from_xml_path``): a model the tool
    wrote keeps its knees' slide joints and equalities, its qpos is the written layout
    (``motion.npz``'s, :mod:`mocap_mj.skeleton.exported`)."""
    path = Path(path)
    if not path.is_file():
        raise MocapError(f"{path}: model file not found")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise MocapError(f"{path}: not a valid MJCF model: {_one_line(exc)}") from None


def _one_line(exc: ValueError) -> str:
    """MuJoCo's message spans lines (error, then element and line): all of them, on one."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return "; ".join(lines) or "compile error"
