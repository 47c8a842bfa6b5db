"""Atomic writes: the destination is replaced whole or left untouched."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from mocap_mj.io import atomic_path, atomic_write_bytes, atomic_write_text


def _leftovers(directory: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name not in keep)


def test_write_text_creates_and_replaces(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    atomic_write_text(target, "first\n")
    assert target.read_bytes() == b"first\n"
    atomic_write_text(target, "second\r\nline ünïcode\n")
    assert target.read_bytes() == "second\r\nline ünïcode\n".encode()
    assert _leftovers(tmp_path, {"out.txt"}) == []


def test_write_bytes(tmp_path: Path) -> None:
    target = tmp_path / "blob.bin"
    atomic_write_bytes(target, b"\x00\x01\xff")
    assert target.read_bytes() == b"\x00\x01\xff"


def test_failed_block_leaves_destination_and_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "keep.c3d"
    target.write_bytes(b"original")
    with pytest.raises(RuntimeError, match="boom"), atomic_path(target) as tmp:
        tmp.write_bytes(b"half-writ")
        raise RuntimeError("boom")
    assert target.read_bytes() == b"original"
    assert _leftovers(tmp_path, {"keep.c3d"}) == []


def test_temp_path_is_beside_destination_with_its_suffix(tmp_path: Path) -> None:
    target = tmp_path / "video.mp4"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent
        assert tmp.suffix == ".mp4"
        assert not tmp.exists()
        assert not target.exists()  # nothing visible until the block succeeds
        tmp.write_bytes(b"data")
    assert target.read_bytes() == b"data"
    assert _leftovers(tmp_path, {"video.mp4"}) == []


def test_block_that_writes_nothing_is_an_error(tmp_path: Path) -> None:
    target = tmp_path / "x.txt"
    target.write_text("old")
    with pytest.raises(FileNotFoundError), atomic_path(target):
        pass
    assert target.read_text() == "old"


def test_existing_permissions_are_kept(tmp_path: Path) -> None:
    target = tmp_path / "script.sh"
    target.write_text("old")
    os.chmod(target, 0o751)
    atomic_write_text(target, "new")
    assert stat.S_IMODE(target.stat().st_mode) == 0o751
    assert target.read_text() == "new"


def test_symlink_target_is_replaced_not_the_link(tmp_path: Path) -> None:
    real = tmp_path / "real.txt"
    real.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    atomic_write_text(link, "new")
    assert link.is_symlink()
    assert real.read_text() == "new"


def test_missing_directory_raises_oserror(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        atomic_write_text(tmp_path / "nope" / "x.txt", "a")
    assert _leftovers(tmp_path, set()) == []
