"""The ``mocap-mj`` command line: one entry point, subcommands registered by modules.

Core subcommands live in ``mocap_mj.commands``. Packages that build on the library (``synth``,
``viewer``) add theirs through the ``mocap_mj.commands`` entry-point group, so the library never
imports them. A subcommand module exposes ``register(subparsers)``, which adds a parser whose
default ``func(args)`` returns an exit code.

Every error derived from :class:`mocap_mj.MocapError` becomes one line on stderr and exit
status 2; no traceback is shown for bad input. An operating-system error (disk full,
permission denied) is one line and exit status 1; Ctrl-C, SIGTERM or SIGHUP exits with
130 / 143 / 129. A result that the tool's own checks call implausible (a summary whose
``implausible`` list is not empty) is written for inspection, the reasons printed in one line,
and the command exits with :data:`~mocap_mj.commands.common.EXIT_IMPLAUSIBLE` (3), which
summary.json records as ``exit_status``. Commands write their output folder with
:func:`mocap_mj.io.atomic.atomic_folder` (see :func:`~mocap_mj.commands.common.output_folder`),
so an interrupted or failed run leaves no folder that looks like a result. Before any work,
an ``--out`` that is an input or holds one is refused (:mod:`mocap_mj.commands._inputs`): an
input is never replaced or deleted.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import signal
import sys
from collections.abc import Iterator, Sequence

from .commands.registry import build_parser
from .errors import MocapError


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: parse ``argv`` (default: ``sys.argv``), run the command, return its
    exit status. A Ctrl-C while the modules load (the first second or so) is one line and
    exit status 130, as during the command: this module imports nothing heavy itself."""
    try:
        words = sys.argv[1:] if argv is None else list(argv)
        parser = build_parser(words)
        args = parser.parse_args(words)
        if getattr(args, "func", None) is None:
            parser.print_help()
            return 2
        from mocap_mj.kernels._threads import one_blas_thread

        from .commands._inputs import refuse_out_holding_inputs
    except KeyboardInterrupt:
        return _interrupted("mocap-mj")
    except Exception as exc:  # a Ctrl-C in a module's loading, reported so
        if not _from_interrupt(exc):
            raise
        return _interrupted("mocap-mj")
    atexit.unregister(_ignore_late_interrupts)
    atexit.register(_ignore_late_interrupts)
    from .io.ownership import set_command

    set_command(" ".join(["mocap-mj", *(sys.argv[1:] if argv is None else argv)]))
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
    except Exception as exc:  # as above, in a lazy import
        if not _from_interrupt(exc):
            raise
        return _interrupted(f"mocap-mj {args.command}")


def _from_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` was raised while handling a Ctrl-C: ``KeyboardInterrupt`` among its
    causes (a compiled module's "initialization failed", or the RuntimeError a class's
    creation raises when the Ctrl-C lands in a field's ``__set_name__``), or a ctypes call's
    ``ArgumentError`` that names it (ctypes replaces an exception raised while it converts
    an argument, as when a Ctrl-C lands in an OpenGL binding's call, by one that carries only
    its text)."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        if isinstance(cause, ctypes.ArgumentError) and "KeyboardInterrupt" in str(cause):
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


#: Signals that end a command as Ctrl-C does (its folders cleaned up): SIGTERM, and SIGHUP
#: (the terminal closed), where the platform has them.
_ENDING = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


@contextlib.contextmanager
def _sigterm_as_exit() -> Iterator[None]:
    """SIGTERM and SIGHUP raise SystemExit(128 + signal number: 143, 129), so output folders
    are cleaned up as on Ctrl-C; one the caller ignores stays ignored."""

    def handler(signum: int, frame: object) -> None:
        print("mocap-mj: terminated", file=sys.stderr)
        raise SystemExit(128 + signum)

    try:
        # A signal the caller ignores (``nohup`` ignores SIGHUP) stays ignored.
        previous = [
            (sig, signal.signal(sig, handler))
            for sig in _ENDING
            if signal.getsignal(sig) is not signal.SIG_IGN
        ]
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        for sig, action in previous:
            signal.signal(sig, action)
