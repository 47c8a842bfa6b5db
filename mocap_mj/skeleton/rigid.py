"""The rigid (Kabsch) fit of a body's markers: shared by the IK's chain starts and the initial
model's segment frames; and the same fit by Horn's quaternion method, in whole-array
arithmetic, for the many small fits of the relabelling's screen."""

from __future__ import annotations

import numpy as np

#: Newton steps on the quaternion matrix's characteristic polynomial at most (each halves the
#: error of a double root and squares that of a simple one: a simple root converges in a few).
NEWTON_STEPS = 60
#: Newton steps taken on every frame before only those still falling are stepped.
WHOLE_STEPS = 3


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


def rigid_fit_horn(measured: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fit of :func:`rigid_fit` (the same rotation and shift, to rounding) by Horn's
    quaternion method: the rotation's quaternion is the eigenvector of the largest
    eigenvalue of a symmetric 4 x 4 matrix, found by Newton's method on its characteristic
    polynomial (started above the root, so it falls to it monotonically) and a column of
    the adjugate. Every step is arithmetic on whole arrays of one component over the frames,
    with no per-frame factorisation: several times faster than the stacked SVD on many
    frames of a few markers.

    Parameters
    ----------
    measured : (T, n, 3) [m], NaN where missing
    reference : (n, 3) [m], in the body frame

    Returns
    -------
    R : (T, 3, 3), p : (T, 3) [m]
        NaN in frames with fewer than three markers seen.
    """
    fit = _Horn(measured, reference)
    pos = fit.c_meas - np.einsum("ijt,jt->it", fit.rot, fit.c_ref)
    rot, pos = np.ascontiguousarray(fit.rot.transpose(2, 0, 1)), np.ascontiguousarray(pos.T)
    rot[fit.bad], pos[fit.bad] = np.nan, np.nan
    return rot, pos


def rigid_residuals_horn(measured: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(T, n) [m^2]: each point's squared distance from its place in the fit of
    :func:`rigid_fit_horn` (measured (T, n, 3) [m], NaN where missing; reference (n, 3)
    [m]); NaN where the point is missing and in frames with fewer than three seen. The
    rotation is applied to the centred points, the shift never formed."""
    fit = _Horn(measured, reference)
    r, a, b = fit.rot, fit.a, fit.b
    sq = sum((r[i, 0] * a[0] + r[i, 1] * a[1] + r[i, 2] * a[2] - b[i]) ** 2 for i in range(3))
    out = np.where(fit.ok, sq, np.nan).T  # (T, n)
    out[fit.bad] = np.nan
    return out


class _Horn:
    """Horn's fit of measured (T, n, 3) [m] to reference (n, 3) [m], in component-first
    arrays: ``ok`` (n, T) the points seen, ``a``, ``b`` (3, n, T) [m] the reference and
    the measured points about their centroids ``c_ref``, ``c_meas`` (3, T) [m] (zero where
    missing), ``rot`` (3, 3, T) the rotations, ``bad`` (T,) the frames without a fit."""

    def __init__(self, measured: np.ndarray, reference: np.ndarray) -> None:
        x = np.ascontiguousarray(np.moveaxis(measured, 0, -1).transpose(1, 0, 2))  # (3, n, T)
        self.ok = np.all(np.isfinite(x), axis=0)
        w = self.ok.astype(float)
        cnt = w.sum(axis=0)
        safe = np.maximum(cnt, 1.0)
        x = np.where(self.ok, x, 0.0)
        self.c_meas = x.sum(axis=1) / safe
        self.c_ref = (reference.T @ w) / safe
        a = self.a = (reference.T[:, :, None] - self.c_ref[:, None]) * w
        b = self.b = (x - self.c_meas[:, None]) * w
        s = np.array([[np.sum(a[i] * b[j], axis=0) for j in range(3)] for i in range(3)])
        top = 0.5 * (np.sum(a * a, axis=(0, 1)) + np.sum(b * b, axis=(0, 1)))
        with np.errstate(invalid="ignore", divide="ignore"):
            self.rot = _rotation(_largest_eigenvector(_horn_matrix(s), s, top))
        self.bad = (cnt < 3) | ~np.all(np.isfinite(self.rot), axis=(0, 1))


def _horn_matrix(s: np.ndarray) -> np.ndarray:
    """(4, 4, T): Horn's symmetric matrix of the cross-covariances s (3, 3, T) [m^2]
    (``s[i, j]``: reference axis i with measured axis j), whose quadratic form in a unit
    quaternion (w, x, y, z) is the summed dot product of the measured points with the
    rotated reference."""
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = s
    return np.array(
        [
            [xx + yy + zz, yz - zy, zx - xz, xy - yx],
            [yz - zy, xx - yy - zz, xy + yx, zx + xz],
            [zx - xz, xy + yx, yy - xx - zz, yz + zy],
            [xy - yx, zx + xz, yz + zy, zz - xx - yy],
        ]
    )


def _largest_eigenvector(k: np.ndarray, s: np.ndarray, top: np.ndarray) -> np.ndarray:
    """(4, T): the unit eigenvector of the largest eigenvalue of each k (4, 4, T) [m^2]
    (Horn's matrix of s (3, 3, T) [m^2]); top (T,) [m^2]: an upper bound of that
    eigenvalue (half the summed squared distances of both point sets from their
    centroids)."""
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = s
    det_s = xx * (yy * zz - yz * zy) - xy * (yx * zz - yz * zx) + xz * (yx * zy - yy * zx)
    c2 = -2.0 * np.sum(s * s, axis=(0, 1))  # char. polynomial x^4 + c2 x^2 + c1 x + c0
    c1 = -8.0 * det_s
    c0 = _det(k)
    lam = top.copy()
    falling = np.ones(len(lam), dtype=bool)
    todo = np.arange(len(lam))
    for n in range(NEWTON_STEPS):
        whole = n < WHOLE_STEPS  # most frames still fall: every one stepped, none gathered
        x, p2, p1, p0 = (lam, c2, c1, c0) if whole else (lam[todo], c2[todo], c1[todo], c0[todo])
        x2 = x * x
        slope = (4.0 * x2 + 2.0 * p2) * x + p1
        step = np.where(slope > 0, ((x2 + p2) * x2 + p1 * x + p0) / slope, 0.0)
        if whole:
            lam = np.where(falling, x - step, lam)
            falling &= step > 1e-15 * top
            todo = np.flatnonzero(falling)
        else:
            lam[todo] = x - step
            todo = todo[step > 1e-15 * top[todo]]  # falling still: a rise is rounding
        if not len(todo):
            break
    adj = _adjugate(k - lam * np.eye(4)[:, :, None])
    # adj = c q q^T: the column of the largest diagonal entry is q times its largest part
    j = np.argmax(np.abs(np.einsum("iit->it", adj)), axis=0)
    q = np.take_along_axis(adj, j[None, None], axis=1)[:, 0]
    return q / np.sqrt(np.sum(q * q, axis=0))


def _minors(m: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The 2 x 2 minors of rows 0-1 and of rows 2-3 of each m (4, 4, T), by column pairs
    (0 1, 0 2, 0 3, 1 2, 1 3, 2 3)."""
    pairs = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
    low = [m[0, i] * m[1, j] - m[1, i] * m[0, j] for i, j in pairs]
    high = [m[2, i] * m[3, j] - m[3, i] * m[2, j] for i, j in pairs]
    return low, high


def _det(m: np.ndarray) -> np.ndarray:
    """(T,): the determinant of each m (4, 4, T), by Laplace expansion in 2 x 2 minors."""
    (s0, s1, s2, s3, s4, s5), (c0, c1, c2, c3, c4, c5) = _minors(m)
    return s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0


def _adjugate(m: np.ndarray) -> np.ndarray:
    """(4, 4, T): the adjugate (transposed cofactors) of each m (4, 4, T), by 2 x 2 minors."""
    (s0, s1, s2, s3, s4, s5), (c0, c1, c2, c3, c4, c5) = _minors(m)
    r0, r1, r2, r3 = m
    return np.array(
        [
            [
                r1[1] * c5 - r1[2] * c4 + r1[3] * c3,
                -r0[1] * c5 + r0[2] * c4 - r0[3] * c3,
                r3[1] * s5 - r3[2] * s4 + r3[3] * s3,
                -r2[1] * s5 + r2[2] * s4 - r2[3] * s3,
            ],
            [
                -r1[0] * c5 + r1[2] * c2 - r1[3] * c1,
                r0[0] * c5 - r0[2] * c2 + r0[3] * c1,
                -r3[0] * s5 + r3[2] * s2 - r3[3] * s1,
                r2[0] * s5 - r2[2] * s2 + r2[3] * s1,
            ],
            [
                r1[0] * c4 - r1[1] * c2 + r1[3] * c0,
                -r0[0] * c4 + r0[1] * c2 - r0[3] * c0,
                r3[0] * s4 - r3[1] * s2 + r3[3] * s0,
                -r2[0] * s4 + r2[1] * s2 - r2[3] * s0,
            ],
            [
                -r1[0] * c3 + r1[1] * c1 - r1[2] * c0,
                r0[0] * c3 - r0[1] * c1 + r0[2] * c0,
                -r3[0] * s3 + r3[1] * s1 - r3[2] * s0,
                r2[0] * s3 - r2[1] * s1 + r2[2] * s0,
            ],
        ]
    )


def _rotation(q: np.ndarray) -> np.ndarray:
    """(3, 3, T): the rotation matrices of unit quaternions q (4, T) (w, x, y, z)."""
    w, x, y, z = q
    return np.array(
        [
            [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
        ]
    )


__all__ = ["NEWTON_STEPS", "WHOLE_STEPS", "rigid_fit", "rigid_fit_horn", "rigid_residuals_horn"]
