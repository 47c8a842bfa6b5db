"""Identification on real recordings, and the initial model scaled to a subject.

The real-data checks use ../shared/data/real (see SOURCES.md there) and skip without it; they
fit frame subsets to stay fast. The scaling checks run on synthetic data.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.initial import place_markers, scaled_theta, segment_scales
from mocap_mj.cli import main
from mocap_mj.io import load_markers
from mocap_synth import SynthConfig, synthesize

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: real-data checks need the shared folder beside the repo"


def real(name: str) -> Path:
    path = REAL / name
    if not path.is_file():
        pytest.skip(SKIP)
    return path


def identify(capsys: pytest.CaptureFixture[str], *args: str) -> dict:  # type: ignore[type-arg]
    assert main(["identify", *args, "--json", "--force"]) == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


# ------------------------------------------------------------------ scaling on synthetic data
@pytest.fixture(scope="module")
def scaled_subject():  # type: ignore[no-untyped-def]
    """Markers (T, M, 3) [m] of the nominal model scaled by 1.1, walking, 1 mm noise."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=150, motion="walk", kappa_scale=0.0, offset_mm=0.0), pset)
    kin = Kinematics(pset)
    truth = pset.nominal * 1.1
    kin.set_theta(truth)
    markers = kin.marker_positions(np.asarray(exp.qpos))
    markers += np.random.default_rng(0).normal(0.0, 1e-3, markers.shape)
    return pset, truth, markers


def test_scaled_theta_recovers_an_overall_scale(scaled_subject) -> None:  # type: ignore[no-untyped-def]
    pset, truth, markers = scaled_subject
    scales = segment_scales(pset, markers)
    assert abs(scales["overall"].value - 1.1) < 0.01
    assert all(abs(s.value - 1.1) < 0.02 for s in scales.values()), scales
    theta = scaled_theta(pset, markers, scales)
    k = pset.n_kappa
    scaled = truth[:k] != 0.0  # the alignment parameters are 0 on the scaled nominal model
    rel = theta[:k][scaled] / truth[:k][scaled] - 1.0
    names = [n for n, s in zip(pset.kappa_names, scaled, strict=True) if s]
    assert np.max(np.abs(rel)) < 0.03, dict(zip(names, rel, strict=True))
    assert np.max(np.abs(theta[:k][~scaled] - truth[:k][~scaled])) < 0.002  # [m]
    off = np.linalg.norm((theta[k:] - truth[k:]).reshape(-1, 3), axis=1)
    assert np.max(off) < 0.005  # [m]
    # Several trials give the scales of their frames together.
    both = scaled_theta(pset, [markers[:70], markers[70:]])
    np.testing.assert_allclose(both, theta, atol=1e-3)


def test_scales_shrink_toward_the_overall_and_fall_back(scaled_subject) -> None:  # type: ignore[no-untyped-def]
    pset, _, markers = scaled_subject
    lp, rp = pset.marker_index("LPSI"), pset.marker_index("RPSI")
    wide = markers.copy()
    across = wide[:, lp] - wide[:, rp]
    wide[:, lp] += 0.03 * across / np.linalg.norm(across, axis=1, keepdims=True)  # 30 mm wider
    wide[:, pset.marker_index("LTOE")] = np.nan  # foot_l: no HEE-TOE distance
    sc = segment_scales(pset, wide)
    # A short distance is hardly trusted for the skeleton ...
    assert sc["psis_width"].ratio > 1.35
    assert abs(sc["psis_width"].value - sc["overall"].value) < 0.05
    assert np.isnan(sc["foot_l"].measured) and sc["foot_l"].value == sc["overall"].value
    # ... but the pelvis markers reproduce the measured distance.
    _, offsets = pset.split(scaled_theta(pset, wide, sc))
    width = np.linalg.norm(offsets[lp] - offsets[rp])
    measured = np.median(np.linalg.norm(wide[:, lp] - wide[:, rp], axis=1))
    assert width == pytest.approx(measured, abs=0.002)


def test_place_markers_moves_offsets_toward_the_truth() -> None:
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=150, seed=2), pset)
    start = np.array(exp.theta_true)
    k = pset.n_kappa
    start[k:] = pset.nominal[k:]  # true skeleton, nominal offsets (truth: +-20 mm away)
    placed = place_markers(pset, start, np.asarray(exp.markers))
    np.testing.assert_array_equal(placed[:k], start[:k])
    rms = lambda th: float(np.sqrt(np.mean((th[k:] - exp.theta_true[k:]) ** 2)))  # noqa: E731
    assert rms(placed) < 0.75 * rms(start), (rms(placed), rms(start))


# ------------------------------------------------------------------------- real recordings
def test_real_scales_agree_between_trials_of_one_subject() -> None:
    names = ("Test_func_rknee.c3d", "Test_func_rhip.c3d")
    pset = ParameterSet()
    sc = [segment_scales(pset, load_markers(real(n)).select(pset.marker_names)) for n in names]
    for key in ("thigh_l", "thigh_r", "shank_l", "shank_r", "upperarm_l", "forearm_l"):
        assert abs(sc[0][key].value - sc[1][key].value) < 0.04, key


@pytest.mark.slow
def test_real_trial_identifies_without_flags(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = real("Test_func_rknee.c3d")
    s = identify(capsys, "--markers", str(path), "--out", str(tmp_path / "r"), "--frames", "0:120")
    assert s["init"] == "constructed" and s["frames_used"] == 120
    assert s["marker_rmse_mm"] <= 10.0
    worst = max(v for v in s["marker_rmse_by_marker_mm"].values() if v is not None)
    assert worst <= 25.0
    assert (tmp_path / "r" / "model.xml").is_file()


@pytest.mark.slow
def test_real_trials_identify_one_model_together(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    a, b = real("Test_func_rknee.c3d"), real("Test_func_rhip.c3d")
    out = tmp_path / "both"
    s = identify(capsys, "--markers", str(a), str(b), "--out", str(out), "--frames", "0:80")
    assert s["frames_used"] == 160
    assert s["marker_rmse_mm"] <= 10.0
    assert (out / "motion.npz").is_file()
    assert (out / "trials" / "Test_func_rhip" / "motion.npz").is_file()
