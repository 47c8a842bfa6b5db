"""Atomic file writes: a file is either left as it was or replaced whole, never half-written.

Every writer in mocap-mj goes through these helpers. The data go to a temporary file in the
destination's own directory (so the final :func:`os.replace` is a rename on one file system),
which is flushed to disk and then renamed over the destination. If anything fails before the
rename, the temporary file is removed and the destination is untouched.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text"]


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
