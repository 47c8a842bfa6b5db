"""The ``mocap-mj`` command line: one entry point, subcommands registered by modules.

Core subcommands live in ``mocap_mj.commands``. Packages that build on the library (``synth``,
``viewer``) add theirs through the ``mocap_mj.commands`` entry-point group, so the library never
imports them. A subcommand module exposes ``register(subparsers)``, which adds a parser whose
default ``func(args)`` returns an exit code.

Every error derived from :class:`mocap_mj.MocapError` becomes one line on stderr and exit
status 2; no traceback is shown for bad input. An operating-system error (disk full,
permission denied) is one line and exit status 1; Ctrl-C or SIGTERM exits with 130 / 143. A
result that the tool's own checks call implausible (a summary whose ``implausible`` list is
not empty) is written for inspection, the reasons printed in one line, and the command exits
with :data:`EXIT_IMPLAUSIBLE` (3), which summary.json records as ``exit_status``.
Commands write their output folder with :func:`mocap_mj.io.atomic.atomic_folder` (see
:func:`output_folder`), so an interrupted or failed run leaves no folder that looks like a
result. Before any work, an ``--out`` that is an input or holds one is refused
(:mod:`mocap_mj.commands._inputs`): an input is never replaced or deleted.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import importlib
import math
import signal
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

from .commands._removed import add_removed_flags as add_removed_flags
from .errors import MocapError

#: Exit status of a command whose result its own checks call implausible (see
#: :func:`mocap_mj.anatomy.plausibility.implausible_reasons`): distinct from 1 (an
#: operating-system error), 2 (bad input), 130 and 143 (interrupted).
EXIT_IMPLAUSIBLE = 3

#: Core subcommand modules (``mocap_mj.commands.<name>``), in help order.
CORE_COMMANDS: tuple[str, ...] = (
    "info", "ik", "identify", "score", "export", "batch", "plug_in_gait",
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
    from . import __version__

    parser.add_argument("--version", action="version", version=f"mocap-mj {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in _registrars():
        register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: parse ``argv`` (default: ``sys.argv``), run the command, return its
    exit status. A Ctrl-C while the modules load (the first second or so) is one line and
    exit status 130, as during the command: this module imports nothing heavy itself."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if getattr(args, "func", None) is None:
            parser.print_help()
            return 2
        from mocap_mj.kernels._threads import one_blas_thread

        from .commands._inputs import refuse_out_holding_inputs
    except KeyboardInterrupt:
        return _interrupted("mocap-mj")
    except ImportError as exc:  # a compiled module reports a Ctrl-C in its loading so
        if not _from_interrupt(exc):
            raise
        return _interrupted("mocap-mj")
    atexit.unregister(_ignore_late_interrupts)
    atexit.register(_ignore_late_interrupts)
    try:
        with _sigterm_as_exit(), one_blas_thread():
            refuse_out_holding_inputs(args)  # before any work: an input is never touched
            return int(args.func(args) or 0)
    except MocapError as exc:
        print(f"mocap-mj {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"mocap-mj {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return _interrupted(f"mocap-mj {args.command}")
    except ImportError as exc:
        if not _from_interrupt(exc):
            raise
        return _interrupted(f"mocap-mj {args.command}")


def _from_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` was raised while handling a Ctrl-C (``KeyboardInterrupt`` among its
    causes: a compiled module's "initialization failed")."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def _interrupted(who: str) -> int:
    """Ctrl-C: one line on stderr, exit status 130.

    CPython (3.11) notes a Ctrl-C that passes through a string ``exec`` (SciPy's array-API
    layer runs one while it loads) and, at exit, ends the process by the signal whatever
    the status returned; the next ``exec`` of a string clears that note, so one is run here.
    """
    print(f"{who}: interrupted", file=sys.stderr)
    exec("None")  # a constant: clears the interpreter's note, see above
    return 130


def _ignore_late_interrupts() -> None:
    """At interpreter exit, ignore Ctrl-C, so that the exit status stays the command's: the
    interpreter restores the default SIGINT action while it shuts down (which takes a while
    with the numeric libraries loaded), and a Ctrl-C in that window would otherwise kill the
    process by the signal after its result was written or its folder cleaned up. An ignored
    signal is the one disposition shutdown leaves alone. Registered as an exit handler, so
    that a caller running :func:`main` in its own process keeps its Ctrl-C until it exits."""
    with contextlib.suppress(ValueError):  # not the main thread: leave signals alone
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _sigterm_as_exit() -> Iterator[None]:
    """SIGTERM raises SystemExit(143), so output folders are cleaned up as on Ctrl-C."""

    def handler(signum: int, frame: object) -> None:
        print("mocap-mj: terminated", file=sys.stderr)
        raise SystemExit(128 + signum)

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


# ----------------------------------------------------------------- helpers for commands
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


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="print the final summary as one JSON object on stdout"
    )


def add_force_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace an existing --out folder if it is a mocap-mj result (holds summary.json) "
        "or empty; any other folder is refused, so that nothing but a result is deleted, and "
        "an --out that is or holds an input is always refused (default: refuse a non-empty "
        "folder)",
    )


def prepare_out(path: str | Path, *, force: bool = False) -> Path:
    """Create the output folder in place; refuse an existing non-empty one unless ``force``.

    For folders written inside a command's :func:`output_folder` (which is atomic already);
    a command's own ``--out`` goes through :func:`output_folder`.
    """
    from .io.atomic import stale_temporaries

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
    from .io.atomic import atomic_folder

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
    from mocap_mj.io.strict_json import dumps

    from .io.atomic import atomic_write_text

    atomic_write_text(out / "summary.json", dumps(summary, indent=2) + "\n")
