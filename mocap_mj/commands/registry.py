"""The subcommands of ``mocap-mj``: the core ones (``mocap_mj.commands.<name>``) and those of the
``mocap_mj.commands`` entry-point group (``synth``, ``viewer``), each loaded by name and asked to
``register(subparsers)``, so that the library never imports its add-ons."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable
from typing import Any

#: Core subcommand modules (``mocap_mj.commands.<name>``), in help order.
CORE_COMMANDS: tuple[str, ...] = (
    "info", "ik", "identify", "score", "export", "batch", "plug_in_gait", "marker_sets",
)  # fmt: skip


def _registrars() -> list[Callable[[Any], None]]:
    from importlib.metadata import entry_points

    regs = []
    for name in CORE_COMMANDS:
        try:
            module = importlib.import_module(f"mocap_mj.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"mocap_mj.commands.{name}":
                raise
            continue
        regs.append(module.register)
    for ep in sorted(entry_points(group="mocap_mj.commands"), key=lambda e: e.name):
        try:
            regs.append(ep.load())
        except ImportError as exc:  # a broken add-on must not take the other commands down
            print(f"mocap-mj: command {ep.name!r} unavailable: {exc}", file=sys.stderr)
    return regs


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mocap-mj",
        description="Identify subject-specific MuJoCo human models from motion-capture markers.",
    )
    from mocap_mj import __version__

    parser.add_argument("--version", action="version", version=f"mocap-mj {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in _registrars():
        register(sub)
    return parser
