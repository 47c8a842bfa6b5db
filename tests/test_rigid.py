"""mocap_mj.skeleton.rigid: Horn's quaternion fit gives the Kabsch (SVD) fit's rotation and
shift (and residuals), to rounding, over frames of a few markers with noise, gaps and
reflections."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.skeleton.rigid import rigid_fit, rigid_fit_horn, rigid_residuals_horn


def _frames(rng: np.random.Generator, t: int, m: int, noise: float) -> tuple[np.ndarray, ...]:
    """reference (m, 3) [m], measured (t, m, 3) [m]: the reference turned and moved at
    random, with noise [m]."""
    ref = rng.normal(scale=0.08, size=(m, 3))
    rot = Rotation.random(t, random_state=rng).as_matrix()
    shift = rng.normal(scale=0.5, size=(t, 3))
    meas = np.einsum("tij,mj->tmi", rot, ref) + shift[:, None]
    return ref, meas + rng.normal(scale=noise, size=meas.shape)


def _placed(rot: np.ndarray, pos: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.einsum("tij,mj->tmi", rot, ref) + pos[:, None]


def test_horn_fit_equals_the_kabsch_fit() -> None:
    rng = np.random.default_rng(7)
    for m, noise in ((3, 0.0), (4, 0.001), (5, 0.01), (6, 0.03)):
        ref, meas = _frames(rng, 2000, m, noise)
        rot, pos = rigid_fit(meas, ref)
        got_rot, got_pos = rigid_fit_horn(meas, ref)
        np.testing.assert_allclose(got_rot, rot, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got_pos, pos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.linalg.det(got_rot), 1.0, rtol=0, atol=1e-12)


def test_horn_fit_with_gaps_and_unrelated_points() -> None:
    rng = np.random.default_rng(8)
    ref, meas = _frames(rng, 3000, 5, 0.01)
    meas[rng.random(meas.shape[:2]) < 0.25] = np.nan  # some frames keep fewer than three
    meas[:100] = rng.normal(scale=0.1, size=(100, 5, 3))  # no rigid relation at all
    meas[100:200, :, 0] *= -1  # mirrored: the best proper rotation, not a reflection
    rot, pos = rigid_fit(meas, ref)
    got_rot, got_pos = rigid_fit_horn(meas, ref)
    assert np.array_equal(np.isnan(got_rot), np.isnan(rot))
    assert np.isnan(rot).any()
    placed, got = _placed(rot, pos, ref), _placed(got_rot, got_pos, ref)
    # as close a fit everywhere (three points nearly in line turn about that line freely:
    # there both fits are equally good, the rotations not the same to 1e-12)
    sq = np.nansum((placed - meas) ** 2, axis=(1, 2))
    np.testing.assert_allclose(np.nansum((got - meas) ** 2, axis=(1, 2)), sq, rtol=0, atol=1e-15)
    # the fitted points (what the relabelling's screen reads), to 1e-12 m, of four or more
    four = np.all(np.isfinite(meas), axis=2).sum(axis=1) >= 4
    np.testing.assert_allclose(got[four], placed[four], rtol=0, atol=1e-12)


def test_horn_fit_of_one_frame_and_of_none() -> None:
    ref = np.array([[0.0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
    rot, pos = rigid_fit_horn(ref[None] + [1.0, 2.0, 3.0], ref)
    np.testing.assert_allclose(rot[0], np.eye(3), atol=1e-14)
    np.testing.assert_allclose(pos[0], [1.0, 2.0, 3.0], atol=1e-14)
    rot, pos = rigid_fit_horn(np.zeros((0, 4, 3)), ref)
    assert rot.shape == (0, 3, 3) and pos.shape == (0, 3)


def test_horn_residuals_are_the_kabsch_fits() -> None:
    rng = np.random.default_rng(9)
    ref, meas = _frames(rng, 2000, 5, 0.02)
    meas[rng.random(meas.shape[:2]) < 0.2] = np.nan
    rot, pos = rigid_fit(meas, ref)
    want = np.sum((_placed(rot, pos, ref) - meas) ** 2, axis=2)  # NaN: missing, or no fit
    got = rigid_residuals_horn(meas, ref)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    four = np.all(np.isfinite(meas), axis=2).sum(axis=1) >= 4
    np.testing.assert_allclose(got[four], want[four], rtol=0, atol=1e-12)
