"""Marker labels: subject prefixes, non-marker points, and lab-to-model name maps."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping
from pathlib import Path

import yaml

from mocap_mj.errors import InputFileError
from mocap_mj.markers import MARKER_NAMES

#: Names of points that are not markers: Plug-in Gait model outputs and unlabelled points.
_NON_MARKER = re.compile(
    r"""
    (?:PEL|HED|TRX|[LR](?:FE|TI|FO|TO|CL|HU|RA|HN))[OALP]   # PiG segment origin/axes
    | .*(?:Angles?|Forces?|Moments?|Powers?|GRF|Scalars?)    # PiG kinetics and angles
    | Cent(?:re|er)OfMass.*                                  # centre of mass (+Floor)
    | \*\d+                                                  # Nexus unlabelled: *115
    | Unlabell?ed(?:\s.*)?                                   # Motive unlabelled: Unlabeled 1000
    | uname\*?\d*                                            # other unnamed points
    """,
    re.VERBOSE,
)


def is_non_marker(name: str) -> bool:
    """True if ``name`` (without subject prefix) names a model output or an unlabelled point."""
    return name not in MARKER_NAMES and (not name or _NON_MARKER.fullmatch(name) is not None)


def split_prefix(label: str) -> tuple[str | None, str]:
    """``"Derrick:LASI"`` -> ``("Derrick", "LASI")``; ``"LASI"`` -> ``(None, "LASI")``."""
    prefix, sep, name = label.rpartition(":")
    return (prefix.strip(), name.strip()) if sep else (None, label.strip())


def load_marker_map(marker_map: Mapping[str, str] | str | os.PathLike[str]) -> dict[str, str]:
    """A lab-name -> model-name dict from a mapping or a YAML/JSON file.

    Raises
    ------
    InputFileError
        If the file cannot be read or parsed, or is not a flat string -> string mapping.
    """
    where = "marker_map"
    if isinstance(marker_map, Mapping):
        raw: object = dict(marker_map)
    else:
        path = Path(marker_map)
        where = str(path)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise InputFileError(f"{path}: cannot read the marker map: {exc}") from exc
        try:
            if path.suffix.lower() == ".json":
                raw = json.loads(text)
            else:
                raw = yaml.safe_load(text)
        except (ValueError, yaml.YAMLError) as exc:
            first = " ".join(str(exc).split())[:120] or type(exc).__name__
            raise InputFileError(f"{path}: expected a YAML or JSON mapping, got {first}") from exc
    if not isinstance(raw, dict):
        raise InputFileError(
            f"{where}: expected a mapping of lab names to model names, got {type(raw).__name__}"
        )
    out: dict[str, str] = {}
    for key, value in raw.items():
        if not (isinstance(key, str) and isinstance(value, str) and key.strip() and value.strip()):
            raise InputFileError(
                f"{where}: expected lab name: model name (two non-empty strings), got "
                f"{key!r}: {value!r}"
            )
        out[key.strip()] = value.strip()
    return out
