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

__all__ = [
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
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
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
#: (``.<name>.old-<pid>-<hex>``); a file being written has ``.<stem>.tmp-<pid>-<hex>``.
_STAGING = re.compile(r"^\.(?P<name>.+)\.(?P<kind>partial|old|tmp)-(?P<pid>\d+)-[0-9a-f]+")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def stale_temporaries(directory: Path, name: str | None = None) -> list[Path]:
    """This package's temporaries in ``directory`` left by processes that no longer run.

    ``name`` limits them to those of one entry (a folder's or file's name, a file's stem).
    """
    found = []
    with contextlib.suppress(OSError):
        for entry in directory.iterdir():
            m = _STAGING.match(entry.name)
            if m is None or _alive(int(m["pid"])):
                continue
            base = m["name"]
            while (inner := _STAGING.match(base)) is not None:  # a temporary of a temporary
                base = inner["name"]
            if name is None or base in (name, Path(name).stem):
                found.append(entry)
    return found


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()


def _is_empty(folder: Path) -> bool:
    """No entries but stale temporaries of this package (which are removed)."""
    stale = set(stale_temporaries(folder))
    for path in stale:
        _remove(path)
    return not any(entry not in stale for entry in folder.iterdir())


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike[str], *, force: bool = False) -> Iterator[Path]:
    """Yield an empty hidden folder beside ``path``; rename it to ``path`` if the block succeeds.

    A reader therefore sees either no folder (or the previous one) or the complete result,
    never a half-written one: on an exception or Ctrl-C (``KeyboardInterrupt``) the temporary
    folder is deleted, and one left by a killed process is deleted by the next call for the
    same ``path``. Everything that can make the final rename fail is checked before the
    block runs (before the work): ``path`` is a file, a non-empty folder without ``force``,
    a read-only folder, or its parent cannot be written.

    Raises
    ------
    OutputFolderError
        One of the above, naming ``path`` and what to do.
    """
    from ..errors import OutputFolderError

    final = Path(os.path.abspath(os.fspath(path)))
    parent = final.parent
    if final.exists() and not final.is_dir():
        raise OutputFolderError(f"{path}: exists and is not a folder; choose another --out")
    if final.is_dir():
        if not os.access(final, os.W_OK | os.X_OK):
            raise OutputFolderError(f"{path}: folder is read-only; choose another --out")
        if not force and not _is_empty(final):
            raise OutputFolderError(f"{path}: folder is not empty (use --force to replace it)")
    for stale in stale_temporaries(parent, final.name):
        _remove(stale)
    tag = f"{os.getpid()}-{secrets.token_hex(4)}"
    staging = parent / f".{final.name}.partial-{tag}"
    try:
        parent.mkdir(parents=True, exist_ok=True)
        staging.mkdir()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise OutputFolderError(
            f"{path}: cannot create the folder ({reason}); choose another --out"
        ) from None
    try:
        yield staging
        old = parent / f".{final.name}.old-{tag}"
        if final.is_dir():
            os.replace(final, old)
        try:
            os.replace(staging, final)
        except BaseException:
            if old.exists():
                os.replace(old, final)
            raise
        _remove(old)
    except BaseException:
        _remove(staging)
        raise
    _fsync_dir(parent)
