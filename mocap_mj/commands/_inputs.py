"""An ``--out`` that would replace an input is refused before any work: an input is never
touched.

An output *file* that exists already (``export --to trc --out F.trc``, ``render --out F.png``)
is replaced only with ``--force``: a command never replaces a file it was not asked to.

Every command writes its ``--out`` whole (a result folder replaced with ``--force``, a file
replaced atomically), so an ``--out`` that is an input, or a folder containing one, would
replace or delete it. The inputs are every value of the command line (but ``--out``) that
names an existing file or folder, and every existing file that an input folder's
``summary.json`` names (a result's recordings, subject file, recipe, marker set), compared
after resolving symlinks. Refused, ``--force`` or not: an ``--out`` that is an input, holds
one, or is an existing file inside an input folder (``export RESULT --out RESULT/report.md``:
a file of the result being read). A new ``--out`` inside an input folder (``export RESULT
--to all --out RESULT/export``) is fine: it replaces no input. An empty ``--out`` is refused.
"""

from __future__ import annotations

import argparse
import contextlib
import json
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


#: Largest summary.json whose named files are looked up [bytes].
_SUMMARY_BYTES = 16 * 2**20


def _strings(value: Any) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def named_inputs(folder: str) -> list[str]:
    """The existing files that ``folder``'s ``summary.json`` names (the inputs of the result
    it describes: absolute paths, or relative to the current folder); [] without one."""
    summary = Path(folder) / "summary.json"
    try:
        if not summary.is_file() or summary.stat().st_size > _SUMMARY_BYTES:
            return []
        data = json.loads(summary.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    found = []
    for text in _strings(data):
        if text and len(text) < 4096 and "\n" not in text and "\0" not in text:
            with contextlib.suppress(OSError, ValueError):
                if os.path.isfile(text):
                    found.append(text)
    return found


def input_paths(args: argparse.Namespace) -> list[str]:
    """The command line's values, but ``--out``, that name an existing file or folder, and
    the files that those folders' ``summary.json`` name."""
    found: list[str] = []
    for key, value in vars(args).items():
        if key not in _NOT_INPUTS:
            found.extend(_paths(value))
    for path in list(found):
        if os.path.isdir(path):
            found.extend(named_inputs(path))
    return found


def _holds(folder: str, path: str) -> bool:
    """``path`` is ``folder`` or lies inside it (both resolved)."""
    try:
        return os.path.commonpath([folder, path]) == folder
    except ValueError:  # on different drives (Windows)
        return False


def refuse_out_holding_inputs(args: argparse.Namespace) -> None:
    """Raise :class:`OutputFolderError` if ``args.out`` is empty, is or contains an input
    path, or is an existing file inside an input folder.

    Raises
    ------
    OutputFolderError
        Naming ``--out`` and the input it would replace.
    """
    out = getattr(args, "out", None)
    if isinstance(out, str) and not out.strip():
        raise OutputFolderError("--out: expected a path, got an empty name")
    if not isinstance(out, str | os.PathLike) or not os.fspath(out):
        return
    target = os.path.realpath(out)
    inputs = input_paths(args)
    for path in inputs:
        if _holds(target, os.path.realpath(path)):
            what = "is" if os.path.realpath(path) == target else "holds"
            raise OutputFolderError(
                f"--out {out} {what} the input {path}; an input is never replaced or deleted, "
                "so choose another --out"
            )
    if os.path.lexists(out) and not os.path.isdir(out):
        for path in inputs:
            if os.path.isdir(path) and _holds(os.path.realpath(path), target):
                raise OutputFolderError(
                    f"--out {out} is a file of the input folder {path}; an input is never "
                    "replaced, so choose another --out"
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
