"""Which folders are mocap-mj's: the folder marker, and the only folders the tool may delete.

A command may replace (``--force``) or delete a folder only if the tool wrote it. A common file
name such as ``summary.json`` is no proof of that: a user's folder can hold one. The proof is
the marker :data:`MARKER`, a small JSON file whose name and content no user writes by
accident (its ``format`` is :data:`FORMAT`), written into every folder the tool creates:

* ``kind: result`` -- a finished output folder (a command's ``--out``). It lists every file the
  tool wrote there (``files``, relative paths); a file added later by someone else (a note)
  makes the folder no longer wholly the tool's, and ``--force`` then refuses to replace it.
* ``kind: staging`` / ``scratch`` -- a folder a run works in (a hidden sibling of ``--out``, a
  scratch folder in the temporary folder). It records the process id and host; a later run
  removes it once that process no longer runs on this host (a run killed by SIGKILL), and never
  a folder without the marker, whatever its name.
* ``kind: batch`` -- a ``batch --out`` folder, which later runs of the batch resume into.

A result folder written before the marker existed is the tool's only if it holds
``summary.json`` and nothing but the files the tool writes (:func:`legacy_result`).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import socket
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "FORMAT",
    "MARKER",
    "folder_mark",
    "foreign_files",
    "is_tool_folder",
    "legacy_result",
    "mark_folder",
    "remove_stale",
    "scratch_folder",
    "set_command",
]

#: The marker's file name (hidden; no other program writes it).
MARKER = ".mocap-mj-folder.json"
#: The marker's ``format`` field: what makes a file of that name the tool's marker.
FORMAT = "mocap-mj folder marker, version 1"
#: Kinds of folder the marker names.
KINDS = ("result", "staging", "scratch", "batch", "subject")
#: Most files a result marker lists (a larger folder is not listed, and not replaceable).
MAX_LISTED = 20_000
#: Largest marker read [bytes]: a bigger file of that name is not the tool's.
MAX_MARKER_BYTES = 4 * 2**20

_command = "python API"


def set_command(text: str) -> None:
    """Record the command line that markers written from now on name (the CLI sets it)."""
    global _command
    _command = text


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("mocap-mj")
    except Exception:  # not installed (a source checkout on sys.path)
        return "unknown"


def mark_folder(folder: Path, kind: str, *, files: list[str] | None = None) -> None:
    """Write the marker of ``kind`` (one of :data:`KINDS`) into ``folder``, atomically.

    ``files``: the relative paths the tool wrote (a ``result``); None lists none.
    """
    if kind not in KINDS:
        raise ValueError(f"folder kind {kind!r}: expected one of {', '.join(KINDS)}")
    record: dict[str, Any] = {
        "format": FORMAT,
        "kind": kind,
        "command": _command,
        "version": _version(),
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    if files is not None:
        record["files"] = sorted(files)
    tmp = folder / f"{MARKER}.{os.getpid()}.new"
    tmp.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, folder / MARKER)


def folder_mark(folder: Path) -> dict[str, Any] | None:
    """The marker of ``folder`` as a dict, or None where there is none or it is not the
    tool's (another content, unreadable, a link)."""
    path = folder / MARKER
    try:
        if path.is_symlink() or not path.is_file() or path.stat().st_size > MAX_MARKER_BYTES:
            return None
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        return None
    if record.get("kind") not in KINDS or not isinstance(record.get("pid"), int):
        return None
    return record


def files_below(folder: Path) -> list[str] | None:
    """Relative paths of every file (and link) below ``folder``, the marker aside; None if
    there are more than :data:`MAX_LISTED` or the folder cannot be read."""
    found: list[str] = []
    try:
        for root, dirs, names in os.walk(folder):
            here = Path(root)
            links = [d for d in dirs if (here / d).is_symlink()]
            for name in [*names, *links]:
                rel = (here / name).relative_to(folder).as_posix()
                if rel != MARKER:
                    found.append(rel)
            dirs[:] = [d for d in dirs if d not in links]
            if len(found) > MAX_LISTED:
                return None
    except OSError:
        return None
    return found


def foreign_files(folder: Path) -> list[str]:
    """Files below ``folder`` that its result marker does not list (the tool did not write
    them), sorted; every file where the marker lists none."""
    record = folder_mark(folder)
    listed = set(record.get("files", ())) if record else set()
    present = files_below(folder)
    if present is None:
        return ["(more files than a result holds)"]
    return sorted(set(present) - listed)


#: Files a result folder held before the marker existed (one regular expression a name).
_LEGACY = re.compile(
    r"(summary\.json|model\.xml|theta\.json|motion(_\d+)?\.npz|motion\.csv|"
    r"joint_centres(_\d+)?\.csv|angles(_\d+)?\.csv|segments\.(csv|png)|identifiability\.json|"
    r"report\.md|recipe\.yaml|result\.c3d|coordinates\.mot|markers\.(trc|csv)|"
    r"model_markers\.trc|residuals\.csv|scale\.csv|subject\.(osim|json)|ik_setup\.xml|"
    r"truth(_model\.xml|_motion\.npz|\.json)|score\.json|table1\.(json|csv)|traces\.json|"
    r"frame_error\.csv|summary\.csv|kinetics\.csv|"
    r"(events|dynamics|grf|root_residuals)(_\d+)?\.csv|(marker_error|parameter_errors|residual_per_marker|"
    r"rmse_per_trial|convergence|fig3|fig4|angles_vs_plug_in_gait)\.png|"
    r"[A-Za-z0-9_.-]+_vs_plug_in_gait\.(md|png))"
)


def legacy_result(folder: Path) -> bool:
    """A result written before the marker: ``summary.json`` and nothing but the files the
    tool writes (sub-folders likewise: each a legacy result of its own)."""
    try:
        entries = list(folder.iterdir())
    except OSError:
        return False
    if not (folder / "summary.json").is_file() or (folder / "summary.json").is_symlink():
        return False
    for entry in entries:
        if entry.is_symlink():
            return False
        if entry.is_dir():
            if not (legacy_result(entry) or is_tool_folder(entry)):
                return False
        elif _LEGACY.fullmatch(entry.name) is None:
            return False
    return True


def is_tool_folder(folder: Path) -> bool:
    """Whether ``--force`` may replace ``folder``: a finished result the tool wrote (its
    marker, every file below it one the marker lists) or a legacy result."""
    record = folder_mark(folder)
    if record is None:
        return legacy_result(folder)
    return record["kind"] == "result" and not foreign_files(folder)


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this host (this process included)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _stale(folder: Path) -> bool:
    """A staging or scratch folder of a run that no longer runs on this host."""
    if folder.is_symlink() or not folder.is_dir():
        return False
    record = folder_mark(folder)
    return (
        record is not None
        and record["kind"] in ("staging", "scratch")
        and record.get("host") == socket.gethostname()
        and not alive(int(record["pid"]))
    )


def remove_stale(directory: Path, prefix: str = "") -> list[Path]:
    """Delete the stale staging and scratch folders in ``directory`` whose names start with
    ``prefix``: only folders holding the tool's marker, of a process gone from this host.
    Returns what was removed."""
    removed = []
    with contextlib.suppress(OSError):
        for entry in directory.iterdir():
            if entry.name.startswith(prefix) and _stale(entry):
                shutil.rmtree(entry, ignore_errors=True)
                removed.append(entry)
    return removed


def stale_entries(directory: Path) -> set[Path]:
    """The stale staging and scratch folders in ``directory`` (nothing is removed)."""
    found = set()
    with contextlib.suppress(OSError):
        for entry in directory.iterdir():
            if _stale(entry):
                found.add(entry)
    return found


#: Prefix of scratch folders in the temporary folder.
SCRATCH_PREFIX = "mocap-mj-"


@contextlib.contextmanager
def scratch_folder(parent: Path | None = None, prefix: str = SCRATCH_PREFIX) -> Iterator[Path]:
    """A new empty folder, marked ``scratch``, deleted when the block ends.

    In ``parent`` (default: the temporary folder). Before it is made, the stale scratch
    folders of killed runs there (same ``prefix``, the tool's marker, process gone) go.
    """
    where = Path(tempfile.gettempdir()) if parent is None else parent
    remove_stale(where, prefix)
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir=where))
    try:
        mark_folder(folder, "scratch")
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
