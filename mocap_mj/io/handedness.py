"""A mirrored recording: the subject's left markers on the subject's right.

A misconfigured export that negates one axis writes a left-handed world; a capture whose
every left/right label is swapped gives the same data. No proper rotation (what the loader
applies to put the vertical on +Z) undoes it, and the identification would fit it: a
skeleton with left and right swapped and every joint flexing through its mirror image, at a
small RMSE. The data cannot tell the two causes apart, so the loader refuses the file and
names both.

The rule, per group of markers that defines a left, a right, a front and a back of one rigid
segment (:data:`GROUPS`: the pelvis, LASI/RASI ahead of LPSI/RPSI or SACR; the head,
LFHD/RFHD ahead of LBHD/RBHD): with ``left`` the vector from the right marker to the left
one, ``forward`` from the back markers' midpoint to the front ones' and ``up`` the subject's
own long axis (:data:`UP_PAIRS`: the centroid of the head and trunk markers minus the
pelvis', else minus the feet', else the pelvis' minus the feet'), a person in a right-handed
frame has ``forward x left`` along ``up``. Per frame where they are seen,
``s = (forward x left) . up / (|forward| |left| |up|)`` (the sine of the angle between the
two, signed by handedness: about +1 for an upright trunk, whatever the pose). All three
vectors are the subject's, not the world's: any proper rotation of the file (a wrong
vertical axis included) leaves ``s`` unchanged, any reflection negates it. A group is
mirrored when the median of ``s`` over its frames is below ``-MIN_SINE`` and right-handed
when above ``+MIN_SINE``; the file is refused when a group is mirrored and none is
right-handed (a trial spent bent over at the hips, or one mislabelled group, decides
nothing). ``MIN_SINE`` = 0.5: ``s`` falls below it only with the trunk flexed more than 60
degrees against the pelvis for most of the trial.

Marker sets without these names are not checked.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.errors import InputFileError

__all__ = ["GROUPS", "HANDEDNESS_MARKERS", "MAX_FRAMES", "MIN_SINE", "UP_PAIRS", "check_handedness"]

#: |median sine| above which a group decides (module docstring).
MIN_SINE = 0.5
#: Frames the medians are taken over at most, evenly spaced (a global property of the
#: recording: 20,000 frames decide it as well as an hour's 360,000, without copying them all).
MAX_FRAMES = 20_000


class Group(NamedTuple):
    """A segment's left, right, front and back markers (any one back list that is present
    is used: Plug-in Gait pelvis with PSIS markers or a sacrum marker)."""

    name: str
    left: str
    right: str
    front: tuple[str, ...]
    backs: tuple[tuple[str, ...], ...]


GROUPS: tuple[Group, ...] = (
    Group("pelvis", "LASI", "RASI", ("LASI", "RASI"), (("LPSI", "RPSI"), ("SACR",))),
    Group("head", "LFHD", "RFHD", ("LFHD", "RFHD"), (("LBHD", "RBHD"),)),
)

#: (top, bottom) marker lists whose centroids' difference is the subject's up, in order of
#: preference (module docstring).
_TOP = ("LFHD", "RFHD", "LBHD", "RBHD", "C7", "CLAV")
_PELVIS = ("LASI", "RASI", "LPSI", "RPSI", "SACR")
_FEET = ("LANK", "RANK", "LHEE", "RHEE", "LTOE", "RTOE")
UP_PAIRS: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = (
    (_TOP, _PELVIS), (_TOP, _FEET), (_PELVIS, _FEET),
)  # fmt: skip

#: Every marker name the check may use.
HANDEDNESS_MARKERS: tuple[str, ...] = tuple(
    sorted(
        {n for g in GROUPS for n in (g.left, g.right, *g.front, *(b for bs in g.backs for b in bs))}
        | {*_TOP, *_PELVIS, *_FEET}
    )
)


def _subject_up(positions: np.ndarray, index: dict[str, int]) -> np.ndarray | None:
    """The subject's long axis per frame (T, 3) [m] (:data:`UP_PAIRS`), NaN where unseen;
    None when the file lacks the markers."""
    for top, bottom in UP_PAIRS:
        a, b = (
            [i for n, i in index.items() if n in top],
            [i for n, i in index.items() if n in bottom],
        )
        if a and b:
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # frames with none seen
                return np.nanmean(positions[:, a], axis=1) - np.nanmean(positions[:, b], axis=1)
    return None


def _sines(
    group: Group, positions: np.ndarray, index: dict[str, int], up: np.ndarray
) -> np.ndarray | None:
    """``s`` per frame (T,) for ``group`` against the subject's ``up`` (T, 3), NaN where a
    marker is missing; None when the file lacks one of the group's markers."""
    back = next((b for b in group.backs if all(n in index for n in b)), None)
    if back is None or not all(n in index for n in (group.left, group.right, *group.front)):
        return None

    def mid(names: Sequence[str]) -> np.ndarray:
        return np.mean([positions[:, index[n]] for n in names], axis=0)  # (T, 3)

    left = positions[:, index[group.left]] - positions[:, index[group.right]]
    forward = mid(group.front) - mid(back)
    norm = np.linalg.norm(left, axis=1) * np.linalg.norm(forward, axis=1)
    norm *= np.linalg.norm(up, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.einsum("ti,ti->t", np.cross(forward, left), up) / norm


def check_handedness(file: Path | str, positions: np.ndarray, names: Sequence[str]) -> None:
    """Refuse a mirrored recording (module docstring).

    Parameters
    ----------
    file : path
        Named in the error.
    positions : (T, M, 3) float [m]
        Marker positions in any axes (the rule does not use the vertical); NaN where
        missing.
    names : sequence of M str
        Model marker names of the columns.

    Raises
    ------
    InputFileError
        One line naming the file, the group and the share of its frames that are mirrored,
        what was expected and the two possible causes.
    """
    index = {n: i for i, n in enumerate(names)}
    positions = positions[:: max(1, -(-len(positions) // MAX_FRAMES))]
    up = _subject_up(positions, index)
    if up is None:
        return
    mirrored: list[tuple[Group, float]] = []
    for group in GROUPS:
        s = _sines(group, positions, index, up)
        if s is None or not np.any(np.isfinite(s)):
            continue
        s = s[np.isfinite(s)]
        median = float(np.median(s))
        if median > MIN_SINE:
            return
        if median < -MIN_SINE:
            mirrored.append((group, float(np.mean(s < 0.0))))
    if mirrored:
        group, share = mirrored[0]
        raise InputFileError(
            f"{file}: expected {group.left} on the subject's left of {group.right} in a "
            f"right-handed frame (forward x left = the subject's up), got it on the right in "
            f"{100 * share:.0f} % of the frames: a mirrored (left-handed) export, one axis "
            "negated, or every left/right label swapped; fix the export or the labels"
        )
