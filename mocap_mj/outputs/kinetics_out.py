"""The kinetics of a trial in a result folder: the feet's plate loads on the model's foot
bodies, the inverse dynamics, their tables and summary.json's ``kinetics`` figures.

Each foot's load (:class:`~mocap_mj.capture.contacts.FootLoads`: only the plates that foot
alone stood on) acts on the model's foot body (:data:`FOOT_BODIES`) at the centre of pressure,
with the free moment as its moment (:class:`~mocap_mj.pipeline.dynamics.BodyLoad`); the
inverse dynamics run on the result's model.xml with de Leva's segment parameters for the
subject's mass (:func:`~mocap_mj.outputs.dynamics_out.dynamics_of_files`).

``grf.csv``
    ``time_s``, then per foot (``left``, ``right``) ``<side>_force_X_N`` ... [N] (the force
    on the foot, world frame), ``<side>_cop_X_m`` ... [m] (the centre of pressure, empty
    where the foot is not on a counted plate), ``<side>_free_moment_Z_Nm`` [N m] (about the
    vertical) and ``<side>_on_plate`` (1 on the frames of a counted contact, else 0).

**Stance** is the frames on which some foot stands on a counted plate and no contact is
left out (:func:`stance_frames`): there the loads the dynamics see are the whole ground
reaction, unless a foot stands on the floor beside the plates.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mocap_mj.capture.contacts import Contact, FootLoads
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.outputs.dynamics_out import STANDARD_GRAVITY
from mocap_mj.pipeline.dynamics import BodyLoad, Dynamics

__all__ = [
    "FOOT_BODIES",
    "GRF_CSV",
    "ResidualFigures",
    "body_loads",
    "excluded_frames",
    "grf_table",
    "residual_figures",
    "sliced",
    "stance_frames",
    "write_grf",
]

#: The bundled humanoid's foot bodies, per side: where each foot's ground reaction acts.
FOOT_BODIES: dict[str, str] = {"left": "foot_l", "right": "foot_r"}
GRF_CSV = "grf.csv"


def sliced(foot: FootLoads, frames: slice) -> FootLoads:
    """``foot`` on the rows ``frames`` of its trajectory (a command's ``--frames``)."""
    return FootLoads(
        foot.side,
        foot.force[frames],
        foot.cop[frames],
        foot.free_moment[frames],
        foot.on_plate[frames],
        foot.excluded,
    )


def body_loads(
    feet: Sequence[FootLoads], bodies: Mapping[str, str] = FOOT_BODIES
) -> list[BodyLoad]:
    """One :class:`BodyLoad` per foot on its body ``bodies[side]``: its force (T, 3) [N] at
    its centre of pressure (T, 3) [m] (NaN where it is not on a counted plate: no load), its
    free moment (T, 3) [N m] as the moment."""
    out = []
    for foot in feet:
        point = np.where(foot.on_plate[:, None], foot.cop, np.nan)
        out.append(BodyLoad(bodies[foot.side], foot.force, point, foot.free_moment))
    return out


def grf_table(times: np.ndarray, feet: Sequence[FootLoads]) -> str:
    """grf.csv's text (module docstring) of ``feet`` at ``times`` (T,) [s]."""
    header = ["time_s"]
    cols = []
    for foot in feet:
        s = foot.side
        header += [f"{s}_force_{a}_N" for a in "XYZ"] + [f"{s}_cop_{a}_m" for a in "XYZ"]
        header += [f"{s}_free_moment_Z_Nm", f"{s}_on_plate"]
        cop = np.where(foot.on_plate[:, None], foot.cop, np.nan)
        cols += [foot.force, cop, foot.free_moment[:, 2:3], foot.on_plate[:, None].astype(float)]
    table = np.concatenate(cols, axis=1) if cols else np.zeros((len(times), 0))
    lines = [",".join(header)]
    for t, row in zip(times, table, strict=True):
        cells = ["" if not np.isfinite(v) else f"{v:.6g}" for v in row]
        lines.append(",".join([f"{t:.6f}", *cells]))
    return "\n".join(lines) + "\n"


def write_grf(path: str | Path, times: np.ndarray, feet: Sequence[FootLoads]) -> Path:
    """Write grf.csv (:func:`grf_table`) to ``path``, atomically; the path."""
    atomic_write_text(Path(path), grf_table(times, feet))
    return Path(path)


def excluded_frames(found: Sequence[Contact], frames: int) -> np.ndarray:
    """(T,) bool, T = ``frames``: the frames of the contacts left out (a reason given)."""
    out = np.zeros(frames, dtype=bool)
    for c in found:
        if c.reason is not None:
            out[c.start : c.stop] = True
    return out


def stance_frames(feet: Sequence[FootLoads], excluded: np.ndarray | None = None) -> np.ndarray:
    """(T,) bool: the frames on which some foot is on a counted plate, less ``excluded``
    (T,) bool (the frames of the contacts left out: their load is missing)."""
    on: np.ndarray = np.any([f.on_plate for f in feet], axis=0)
    return on if excluded is None else on & ~excluded


@dataclass(frozen=True)
class ResidualFigures:
    """The root residuals over the stance frames: ``frames`` (their count), RMS of the
    residual force's norm ``force_rms_n`` [N], as per cent of body weight
    ``force_rms_pct_bw`` and of the peak ground reaction's norm ``force_rms_pct_peak_grf``
    (``peak_grf_n`` [N]: the largest total of the feet's forces), and RMS of the residual
    moment's norm ``moment_rms_nm`` [N m]. NaN without stance frames."""

    frames: int
    force_rms_n: float
    force_rms_pct_bw: float
    force_rms_pct_peak_grf: float
    peak_grf_n: float
    moment_rms_nm: float


def residual_figures(
    dyn: Dynamics, feet: Sequence[FootLoads], mass: float, stance: np.ndarray
) -> ResidualFigures:
    """:class:`ResidualFigures` of ``dyn`` over the frames ``stance`` (T,) bool (those the
    dynamics computed) for a subject of ``mass`` [kg] under the loads ``feet``."""
    force = np.linalg.norm(dyn.root_force, axis=1)
    moment = np.linalg.norm(dyn.root_moment, axis=1)
    rows = stance & np.isfinite(force) & np.isfinite(moment)
    grf = np.linalg.norm(np.sum([f.force for f in feet], axis=0), axis=1)
    peak = float(grf.max()) if len(grf) else float("nan")
    if not rows.any():
        nan = float("nan")
        return ResidualFigures(0, nan, nan, nan, peak, nan)
    f_rms = float(np.sqrt(np.mean(force[rows] ** 2)))
    return ResidualFigures(
        frames=int(rows.sum()),
        force_rms_n=f_rms,
        force_rms_pct_bw=100.0 * f_rms / (mass * STANDARD_GRAVITY),
        force_rms_pct_peak_grf=100.0 * f_rms / peak if peak > 0 else float("nan"),
        peak_grf_n=peak,
        moment_rms_nm=float(np.sqrt(np.mean(moment[rows] ** 2))),
    )
