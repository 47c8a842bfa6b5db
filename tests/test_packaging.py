"""The package list in pyproject.toml covers every package folder (a non-editable install
ships only what it lists), and the console entry point and add-on commands resolve."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_folder_is_listed() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    assert "mocap_mj.pipeline" in listed
    folders = {v: k for k, v in config["package-dir"].items()}  # folder -> import name
    found = set()
    for init in ROOT.glob("*/**/__init__.py"):
        rel = init.parent.relative_to(ROOT)
        top = rel.parts[0]
        if top not in folders or "tests" in rel.parts:
            continue
        found.add(".".join([folders[top], *rel.parts[1:]]))
    assert found <= listed, f"not listed in pyproject.toml: {sorted(found - listed)}"


@pytest.mark.slow
def test_cli_lists_every_command() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "--help"], capture_output=True, text=True, check=True
    )
    for command in ("info", "ik", "identify", "score", "synth", "demo", "view", "render",
                    "export", "experiment"):  # fmt: skip
        assert command in out.stdout, command
    assert "unavailable" not in out.stderr, out.stderr
