"""Every subcommand has a description, and every option a help text that states its default.

Placeholders share one style: upper case (``FOLDER``, ``N``, ``A:B``; ``WxH`` for an image
size), or the choices. Removed flags (hidden from ``--help``) are not options.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator
from typing import Any

from mocap_mj.commands.registry import build_parser

FLAGS = (argparse._StoreTrueAction, argparse._HelpAction, argparse._VersionAction)


def subparsers(parser: argparse.ArgumentParser, path: str = "") -> Iterator[tuple[str, Any]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield f"{path} {name}".strip(), sub
                yield from subparsers(sub, f"{path} {name}".strip())


def test_every_subcommand_is_described() -> None:
    subs = dict(subparsers(build_parser()))
    assert {"info", "ik", "identify", "score", "synth", "demo"} <= set(subs)
    for name, sub in subs.items():
        assert sub.description and len(sub.description) > 60, name


def test_every_option_states_its_default() -> None:
    missing = []
    for name, sub in subparsers(build_parser()):
        for action in sub._actions:
            if isinstance(action, FLAGS) or isinstance(action, argparse._SubParsersAction):
                continue
            if action.help == argparse.SUPPRESS:  # a removed flag (mocap_mj.commands._removed)
                continue
            text = action.help or ""
            if not text:
                missing.append(f"{name} {action.option_strings or action.dest}: no help")
            elif action.option_strings and not action.required and "default" not in text:
                missing.append(f"{name} {action.option_strings[0]}: no default in {text!r}")
    assert missing == []


def test_one_placeholder_style() -> None:
    bad = []
    for name, sub in subparsers(build_parser()):
        for action in sub._actions:
            if isinstance(action, FLAGS) or action.choices is not None or not action.nargs != 0:
                continue
            if not action.option_strings or action.help == argparse.SUPPRESS:
                continue
            metavar = action.metavar
            if metavar is None or not re.fullmatch(r"[A-Z][A-Z0-9_.:\[\]]*|WxH", str(metavar)):
                bad.append(f"{name} {action.option_strings[0]}: {metavar!r}")
    assert bad == []


def test_frames_options_say_b_is_excluded() -> None:
    for name, sub in subparsers(build_parser()):
        for action in sub._actions:
            if "--frames" in action.option_strings and action.metavar and ":" in action.metavar:
                assert "excluding B" in (action.help or ""), name
