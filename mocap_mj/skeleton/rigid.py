"""The rigid (Kabsch) fit of a body's markers: shared by the IK's chain starts and the initial
model's segment frames."""

from __future__ import annotations

import numpy as np


def rigid_fit(measured: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame rigid (Kabsch) fit ``measured ~ R @ reference + p``.

    Parameters
    ----------
    measured : (T, n, 3) [m], NaN where missing
    reference : (n, 3) [m], in the body frame

    Returns
    -------
    R : (T, 3, 3), p : (T, 3) [m]
        NaN in frames with fewer than three markers seen.
    """
    ok = np.all(np.isfinite(measured), axis=2)  # (T, n)
    w = ok.astype(float)
    cnt = w.sum(axis=1)
    meas = np.where(ok[..., None], measured, 0.0)
    safe = np.maximum(cnt, 1.0)[:, None]
    c_meas = meas.sum(axis=1) / safe
    c_ref = (w[..., None] * reference[None]).sum(axis=1) / safe
    a = (reference[None] - c_ref[:, None]) * w[..., None]
    b = (meas - c_meas[:, None]) * w[..., None]
    u, _, vt = np.linalg.svd(np.einsum("tmi,tmj->tij", b, a))
    d = np.sign(np.linalg.det(u @ vt))
    u[:, :, 2] *= d[:, None]
    rot = u @ vt
    pos = c_meas - np.einsum("tij,tj->ti", rot, c_ref)
    bad = cnt < 3
    rot[bad], pos[bad] = np.nan, np.nan
    return rot, pos


__all__ = ["rigid_fit"]
