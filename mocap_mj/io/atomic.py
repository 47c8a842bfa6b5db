"""Atomic file writes: a file is either left as it was or replaced whole, never half-written.

Every writer in mocap-mj goes through these helpers. The data go to a temporary file in the
destination's own directory (so the final :func:`os.replace` is a rename on one file system),
which is flushed to disk and then renamed over the destination. If anything fails before the
rename, the temporary file is removed and the destination is untouched.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
from collections.abc import Iterator
from pathlib import Path

from .ownership import (
    MARKER,
    alive,
    files_below,
    folder_mark,
    foreign_files,
    is_tool_folder,
    mark_folder,
    stale_entries,
)

__all__ = [
    "RESULT_MARKER",
    "atomic_folder",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "stale_temporaries",
]


def _destination(path: str | os.PathLike[str]) -> Path:
    """The file a write to ``path`` should replace (a symlink's target, not the link)."""
    return Path(os.path.realpath(os.fspath(path)))


def _fsync_file(path: Path) -> None:
    with open(path, "rb") as handle:
        os.fsync(handle.fileno())


def _fsync_dir(directory: Path) -> None:
    # Makes the rename itself durable; not possible on every platform, so best effort.
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` if the block succeeds.

    The temporary path does not exist yet: the block creates it (with any writer that takes a
    file name, e.g. ezc3d, MuJoCo or imageio). It keeps the destination's suffix so writers
    that choose a format from the extension still work. If the block raises, the temporary
    file is deleted and ``path`` is left as it was. If ``path`` already exists, its permission
    bits are copied to the new file.

    Parameters
    ----------
    path : str or PathLike
        The file to create or replace. Its directory must exist.

    Yields
    ------
    Path
        Where the block must write the complete new content.

    Raises
    ------
    FileNotFoundError
        If the block finished without creating the temporary file.
    OSError
        From the block or the rename (a full disk), naming ``path``, not the temporary file.
    """
    final = _destination(path)
    tmp = final.with_name(f".{final.stem}.tmp-{os.getpid()}-{secrets.token_hex(4)}{final.suffix}")
    try:
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(f"{final}: the write block did not create {tmp.name}")
        _fsync_file(tmp)
        if final.exists():
            with contextlib.suppress(OSError):
                shutil.copymode(final, tmp)
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):
            _name_final(exc, tmp, os.fspath(final))
        raise
    _fsync_dir(final.parent)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp, open(tmp, "xb") as handle:
        handle.write(data)
        handle.flush()


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically, byte for byte (no newline translation)."""
    atomic_write_bytes(path, text.encode(encoding))


# ------------------------------------------------------------------ whole folders
#: Hidden siblings of a folder being written (``.<name>.partial-<pid>-<hex>``) or replaced
#: (``.<name>.old-<pid>-<hex>``), each holding the tool's marker
#: (:mod:`mocap_mj.io.ownership`); a file being written has ``.<stem>.tmp-<pid>-<hex>``.
_STAGING = re.compile(r"^\.(?P<name>.+)\.(?P<kind>partial|old)-(?P<pid>\d+)-[0-9a-f]+$")


def stale_temporaries(directory: Path, name: str | None = None) -> list[Path]:
    """The staging folders in ``directory`` of runs that no longer run (``name``: those of
    one ``--out`` name only).

    Only folders holding the tool's staging marker count, whatever their names: a file or
    folder of a user's that merely looks like a temporary is never one.
    """
    found = []
    for entry in stale_entries(directory):
        if name is None or _base_name(entry.name) == name:
            found.append(entry)
    return sorted(found)


def _base_name(entry: str) -> str | None:
    """The ``--out`` name a staging name belongs to (through a staging of a staging, as a
    nested result folder makes), or None if ``entry`` is no staging name."""
    m = _STAGING.match(entry)
    if m is None:
        return None
    base = m["name"]
    while (inner := _STAGING.match(base)) is not None:
        base = inner["name"]
    return base


def _remove_unmarked_empty(directory: Path, name: str) -> None:
    """Remove the staging folders of ``name`` that a run killed before it had marked them
    left: empty, or holding only that same process's half-written marker
    (``<MARKER>.<pid>.new``, the pid of the folder's name). :func:`os.rmdir` removes only an
    empty folder, so nothing else is ever lost."""
    with contextlib.suppress(OSError):
        for entry in directory.iterdir():
            m = _STAGING.match(entry.name)
            if m is None or _base_name(entry.name) != name or alive(int(m["pid"])):
                continue
            with contextlib.suppress(OSError):
                half = entry / f"{MARKER}.{m['pid']}.new"
                if [p.name for p in entry.iterdir()] == [half.name] and not half.is_symlink():
                    half.unlink()
                os.rmdir(entry)


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()


def _is_empty(folder: Path) -> bool:
    """No entries but the tool's marker and the stale staging folders of killed runs (which
    are removed)."""
    stale = stale_entries(folder)
    for path in stale:
        _remove(path)
    mark = folder / MARKER if folder_mark(folder) is not None else None
    return not any(entry not in stale and entry != mark for entry in folder.iterdir())


#: The marker of a folder mocap-mj wrote (:mod:`mocap_mj.io.ownership`): ``force`` replaces
#: such a folder, or an empty one; any other non-empty folder is never deleted.
RESULT_MARKER = MARKER


def _check_replaceable(final: Path, path: str | os.PathLike[str]) -> None:
    """``force``: refuse unless ``final`` is empty or wholly the tool's (its marker, and no
    file the marker does not list; or a result written before the marker existed)."""
    from ..errors import OutputFolderError

    if _is_empty(final) or is_tool_folder(final):
        return
    if folder_mark(final) is not None:
        extra = foreign_files(final)
        shown = ", ".join(repr(name) for name in extra[:3]) + (", ..." if len(extra) > 3 else "")
        raise OutputFolderError(
            f"{path}: holds {shown}, which mocap-mj did not write; --force replaces only a "
            "folder wholly written by mocap-mj (or an empty one), so move those files away or "
            "choose another --out"
        )
    first = min(entry.name for entry in final.iterdir())
    raise OutputFolderError(
        f"{path}: not a folder mocap-mj wrote (no {MARKER}; holds {first!r}, ...); --force "
        "replaces only an empty folder or one mocap-mj wrote, so choose another --out"
    )


def _check_out(final: Path, path: str | os.PathLike[str], force: bool) -> None:
    """Everything that can make the final rename fail, checked before the work."""
    from ..errors import OutputFolderError

    if final.exists() and not final.is_dir():
        raise OutputFolderError(f"{path}: exists and is not a folder; choose another --out")
    if final.is_dir():
        if not os.access(final, os.W_OK | os.X_OK):
            raise OutputFolderError(f"{path}: folder is read-only; choose another --out")
        if force:
            _check_replaceable(final, path)
        elif not _is_empty(final):
            raise OutputFolderError(f"{path}: folder is not empty (use --force to replace it)")


def _rename_new(staging: Path, final: Path, path: str | os.PathLike[str]) -> None:
    """Rename ``staging`` to ``final``, which must be absent or an empty folder.

    The kernel makes the check and the rename one step: :func:`os.rename` of a folder onto a
    non-empty folder fails (POSIX; on Windows onto any existing name, so an empty folder is
    removed first, and :func:`os.rmdir` refuses a non-empty one). A result another run put
    at ``final`` after this run's checks is therefore never replaced.
    """
    from ..errors import OutputFolderError

    try:
        os.rename(staging, final)
        return
    except OSError:
        if not os.path.lexists(final):
            raise
    try:
        os.rmdir(final)
        os.rename(staging, final)
    except OSError:
        raise OutputFolderError(
            f"{path}: written by another run meanwhile; kept as it is, this run's result "
            "is discarded (use --force to replace it)"
        ) from None


def _rename_over(staging: Path, final: Path, path: str | os.PathLike[str], tag: str) -> None:
    """``force``: move the folder at ``final`` (if any, still empty or the tool's) aside,
    rename ``staging`` to ``final``, then delete the old folder; put it back on failure.

    The folder moved aside is marked ``staging`` of this run while it waits to be deleted,
    so that a kill at that moment leaves it for the next run to remove; on failure its own
    marker (or none) is put back with it."""
    old = final.parent / f".{final.name}.old-{tag}"
    if final.is_symlink() or not final.is_dir():  # nothing of ours to replace
        _rename_new(staging, final, path)
        return
    _check_replaceable(final, path)
    marker = final / MARKER
    kept = marker.read_bytes() if folder_mark(final) is not None else None
    try:
        os.rename(final, old)
    except FileNotFoundError:
        _rename_new(staging, final, path)
        return
    try:
        mark_folder(old, "staging")
        _rename_new(staging, final, path)
    except BaseException:
        with contextlib.suppress(OSError):
            if kept is None:
                (old / MARKER).unlink()
            else:
                (old / MARKER).write_bytes(kept)
            os.rename(old, final)
        raise
    _remove(old)


def _name_final(exc: OSError, staging: Path, final: str) -> None:
    """Name the file of an OS error by its final path (``final/...``), not the temporary
    ``staging`` one; name ``final`` when it names none (a full disk: ``[Errno 28]`` alone)."""
    name = exc.filename
    if name is None:
        exc.filename = final
    elif isinstance(name, str) and name.startswith(str(staging)):
        exc.filename = final + name[len(str(staging)) :]


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike[str], *, force: bool = False) -> Iterator[Path]:
    """Yield an empty hidden folder beside ``path``; rename it to ``path`` if the block succeeds.

    A reader therefore sees either no folder (or the previous one) or the complete result,
    never a half-written one: on an exception or Ctrl-C (``KeyboardInterrupt``) the temporary
    folder is deleted, and one left by a killed process is deleted by the next call for the
    same ``path`` (a folder holding the tool's staging marker, never one that merely bears
    such a name). Everything that can make the final rename fail is checked before the
    block runs (before the work): ``path`` is empty, a file, a non-empty folder without
    ``force``, a read-only folder, or its parent cannot be written. The finished folder
    carries the tool's marker listing every file written (:mod:`mocap_mj.io.ownership`).
    ``force`` replaces only an empty folder or one wholly the tool's (its marker and only
    the files it lists, or a result written before the marker existed); any other folder is
    refused, so that nothing but the tool's own output is ever deleted. Without ``force`` a result
    that another run renamed into place meanwhile is kept and this one is refused. A
    symlink ``path`` stays a link: the folder is written where it points.

    Raises
    ------
    OutputFolderError
        One of the above, naming ``path`` and what to do.
    OSError
        From the block, naming the file by its final path.
    """
    from ..errors import OutputFolderError

    if not os.fspath(path).strip():
        raise OutputFolderError("--out: expected a folder, got an empty name")
    final = Path(os.path.realpath(os.fspath(path)))
    parent = final.parent
    _check_out(final, path, force)
    for stale in stale_temporaries(parent, final.name):
        _remove(stale)
    _remove_unmarked_empty(parent, final.name)
    tag = f"{os.getpid()}-{secrets.token_hex(4)}"
    staging = parent / f".{final.name}.partial-{tag}"
    try:
        parent.mkdir(parents=True, exist_ok=True)
        staging.mkdir()
        mark_folder(staging, "staging")
    except OSError as exc:
        _remove(staging)
        reason = exc.strerror or type(exc).__name__
        raise OutputFolderError(
            f"{path}: cannot create the folder ({reason}); choose another --out"
        ) from None
    try:
        yield staging
        mark_folder(staging, "result", files=files_below(staging) or [])
        if force:
            _rename_over(staging, final, path, tag)
        else:
            _rename_new(staging, final, path)
    except BaseException as exc:
        _remove(staging)
        if isinstance(exc, OSError):
            _name_final(exc, staging, os.fspath(path))
        raise
    _fsync_dir(parent)
