"""The compiled CSV formatter: printf's text byte for byte, ties and all."""

from __future__ import annotations

import numpy as np

from mocap_mj.kernels._fixed_text import csv_rows


def _python(ints: np.ndarray, floats: np.ndarray, formats: tuple[str, ...]) -> bytes:
    rows = []
    for i, f in zip(ints.tolist(), floats.tolist(), strict=True):
        cells = [fmt % v for fmt, v in zip(formats, i, strict=False)]
        cells += [
            "" if not np.isfinite(v) else fmt % v
            for fmt, v in zip(formats[len(i) :], f, strict=True)
        ]
        rows.append(",".join(cells) + "\n")
    return "".join(rows).encode()


def test_rows_equal_python_formatting() -> None:
    """Random cells, NaN cells and rows, negative zero and tiny negatives, exact ties
    (0.03125, 2.5e-5: printf rounds them to even) and near-ties, numbers too large for the
    kernel: the same bytes as Python's % formatting."""
    rng = np.random.default_rng(0)
    n = 3000
    floats = np.concatenate([rng.uniform(0, 100, (n, 1)), rng.normal(0, 1000, (n, 6))], axis=1)
    floats[5] = np.nan
    floats[7, 3] = np.nan
    floats[10, 1:7] = [0.03125, -0.00001, -0.0, 12.00005, 2.5e-5, 1e13]
    floats[11, 1:7] = [0.99995, -9.99995, 0.00015, -0.00015, 1e-300, 123456.78905]
    # many near-ties: decimals of 5 in the 5th (7th) place
    floats[100:, 1] = rng.integers(-(10**9), 10**9, n - 100) / 1e5
    floats[100:, 0] = rng.integers(0, 10**9, n - 100) / 1e7
    ints = np.stack([np.arange(n) - 50, rng.integers(-(10**12), 10**12, n)], axis=1)
    formats = ("%d", "%d", "%.6f", *(["%.4f"] * 6))
    got = csv_rows(ints, floats, [6, *([4] * 6)], formats)
    assert got == _python(ints, floats, formats)


def test_no_rows() -> None:
    assert csv_rows(np.zeros((0, 1)), np.zeros((0, 2)), [4, 4], ("%d", "%.4f", "%.4f")) == b""
