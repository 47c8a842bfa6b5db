"""Vector helpers of the Plug-in Gait construction, over frames: unit vectors, right-handed
frames from two directions, the chord construction and Cardan decompositions.

Every function takes arrays with frames first, ``(T, 3)`` points or directions [m] and
``(T, 3, 3)`` frames whose columns are the segment's x, y and z axes in the lab. NaN in an
input gives NaN in what depends on it (no value is carried over from another frame).
"""

from __future__ import annotations

import numpy as np


def unit(v: np.ndarray) -> np.ndarray:
    """``v / |v|`` along the last axis; NaN where ``v`` has zero length or is missing."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, v / np.where(n > 0, n, 1.0), np.nan)


def frame(a: int, va: np.ndarray, b: int, vb: np.ndarray) -> np.ndarray:
    """Right-handed frames (T, 3, 3) (columns x, y, z) with axis ``a`` (0 x, 1 y, 2 z)
    along ``va`` and axis ``b`` as close to ``vb`` as orthogonality allows."""
    ua = unit(va)
    cyclic = (b - a) % 3 == 1
    uc = unit(np.cross(ua, vb) if cyclic else np.cross(vb, ua))
    ub = np.cross(uc, ua) if cyclic else np.cross(ua, uc)
    out = np.empty((*ua.shape[:-1], 3, 3))
    out[..., a], out[..., b], out[..., 3 - a - b] = ua, ub, uc
    return out


def frame_zy(z: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z along ``z``, y towards ``y`` (:func:`frame`)."""
    return frame(2, z, 1, y)


def frame_zx(z: np.ndarray, x: np.ndarray) -> np.ndarray:
    """z along ``z``, x towards ``x`` (:func:`frame`)."""
    return frame(2, z, 0, x)


def chord(a: np.ndarray, b: np.ndarray, c: np.ndarray, delta: float) -> np.ndarray:
    """Plug-in Gait's chord construction: the joint centre J (T, 3) [m] in the plane of the
    wand marker ``a``, the proximal joint centre ``b`` and the joint marker ``c``, at
    ``delta`` from ``c`` (half the joint width plus the marker radius [m]), with the angle
    b-J-c a right angle (J on the circle whose diameter is b-c), on the side away from ``a``.
    """
    bc = b - c
    length = np.linalg.norm(bc, axis=-1, keepdims=True)
    e1 = unit(bc)
    n = unit(np.cross(a - c, bc))
    e2 = np.cross(n, e1)
    with np.errstate(invalid="ignore"):
        cos = delta / length
        sin = np.sqrt(np.clip(1.0 - cos**2, 0.0, None))
    return c + delta * (cos * e1 + sin * e2)


def relative(proximal: np.ndarray, distal: np.ndarray) -> np.ndarray:
    """The distal frame in the proximal one, ``P^T D`` (T, 3, 3)."""
    return np.einsum("tji,tjk->tik", proximal, distal)


def cardan_yxz(r: np.ndarray) -> np.ndarray:
    """Angles (T, 3) [rad] (about y, then the floating x, then z) of ``r = Ry Rx Rz``."""
    a = np.arctan2(r[:, 0, 2], r[:, 2, 2])
    b = np.arcsin(np.clip(-r[:, 1, 2], -1.0, 1.0))
    c = np.arctan2(r[:, 1, 0], r[:, 1, 1])
    return np.stack([a, b, c], axis=-1)


def cardan_xyz(r: np.ndarray) -> np.ndarray:
    """Angles (T, 3) [rad] (about x, then the floating y, then z) of ``r = Rx Ry Rz``."""
    a = np.arctan2(-r[:, 1, 2], r[:, 2, 2])
    b = np.arcsin(np.clip(r[:, 0, 2], -1.0, 1.0))
    c = np.arctan2(-r[:, 0, 1], r[:, 0, 0])
    return np.stack([a, b, c], axis=-1)


def cardan_zxy(r: np.ndarray) -> np.ndarray:
    """Angles (T, 3) [rad] (about z, then the floating x, then y) of ``r = Rz Rx Ry``."""
    a = np.arctan2(-r[:, 0, 1], r[:, 1, 1])
    b = np.arcsin(np.clip(r[:, 2, 1], -1.0, 1.0))
    c = np.arctan2(-r[:, 2, 0], r[:, 2, 2])
    return np.stack([a, b, c], axis=-1)


def rotate_about(axes: np.ndarray, axis: int, angle: float | np.ndarray) -> np.ndarray:
    """``axes`` (T, 3, 3) turned by ``angle`` [rad] about their own axis ``axis`` (0 x, 1 y,
    2 z), right-handed."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = ((1, 2), (2, 0), (0, 1))[axis]
    out = axes.copy()
    out[..., i] = c * axes[..., i] + s * axes[..., j]
    out[..., j] = -s * axes[..., i] + c * axes[..., j]
    return out
