"""Flags the command line no longer has, each answered by one line naming its new spelling.

A script written for an earlier release that passes a removed flag gets, for one release,
``mocap-mj COMMAND: error: --FLAG: removed; <new spelling>`` on stderr and exit status 2,
instead of argparse's "unrecognized arguments". The rule: a removed flag is an error, never
silently dropped or re-mapped, because its value now lives elsewhere (a ``--subject-file``,
a ``--recipe``, another command) or its name now means one thing across commands; going on
without it would give a different result than the script asked for. The exceptions keep
working with a warning: ``identify --solver lm``, which asks for what ``identify`` does
anyway, and a flag merely renamed (:data:`RENAMED`: ``export --up`` is ``--out-up``, since
``--up`` is the input markers' vertical axis everywhere else; ``synth --plates`` is
``--with-plate``, since ``--plates`` chooses plates in ``plug-in-gait``), whose value means
what it meant. docs/cli.md holds the table of old and new spellings (:data:`REMOVED`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

_RECIPE = "put {field}: {value} in a --recipe file (docs/cli.md#recipe)"
_SUBJECT = "put {names} in --subject-file (docs/cli.md#subject-file)"
_EXPERIMENT = "the paper's solver runs in 'mocap-mj experiment paper' (docs/paper.md)"
_SIDED = ("leg", "knee", "ankle", "elbow", "wrist")


def _sided(flag: str) -> str:
    base = flag.removeprefix("--").replace("-", "_")
    return _SUBJECT.format(names=f"{base}_l and {base}_r")


#: Command -> removed flag -> the new spelling (the end of its one-line message).
REMOVED: dict[str, dict[str, str]] = {
    "identify": {
        "--solver": _EXPERIMENT,
        **{f: _EXPERIMENT for f in ("--sampling", "--iterations", "--step", "--delta")},
        **{f: _EXPERIMENT for f in ("--fraction", "--seed")},
        "--robust": "use --loss cauchy",
        "--init": _RECIPE.format(field="init", value="constructed|placed|scaled|nominal"),
        "--select": _RECIPE.format(field="select", value="N|auto|all"),
        "--max-iterations": _RECIPE.format(field="max_iterations", value="N"),
        "--prior-mm": _RECIPE.format(field="prior_sigma", value="M (in metres: 50 mm is 0.05)"),
        "--observable-mm": _RECIPE.format(
            field="observable_std", value="M (in metres: 5 mm is 0.005)"
        ),
        "--symmetric": _RECIPE.format(field="symmetric", value="M (in metres: 2 mm is 0.002)"),
        "--no-asymmetry-prior": _RECIPE.format(field="asymmetry_prior", value="false"),
        "--no-anatomy": _RECIPE.format(field="anatomy", value="false"),
        "--asis-distance": _SUBJECT.format(names="asis_distance"),
        "--marker-diameter": _SUBJECT.format(names="marker_diameter"),
        **{f"--{s}-width": _sided(f"--{s}-width") for s in _SIDED[1:]},
        "--leg-length": _sided("--leg-length"),
        "--hand-thickness": _sided("--hand-thickness"),
        "--shoulder-offset": _sided("--shoulder-offset"),
    },
    "ik": {"--robust": "use --loss cauchy"},
    "batch": {
        "--init": _RECIPE.format(field="init", value="constructed|placed|scaled|nominal"),
        "--max-iterations": _RECIPE.format(field="max_iterations", value="N"),
        "--prior-mm": _RECIPE.format(field="prior_sigma", value="M (in metres: 50 mm is 0.05)"),
    },
    "synth": {
        "--frames": "use --frame-count N (--frames is a range A:B in the other commands)",
        "--motion": "use --movement rom|walk|static (--motion is a motion file elsewhere)",
        "--mass": "use --with-plate KG (the body mass of the plate's subject)",
    },
    "demo": {"--frames": "use --frame-count N (--frames is a range A:B in the other commands)"},
    "render": {
        "--width": "use --size WxH (e.g. --size 640x480)",
        "--height": "use --size WxH (e.g. --size 640x480); --height is the subject's in identify",
    },
}

#: Command -> old flag -> (its new flag, why): a flag renamed, its value kept (one warning).
RENAMED: dict[str, dict[str, tuple[str, str]]] = {
    "export": {
        "--up": ("--out-up", "--up is the vertical axis of the input markers in the other commands")
    },
    "synth": {
        "--plates": ("--with-plate", "--plates chooses the plates that count in plug-in-gait")
    },
}

#: Command -> removed flag -> value -> warning: a value that keeps working, with the warning.
STILL_WORKS: dict[str, dict[str, dict[str, str]]] = {
    "identify": {"--solver": {"lm": "identify always uses the joint LM; drop the flag"}},
}


def message(command: str, flag: str) -> str:
    """The one line a removed ``flag`` of ``command`` gets."""
    return f"mocap-mj {command}: error: {flag}: removed; {REMOVED[command][flag]}"


class _Removed(argparse.Action):
    """A removed flag: prints its one line and exits with status 2 (or warns, for a value
    of :data:`STILL_WORKS`)."""

    def __init__(self, *args: Any, command: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.command = command

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        flag = option_string or self.option_strings[0]
        given = values if isinstance(values, list) else [values]
        works = STILL_WORKS.get(self.command, {}).get(flag, {})
        if len(given) == 1 and given[0] in works:
            print(
                f"mocap-mj {self.command}: warning: {flag} {given[0]}: removed; {works[given[0]]}",
                file=sys.stderr,
            )
            return
        print(message(self.command, flag), file=sys.stderr)
        sys.exit(2)


class _Renamed(argparse.Action):
    """A renamed flag: warns once, naming the new flag, and stores its value there."""

    def __init__(self, *args: Any, command: str, new: str, why: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.command, self.new, self.why = command, new, why

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        new = parser._option_string_actions[self.new]
        if self.nargs == 0 or values is None:  # a switch or no value: its new flag's const
            values, shown = new.const, ""
        else:
            shown = f" {values}"
            if new.choices is not None and values not in new.choices:
                parser.error(
                    f"argument {option_string}: invalid choice: {values!r} (see {self.new})"
                )
        print(
            f"mocap-mj {self.command}: warning: {option_string}{shown}: renamed; use "
            f"{self.new}{shown} ({self.why})",
            file=sys.stderr,
        )
        setattr(namespace, new.dest, values)


def add_removed_flags(parser: argparse.ArgumentParser, command: str) -> None:
    """Accept ``command``'s removed flags (any number of values) and renamed ones (their new
    flag's value), hidden from ``--help``; a renamed flag's new one is added before."""
    for flag, (new, why) in RENAMED.get(command, {}).items():
        nargs = parser._option_string_actions[new].nargs
        parser.add_argument(  # a renamed flag takes the values its new one takes
            flag,
            action=_Renamed,
            command=command,
            new=new,
            why=why,
            nargs=0 if nargs == 0 else "?" if nargs == "?" else None,
            dest=f"renamed_{flag.removeprefix('--').replace('-', '_')}",
            default=argparse.SUPPRESS,
            help=argparse.SUPPRESS,
        )
    for flag in REMOVED.get(command, {}):
        parser.add_argument(
            flag,
            action=_Removed,
            command=command,
            nargs="*",
            dest=f"removed_{flag.removeprefix('--').replace('-', '_')}",
            default=argparse.SUPPRESS,
            help=argparse.SUPPRESS,
        )
