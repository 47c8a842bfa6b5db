"""What every command shares: the ``--json`` and ``--force`` flags, number arguments, the output
folder (written atomically, never over an input), the summary line and the exit status."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Mapping
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

from mocap_mj.errors import MocapError

#: Exit status of a command whose result its own checks call implausible (see
#: :func:`mocap_mj.anatomy.plausibility.implausible_reasons`): distinct from 1 (an
#: operating-system error), 2 (bad input), 130 and 143 (interrupted).
EXIT_IMPLAUSIBLE = 3


def number(
    kind: type[float] | type[int] = float,
    *,
    above: float | None = None,
    least: float | None = None,
    most: float | None = None,
) -> Callable[[str], Any]:
    """An argparse ``type=`` for a numeric flag with a domain: a finite number of ``kind``,
    greater than ``above``, at least ``least``, at most ``most``. Outside, argparse names the
    flag: ``argument --observable-mm: expected a number > 0, got '0'`` (exit status 2)."""
    bounds = ((">", above), (">=", least), ("<=", most))
    rules = " and ".join(f"{op} {bound:g}" for op, bound in bounds if bound is not None)
    what = ("a whole number" if kind is int else "a number") + (f" {rules}" if rules else "")

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            value = None
        if (
            value is None
            or not math.isfinite(value)
            or (above is not None and not value > above)
            or (least is not None and not value >= least)
            or (most is not None and not value <= most)
        ):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    parse.__name__ = what  # argparse's fallback message names the type
    return parse


#: Metres per unit of a length on the command line (``--height 1750mm``, ``1.75m``, ``175cm``).
LENGTH_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
_LENGTH = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-z]*)\s*")


def length(
    what: str, unit: str, *, least: float, most: float, example: float
) -> Callable[[str], float]:
    """An argparse ``type=`` for a length flag (``what`` it measures): a number with a unit
    (``1750mm``, ``175 cm``, ``1.75m``) or a bare number in ``unit`` (the flag's documented
    unit), returned in metres
    and checked to lie within ``least``..``most`` [m], the plausible range: a bare number in
    the wrong unit (``--height 1.75``: 1.75 mm) is refused, naming the spellings that work
    (of ``example`` [m]), rather than read as a person 2 mm tall."""
    spell = ", ".join(f"{example / f:g}{u}" for u, f in LENGTH_UNITS.items())
    within = f"{what} within {least:g}..{most:g} m"

    def parse(text: str) -> float:
        m = _LENGTH.fullmatch(text)
        if m is None or (m.group(2) or unit) not in LENGTH_UNITS:
            raise argparse.ArgumentTypeError(
                f"expected {what} with its unit, such as {spell} (a bare number is {unit}), "
                f"got {text!r}"
            )
        value = float(m.group(1)) * LENGTH_UNITS[m.group(2) or unit]
        if not (math.isfinite(value) and least <= value <= most):
            bare = "" if m.group(2) else f"; a bare number is {unit}: give the unit, e.g. {spell}"
            raise argparse.ArgumentTypeError(
                f"expected {within} (any person), got {text!r} = {value:.4g} m{bare}"
            )
        return value

    parse.__name__ = "a length"
    return parse


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="print the final summary as one JSON object on stdout"
    )


def add_force_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace an existing --out: a file, or a folder if it is empty or wholly "
        "written by mocap-mj (its marker .mocap-mj-folder.json and only the files it lists); "
        "any other folder is refused, so that nothing but the tool's own output is deleted, "
        "and an --out that is, holds or lies among the files of an input is always refused "
        "(default: refuse an existing file or a non-empty folder)",
    )


def prepare_out(path: str | Path, *, force: bool = False) -> Path:
    """Create the output folder in place; refuse an existing non-empty one unless ``force``.

    For folders written inside a command's :func:`output_folder` (which is atomic already);
    a command's own ``--out`` goes through :func:`output_folder`.
    """
    from mocap_mj.io.atomic import stale_temporaries

    out = Path(path)
    if out.exists() and not out.is_dir():
        raise MocapError(f"{out}: exists and is not a folder")
    if out.is_dir() and not force:
        stale = set(stale_temporaries(out))
        if any(p not in stale for p in out.iterdir()):
            raise MocapError(f"{out}: folder is not empty (use --force to overwrite)")
    out.mkdir(parents=True, exist_ok=True)
    return out


def output_folder(path: str | Path, *, force: bool = False) -> AbstractContextManager[Path]:
    """A command's ``--out``: checked now, written in a hidden sibling, renamed at the end.

    See :func:`mocap_mj.io.atomic.atomic_folder`. Print the final path (``path``), not the
    yielded one, in messages.
    """
    from mocap_mj.io.atomic import atomic_folder

    return atomic_folder(path, force=force)


def finish(
    args: argparse.Namespace,
    summary: Mapping[str, Any],
    text: str,
    out: Path | None = None,
) -> int:
    """Write ``summary.json`` into ``out`` (if any), then print JSON or the readable text;
    return the exit status (:func:`with_exit_status`: 0, or :data:`EXIT_IMPLAUSIBLE` with
    the reasons printed in one line on stderr).

    Both are strict JSON: a value that could not be computed (NaN) is ``null``.
    """
    from mocap_mj.io.strict_json import dumps

    summary = with_exit_status(summary)
    if out is not None:
        write_summary(out, summary)
    if getattr(args, "json", False):
        print(dumps(summary))
    else:
        print(text)
    status = int(summary.get("exit_status", 0))
    if status == EXIT_IMPLAUSIBLE and summary.get("implausible"):
        where = getattr(args, "out", None) or out
        print(
            f"mocap-mj {args.command}: implausible result (exit status {status}; written to "
            f"{where} for inspection): {'; '.join(summary['implausible'])}",
            file=sys.stderr,
        )
    return status


def with_exit_status(summary: Mapping[str, Any]) -> dict[str, Any]:
    """``summary`` with ``exit_status`` when it holds the ``implausible`` list of a fit's
    checks: :data:`EXIT_IMPLAUSIBLE` when the list is not empty, else 0; other summaries as
    they are (their commands exit 0)."""
    if "implausible" not in summary:
        return dict(summary)
    return {**summary, "exit_status": EXIT_IMPLAUSIBLE if summary["implausible"] else 0}


def into_out_folder(
    args: argparse.Namespace, work: Callable[[Path], tuple[Mapping[str, Any], str]]
) -> int:
    """Run ``work(folder)`` into ``args.out`` and report: the usual end of a command.

    ``work`` writes its files into the folder it is given (a hidden sibling of ``--out``,
    see :func:`output_folder`; ``--force`` honoured) and returns (summary, text). The summary
    is written as ``summary.json``, the folder renamed into place, then :func:`finish` prints.
    """
    with output_folder(args.out, force=getattr(args, "force", False)) as out:
        summary, text = work(out)
        summary = with_exit_status(summary)
        write_summary(out, summary)
    return finish(args, summary, text)


def write_summary(out: Path, summary: Mapping[str, Any]) -> None:
    """``out/summary.json``, strict JSON, written atomically."""
    from mocap_mj.io.atomic import atomic_write_text
    from mocap_mj.io.strict_json import dumps

    atomic_write_text(out / "summary.json", dumps(summary, indent=2) + "\n")


def add_trial_flag(p: Any) -> None:
    """``--trial NAME|INDEX``: which trial of a multi-trial result a command reads."""
    p.add_argument(
        "--trial",
        metavar="TRIAL",
        help="which trial of a result of several: its index (0 = the first) or its name, its "
        "file's stem, as summary.json's trials and report.md list them; the first trial's "
        "files are at the top of the result, each further one's in trials/NAME/ "
        "(default: the first)",
    )
