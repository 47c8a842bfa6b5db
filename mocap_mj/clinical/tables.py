"""The angle and point tables of the clinical outputs (CSV text), in degrees or mm.

``frame`` (the recording's frame number), ``time_s``, then ``<Name>_X``, ``_Y``, ``_Z``
per angle or point; an empty cell where a value could not be computed.
"""

from __future__ import annotations

import numpy as np


def series_table(
    frames: np.ndarray, times: np.ndarray, series: dict[str, np.ndarray], scale: float
) -> str:
    """CSV text: ``frame,time_s``, then ``<name>_X,_Y,_Z`` of each series (T, 3) times
    ``scale`` (frames (T,), times (T,) [s]); an empty cell for a NaN."""
    names = list(series)
    header = ["frame", "time_s"] + [f"{n}_{a}" for n in names for a in "XYZ"]
    cols = np.concatenate([series[n] * scale for n in names], axis=1) if names else None
    values = cols.tolist() if cols is not None else [[] for _ in frames]
    whole = np.all(np.isfinite(cols), axis=1).tolist() if cols is not None else None
    # a row with every value: one printf-style format (the text of the per-value format)
    fmt = ",".join(["%d", "%.6f"] + ["%.4f"] * (3 * len(names)))
    lines = [",".join(header)]
    rows = zip(np.asarray(frames).tolist(), np.asarray(times).tolist(), strict=True)
    for i, (f, t) in enumerate(rows):
        if whole is None or whole[i]:
            lines.append(fmt % (int(f), t, *values[i]))
            continue
        row = [str(int(f)), f"{t:.6f}"]
        row += ["" if not np.isfinite(v) else f"{v:.4f}" for v in values[i]]
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"
