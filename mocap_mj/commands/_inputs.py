"""An ``--out`` that holds an input is refused before any work: an input is never touched.

An output *file* that exists already (``export --to trc --out F.trc``, ``render --out F.png``)
is replaced only with ``--force``: a command never replaces a file it was not asked to.

Every command writes its ``--out`` whole (a result folder replaced with ``--force``, a file
replaced atomically), so an ``--out`` that is an input, or a folder containing one, would
replace or delete it. The inputs are every value of the command line (but ``--out``) that
names an existing file or folder, compared after resolving symlinks. An ``--out`` inside an
input folder (``export RESULT --to all --out RESULT/export``) is fine: it touches no input.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..errors import OutputFolderError

#: Namespace entries that are not paths given by the user.
_NOT_INPUTS = frozenset({"out", "func", "command"})


def _paths(value: Any) -> Iterator[str]:
    if isinstance(value, str | os.PathLike):
        text = os.fspath(value)
        if isinstance(text, str) and text and os.path.exists(text):
            yield text
    elif isinstance(value, list | tuple):
        for item in value:
            yield from _paths(item)


def input_paths(args: argparse.Namespace) -> list[str]:
    """The command line's values, but ``--out``, that name an existing file or folder."""
    found: list[str] = []
    for key, value in vars(args).items():
        if key not in _NOT_INPUTS:
            found.extend(_paths(value))
    return found


def _holds(folder: str, path: str) -> bool:
    """``path`` is ``folder`` or lies inside it (both resolved)."""
    try:
        return os.path.commonpath([folder, path]) == folder
    except ValueError:  # on different drives (Windows)
        return False


def refuse_out_holding_inputs(args: argparse.Namespace) -> None:
    """Raise :class:`OutputFolderError` if ``args.out`` is, or contains, an input path.

    Raises
    ------
    OutputFolderError
        Naming ``--out`` and the input it holds.
    """
    out = getattr(args, "out", None)
    if not isinstance(out, str | os.PathLike) or not os.fspath(out):
        return
    folder = os.path.realpath(out)
    for path in input_paths(args):
        if _holds(folder, os.path.realpath(path)):
            what = "is" if os.path.realpath(path) == folder else "holds"
            raise OutputFolderError(
                f"--out {out} {what} the input {path}; an input is never replaced or deleted, "
                "so choose another --out"
            )


def refuse_overwriting(out: str | Path, sources: list[Path]) -> None:
    """Raise :class:`OutputFolderError` if the output file ``out`` is one of ``sources``
    (files the command reads, e.g. a result folder's ``model.xml``)."""
    target = os.path.realpath(out)
    for source in sources:
        if os.path.realpath(source) == target:
            raise OutputFolderError(
                f"--out {out} is the input {source}; an input is never replaced, "
                "so choose another --out"
            )


def refuse_replacing_file(out: str | Path, *, force: bool) -> None:
    """Raise :class:`OutputFolderError` if the output file ``out`` exists and ``force`` is not
    set, or if it is a folder where a file is expected.

    A file written with ``force`` is still replaced atomically (whole or not at all).
    """
    path = Path(out)
    if path.is_dir():
        raise OutputFolderError(f"--out {out}: is a folder, expected a file")
    if (path.exists() or path.is_symlink()) and not force:
        raise OutputFolderError(
            f"--out {out}: exists; use --force to replace it (an existing file is never "
            "replaced unasked)"
        )
