"""Exporters of ``mocap-mj export``: the built-in formats and those other packages register.

An :class:`Exporter` writes one result (``args.result``) to ``args.out``. The built-in ones
live in :mod:`mocap_mj.commands.export`; a package that builds on the library (the viewer's GLB
scene) adds its own through the ``mocap_mj.exporters`` entry-point group, whose value is an
:class:`Exporter`, so that the library never imports it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint

#: Entry-point group of exporters registered by other packages.
ENTRY_POINT_GROUP = "mocap_mj.exporters"


@dataclass(frozen=True)
class Exporter:
    """One ``--to`` format.

    Attributes
    ----------
    name : str
        The ``--to`` value.
    suffix : str
        File suffix (``".osim"``) that selects this format when ``--to`` is not given; empty
        for formats that need ``--to`` (CSV tables, folders).
    help : str
        One line for ``--help``.
    run : callable
        ``run(args) -> summary dict``; raises :class:`mocap_mj.errors.MocapError` on bad input.
    add_arguments : callable, optional
        Adds the format's own options to the ``export`` parser.
    """

    name: str
    suffix: str
    help: str
    run: Callable[[argparse.Namespace], dict[str, Any]]
    add_arguments: Callable[[argparse.ArgumentParser], None] | None = None


@cache
def entry_points_of(group: str) -> tuple[EntryPoint, ...]:
    """The installed packages' entry points of ``group``, by name; every group read in one
    scan of the installed packages (for the command line's start: the commands' and the
    exporters' groups)."""
    from importlib.metadata import entry_points  # its own import takes ~0.1 s: when needed

    every = entry_points()
    return tuple(sorted(every.select(group=group), key=lambda e: e.name))


def plugin_exporters() -> list[Exporter]:
    """Exporters registered in :data:`ENTRY_POINT_GROUP`, by name; broken ones are reported
    on stderr and skipped, so that a broken add-on does not take the command down."""
    found = []
    for ep in entry_points_of(ENTRY_POINT_GROUP):
        try:
            exporter = ep.load()
        except ImportError as exc:
            print(f"mocap-mj export: format {ep.name!r} unavailable: {exc}", file=sys.stderr)
            continue
        found.append(exporter)
    return found
