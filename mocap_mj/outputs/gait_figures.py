"""The gait report's figures, as PNG bytes: the kinematics page (pelvis, hip, knee, ankle and
foot progression in the three planes) and the kinetics page (hip, knee and ankle moments in
the three planes and powers), each panel against the cycle's 0-100 %.

As gait labs draw them: the left side red, the right green; each cycle a thin line, the
side's mean a thick one; the side's mean foot off a dashed vertical line; the normative
mean +/- 1 sd a grey band when a normative set is given. Angles in degrees, moments in
N m/kg, powers in W/kg (:func:`~mocap_mj.clinical.gait_scores.unit_scale`).
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np

from mocap_mj.clinical.cycles import PERCENT
from mocap_mj.clinical.gait_scores import Normative, unit_scale
from mocap_mj.io.plots import held_interrupts

from .gait_report import TrialCycles

__all__ = ["COLOURS", "KINEMATIC_PANELS", "KINETIC_PANELS", "page_png"]

#: The sides' colours.
COLOURS = {"left": "#d62728", "right": "#2ca02c"}
#: The kinematics page: rows of (variable with its axis, title, unit).
KINEMATIC_PANELS = tuple(
    tuple((f"{v}_{a}", f"{title} {plane}", "deg") for a, plane in zip("XYZ", planes, strict=True))
    for v, title, planes in (
        ("PelvisAngles", "Pelvis", ("tilt", "obliquity", "rotation")),
        ("HipAngles", "Hip", ("flexion", "adduction", "rotation")),
        ("KneeAngles", "Knee", ("flexion", "varus", "rotation")),
        ("AnkleAngles", "Ankle", ("dorsiflexion", "inversion", "rotation")),
        ("FootProgressAngles", "Foot progression", ("tilt", "roll", "(internal +)")),
    )
)
#: The kinetics page: per joint its three moments and its power.
KINETIC_PANELS = tuple(
    (
        *((f"{j}Moment_{a}", f"{j} moment {a}", "N m/kg") for a in "XYZ"),
        (f"{j}Power_Z", f"{j} power", "W/kg"),
    )
    for j in ("Hip", "Knee", "Ankle")
)


def _panel(
    ax: object,
    variable: str,
    title: str,
    unit: str,
    trials: Sequence[TrialCycles],
    kinetic: bool,
    normative: Normative | None,
) -> None:
    from matplotlib.axes import Axes

    assert isinstance(ax, Axes)
    name, axis = variable[:-2], "XYZ".index(variable[-1])
    scale = unit_scale(name)
    if normative is not None and variable in normative.curves:
        mean, sd = (c * scale for c in normative.curves[variable])
        ax.fill_between(PERCENT, mean - sd, mean + sd, color="0.8", lw=0, label="normative")
    for side, colour in COLOURS.items():
        curves = []
        offs = []
        for t in trials:
            source = t.kinetics if kinetic else t.angles
            for c in t.cycles:
                values = source.get((side, c.number, name))
                if values is None:
                    continue
                curves.append(values[:, axis] * scale)
                offs.append(c.percent(c.foot_off))
                ax.plot(PERCENT, curves[-1], color=colour, lw=0.6, alpha=0.6)
        if curves:
            ax.plot(PERCENT, np.nanmean(curves, axis=0), color=colour, lw=2.0, label=side)
            ax.axvline(float(np.mean(offs)), color=colour, ls="--", lw=0.8)
    ax.set_title(title, fontsize=8)
    ax.set_xlim(0, 100)
    ax.set_ylabel(unit, fontsize=7)
    ax.tick_params(labelsize=6)
    ax.grid(alpha=0.3)


@held_interrupts
def page_png(
    panels: Sequence[Sequence[tuple[str, str, str]]],
    trials: Sequence[TrialCycles],
    *,
    kinetic: bool = False,
    normative: Normative | None = None,
    title: str = "",
) -> bytes:
    """One page of ``panels`` (rows of (variable, title, unit)) as PNG bytes: the trials'
    cycles of each side (``kinetic``: their kinetics, else their angles) against the cycle,
    the normative band when ``normative`` holds the variable."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows, cols = len(panels), max(len(r) for r in panels)
    fig = Figure(figsize=(2.6 * cols, 1.9 * rows), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    for i, row in enumerate(panels):
        for j, (variable, panel_title, unit) in enumerate(row):
            _panel(axes[i][j], variable, panel_title, unit, trials, kinetic, normative)
        for j in range(len(row), cols):
            axes[i][j].set_axis_off()
    for ax in axes[-1]:
        ax.set_xlabel("% gait cycle", fontsize=7)
    handles, labels = axes[0][0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside upper right", ncols=3, fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()
