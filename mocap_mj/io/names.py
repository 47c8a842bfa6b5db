"""Marker labels: subject prefixes, non-marker points, lab-to-model name maps, built-in aliases."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Collection, Mapping
from pathlib import Path

from mocap_mj.errors import InputFileError
from mocap_mj.io.marker_names import MARKER_NAMES
from mocap_mj.io.yaml_file import parse_yaml, read_text

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
        text = read_text(path, "marker map")
        if path.suffix.lower() == ".json":
            try:
                raw = json.loads(text)
            except ValueError as exc:
                first = " ".join(str(exc).split())[:120] or type(exc).__name__
                raise InputFileError(f"{path}: expected a JSON marker map: {first}") from None
            except RecursionError:
                raise InputFileError(
                    f"{path}: expected a JSON marker map: nested too deep"
                ) from None
        else:
            raw = parse_yaml(text, str(path), "marker map")
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


#: Built-in spellings of Plug-in Gait markers, keyed by :func:`name_key` (upper case, no
#: spaces, underscores, dots or hyphens). Lower-case and spaced spellings of the model's own
#: names ("lasi", "l asi") need no entry. Only one-to-one equivalences are listed: the
#: anatomical names of the ISB / Qualisys convention for the same landmark (L_IAS is the
#: anterior superior iliac spine, L_FLE the lateral femoral epicondyle...), Plug-in Gait's
#: older LFRA/RFRA, the spelt-out names of other labs (r asis, r heel, r should, ASISl), and
#: numbered single markers (LUPA1). Vicon's older labelling templates (the CMU 41-marker set
#: and the Plug-in Gait labelling skeleton, whose parameters in Nexus files are still named
#: ``LFWT_Root_Z``, ``RBWT_Root_X``, ``LSHN_L_Tibia_X``) call the pelvis markers front and back
#: waist (LFWT = LASI, LBWT = LPSI), the tibia wand the shin (LSHN = LTIB) and the offset back
#: marker RBAC. A file column keeps its own name when the alias target is already in the file,
#: or when two columns would take the same name.
PIG_ALIASES: dict[str, str] = {
    # pelvis
    "LIAS": "LASI", "RIAS": "RASI", "LIPS": "LPSI", "RIPS": "RPSI",
    "LFWT": "LASI", "RFWT": "RASI", "LBWT": "LPSI", "RBWT": "RPSI",
    "LASIS": "LASI", "RASIS": "RASI", "LPSIS": "LPSI", "RPSIS": "RPSI",
    "ASISL": "LASI", "ASISR": "RASI", "PSISL": "LPSI", "PSISR": "RPSI",
    # thorax and head
    "CV7": "C7", "TV10": "T10", "SJN": "CLAV", "SNJ": "CLAV", "SXS": "STRN", "RBAC": "RBAK",
    "LHDF": "LFHD", "RHDF": "RFHD", "LHDB": "LBHD", "RHDB": "RBHD",
    # arms
    "LFRA": "LFRM", "RFRA": "RFRM", "LUPA1": "LUPA", "RUPA1": "RUPA",
    "LSAJ": "LSHO", "RSAJ": "RSHO", "LSAE": "LSHO", "RSAE": "RSHO",
    "LSHOULDER": "LSHO", "RSHOULDER": "RSHO", "LSHOULD": "LSHO", "RSHOULD": "RSHO",
    "LHLE": "LELB", "RHLE": "RELB", "LRSP": "LWRA", "RRSP": "RWRA",
    "LUSP": "LWRB", "RUSP": "RWRB", "LUHE": "LWRB", "RUHE": "RWRB",
    "LHM2": "LFIN", "RHM2": "RFIN",
    # legs
    "LFLE": "LKNE", "RFLE": "RKNE", "LFAL": "LANK", "RFAL": "RANK",
    "LSHN": "LTIB", "RSHN": "RTIB",
    "LMALL": "LANK", "RMALL": "RANK", "LFCC": "LHEE", "RFCC": "RHEE",
    "LHEEL": "LHEE", "RHEEL": "RHEE", "LFM2": "LTOE", "RFM2": "RTOE",
}  # fmt: skip


def name_key(name: str) -> str:
    """``name`` in upper case without spaces, underscores, dots or hyphens ("l_ias" -> "LIAS")."""
    return re.sub(r"[\s_.\-]", "", name).upper()


def _keys(names: Collection[str]) -> dict[str, str]:
    """Each of ``names`` by its :func:`name_key`."""
    return {name_key(n): n for n in names}


#: The bundled markers by :func:`name_key` (the default of :func:`builtin_alias`, made once).
_BUILTIN_KEYS = _keys(MARKER_NAMES)


def builtin_alias(name: str, model_names: Collection[str] = MARKER_NAMES) -> str | None:
    """The model marker ``name`` spells (case-insensitively, or by :data:`PIG_ALIASES`), or None.

    >>> builtin_alias("l_ias"), builtin_alias("lasi"), builtin_alias("LFRA"), builtin_alias("X")
    ('LASI', 'LASI', 'LFRM', None)
    """
    key = name_key(name)
    by_key = _BUILTIN_KEYS if model_names is MARKER_NAMES else _keys(model_names)
    target = by_key.get(key) or PIG_ALIASES.get(key)
    return target if target in model_names and target != name else None
