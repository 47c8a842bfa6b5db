"""The synthesizer: truth model, truth motion, measurement model, files, reproducibility."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mocap_mj import MocapError, ParameterSet
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.capture.marker_set import marker_class
from mocap_mj.io import MarkerTrajectory, load_markers
from mocap_mj.io.ownership import MARKER
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.exported import Layout
from mocap_synth import (
    FILES,
    ConfigError,
    Experiment,
    SynthConfig,
    perturb_theta,
    synthesize,
    write_experiment,
)
from mocap_synth.perturb import mirror_pairs

CORRUPT = SynthConfig(
    frames=300, motion="walk", sta_mm=4.0, gaps=0.08, outliers=0.02, swaps=3, seed=11
)


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


@pytest.fixture(scope="module")
def corrupt(pset: ParameterSet) -> Experiment:
    return synthesize(CORRUPT, pset)


# ------------------------------------------------------------------------------------ config
@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"frames": 0}, "frames"),
        ({"frames": 2.5}, "frames"),
        ({"rate": 0.0}, "rate"),
        ({"rate": float("nan")}, "rate"),
        ({"motion": "run"}, "motion"),
        ({"noise_mm": -1.0}, "noise_mm"),
        ({"sta_mm": -0.1}, "sta_mm"),
        ({"gaps": 1.0}, "gaps"),
        ({"gaps": -0.01}, "gaps"),
        ({"outliers": 1.5}, "outliers"),
        ({"gaps": 0.6, "outliers": 0.5}, "gaps + outliers"),
        ({"outlier_mm": -5.0}, "outlier_mm"),
        ({"swaps": -1}, "swaps"),
        ({"seed": -3}, "seed"),
        ({"kappa_scale": 1.0}, "kappa_scale"),
        ({"offset_mm": -1.0}, "offset_mm"),
    ],
)
def test_config_rejects_bad_values(kwargs: dict[str, object], words: str) -> None:
    with pytest.raises(ConfigError) as info:
        SynthConfig(**kwargs)  # type: ignore[arg-type]
    message = str(info.value)
    assert message.startswith(words) and "\n" not in message
    assert isinstance(info.value, MocapError)


def test_config_defaults_and_frozen() -> None:
    cfg = SynthConfig()
    assert (cfg.frames, cfg.rate, cfg.motion, cfg.noise_mm, cfg.seed) == (500, 100.0, "rom", 1.0, 0)
    assert cfg.to_dict()["outlier_mm"] == 50.0
    with pytest.raises(AttributeError):
        cfg.frames = 3  # type: ignore[misc]
    assert SynthConfig(frames=np.int64(20), rate=np.float32(50)).frames == 20  # type: ignore[arg-type]


# -------------------------------------------------------------------------- the experiment
def test_experiment_shapes(corrupt: Experiment, pset: ParameterSet) -> None:
    t, m = CORRUPT.frames, pset.n_markers
    assert corrupt.theta_true.shape == corrupt.theta_nominal.shape == (pset.size,)
    assert corrupt.times.shape == (t,)
    np.testing.assert_allclose(np.diff(corrupt.times), 1.0 / CORRUPT.rate)
    assert corrupt.qpos.shape == (t, 55)
    assert corrupt.markers_clean.shape == corrupt.markers.shape == (t, m, 3)
    assert corrupt.gap_mask.shape == corrupt.outlier_mask.shape == (t, m)
    assert corrupt.sigma == pytest.approx(1e-3)
    assert not corrupt.markers.flags.writeable
    assert np.all(np.isfinite(corrupt.markers_clean))
    traj = corrupt.trajectory()
    assert isinstance(traj, MarkerTrajectory)
    assert traj.names == pset.marker_names and traj.rate == CORRUPT.rate
    np.testing.assert_array_equal(traj.positions, corrupt.markers)


def test_clean_markers_are_truth_forward_kinematics(corrupt: Experiment) -> None:
    model = corrupt.pset.model_for(corrupt.theta_true)
    data = mujoco.MjData(model)
    for t in (0, 123, CORRUPT.frames - 1):
        data.qpos[:] = corrupt.qpos[t]
        rolling.kinematics(model, data)  # the knee rolling placed (mocap_mj.skeleton.rolling)
        np.testing.assert_allclose(corrupt.markers_clean[t], data.site_xpos, atol=1e-12)


def test_same_seed_same_bytes(tmp_path: Path, corrupt: Experiment) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    summary = write_experiment(corrupt, a)
    write_experiment(synthesize(CORRUPT), b)
    assert sorted(p.name for p in a.iterdir()) == sorted([*FILES, MARKER])  # + the marker
    for name in FILES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert summary["swapped"] and summary["files"] == list(FILES)
    # Another seed is another experiment.
    other = synthesize(SynthConfig(frames=300, motion="walk", seed=12))
    assert not np.allclose(other.theta_true, corrupt.theta_true)
    assert not np.allclose(other.markers_clean, corrupt.markers_clean)


def test_write_refuses_non_empty_folder(tmp_path: Path) -> None:
    exp = synthesize(SynthConfig(frames=5))
    write_experiment(exp, tmp_path / "x")
    with pytest.raises(MocapError, match="not empty"):
        write_experiment(exp, tmp_path / "x")
    write_experiment(exp, tmp_path / "x", force=True)


def test_streams_are_independent(pset: ParameterSet) -> None:
    # Turning a corruption on does not change the truth or the noise of the other samples.
    plain = synthesize(SynthConfig(frames=200, seed=5), pset)
    noisy = synthesize(SynthConfig(frames=200, seed=5, gaps=0.1, outliers=0.01), pset)
    np.testing.assert_array_equal(plain.theta_true, noisy.theta_true)
    np.testing.assert_array_equal(plain.qpos, noisy.qpos)
    keep = ~noisy.gap_mask & ~noisy.outlier_mask
    np.testing.assert_array_equal(plain.markers[keep], noisy.markers[keep])


# ---------------------------------------------------------------------------- truth model
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_perturbation_within_bounds_and_size(pset: ParameterSet, seed: int) -> None:
    rng = np.random.default_rng(seed)
    theta = perturb_theta(pset, rng, kappa_scale=0.10, offset_mm=20.0)
    assert pset.within_bounds(theta)
    kappa, offsets = pset.split(theta)
    kappa0, offsets0 = pset.split(pset.nominal)
    scaled = kappa0 != 0.0  # the alignment parameters (nominal 0) are drawn, not scaled
    rel = np.abs(kappa[scaled] / kappa0[scaled] - 1.0)
    shift = np.abs(offsets - offsets0)
    assert rel.max() <= 0.10 + 1e-12 and rel.max() > 0.07  # 30 draws in +-10 %
    assert np.all(kappa[~scaled] != 0.0) and np.abs(kappa[~scaled]).max() < 0.1  # 22.5 mm sd
    assert shift.max() <= 0.020 + 1e-12 and shift.max() > 0.017  # 117 draws in +-20 mm
    # The amount is configurable, and large amounts are clipped to the bounds.
    small = perturb_theta(pset, np.random.default_rng(seed), kappa_scale=0.01, offset_mm=1.0)
    assert np.abs(pset.split(small)[0][scaled] / kappa0[scaled] - 1.0).max() <= 0.01 + 1e-12
    assert np.abs(pset.split(small)[1] - offsets0).max() <= 0.001 + 1e-12
    big = perturb_theta(pset, np.random.default_rng(seed), kappa_scale=0.9, offset_mm=500.0)
    assert pset.within_bounds(big)
    assert np.any(big == pset.upper) or np.any(big == pset.lower)
    zero = perturb_theta(pset, np.random.default_rng(seed), kappa_scale=0.0, offset_mm=0.0)
    np.testing.assert_array_equal(zero, pset.nominal)


def test_symmetric_perturbation(pset: ParameterSet) -> None:
    kappa0, offsets0 = pset.split(pset.nominal)
    kappa_pairs = mirror_pairs(pset.kappa_names)
    marker_pairs = mirror_pairs(pset.marker_names)
    assert len(kappa_pairs) == 14 and len(marker_pairs) == 17
    sym = perturb_theta(pset, np.random.default_rng(3), symmetric=True)
    free = perturb_theta(pset, np.random.default_rng(3), symmetric=False)
    for theta, equal in ((sym, True), (free, False)):
        kappa = pset.split(theta)[0]
        factor = np.divide(kappa, kappa0, out=kappa.copy(), where=kappa0 != 0.0)  # drawn: value
        shift = pset.split(theta)[1] - offsets0
        same_k = [np.isclose(factor[a], factor[b]) for a, b in kappa_pairs]
        same_m = [np.allclose(shift[a] * [1, -1, 1], shift[b]) for a, b in marker_pairs]
        assert all(same_k) == equal and all(same_m) == equal
        assert any(same_k) == equal and any(same_m) == equal


@pytest.mark.slow
def test_anatomical_marker_placement(pset: ParameterSet) -> None:
    """Landmark markers (and the wands, by their chord planes) follow the perturbed skeleton,
    within the priors' widths; the skeleton and the free markers are the uniform draw's (the
    same stream)."""
    prior = landmark_prior(pset)
    k = pset.n_kappa
    named = np.any(prior.a[:, k:] != 0.0, axis=0).reshape(-1, 3).any(axis=1)
    for seed in range(4):
        uniform = perturb_theta(pset, np.random.default_rng(seed))
        placed = perturb_theta(pset, np.random.default_rng(seed), placement="anatomical")
        again = perturb_theta(pset, np.random.default_rng(seed), placement="anatomical")
        np.testing.assert_array_equal(placed, again)
        np.testing.assert_array_equal(placed[:k], uniform[:k])
        moved = np.any(pset.split(placed)[1] != pset.split(uniform)[1], axis=1)
        np.testing.assert_array_equal(moved, named)  # exactly the markers the rows name
        # landmarks, and the wands their joints' chord planes name (THI, TIB)
        wands = {p + w for p in "LR" for w in ("THI", "TIB")}
        names = np.array(pset.marker_names)[moved]
        assert all(marker_class(n) == "landmark" or n in wands for n in names)
        # Each row holds to its own width: normalized residuals of unit scale (a few rows
        # overlap, e.g. the left and right Harrington rows share the PSIS depth, so the RMS
        # is a little below 1), where the uniform truth's stray up to 4 widths.
        r = prior.residuals(placed)
        assert 0.5 < np.sqrt(np.mean(r**2)) < 1.2 and np.abs(r).max() < 3.5, r
    # KNE on the knee's level whatever the thigh length: within 3 widths (30 mm).
    knee = placed[k + 3 * pset.marker_index("LKNE") + 2] + placed[pset.index("thigh_length_l")]
    assert abs(knee) < 0.03
    with pytest.raises(MocapError, match="placement"):
        perturb_theta(pset, np.random.default_rng(0), placement="random")
    with pytest.raises(ConfigError, match="marker_placement"):
        SynthConfig(marker_placement="random")


# ------------------------------------------------------------------------ measurement model
def test_noise_standard_deviation(pset: ParameterSet) -> None:
    exp = synthesize(SynthConfig(frames=2000, noise_mm=1.0, motion="static", seed=4), pset)
    err = (exp.markers - exp.markers_clean).reshape(-1, 3)
    assert np.all(np.isfinite(err))
    for axis in range(3):
        assert np.std(err[:, axis]) == pytest.approx(exp.sigma, rel=0.05)
        assert abs(np.mean(err[:, axis])) < 0.05 * exp.sigma
    quiet = synthesize(SynthConfig(frames=50, noise_mm=0.0), pset)
    np.testing.assert_array_equal(quiet.markers, quiet.markers_clean)


def test_soft_tissue_artefact(pset: ParameterSet) -> None:
    off = synthesize(SynthConfig(frames=500, seed=2), pset)
    on = synthesize(SynthConfig(frames=500, seed=2, sta_mm=5.0), pset)
    assert on.sta is not None and off.sta is not None
    np.testing.assert_array_equal(off.sta, 0.0)
    np.testing.assert_allclose(
        on.markers - on.markers_clean - on.sta, off.markers - off.markers_clean
    )
    size = np.linalg.norm(on.sta, axis=-1)  # (T, M) [m]
    assert 0.001 < np.sqrt(np.mean(size**2)) < 0.01  # several mm over a ROM
    assert np.all(size.max(axis=0) > 0)  # every marker has its own artefact
    assert size[0].max() < 1e-9  # none in the standing pose the ROM starts from
    accel = np.diff(on.sta, 2, axis=0) * 100.0**2
    assert np.abs(accel).max() < 5.0  # smooth (m/s^2), unlike noise


def test_gaps_outliers_swaps(corrupt: Experiment, pset: ParameterSet) -> None:
    n = corrupt.gap_mask.size
    assert corrupt.gap_mask.sum() == round(CORRUPT.gaps * n)
    assert corrupt.outlier_mask.sum() == round(CORRUPT.outliers * n)
    np.testing.assert_array_equal(np.isnan(corrupt.markers).any(axis=-1), corrupt.gap_mask)
    np.testing.assert_array_equal(np.isnan(corrupt.markers).all(axis=-1), corrupt.gap_mask)
    assert not np.any(corrupt.gap_mask & corrupt.outlier_mask)
    # Gaps come in runs: far fewer starts than missing samples.
    starts = corrupt.gap_mask[1:] & ~corrupt.gap_mask[:-1]
    assert starts.sum() < corrupt.gap_mask.sum() / 3
    # Outliers are displaced by outlier_mm (plus noise and soft tissue).
    expected = corrupt.markers_clean + corrupt.sta
    moved = np.linalg.norm(corrupt.markers - expected, axis=-1)
    swapped = np.zeros_like(corrupt.gap_mask)
    for a, b, first, last in corrupt.swapped:
        for name in (a, b):
            swapped[first : last + 1, pset.marker_index(name)] = True
    plain_outliers = corrupt.outlier_mask & ~swapped
    np.testing.assert_allclose(moved[plain_outliers], 0.05, atol=0.008)
    assert np.all(moved[~corrupt.gap_mask & ~corrupt.outlier_mask & ~swapped] < 0.008)
    # Label swaps: K distinct left/right pairs, each over a window.
    assert len(corrupt.swapped) == CORRUPT.swaps
    assert len({a for a, *_ in corrupt.swapped}) == CORRUPT.swaps
    for a, b, first, last in corrupt.swapped:
        assert a[0] == "L" and b == "R" + a[1:] and 0 <= first <= last < CORRUPT.frames
        ia, ib = pset.marker_index(a), pset.marker_index(b)
        window = slice(first, last + 1)
        ok = ~corrupt.gap_mask[window, ia] & ~corrupt.outlier_mask[window, ia]
        got = corrupt.markers[window, ia][ok]
        np.testing.assert_allclose(got, expected[window, ib][ok], atol=0.008)
    with pytest.raises(MocapError, match="pairs"):
        synthesize(SynthConfig(frames=20, swaps=18), pset)


# ---------------------------------------------------------------------------------- files
def test_files_round_trip(tmp_path: Path, corrupt: Experiment, pset: ParameterSet) -> None:
    write_experiment(corrupt, tmp_path)
    for name in ("markers.csv", "markers.trc"):
        traj = load_markers(tmp_path / name)
        assert traj.names == pset.marker_names
        np.testing.assert_allclose(traj.times, corrupt.times, atol=1e-9)
        np.testing.assert_array_equal(np.isnan(traj.positions), np.isnan(corrupt.markers))
        np.testing.assert_array_equal(np.isnan(traj.positions).any(-1), corrupt.gap_mask)
        ok = ~np.isnan(corrupt.markers)
        np.testing.assert_allclose(traj.positions[ok], corrupt.markers[ok], rtol=0, atol=1e-6)
    truth = pset.load_json(tmp_path / "truth.json")
    np.testing.assert_allclose(truth, corrupt.theta_true, rtol=0, atol=1e-15)
    import json

    data = json.loads((tmp_path / "truth.json").read_text())
    assert data["seed"] == CORRUPT.seed and data["sigma_m"] == corrupt.sigma
    assert data["settings"] == CORRUPT.to_dict()
    np.testing.assert_array_equal(pset.from_dict(data["theta_nominal"]), pset.nominal)
    motion = load_motion(tmp_path / "truth_motion.npz", pset.model)
    np.testing.assert_array_equal(motion.qpos, corrupt.qpos)
    np.testing.assert_array_equal(motion.markers, corrupt.markers_clean)
    assert motion.marker_names == pset.marker_names


def test_truth_model_reloads_to_same_markers(tmp_path: Path, corrupt: Experiment) -> None:
    write_experiment(corrupt, tmp_path)
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "truth_model.xml"))
    data = mujoco.MjData(model)
    names = [model.site(i).name for i in range(model.nsite)]
    assert tuple(names) == corrupt.marker_names
    written = Layout.of(corrupt.pset.model).written(corrupt.qpos)
    np.testing.assert_array_equal(load_motion(tmp_path / "truth_motion.npz").qpos, written)
    for t in range(0, CORRUPT.frames, 37):
        data.qpos[:] = written[t]  # plain MuJoCo: the knees' slide joints carry the rolling
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site_xpos, corrupt.markers_clean[t], rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        ParameterSet(tmp_path / "truth_model.xml").nominal, corrupt.theta_true, atol=1e-12
    )
