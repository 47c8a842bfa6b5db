"""Marker file readers (one module per format) and detection of a file's format."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mocap_mj.errors import InputFileError
from mocap_mj.io.formats import c3d, mocap_csv, motive_csv, nexus_csv, trc
from mocap_mj.io.formats._common import RawMarkers, show

__all__ = ["FORMATS", "RawMarkers", "detect_format", "read_raw"]

#: Format name -> reader.
FORMATS: dict[str, Callable[[Path], RawMarkers]] = {
    "c3d": c3d.read,
    "trc": trc.read,
    "mocap-mj csv": mocap_csv.read,
    "vicon nexus csv": nexus_csv.read,
    "optitrack motive csv": motive_csv.read,
}

_TEXT_FORMATS = (
    ("trc", trc.looks_like),
    ("mocap-mj csv", mocap_csv.looks_like),
    ("optitrack motive csv", motive_csv.looks_like),
    ("vicon nexus csv", nexus_csv.looks_like),
)


def detect_format(path: Path) -> str:
    """The format of the marker file ``path``, from its first bytes (the extension decides
    only between C3D and "unknown" when the content is not recognised).

    Raises
    ------
    InputFileError
        If the file cannot be opened or is in none of the known formats.
    """
    try:
        with open(path, "rb") as handle:
            head = handle.read(4096)
    except OSError as exc:
        raise InputFileError(f"{path}: cannot open: {exc.strerror or exc}") from exc
    first = head.split(b"\n", 1)[0].rstrip(b"\r").decode("latin-1").lstrip("\ufeff")
    if first.startswith("\xef\xbb\xbf"):  # UTF-8 byte-order mark seen as Latin-1
        first = first[3:]
    for name, looks_like in _TEXT_FORMATS:
        if looks_like(first):
            return name
    if c3d.looks_like(head) or path.suffix.lower() == ".c3d":
        return "c3d"
    got = show(first) if head else "an empty file"
    raise InputFileError(
        f"{path}: line 1: expected a marker file (C3D, TRC, mocap-mj CSV, Vicon Nexus CSV or "
        f"OptiTrack Motive CSV), got {got}"
    )


def read_raw(path: Path) -> RawMarkers:
    """Detect the format of ``path`` and read it, in the file's own units and axes."""
    return FORMATS[detect_format(path)](path)
