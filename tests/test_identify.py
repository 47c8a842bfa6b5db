"""Joint LM identification against synthetic truth: the Cramer-Rao bound, the noise floor,
the null directions, corrupted data with a robust loss, several trials, and the CLI."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.capture.marker_set import marked_bodies
from mocap_mj.capture.subject import Subject
from mocap_mj.outputs.score import align_truth, joint_centres
from mocap_mj.pipeline.anatomical import AnatomyPriors, anatomical_priors, prior_information
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.centres import joint_centre_bound
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import InitialPoses, LMSettings, identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

FRAMES = 500
SIGMA = 1e-3  # [m]


def errors(pset: ParameterSet, result, exp, idf: Identifiability, n: int):  # type: ignore[no-untyped-def]
    """(kappa ratio, offset ratio, joint-centre errors (T, bodies) [m]) against the truth
    (theta aligned along the null directions)."""
    aligned = align_truth(
        pset, result.theta, np.asarray(exp.markers_clean[:n]), np.asarray(exp.times[:n])
    )
    eo, _ = idf.project(result.theta - aligned)
    bk, bo = idf.bound_rms()
    k = pset.n_kappa
    kin_hat, kin_true = Kinematics(pset), Kinematics(pset)
    kin_hat.set_theta(result.theta)
    kin_true.set_theta(exp.theta_true)
    q = result.qpos[0]
    jc = np.linalg.norm(
        joint_centres(kin_hat, q) - joint_centres(kin_true, np.asarray(exp.qpos[:n])), axis=2
    )
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    return rms(eo[:k]) / bk, rms(eo[k:]) / bo, jc


@pytest.fixture(scope="module")
def clean():  # type: ignore[no-untyped-def]
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=FRAMES, seed=0), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    # As `mocap-mj demo` solves it: anatomical ranges and landmark priors on, no population
    # asymmetry prior (the synthetic truth draws left and right lengths independently).
    result, _ = solve_anatomical(
        [trial], pset=pset, theta0=None, settings=LMSettings(), anatomy=AnatomyPriors(Subject())
    )
    idf = Identifiability(pset, result.reduced_information, result.sigma, theta=result.theta)
    return pset, exp, result, idf


@pytest.mark.slow
def test_reaches_the_bound_on_the_observable_subspace(clean) -> None:  # type: ignore[no-untyped-def]
    pset, exp, result, idf = clean
    k_ratio, o_ratio, jc = errors(pset, result, exp, idf, FRAMES)
    # The target of `mocap-mj demo` (within 1.3x the bound) is a property of the estimator,
    # i.e. of the ratio's distribution over seeds, not of one draw: over seeds 0-31
    # (benchmarks/seeds.py, with Reed's L5/S1; docs/validation.md) the
    # RMS ratio is 0.97-0.98 but one seed's ratio has sd 0.34 (kappa) / 0.26 (offsets), and 4
    # and 3 of the 32 seeds exceed 1.3. This seed is held to the 95th percentile of those 64
    # draws (kappa 1.45, offsets 1.33): beyond it, it is outside an efficient estimator's
    # spread. The truth's landmark markers sit where the marker set puts them
    # (SynthConfig.marker_placement), as the priors expect.
    assert k_ratio <= 1.45, k_ratio
    assert o_ratio <= 1.35, o_ratio
    # The bound with the priors' information: never above the data's, and close to it (the
    # priors inform the directions the score leaves out), so the ratios hold against it too.
    bk, bo = idf.bound_rms()
    info = prior_information(
        anatomical_priors(pset, AnatomyPriors(Subject())), LMSettings(), pset.size
    )
    pk, po = idf.bound_rms_with_prior(info)
    assert 0.9 * bk < pk <= bk and 0.9 * bo < po <= bo, (pk / bk, po / bo)
    # Against the bound with the priors (3-6 % below the data's since the 3 mm convention
    # rows): the same seeds' 95th percentiles are 1.51 (kappa) and 1.38 (offsets), RMS 1.01-1.03
    # / 1.00-1.02 (benchmarks/seeds.py, docs/validation.md).
    assert k_ratio * bk / pk <= 1.55 and o_ratio * bo / po <= 1.4
    # A prior that says nothing leaves the data's bound.
    assert np.allclose(idf.bound_rms_with_prior(np.eye(pset.size) * 1e-6), (bk, bo), rtol=1e-3)
    # Joint centres (world positions of the body origins over the frames) against their own
    # bound (pose and model uncertainty, solve/centres.py): 1.5 mm RMS on this trial, so
    # the 1 mm is below what 1 mm markers allow (even with the model known the
    # poses alone give 1.17 mm, tests/test_centres.py).
    kin_hat = Kinematics(pset)
    kin_hat.set_theta(result.theta)
    bound = joint_centre_bound(kin_hat, np.asarray(exp.markers), result.qpos[0], idf)
    # The centres some marker follows (not the toes: their origin is the TOE rows' alone).
    seen = marked_bodies(pset.model)[2:]
    assert seen.sum() == len(seen) - 2
    assert np.sqrt(np.mean(jc[:, seen] ** 2)) <= 1.3 * np.sqrt(np.mean(bound.total[seen] ** 2))
    per_body = np.sqrt(np.mean(jc[:, seen] ** 2, axis=0))
    assert np.all(per_body <= 2.0 * bound.total[seen]), per_body / bound.total[seen]


def test_fit_rmse_is_the_noise_floor(clean) -> None:  # type: ignore[no-untyped-def]
    _, _, result, _ = clean
    p = result.n_unknowns
    n = result.n_residuals
    expected = np.sqrt(3) * SIGMA * np.sqrt(1 - p / n)
    assert result.marker_rmse == pytest.approx(expected, rel=0.05)
    assert result.sigma == pytest.approx(SIGMA, rel=0.05)


def test_null_directions_are_found_and_named(clean) -> None:  # type: ignore[no-untyped-def]
    _, _, _, idf = clean
    words = [d.description for d in idf.directions() if d.kind == "unobservable"]
    assert sum("rotation about the neck joint" in w for w in words) == 3
    for side in "lr":
        # TOE is on the foot (Plug-in Gait): the toes carry no marker, so the MTP joint's
        # position is seen by no marker at all.
        for length in ("foot_length", "foot_height"):
            assert f"{length}_{side}: moves no marker (its prior rows alone decide it)" in words
        assert sum(f"wrist_flex_{side}/wrist_dev_{side}" in w for w in words) == 2
        assert any(f"radius_{side} markers" in w and "pronation" in w for w in words)
    assert any("pelvis frame" in w for w in words)
    # Every exact null direction leaves the markers unchanged to first order.
    assert np.all(idf.eigenvalues[~idf.observable] < 1e-3 * idf.eigenvalues.max())


@pytest.mark.slow
def test_robust_loss_resists_gaps_outliers_and_swaps(clean) -> None:  # type: ignore[no-untyped-def]
    pset, _, result_clean, idf_clean = clean
    exp = synthesize(SynthConfig(frames=FRAMES, seed=0, gaps=0.10, outliers=0.01, swaps=1), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    result = identify_lm([trial], pset=pset, settings=LMSettings(loss="cauchy"))
    idf = Identifiability(pset, result.reduced_information, result.sigma, theta=result.theta)
    k_ratio, o_ratio, _ = errors(pset, result, exp, idf, FRAMES)
    exp_clean = synthesize(SynthConfig(frames=FRAMES, seed=0), pset)
    k0, o0, _ = errors(pset, result_clean, exp_clean, idf_clean, FRAMES)
    # Errors within 1.5x the clean run's (each measured against its own bound).
    assert k_ratio <= 1.5 * max(k0, 1.0)
    assert o_ratio <= 1.5 * max(o0, 1.0)


def test_several_trials_share_one_model() -> None:
    pset = ParameterSet()
    a = synthesize(SynthConfig(frames=250, seed=3), pset)
    b_cfg = SynthConfig(frames=150, seed=3, motion="walk")
    b = synthesize(b_cfg, pset)
    assert np.array_equal(a.theta_true, b.theta_true)  # same subject: same seed
    trials = [
        TrialData("rom", np.asarray(a.markers), np.asarray(a.times)),
        TrialData("walk", np.asarray(b.markers), np.asarray(b.times)),
    ]
    result = identify_lm(trials, pset=pset)
    assert [q.shape for q in result.qpos] == [(250, 55), (150, 55)]
    p, n = result.n_unknowns, result.n_residuals
    assert result.marker_rmse == pytest.approx(np.sqrt(3) * SIGMA * np.sqrt(1 - p / n), rel=0.05)


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True, timeout=600
    )


@pytest.mark.slow
def test_cli_identify_score_demo(tmp_path: Path) -> None:
    synth = tmp_path / "synth"
    assert (
        run_cli("synth", "--out", str(synth), "--frame-count", "160", "--seed", "2").returncode == 0
    )
    res = tmp_path / "res"
    out = run_cli(
        "identify",
        "--markers",
        str(synth / "markers.csv"),
        "--frames",
        "0:120",
        "--out",
        str(res),
        "--json",
    )
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout)
    assert summary["frames_used"] == 120
    for name in (
        "model.xml",
        "theta.json",
        "motion.npz",
        "angles.csv",
        "identifiability.json",
        "report.md",
        "summary.json",
        "marker_error.png",
        "residual_per_marker.png",
    ):
        assert (res / name).is_file(), name
    scored = run_cli("score", "--truth", str(synth), "--result", str(res), "--json")
    assert scored.returncode == 0, scored.stderr
    s = json.loads(scored.stdout)
    for key in (
        "kappa_rmse_mm",
        "offset_rmse_mm",
        "marker_rmse_mm",
        "joint_rmse_deg",
        "kappa_crlb_ratio",
        "offset_crlb_ratio",
        "heldout_marker_rmse_mm",
    ):
        assert np.isfinite(s[key]), key
    assert s["frames_held_out"] == 40
    # Refuses to overwrite, and bad input is one line without a traceback.
    again = run_cli("identify", "--markers", str(synth / "markers.csv"), "--out", str(res))
    assert again.returncode == 2 and "not empty" in again.stderr
    bad = run_cli("identify", "--markers", str(tmp_path / "nope.csv"), "--out", str(tmp_path / "x"))
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_score_of_truth_against_itself_is_zero(tmp_path: Path) -> None:
    """A result folder made from the truth itself scores zero parameter error."""
    from mocap_mj.outputs.write_fit import write_files
    from mocap_synth import write_experiment

    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=80, seed=5, noise_mm=0.0), pset)
    write_experiment(exp, tmp_path / "synth")
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    result = identify_lm(
        [trial],
        pset=pset,
        theta0=np.asarray(exp.theta_true),
        initial=InitialPoses([np.asarray(exp.qpos)]),
        settings=LMSettings(max_iterations=1),
    )
    result.theta = np.asarray(exp.theta_true).copy()
    result.qpos = [np.asarray(exp.qpos).copy()]
    idf = Identifiability(pset, result.reduced_information, 1e-3, theta=result.theta)
    out = tmp_path / "res"
    out.mkdir()
    summary = {
        "frames_fitted_range": [[0, 80]],
        "frames": 80,
        "frames_used": 80,
        "solver": "lm",
        "seconds": 0.0,
        "expected_rmse_mm": 0.0,
    }
    write_files(out, pset, result, idf, [trial], summary)
    (out / "summary.json").write_text(json.dumps(summary))
    from mocap_mj.outputs.score import score

    s = score(tmp_path / "synth", out, plot=False)
    assert s["kappa_rmse_all_mm"] < 1e-6
    assert s["offset_rmse_all_mm"] < 1e-6
    assert s["joint_centre_rmse_mm"] < 1e-6
    assert s["joint_rmse_deg"] < 1e-6
    assert s["marker_rmse_mm"] < 1e-6


def test_accepted_iterations_never_raise_the_cost(clean) -> None:  # type: ignore[no-untyped-def]
    # L2 loss: F at the start of an iteration is the previous entry's F (a refit in between
    # only replaces poses that fit better), so the trace never rises and accepted steps lower it.
    # Within each phase: the coarse phase's F is that of its subset of frames.
    _, _, result, _ = clean
    for frames in {log.frames for log in result.trace}:
        costs = np.array([log.cost for log in result.trace if log.frames == frames])
        assert np.all(np.diff(costs) <= 1e-12 * costs[:-1]), (frames, np.diff(costs))
    accepted = [log.accepted for log in result.trace]
    assert any(accepted) and result.status.name in ("NOISE", "COST", "STEP", "STALL")
