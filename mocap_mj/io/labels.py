"""A marker file's labels, without its positions: what marker-set detection looks at.

:func:`file_labels` gives the names :func:`~mocap_mj.io.load.load_markers` keeps (one
subject's labels without their prefix, non-marker points dropped, the ``marker_map``
applied), before the built-in aliases, which depend on the marker set the names are matched
against: :func:`names_in_set` applies them for one set. C3D files are read from their header
and parameters only (:func:`mocap_mj.io.formats.c3d.open_chunks`); text files are parsed as
the chunked readers parse them, never held whole.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import Any

from mocap_mj.io.formats import (
    RawMarkers,
    c3d,
    detect_format,
    mocap_csv,
    motive_csv,
    nexus_csv,
    read_raw,
    trc,
)
from mocap_mj.io.load import _apply_aliases, _arguments, _select_markers

__all__ = ["file_labels", "names_in_set"]


def _raw_without_positions(file: Path) -> RawMarkers:
    readers: dict[str, Callable[[Path], Any]] = {
        "c3d": c3d.open_chunks,
        "trc": trc.open_chunks,
        "mocap-mj csv": mocap_csv.open_chunks,
        "vicon nexus csv": nexus_csv.open_chunks,
        "optitrack motive csv": motive_csv.open_chunks,
    }
    reader = readers.get(detect_format(file))
    if reader is not None:
        opened = reader(file)
        if not isinstance(opened, str):
            raw: RawMarkers = opened.raw
            return raw
    return read_raw(file)


def file_labels(
    path: str | os.PathLike[str],
    *,
    subject: str | None = None,
    marker_map: Mapping[str, str] | str | os.PathLike[str] | None = None,
) -> list[str]:
    """The marker names of ``path`` as :func:`~mocap_mj.io.load.load_markers` keeps them,
    before the built-in aliases: the chosen subject's labels without prefix, non-marker
    points dropped, ``marker_map`` applied. Errors as ``load_markers`` raises them (a
    missing file, several subjects without ``subject``, an unreadable map)."""
    file, _, rename = _arguments(path, marker_map, None, None)
    raw = _raw_without_positions(file)
    keep, *_ = _select_markers(file, raw, subject, rename)
    return [rename.get(name, name) for _, name in keep]


def non_marker_points(
    path: str | os.PathLike[str],
    *,
    subject: str | None = None,
    marker_map: Mapping[str, str] | str | os.PathLike[str] | None = None,
) -> list[str]:
    """The points of ``path`` that are no markers and that :func:`file_labels` leaves out:
    a Nexus output's angles, bone points, moments, powers (the file's labels)."""
    file, _, rename = _arguments(path, marker_map, None, None)
    _, _, _, dropped, _ = _select_markers(file, _raw_without_positions(file), subject, rename)
    return dropped


def names_in_set(
    labels: list[str], set_names: Collection[str], renamed: Collection[str] = ()
) -> list[str]:
    """``labels`` as :func:`~mocap_mj.io.load.load_markers` names them for a model whose
    markers are ``set_names``: a label spelling one of them (``L_IAS`` for LASI) takes its
    name, unless it is one of the ``renamed`` (the marker map's targets) or ambiguous."""
    names = list(labels)
    _apply_aliases(names, {n: n for n in renamed}, set(set_names))
    return names
