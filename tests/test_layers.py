"""The layers of mocap_mj (docs/architecture.md): import-linter's contracts in pyproject.toml
hold (a package imports only downward, lazy imports included; no cycle between the modules of
a package; the library never imports its add-ons), every package is in a layer, and
docs/architecture.md names every module."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "mocap_mj"


def _config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]


def _modules() -> list[str]:
    """Every module under mocap_mj/, as its path from mocap_mj/ (``solve/lm.py``)."""
    return sorted(
        str(p.relative_to(PACKAGE))
        for p in PACKAGE.rglob("*.py")
        if "__pycache__" not in p.parts and p.name != "__init__.py"
    )


def test_import_contracts_hold(capsys: pytest.CaptureFixture[str]) -> None:
    cli = pytest.importorskip("importlinter.cli", reason="import-linter (the dev extra) is absent")
    cwd = Path.cwd()
    os.chdir(ROOT)
    try:
        status = cli.lint_imports(config_filename="pyproject.toml", no_cache=True, no_logo=True)
    finally:
        os.chdir(cwd)
    assert status == 0, capsys.readouterr().out[-4000:]


def test_every_package_is_in_a_layer() -> None:
    (layers,) = [c["layers"] for c in _config()["contracts"] if c["type"] == "layers"]
    named = {n.strip() for layer in layers for n in layer.replace(":", "|").split("|")}
    children = {p.stem for p in PACKAGE.glob("*.py") if p.name != "__init__.py"}
    children |= {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    assert children <= named, f"not in a layer of pyproject.toml: {sorted(children - named)}"


def _named(module: str, lines: list[str]) -> bool:
    """``module`` (``solve/lm.py``) by its path, or as ```lm.py``` on its package's line
    (one that names ```solve/```)."""
    folder, _, name = module.rpartition("/")
    if folder:
        return any(
            module in line or (f"`{folder}/`" in line and f"`{name}`" in line) for line in lines
        )
    return any(f"`{name}`" in line for line in lines)


def test_architecture_names_every_module() -> None:
    lines = (ROOT / "docs" / "architecture.md").read_text().splitlines()
    missing = [m for m in _modules() if not _named(m, lines)]
    assert not missing, f"docs/architecture.md does not name: {missing}"
