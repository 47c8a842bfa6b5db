"""Multi-trial weighting and the thorax without T10.

A static trial whose soft tissue is one constant offset must not outvote a movement: each
trial weighs by its independent observations (:func:`mocap_mj.solve.noise.trial_weights`);
white noise keeps every weight 1. Without T10 data the thorax origin's depth and the thorax
frame's tilt are placed from C7 and the sternum, so that nothing sits at a bound.

The synthetic subject is the demo's (seed 0: segment lengths +-10 %, offsets +-20 mm,
landmarks placed anatomically), 1 mm white noise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy import anatomy
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.partial import freeze_unmeasured, on_measured
from mocap_mj.capture.subject import Subject
from mocap_mj.cli import main
from mocap_mj.outputs.write_fit import _anatomy_lines
from mocap_mj.pipeline import steps as pipeline
from mocap_mj.pipeline.anatomical import AnatomyPriors
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.consistency import joint_centre_lengths
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.noise import (
    CORRELATED_TAU,
    TRIAL_WEIGHT_RANGE,
    residual_correlation_time,
    trial_weights,
)
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

#: Per-axis RMS [m] of the static trial's constant soft-tissue offset per marker.
STATIC_OFFSET = 0.005


def test_one_trial_or_white_noise_keeps_weight_one() -> None:
    assert trial_weights([40.0], [300]) == [1.0]
    rng = np.random.default_rng(0)
    white = [rng.normal(0, 1e-3, (n, 30, 3)) for n in (300, 500)]
    taus = [residual_correlation_time(r, about_mean=False) for r in white]
    assert max(taus) < CORRELATED_TAU
    assert trial_weights(taus, [300, 500]) == [1.0, 1.0]


def test_constant_offset_counts_as_few_observations() -> None:
    """A static trial's residual, one constant offset plus noise, has a correlation time
    about zero near its length (its mean is the artefact, repeated every frame); the weights
    keep the weighted frames' total and stay in TRIAL_WEIGHT_RANGE."""
    rng = np.random.default_rng(1)
    static = rng.normal(0, 5e-3, (1, 30, 3)) + rng.normal(0, 1e-3, (500, 30, 3))
    tau = residual_correlation_time(static, about_mean=False)
    assert tau > 100.0
    assert residual_correlation_time(static) < CORRELATED_TAU  # about the mean: white
    w = trial_weights([10.0, 40.0], [300, 500])
    assert w[0] > 1.0 > w[1]
    assert w[0] * 300 + w[1] * 500 == pytest.approx(800)
    lo, hi = TRIAL_WEIGHT_RANGE
    assert trial_weights([2.0, tau], [300, 500])[1] == lo
    assert trial_weights([tau, 2.0], [30000, 5])[1] == hi


@pytest.fixture(scope="module")
def pair() -> dict[str, Any]:
    """A range-of-motion trial (200 frames) and a quiet-standing trial (300 frames) of one
    subject, the static one with a constant offset on every marker, identified together
    with and without the per-trial weights."""
    pset = ParameterSet()
    move = synthesize(SynthConfig(frames=200, motion="rom", seed=0), pset)
    still = synthesize(SynthConfig(frames=300, motion="static", seed=0), pset)
    assert np.allclose(move.theta_true, still.theta_true)
    offset = np.random.default_rng(7).normal(0, STATIC_OFFSET, (1, still.markers.shape[1], 3))
    trials = [
        TrialData("rom", np.asarray(move.markers), np.asarray(move.times)),
        TrialData("static", np.asarray(still.markers) + offset, np.asarray(still.times)),
    ]
    out: dict[str, Any] = {"pset": pset, "truth": np.asarray(move.theta_true)}
    for name, rule in (("weighed", trial_weights), ("unweighed", lambda t, n: [1.0] * len(t))):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(pipeline, "trial_weights", rule)
            out[name] = solve_anatomical(trials, pset=pset, theta0=None, settings=LMSettings(),
                                         anatomy=AnatomyPriors(Subject()))  # fmt: skip
    return out


def _length_error(pset: ParameterSet, theta: np.ndarray, truth: np.ndarray) -> float:
    """RMS [m] over the joint-centre distances of theta against the truth's."""
    a, b = joint_centre_lengths(pset, theta), joint_centre_lengths(pset, truth)
    return float(np.sqrt(np.mean([(a[k] - b[k]) ** 2 for k in a])))


def test_static_trial_does_not_outvote_the_movement(pair: dict[str, Any]) -> None:
    """The static trial weighs less than the movement, and the joint-centre distances are
    closer to the truth than without the weights (measured on seed 0: 4.4 mm against 8.0 mm
    RMS; benchmarks/trial_weights.py for more seeds): at least 30 % closer."""
    (result, weighting), (plain, _) = pair["weighed"], pair["unweighed"]
    w = weighting.trial_weights
    assert w[1] < 1.0 < w[0]
    pset, truth = pair["pset"], pair["truth"]
    weighed = _length_error(pset, result.theta, truth)
    unweighed = _length_error(pset, plain.theta, truth)
    assert weighed < 0.7 * unweighed


def _thorax_origin_forward(pset: ParameterSet) -> np.ndarray:
    """theta's direction (P,) that moves the thorax origin 1 m forward against everything
    on the thorax (its markers' x offsets, neck_depth, sc_depth all -1)."""
    v = np.zeros(pset.size)
    thorax = pset.model.body("thorax").id
    for i, m in enumerate(pset.marker_names):
        if pset.model.site_bodyid[pset.model.site(m).id] == thorax:
            v[pset.n_kappa + 3 * i] = -1.0
    for n in ("neck_depth", "sc_depth"):
        v[pset.index(n)] = -1.0
    return v


def test_without_t10_a_prior_places_the_thorax_origin_depth(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With T10 frozen (no data) the landmark prior holds the thorax origin's depth as with
    T10 (3 mm: the convention rows, here the tilt row on neck_depth); without the no-T10
    rows nothing does (no information along that direction: the gap on Qualisys.c3d)."""
    pset = ParameterSet()
    markers = np.zeros((5, len(pset.marker_names), 3))
    markers[:, pset.marker_names.index("T10")] = np.nan
    frozen, _ = freeze_unmeasured(pset, [TrialData("no-T10", markers, np.arange(5.0))])
    v = _thorax_origin_forward(pset)

    def std_along(ps: ParameterSet) -> float:
        prior = landmark_prior(ps, Subject())
        a = on_measured(prior, ps.frozen).a
        info = float(np.sum((a @ v / np.asarray(on_measured(prior, ps.frozen).sigma)) ** 2))
        return 1.0 / np.sqrt(info) if info > 0 else np.inf

    assert std_along(pset) < 0.01  # T10 present: its rows place it
    assert std_along(frozen) < 0.01
    monkeypatch.setattr(anatomy, "_depth_without_t10", lambda rows, s: None)
    assert std_along(frozen) > 1.0


def test_without_t10_the_thorax_depth_is_placed() -> None:
    """T10 without data: the T12/L1 depth row and the tilt row exist, and the fit of a
    synthetic trial leaves no kinematic parameter at a bound, neck_depth within 5 mm of the
    truth (the tilt convention is the nominal model's, the truth's is perturbed +-10 %)."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=200, motion="rom", seed=0), pset)
    markers = np.array(exp.markers)
    markers[:, pset.marker_names.index("T10")] = np.nan
    trials = [TrialData("no-T10", markers, np.asarray(exp.times))]
    frozen, _ = freeze_unmeasured(pset, trials)
    labels = landmark_prior(frozen, Subject()).labels
    assert any("no T10" in label for label in labels)
    assert not any("no T10" in label for label in landmark_prior(pset, Subject()).labels)
    result, _ = solve_anatomical(trials, pset=frozen, theta0=None, settings=LMSettings(),
                                 anatomy=AnatomyPriors(Subject()))  # fmt: skip
    at_bound = [n for n, b in zip(pset.kappa_names, result.at_bound, strict=False) if b]
    assert at_bound == []
    k = pset.kappa_names.index("neck_depth")
    assert abs(result.theta[k] - exp.theta_true[k]) < 0.005


REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


def test_strict_refuses_a_misplaced_t10(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Movement_trial's T10 sits 89 mm further from C7 than its stature predicts: --strict
    refuses the placement finding like the marker-data findings (exit 2, one line naming
    the file, nothing written); without --strict it is a warning (tests/test_trunk.py)."""
    trial = REAL / "Movement_trial.c3d"
    if not trial.exists():
        pytest.skip("../shared/data/real not present: the real trial is in the shared folder")
    out = tmp_path / "out"
    assert main(["identify", "--markers", str(trial), "--out", str(out), "--strict"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "Movement_trial.c3d: T10" in err[0] and "--strict" in err[0]
    assert not out.exists()


def test_report_lists_the_trial_weights() -> None:
    summary = {
        "anatomical_priors": True,
        "markers_files": ["a/Movement.c3d", "a/Static.c3d"],
        "prior_weighting": {
            "noise_mm": 30.0, "sigma_mm": 2.0, "tau_frames": 45.0,
            "trial_weights": [1.6, 0.61], "trial_tau_frames": [163.0, 431.0],
        },
    }  # fmt: skip
    text = "\n".join(_anatomy_lines(summary))
    assert (
        "Movement.c3d 1.60 (correlation time 163.0 frames), "
        "Static.c3d 0.61 (correlation time 431.0 frames)" in text
    )  # the correlation time named as such, not as a count of frames
    summary["prior_weighting"].update(trial_weights=[1.0], trial_tau_frames=[40.0])
    assert "independent frames" not in "\n".join(_anatomy_lines(summary))
