"""Refusing marker data a solver cannot use, before any work, with one line saying why.

A frame is usable when at least ``min_markers`` of the model's markers are present (finite)
in it (the IK rule, :class:`mocap_mj.solve.ik.IKSettings`; by default :func:`frame_floor` of
the markers the trial records, so a partial set is not held to a full set's count). Without a
usable frame ``ik`` would write a motion of NaN; with fewer residuals (3 per present marker of
the usable frames) than unknowns (the joint dofs each usable frame's present markers
determine, :func:`mocap_mj.capture.marker_set.measured_dofs`, plus the free model
parameters) ``identify`` would report bounds of a problem the data cannot determine. Both are
refused here. The dofs of a body no present marker determines (the arms of a lower-body
marker set) are not counted: the solver holds them, so they are not unknowns.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from mocap_mj.capture.marker_set import measured_dofs
from mocap_mj.errors import SolverError

__all__ = ["check_determined", "check_markers", "frame_floor", "recorded_floor", "usable_frames"]

#: Present markers a frame of a full marker set needs to be solved.
FULL_SET_FLOOR = 16
#: Fewest present markers any frame needs (three on a segment fix its pose; one more checks).
LEAST_FLOOR = 4
#: Share of the recorded markers a frame needs where the set records fewer than
#: ``FULL_SET_FLOOR / FRACTION``: a frame missing a quarter of a partial set's markers is
#: solved (its unobserved joints held), one missing more is not.
FRACTION = 0.75


def frame_floor(recorded: int) -> int:
    """Present markers a frame needs when the recording records ``recorded`` of the model's
    markers (any sample in the trial): ``min(16, max(4, ceil(0.75 * recorded)))``. A full
    Plug-in Gait set (39) keeps 16; a lower-body set (16) needs 12, so one occluded marker
    does not cost the frame."""
    return min(FULL_SET_FLOOR, max(LEAST_FLOOR, int(np.ceil(FRACTION * recorded))))


def recorded_floor(markers: np.ndarray) -> int:
    """:func:`frame_floor` of the markers (T, M, 3) [m] of a trial (NaN where missing)."""
    present = np.any(np.all(np.isfinite(markers), axis=2), axis=0)
    return frame_floor(int(np.count_nonzero(present)))


def usable_frames(markers: np.ndarray, min_markers: int) -> np.ndarray:
    """(T,) bool: frames of markers (T, M, 3) [m] with at least ``min_markers`` present."""
    present = np.all(np.isfinite(markers), axis=2)
    return np.asarray(np.count_nonzero(present, axis=1) >= min_markers)


def check_markers(
    path: str, names: Sequence[str], markers: np.ndarray, min_markers: int
) -> np.ndarray:
    """Raise :class:`SolverError` naming ``path`` unless some frame is usable.

    markers (T, M, 3) [m] in the order of ``names`` (M,), NaN where missing. Returns the
    usable-frame mask (T,).
    """
    ok = usable_frames(markers, min_markers)
    if ok.any():
        return ok
    present = np.any(np.all(np.isfinite(markers), axis=2), axis=0)
    n_with_data = int(present.sum())
    if n_with_data == 0:
        what = f"none of the model's {len(names)} markers has a single valid sample (all NaN)"
    else:
        best = int(np.count_nonzero(np.all(np.isfinite(markers), axis=2), axis=1).max())
        found = ", ".join(n for n, p in zip(names, present, strict=True) if p)
        what = (
            f"only {n_with_data} of the model's {len(names)} markers have data ({found}), "
            f"at most {best} in one frame"
        )
    raise SolverError(
        f"{path}: {what}; a frame needs {min_markers} (--min-markers): check the marker "
        "names (--marker-map) and that the file holds marker trajectories"
    )


def check_determined(
    paths: Sequence[str],
    markers: Sequence[np.ndarray],
    min_markers: int,
    model: mujoco.MjModel,
    n_free: int,
) -> None:
    """Raise :class:`SolverError` if the trials hold fewer residuals than unknowns.

    markers: per trial (T, M, 3) [m] in the order of ``model``'s marker sites; the unknowns
    are each usable frame's determined joint dofs (:func:`measured_dofs`) plus ``n_free``
    model parameters.
    """
    frames = 0
    residuals = 0
    dofs = 0
    for m in markers:
        ok = usable_frames(m, min_markers)
        present = np.all(np.isfinite(m[ok]), axis=2)
        frames += int(ok.sum())
        residuals += 3 * int(present.sum())
        dofs += int(measured_dofs(model, present).sum())
    unknowns = dofs + n_free
    if residuals <= unknowns:
        per_frame = f"{dofs / frames:.0f}" if frames else "0"
        raise SolverError(
            f"{', '.join(paths)}: {frames} usable frame(s) give {residuals} marker coordinates "
            f"for {unknowns} unknowns ({per_frame} determined joint dofs per frame + {n_free} "
            "model parameters): the model cannot be identified from so little data; fit more "
            "frames or record more markers"
        )
