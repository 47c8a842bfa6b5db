"""mocap_mj.io.plots: each figure writes a PNG of the requested size and rejects bad arrays."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mocap_mj import MocapError
from mocap_mj.io.plots import (
    plot_error_accumulation,
    plot_marker_error_per_frame,
    plot_parameter_errors,
    plot_residual_per_marker,
)

T = 200
TIMES = np.arange(T) / 100.0
RNG = np.random.default_rng(3)
ERRORS = {"nominal": 10 + RNG.normal(0, 1, T), "identified": 3 + RNG.normal(0, 0.3, T)}
ERRORS["identified"][20:30] = np.nan
NAMES = [f"p{i}" for i in range(12)]


def _png_size(path: Path) -> tuple[int, int]:
    assert path.stat().st_size > 1000
    with Image.open(path) as im:
        assert im.format == "PNG"
        return im.size


@pytest.mark.slow
@pytest.mark.parametrize("plot", [plot_marker_error_per_frame, plot_error_accumulation])
def test_series_plots_write_pngs_of_the_size_asked(
    plot: Callable[..., Path], tmp_path: Path
) -> None:
    out = tmp_path / "fig.png"
    assert plot(out, TIMES, ERRORS, size=(900, 500)) == out
    assert _png_size(out) == (900, 500)
    assert _png_size(plot(tmp_path / "default.png", list(TIMES), ERRORS)) == (1200, 700)


@pytest.mark.slow
def test_parameter_and_residual_plots(tmp_path: Path) -> None:
    err = RNG.normal(0, 2e-3, len(NAMES))  # [m]
    err[2] = np.nan
    crlb = RNG.uniform(0.5e-3, 3e-3, len(NAMES))
    crlb[5] = np.inf
    out = plot_parameter_errors(tmp_path / "par.png", NAMES, err, crlb, size=(800, 600))
    assert _png_size(out) == (800, 600)
    assert _png_size(plot_parameter_errors(tmp_path / "tall.png", NAMES, err, crlb)) == (1000, 400)
    rmse = RNG.uniform(1e-3, 8e-3, len(NAMES))
    rmse[0] = np.nan
    out = plot_residual_per_marker(tmp_path / "res.png", NAMES, rmse, size=(1000, 450))
    assert _png_size(out) == (1000, 450)


def test_mismatched_lengths_raise_mocap_errors(tmp_path: Path) -> None:
    out = tmp_path / "x.png"
    bad = {"a": np.ones(T - 1)}
    cases = [
        lambda: plot_marker_error_per_frame(out, TIMES, bad),
        lambda: plot_error_accumulation(out, TIMES, {"a": np.ones((T, 2))}),
        lambda: plot_marker_error_per_frame(out, TIMES, {}),
        lambda: plot_error_accumulation(out, [], {"a": []}),
        lambda: plot_parameter_errors(out, NAMES, np.ones(3), np.ones(len(NAMES))),
        lambda: plot_parameter_errors(out, NAMES, np.ones(len(NAMES)), np.ones(3)),
        lambda: plot_parameter_errors(out, NAMES, np.ones(12), -np.ones(12)),
        lambda: plot_residual_per_marker(out, NAMES, np.ones(len(NAMES) + 1)),
        lambda: plot_residual_per_marker(out, [], []),
        lambda: plot_marker_error_per_frame(out, TIMES, ERRORS, size=(10, 10)),
    ]
    for case in cases:
        with pytest.raises(MocapError):
            case()
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # nothing half-written
