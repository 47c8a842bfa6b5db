"""Figures that mocap-mj commands write: marker errors over time, parameter errors, residuals.

Pure functions of arrays: each takes the output path first, validates its inputs (a length
mismatch raises :class:`mocap_mj.errors.ShapeError`, a :class:`MocapError`) and writes one PNG
atomically. The figures are drawn on matplotlib's Agg canvas directly (no ``pyplot``, no global
backend switch), at 150 dpi; ``size`` is the image size in pixels. A figure of one axes is
laid out by one measurement of its labels (:func:`_fit_axes`), one of several by
constrained layout.

Errors are in millimetres, times in seconds.

Ctrl-C, SIGTERM and SIGALRM (``batch --timeout``) are held while a figure is drawn and act
when it is written (then as anywhere else): matplotlib's objects run Python callbacks as
they are freed (weak-reference callbacks of its transforms and callback registries), and an
interrupt raised inside one cannot propagate: Python prints "Exception ignored in ...
Traceback" and goes on.
"""

from __future__ import annotations

import functools
import gc
import io
import signal
import threading
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from mocap_mj.errors import MocapError, ShapeError
from mocap_mj.io.atomic import atomic_write_bytes

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "DPI",
    "PAD",
    "PNG_LEVEL",
    "plot_angle_comparison",
    "plot_error_accumulation",
    "plot_marker_error_per_frame",
    "plot_parameter_errors",
    "plot_residual_per_marker",
]

F = TypeVar("F", bound=Callable[..., Any])

#: Resolution of every figure [dots per inch].
DPI = 150
#: Space kept between an axes' labels and the figure's edge [inch] (constrained layout's).
PAD = 3 / 72
#: zlib level of the PNG files: 3 writes a figure in about half the time of the default 6,
#: in files about a fifth larger (lossless either way).
PNG_LEVEL = 3
_SERIES_SIZE = (1200, 700)


# --------------------------------------------------------------------------- checks
def _vector(name: str, values: ArrayLike, n: int | None = None) -> np.ndarray:
    """``values`` as a 1-D float array (of length ``n`` if given), or ShapeError."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"{name}: expected numbers") from None
    if arr.ndim != 1:
        raise ShapeError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    if n is not None and len(arr) != n:
        raise ShapeError(f"{name}: expected {n} values, got {len(arr)}")
    return arr


def _times(times: ArrayLike) -> np.ndarray:
    t = _vector("times", times)
    if len(t) == 0:
        raise ShapeError("times: expected at least one frame")
    if not np.all(np.isfinite(t)):
        raise ShapeError("times: expected finite values")
    return t


def _series(errors: Mapping[str, ArrayLike], n: int) -> dict[str, np.ndarray]:
    if not errors:
        raise MocapError("errors: expected at least one labelled series")
    return {str(k): _vector(f"errors[{k!r}]", v, n) for k, v in errors.items()}


def _names(names: Sequence[str]) -> list[str]:
    out = [str(n) for n in names]
    if not out:
        raise ShapeError("names: expected at least one name")
    return out


def _size(size: tuple[int, int]) -> tuple[int, int]:
    w, h = (int(s) for s in size)
    if w < 100 or h < 100:
        raise MocapError(f"size: expected at least 100 x 100 pixels, got {w} x {h}")
    return w, h


# --------------------------------------------------------------------------- output
#: How many figures :func:`held_interrupts` is drawing (nested ones freeze nothing more).
_FROZEN = {"depth": 0}


def held_interrupts(fn: F) -> F:
    """Decorator: run ``fn`` (that draws a figure) with SIGINT, SIGTERM and SIGALRM held, its
    figure's objects freed before they are let go; a signal that came meanwhile is then
    raised again, to the handler in place before. Outside the main thread, ``fn`` as is."""

    @functools.wraps(fn)
    def held(*args: Any, **kwargs: Any) -> Any:
        if threading.current_thread() is not threading.main_thread():
            return fn(*args, **kwargs)
        came: list[int] = []
        wanted = [signal.SIGINT, signal.SIGTERM]
        if hasattr(signal, "SIGALRM"):  # batch --timeout; not on Windows
            wanted.append(signal.SIGALRM)
        previous = {s: signal.signal(s, lambda signum, _: came.append(signum)) for s in wanted}
        # What exists before the figure is frozen out of the collection below, which then
        # scans the figure's objects only, not the whole process's (a full collection over
        # a fit's objects took 0.1-0.15 s per figure).
        outer = _FROZEN["depth"] == 0
        _FROZEN["depth"] += 1
        if outer:
            gc.freeze()
        try:
            out = fn(*args, **kwargs)
            gc.collect()  # the figure's reference cycles, with their callbacks, now
        finally:
            _FROZEN["depth"] -= 1
            if outer:
                gc.unfreeze()
            for wanted_signal, handler in previous.items():
                signal.signal(wanted_signal, handler)
            for signum in dict.fromkeys(came):
                signal.raise_signal(signum)
        return out

    return held  # type: ignore[return-value]


def _figure(size: tuple[int, int], *, constrained: bool = False) -> Figure:
    """An empty figure of ``size`` pixels on an Agg canvas. By default it has one axes'
    worth of layout: :func:`_save` places its only axes by one measurement of its labels
    (:func:`_fit_axes`); ``constrained`` (several axes, a legend outside them) gives it
    matplotlib's constrained layout instead, which measures every axes twice."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    w, h = _size(size)
    fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI, layout="constrained" if constrained else None)
    FigureCanvasAgg(fig)
    return fig


def _fit_axes(fig: Figure) -> None:
    """The figure's only axes moved so that its title, labels, tick labels and legend fit the
    figure with :data:`PAD` inches to spare on every side (constrained layout's default pad):
    the placement constrained layout finds, from one measurement of the labels' extent
    instead of two (each lays out every tick label: a third of a simple figure's time)."""
    (ax,) = fig.axes
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    tight = ax.get_tightbbox(renderer)
    box = ax.get_window_extent(renderer)
    if tight is None:
        return
    w, h, pad = fig.bbox.width, fig.bbox.height, PAD * DPI
    left = (box.x0 - tight.x0 + pad) / w
    right = 1 - (tight.x1 - box.x1 + pad) / w
    bottom = (box.y0 - tight.y0 + pad) / h
    top = 1 - (tight.y1 - box.y1 + pad) / h
    if right - left > 0.1 and top - bottom > 0.1:  # else labels larger than the figure: as is
        ax.set_position((left, bottom, right - left, top - bottom))


def _save(fig: Figure, path: str | Path) -> Path:
    """fig written to path as a PNG (zlib level :data:`PNG_LEVEL`), its axes placed by
    :func:`_fit_axes` when it has no layout engine and one axes."""
    path = Path(path)
    if fig.get_layout_engine() is None and len(fig.axes) == 1:
        _fit_axes(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": PNG_LEVEL})
    atomic_write_bytes(path, buf.getvalue())
    return path


def _mean_text(values: np.ndarray) -> str:
    finite = values[np.isfinite(values)]
    return f"{finite.mean():.2f}" if len(finite) else "n/a"


# --------------------------------------------------------------------------- figures
@held_interrupts
def plot_marker_error_per_frame(
    path: str | Path,
    times: ArrayLike,
    errors: Mapping[str, ArrayLike],
    *,
    title: str = "Marker error per frame",
    size: tuple[int, int] = _SERIES_SIZE,
) -> Path:
    """Marker error of every frame, one line per identified model (the paper's Fig. 3).

    Parameters
    ----------
    path : path
        PNG file to write.
    times : (T,) array [s]
        Frame times.
    errors : mapping of label -> (T,) array [mm]
        Per-frame marker error (e.g. RMSE over the markers) of each model; NaN leaves a gap.
    title : str
    size : (width, height) [px]

    Returns
    -------
    Path
        ``path``.
    """
    t = _times(times)
    series = _series(errors, len(t))
    fig = _figure(size)
    ax = fig.add_subplot()
    for label, e in series.items():
        ax.plot(t, e, lw=1.2, label=f"{label} (mean {_mean_text(e)} mm)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("marker error [mm]")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize="small")
    return _save(fig, path)


@held_interrupts
def plot_error_accumulation(
    path: str | Path,
    times: ArrayLike,
    errors: Mapping[str, ArrayLike],
    *,
    title: str = "Accumulated marker error",
    size: tuple[int, int] = _SERIES_SIZE,
) -> Path:
    """Running sum over frames of each model's per-frame marker error (the paper's Fig. 4).

    The value at frame k is the sum of the errors of frames 0..k [mm]; frames with a NaN error
    add nothing. A model that fits worse climbs faster.

    Parameters
    ----------
    path : path
        PNG file to write.
    times : (T,) array [s]
    errors : mapping of label -> (T,) array [mm]
    title : str
    size : (width, height) [px]
    """
    t = _times(times)
    series = _series(errors, len(t))
    fig = _figure(size)
    ax = fig.add_subplot()
    for label, e in series.items():
        total = np.cumsum(np.where(np.isfinite(e), e, 0.0))
        ax.plot(t, total, lw=1.5, label=f"{label} (total {total[-1]:.4g} mm)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("accumulated marker error [mm]")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize="small")
    return _save(fig, path)


@held_interrupts
def plot_parameter_errors(
    path: str | Path,
    names: Sequence[str],
    errors: ArrayLike,
    crlb: ArrayLike,
    *,
    title: str = "Parameter error and Cramér-Rao bound",
    size: tuple[int, int] | None = None,
) -> Path:
    """Signed error of each identified parameter against its Cramér-Rao bound.

    One row per parameter: a grey band from -CRLB to +CRLB (the bound on the standard deviation
    of any unbiased estimate) and a bar for the error. Bars outside their band are red. A
    parameter whose bound is infinite (not identifiable) gets a hatched band across the axis.

    Parameters
    ----------
    path : path
        PNG file to write.
    names : sequence of str, (P,)
        Parameter names.
    errors : (P,) array [m]
        Estimate minus truth; NaN draws no bar. Drawn in mm.
    crlb : (P,) array [m]
        Square root of the CRLB's diagonal; ``inf`` for an unidentifiable parameter.
    title : str
    size : (width, height) [px], optional
        By default 1000 wide and 16 px per parameter high (at least 400).
    """
    labels = _names(names)
    n = len(labels)
    err = _vector("errors", errors, n) * 1e3
    bound = _vector("crlb", crlb, n) * 1e3
    if np.any(bound[np.isfinite(bound)] < 0):
        raise MocapError("crlb: expected non-negative bounds")
    fig = _figure(size or (1000, max(400, 90 + 16 * n)), constrained=True)
    ax = fig.add_subplot()
    y = np.arange(n)
    finite_b = np.isfinite(bound)
    reach = [np.abs(err[np.isfinite(err)]), bound[finite_b]]
    span = max((float(r.max()) for r in reach if len(r)), default=1.0) * 1.15 or 1.0
    ax.barh(y[finite_b], 2 * bound[finite_b], left=-bound[finite_b], height=0.8,
            color="0.82", label="±CRLB (1σ)")  # fmt: skip
    if np.any(~finite_b):
        ax.barh(y[~finite_b], 2 * span, left=-span, height=0.8, color="none", hatch="///",
                edgecolor="0.6", label="no bound (not identifiable)")  # fmt: skip
    has_err = np.isfinite(err)
    outside = has_err & finite_b & (np.abs(err) > bound)
    colours = np.where(outside, "tab:red", "tab:blue")
    ax.barh(y[has_err], err[has_err], height=0.45, color=colours[has_err], label="error")
    ax.axvline(0.0, color="0.3", lw=0.8)
    ax.set_yticks(y, labels, fontsize=max(4.0, min(8.0, 900.0 / n)))
    ax.set_ylim(n - 0.5, -0.5)
    ax.set_xlim(-span, span)
    ax.set_xlabel("error [mm]")
    ax.set_title(title)
    ax.grid(axis="x", alpha=0.3)
    fig.legend(loc="outside upper center", ncol=3, fontsize="small", frameon=False)
    return _save(fig, path)


@held_interrupts
def plot_residual_per_marker(
    path: str | Path,
    names: Sequence[str],
    rmse: ArrayLike,
    *,
    title: str = "Marker residual RMSE",
    size: tuple[int, int] = (1200, 600),
) -> Path:
    """RMSE of each marker's residual over the trial, as bars, with their mean as a line.

    Parameters
    ----------
    path : path
        PNG file to write.
    names : sequence of str, (M,)
        Marker names.
    rmse : (M,) array [m]
        RMSE of each marker; NaN (never seen) draws no bar and an "n/a" label. Drawn in mm.
    title : str
    size : (width, height) [px]
    """
    labels = _names(names)
    rmse = _vector("rmse", rmse, len(labels)) * 1e3
    fig = _figure(size)
    ax = fig.add_subplot()
    x = np.arange(len(labels))
    seen = np.isfinite(rmse)
    ax.bar(x[seen], rmse[seen], color="tab:blue", width=0.75)
    for i in np.flatnonzero(~seen):
        ax.text(x[i], 0, "n/a", rotation=90, ha="center", va="bottom", fontsize=7, color="0.4")
    if np.any(seen):
        mean = float(rmse[seen].mean())
        ax.axhline(mean, color="tab:orange", lw=1.2, label=f"mean {mean:.2f} mm")
        ax.legend(loc="upper right", fontsize="small")
    _bar_names(fig, ax, labels, max(5.0, min(8.0, 1400.0 / len(labels))))
    ax.set_xlim(-0.6, len(labels) - 0.4)
    ax.set_ylim(bottom=0)
    ax.set_ylabel("RMSE [mm]")
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, path)


def _bar_names(fig: Figure, ax: Axes, labels: Sequence[str], fontsize: float) -> None:
    """labels under the bars at x = 0, 1, ... of ax (in fig), upright, where tick labels go, with
    their tick marks: as plain texts and one line of tick marks, not one tick object (five
    artists) per bar: a figure of 40 markers draws in two thirds of the time."""
    import matplotlib as mpl
    from matplotlib.markers import TICKDOWN
    from matplotlib.transforms import offset_copy

    rc = mpl.rcParams
    size, pad = float(rc["xtick.major.size"]), float(rc["xtick.major.pad"])
    ax.set_xticks([])
    along = ax.get_xaxis_transform()  # x in data, y in axes
    below = offset_copy(along, fig=fig, y=-(size + pad), units="points")
    colour = rc["xtick.color"] if rc["xtick.labelcolor"] == "inherit" else rc["xtick.labelcolor"]
    for i, name in enumerate(labels):
        ax.text(i, 0, name, transform=below, rotation=90, ha="center", va="top",
                fontsize=fontsize, color=colour)  # fmt: skip
    ax.plot(np.arange(len(labels)), np.zeros(len(labels)), ls="none", marker=TICKDOWN,
            ms=size, mew=float(rc["xtick.major.width"]), color=rc["xtick.color"],
            transform=along, clip_on=False, scalex=False, scaley=False)  # fmt: skip


def plot_angle_comparison(
    path: str | Path,
    times: ArrayLike,
    ours: Mapping[str, np.ndarray],
    theirs: Mapping[str, np.ndarray],
    *,
    labels: tuple[str, str] = ("ours", "Plug-in Gait"),
) -> Path:
    """Each angle's three components, ours and the reference's in one panel per component
    (rows: the angles without the side letter; left side blue, right red; ours solid, the
    reference dashed).

    Parameters
    ----------
    path : path
        PNG file to write.
    times : (T,) array [s]
    ours, theirs : mapping of Vicon name (``LKneeAngles``) -> (T, 3) array [deg]
        Only the names both hold are drawn.
    labels : (str, str)
        Legend names of ours and the reference.
    """
    t = _times(times)
    names = [n for n in ours if n in theirs]
    for n in names:
        for what, a in (("ours", ours[n]), ("reference", theirs[n])):
            if np.shape(a) != (len(t), 3):
                raise ShapeError(f"{what} {n}: expected shape ({len(t)}, 3)")
    joints = list(dict.fromkeys(n[1:] for n in names))
    if not joints:
        raise MocapError("no angle in both tables to plot")
    fig = _figure((1800, 260 * len(joints) + 120), constrained=True)
    axes = fig.subplots(len(joints), 3, squeeze=False, sharex=True)
    for row, joint in enumerate(joints):
        for k, axis in enumerate("XYZ"):
            ax = axes[row][k]
            for side, color in (("L", "tab:blue"), ("R", "tab:red")):
                name = side + joint
                if name in names:
                    ax.plot(t, ours[name][:, k], color=color, lw=1.0, label=f"{side} {labels[0]}")
                    ax.plot(t, theirs[name][:, k], color=color, lw=1.0, ls="--",
                            label=f"{side} {labels[1]}")  # fmt: skip
            ax.set_title(f"{joint} {axis} (deg)", fontsize=8)
            ax.tick_params(labelsize=6)
    axes[0][0].legend(fontsize=6)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)", fontsize=7)
    return _save(fig, path)
