"""The subcommands of ``mocap-mj``: the core ones (their flags in :mod:`.parsers`, their work in
``mocap_mj.commands.<name>``, imported when the command runs) and those of the
``mocap_mj.commands`` entry-point group (``synth``, ``viewer``), each loaded by name and asked to
``register(subparsers)``, so that the library never imports its add-ons."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any

#: Core subcommands, in help order: each a ``register_<name>`` of :mod:`.parsers`, which
#: defines the flags and loads ``mocap_mj.commands.<name>`` only when the command runs.
CORE_COMMANDS: tuple[str, ...] = (
    "info", "ik", "identify", "score", "export", "batch", "plug_in_gait", "gait_report",
    "marker_sets",
)  # fmt: skip


def _registrars(only: str | None = None) -> list[Callable[[Any], None]]:
    from . import parsers

    regs = [getattr(parsers, f"register_{name}") for name in CORE_COMMANDS]
    if only is not None:  # a core command's name: its parser alone, no add-on's
        return [regs[[n.replace("_", "-") for n in CORE_COMMANDS].index(only)]]
    from mocap_mj.export.registry import entry_points_of  # importlib.metadata: ~0.1 s

    for ep in entry_points_of("mocap_mj.commands"):
        try:
            regs.append(ep.load())
        except ImportError as exc:  # a broken add-on must not take the other commands down
            print(f"mocap-mj: command {ep.name!r} unavailable: {exc}", file=sys.stderr)
    return regs


class _StoreOnce(argparse._StoreAction):
    """An option's value, given at most once: argparse would keep the last of ``--out A --out
    B`` and drop A without a word. An option of one or more values (``nargs="+"``, such as
    ``identify --markers``) accumulates instead: ``--markers A --markers B`` is ``--markers A
    B``."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        if not self.option_strings:  # a positional argument is given once by its place
            setattr(namespace, self.dest, values)
            return
        given: set[str] = namespace.__dict__.setdefault(GIVEN, set())
        if self.nargs in ("+", "*"):
            before = list(getattr(namespace, self.dest) or []) if self.dest in given else []
            setattr(namespace, self.dest, before + list(values))
        elif self.dest in given:
            raise argparse.ArgumentError(
                self,
                f"given twice ({getattr(namespace, self.dest)!s:.80} and {values!s:.80}); "
                "give it once",
            )
        else:
            setattr(namespace, self.dest, values)
        given.add(self.dest)


#: The namespace attribute holding the options given on the command line (their ``dest``).
GIVEN = "_given_options"


class _Parser(argparse.ArgumentParser):
    """argparse's parser whose plain options (no ``action=``) are :class:`_StoreOnce`: a
    repeated option is refused, or accumulates when it takes one or more values; the
    subcommands' parsers (the add-ons' too) are of this class."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """``mocap-mj``'s parser: every command's, or, when ``argv`` starts with a core command's
    name, that command's alone (the same parse, without building the others or loading the
    add-ons: ``mocap-mj identify --help`` answers at once)."""
    core = [n.replace("_", "-") for n in CORE_COMMANDS]
    only = argv[0] if argv and argv[0] in core else None
    parser = _Parser(
        prog="mocap-mj",
        description="Identify subject-specific MuJoCo human models from motion-capture markers.",
    )
    from mocap_mj import __version__

    parser.add_argument("--version", action="version", version=f"mocap-mj {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in _registrars(only):
        register(sub)
    return parser
