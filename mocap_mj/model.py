"""Where the bundled humanoid lives, and loading MJCF files with clear errors."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import mujoco

from .errors import MocapError

#: File name of the bundled 22-body, 48-DOF humanoid with 39 Plug-in Gait marker sites.
HUMANOID = "humanoid.xml"


def model_path(name: str = HUMANOID) -> Path:
    """Path of a bundled MJCF file.

    Installed, the top-level ``models/`` folder ships as package data ``mocap_mj.models``; run
    from a source checkout without installing, it is found beside the package.
    """
    try:
        path = Path(str(resources.files("mocap_mj.models") / name))
    except ModuleNotFoundError:
        path = Path(__file__).resolve().parent.parent / "models" / name
    if not path.is_file():
        raise MocapError(f"bundled model {name!r} not found at {path}")
    return path


def load_model(path: str | Path | None = None) -> mujoco.MjModel:
    """Compile an MJCF file (the bundled humanoid by default) into an ``MjModel``."""
    path = model_path() if path is None else Path(path)
    if not path.is_file():
        raise MocapError(f"{path}: model file not found")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        # MuJoCo's message spans lines (error, then element and line): keep them all, on one.
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        detail = "; ".join(lines) or "compile error"
        raise MocapError(f"{path}: not a valid MJCF model: {detail}") from None
