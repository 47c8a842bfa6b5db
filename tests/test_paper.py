"""Algorithm 1 of Zou & Sugihara (``mocap_synth.paper``), the baseline of
``mocap-mj experiment paper``."""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.errors import MocapError
from mocap_mj.kernels import _tree
from mocap_mj.outputs.score import score
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import TrialData
from mocap_synth import SynthConfig, synthesize, write_experiment
from mocap_synth.paper import (
    IK_SETTINGS,
    FrameSampler,
    GradientEstimator,
    PaperSettings,
    analytic_gradient,
    identify_paper,
    reduced_information,
)

# Well-observed parameters (segment lengths of the limbs, pelvis and knee markers).
PERTURBED = {"thigh_length_l": 0.012, "shank_length_r": -0.010, "LASI.x": 0.010, "RKNE.y": -0.008}


@pytest.fixture(scope="module")
def exp():  # type: ignore[no-untyped-def]
    return synthesize(SynthConfig(frames=20, seed=3))


def _theta0(exp) -> np.ndarray:  # type: ignore[no-untyped-def]
    theta = np.array(exp.theta_true)
    for name, d in PERTURBED.items():
        theta[exp.pset.index(name)] += d
    return theta


def _energy(exp, theta: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """E over all frames with every frame's IK under theta [m^2]."""
    kin = Kinematics(exp.pset)
    kin.set_theta(theta)
    r = IKSolver(kin, IK_SETTINGS).solve_trial(np.array(exp.markers))
    return float(np.sum(r.marker_rmse**2 * r.n_markers))


def test_perturbed_trees_are_the_perturbed_models(exp) -> None:  # type: ignore[no-untyped-def]
    pset = exp.pset
    delta = 1e-3
    est = GradientEstimator(pset, delta)
    est.set_theta(exp.theta_true)
    trees = est.perturbed_trees()
    assert len(trees) == est.params.size
    kin = Kinematics(pset)
    q = np.array(exp.qpos[:4])
    for i in (0, 11, 16, 22, 29, pset.n_kappa, pset.size - 1):
        theta = np.array(exp.theta_true)
        theta[i] += delta
        kin.set_theta(theta)
        j = int(np.flatnonzero(est.params == i)[0])
        got = _tree.forward(trees[j], q)
        np.testing.assert_allclose(got, kin.marker_positions(q), rtol=0, atol=1e-14)


def test_finite_difference_gradient_matches_envelope_gradient(exp) -> None:  # type: ignore[no-untyped-def]
    """Forward differences through IK re-solves vs dE/dtheta = -2 sum J_theta^T r.

    The forward difference differs from the derivative by Delta/2 times E's curvature along
    each parameter (O(Delta)): at Delta = 1e-6 m the gradient agrees to 1e-4 relative, and
    the discrepancy shrinks tenfold with Delta (measured 1.3e-4 and 1.3e-3 relative).
    """
    pset = exp.pset
    theta = _theta0(exp)
    kin = Kinematics(pset)
    kin.set_theta(theta)
    markers = np.array(exp.markers[::2])
    q = IKSolver(kin).solve_trial(np.array(exp.markers)).qpos[::2]
    errors = {}
    for delta in (1e-5, 1e-6):
        est = GradientEstimator(pset, delta)
        est.set_theta(theta)
        qq = est.solve(markers, est.solve(markers, q))  # converged poses
        e0, ep = est.perturbed_energy(markers, qq)
        g = np.sum(ep - e0[:, None], axis=0) / delta
        ga = analytic_gradient(kin, markers, qq)
        errors[delta] = np.linalg.norm(g - ga) / np.linalg.norm(ga)
        assert np.linalg.norm(ga) > 1e-3  # a real gradient, not noise
    assert errors[1e-6] < 1e-3
    assert 5 < errors[1e-5] / errors[1e-6] < 20  # first order in Delta


@pytest.mark.slow
@pytest.mark.parametrize("sampling", ["batch", "even", "random", "stochastic"])
def test_each_sampling_decreases_E(exp, sampling: str) -> None:  # type: ignore[no-untyped-def]
    theta0 = _theta0(exp)
    trials = [TrialData("t", np.array(exp.markers), np.array(exp.times))]
    iterations = 3 if sampling == "batch" else 6
    settings = PaperSettings(sampling=sampling, iterations=iterations, fraction=0.25, seed=1)
    r = identify_paper(trials, pset=exp.pset, theta0=theta0, settings=settings)
    e0 = _energy(exp, theta0)
    assert r.energy < 0.8 * e0
    assert r.energy == pytest.approx(_energy(exp, r.theta), rel=1e-6)
    assert len(r.trace) == iterations
    idx = [exp.pset.index(n) for n in PERTURBED]
    before = np.abs(theta0 - exp.theta_true)[idx]
    after = np.abs(r.theta - exp.theta_true)[idx]
    assert np.linalg.norm(after) < np.linalg.norm(before)
    if sampling == "batch":  # full gradient descent: E falls every iteration
        energies = [p.energy for p in r.trace]
        assert all(b < a for a, b in pairwise(energies))


def test_stochastic_one_frame_per_iteration_reproducible(exp) -> None:  # type: ignore[no-untyped-def]
    trials = [TrialData("t", np.array(exp.markers), np.array(exp.times))]

    def run(seed: int):  # type: ignore[no-untyped-def]
        st = PaperSettings(sampling="stochastic", iterations=8, seed=seed)
        return identify_paper(trials, pset=exp.pset, theta0=_theta0(exp), settings=st)

    a, b, c = run(5), run(5), run(6)
    assert all(len(p.frames) == 1 for p in a.trace)
    assert [int(p.frames[0]) for p in a.trace] == [int(p.frames[0]) for p in b.trace]
    np.testing.assert_array_equal(a.theta, b.theta)
    assert [int(p.frames[0]) for p in a.trace] != [int(p.frames[0]) for p in c.trace]
    assert a.ik_problems == 8 * (1 + exp.pset.size) + 8  # per frame: unperturbed x2, P perturbed


def test_frame_sampler() -> None:
    even = FrameSampler(500, "even", 0.1)
    first = even.draw()
    assert len(first) == 50 and np.all(np.diff(first) == 10)
    np.testing.assert_array_equal(even.draw(), first)
    rnd = FrameSampler(500, "random", 0.1, seed=2)
    a, b = rnd.draw(), rnd.draw()
    assert len(a) == len(np.unique(a)) == 50 and not np.array_equal(a, b)
    np.testing.assert_array_equal(FrameSampler(7, "batch").draw(), np.arange(7))
    with pytest.raises(MocapError, match="sampling"):
        PaperSettings(sampling="all")
    with pytest.raises(MocapError, match="alpha"):
        PaperSettings(step=0.0)


@pytest.mark.slow
def test_score_of_the_truth_is_zero(tmp_path: Path) -> None:
    """A hand-made result folder holding the truth itself scores zero error."""
    exp = synthesize(SynthConfig(frames=12, seed=2, noise_mm=0.0))
    synth, res = tmp_path / "synth", tmp_path / "truth_as_result"
    write_experiment(exp, synth)
    res.mkdir()
    pset = exp.pset
    theta = np.array(exp.theta_true)
    trials = [TrialData("t", np.array(exp.markers_clean), np.array(exp.times))]
    info, _, _, _ = reduced_information(pset, theta, trials, [np.array(exp.qpos)])
    idf = Identifiability(pset, info, 1e-3, theta=theta)
    pset.save_json(res / "theta.json", theta)
    pset.export_mjcf(res / "model.xml", theta)
    motion = Motion(
        np.array(exp.qpos), np.array(exp.times), np.array(exp.markers_clean), pset.marker_names
    )
    save_motion(res / "motion.npz", motion)
    (res / "identifiability.json").write_text(json.dumps(idf.to_json()))
    (res / "summary.json").write_text(json.dumps({"frames_fitted_range": [[0, 12]]}))
    s = score(synth, res, pset=pset)
    for key in (
        "kappa_rmse_mm",
        "offset_rmse_mm",
        "kappa_rmse_all_mm",
        "offset_rmse_all_mm",
        "marker_rmse_mm",
        "joint_centre_rmse_mm",
        "gauge_displacement_mm",
    ):
        assert s[key] == pytest.approx(0.0, abs=1e-3), key
    assert s["joint_rmse_deg"] == pytest.approx(0.0, abs=1e-4)
    assert s["frames_fitted"] == 12


@pytest.mark.slow
def test_experiment_writes_table_and_figures(tmp_path: Path) -> None:
    """The Table 1 experiment end to end, on a tiny trial (the CLI's --quick is 100 frames)."""
    from mocap_synth.experiment_paper import PaperExperiment, run_experiment

    cfg = PaperExperiment(
        frames=30, iterations=2, batch_iterations=1, stochastic=(2, 4), lm_iterations=3
    )
    summary = run_experiment(cfg, tmp_path, progress=False)
    names = {
        "report.md",
        "table1.csv",
        "table1.json",
        "frame_error.csv",
        "traces.json",
        "fig3.png",
        "fig4.png",
        "convergence.png",
    }
    assert names <= {p.name for p in tmp_path.iterdir()}
    labels = [t["label"] for t in summary["table"]]
    assert labels[0] == "initial (nominal) model" and labels[-1] == "joint LM (this project)"
    assert {"batch", "1/10 even", "1/10 random", "stochastic 2", "stochastic 4"} <= set(labels)
    batch = summary["table"][1]
    assert batch["speed_vs_batch"] == 1.0 and "extrapolated" in batch["note"]
    for t in summary["table"]:
        assert np.isfinite(t["marker_rmse_mm"]) and np.isfinite(t["kappa_rmse_mm"])
    assert "## Table 1" in (tmp_path / "report.md").read_text()
