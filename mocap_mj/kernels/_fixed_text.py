"""Numeric tables as CSV text, compiled: printf's ``%d`` and ``%.Nf`` cells, byte for byte.

``joint_centres.csv`` of an hour holds 360,000 rows of 59 numbers, which Python's ``%``
formatting turns into text several times slower than this kernel. Here
a compiled kernel writes the rows into a byte buffer: each number ``v`` with ``N`` decimals is
rounded as printf rounds it (correctly, from the exact binary value) through
``y = |v| 10^N`` in floating point. The product's rounding error is below ``|y| 2^-52``, so
``y``'s fractional part decides the rounding unless it lies that close to one half; such cells
(and numbers of 2^52 and more after scaling) are left to Python's ``%`` formatting, whose text
is then the row's. Non-finite numbers are empty cells.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba as nb
import numpy as np

from mocap_mj.kernels._kernel_cache import share_cache

#: Bytes a cell may take at most: sign, 16 integer digits (y < 2^52 < 10^16), point, decimals.
_CELL = 40
_TWO52 = float(2**52)


@share_cache
@nb.njit(cache=True, nogil=True, error_model="numpy")
def _rows(
    ints: np.ndarray, floats: np.ndarray, decimals: np.ndarray, out: np.ndarray, ends: np.ndarray
) -> np.ndarray:
    """Rows of integer cells ``ints`` (n, a) then float cells ``floats`` (n, b) with
    ``decimals`` (b,) digits into ``out`` (bytes); ``ends`` (n,) receives each row's end.
    Returns (n,) bool: rows to format in Python (a cell too close to a rounding tie)."""
    n, a = ints.shape
    b = floats.shape[1]
    python = np.zeros(n, dtype=np.bool_)
    digits = np.zeros(24, dtype=np.uint8)
    pos = 0
    for t in range(n):
        for j in range(a + b):
            if j > 0:
                out[pos] = 44  # ","
                pos += 1
            if j < a:
                k, d, neg = ints[t, j], 0, False
            else:
                v = floats[t, j - a]
                if not math.isfinite(v):
                    continue
                d = decimals[j - a]
                y = abs(v) * 10.0**d
                if y >= _TWO52:
                    python[t] = True
                    continue
                whole = math.floor(y)
                frac = y - whole
                if abs(frac - 0.5) <= y * 2.0**-50 + 1e-300:
                    python[t] = True
                    continue
                k = np.int64(whole) + (1 if frac > 0.5 else 0)
                neg = math.copysign(1.0, v) < 0
            if j < a and k < 0:
                neg, k = True, -k
            if neg:
                out[pos] = 45  # "-"
                pos += 1
            m = 0
            while k > 0 or m <= d:  # at least one digit before the point
                digits[m] = 48 + k % 10
                k //= 10
                m += 1
            for i in range(m - 1, -1, -1):
                if d > 0 and i == d - 1:
                    out[pos] = 46  # "."
                    pos += 1
                out[pos] = digits[i]
                pos += 1
        out[pos] = 10  # "\n"
        pos += 1
        ends[t] = pos
    return python


def csv_rows(
    ints: np.ndarray, floats: np.ndarray, decimals: Sequence[int], python_formats: Sequence[str]
) -> bytes:
    """The CSV text (UTF-8, one ``\\n``-ended line per row) of the integer columns ints
    (n, a) followed by the float columns floats (n, b), column j with ``decimals[j]`` digits;
    the same text as ``",".join(python_formats[i] % cell)`` per row, non-finite floats as empty
    cells (``python_formats``: the a + b cells' ``%`` formats, used for the rare rows whose
    rounding the kernel leaves to Python)."""
    ints = np.ascontiguousarray(ints, dtype=np.int64)
    floats = np.ascontiguousarray(floats, dtype=np.float64)
    ints = ints[:, None] if ints.ndim == 1 else ints
    floats = floats[:, None] if floats.ndim == 1 else floats
    n = len(ints)
    width = ints.shape[1] + floats.shape[1]
    out = np.empty(n * (width * _CELL + 1), dtype=np.uint8)
    ends = np.empty(n, dtype=np.int64)
    digits = np.ascontiguousarray(decimals, dtype=np.int64)
    python = _rows(ints, floats, digits, out, ends) if n else np.zeros(0, dtype=bool)
    if not python.any():
        return out[: ends[-1] if n else 0].tobytes()
    pieces, start = [], 0
    for t in np.flatnonzero(python):
        pieces.append(out[start : ends[t - 1] if t else 0].tobytes())
        cells = [*ints[t].tolist(), *floats[t].tolist()]
        text = (
            "" if isinstance(c, float) and not math.isfinite(c) else f % c
            for f, c in zip(python_formats, cells, strict=True)
        )
        pieces.append((",".join(text) + "\n").encode())
        start = int(ends[t])
    pieces.append(out[start : ends[-1]].tobytes())
    return b"".join(pieces)
