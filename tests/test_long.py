"""Long recordings: pose-diverse frame selection, identification on it, IK in chunks."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.errors import MocapError
from mocap_mj.identify.identifiability import Identifiability
from mocap_mj.identify.long import identify_long
from mocap_mj.identify.problem import IdentificationProblem
from mocap_mj.identify.selection import select_frames
from mocap_mj.score import align_truth
from mocap_synth import SynthConfig, synthesize


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def test_selection_skips_repeated_poses(pset: ParameterSet) -> None:
    still = synthesize(SynthConfig(frames=600, motion="static", seed=3), pset)
    rom = synthesize(SynthConfig(frames=600, motion="rom", seed=3), pset)
    markers = np.concatenate([still.markers, rom.markers])
    sel = select_frames(markers, pset.marker_names, 60)
    assert len(np.unique(sel.frames)) == 60 and np.all(np.diff(sel.frames) > 0)
    # Standing still is one pose (sway ~ cm): a handful of frames cover it.
    assert np.sum(sel.frames < 600) <= 3
    assert 0 < sel.cover_median <= sel.cover_max
    # A smaller pool is evenly spaced: every kept frame is on its grid.
    coarse = select_frames(markers, pset.marker_names, 30, pool=400)
    assert coarse.pool == 400 and np.all(coarse.frames % 3 == 0)
    # Short recordings are kept whole.
    assert np.array_equal(select_frames(markers[:50], pset.marker_names, 80).frames, np.arange(50))


def test_selection_needs_the_pelvis(pset: ParameterSet) -> None:
    rom = synthesize(SynthConfig(frames=20, motion="rom", seed=0), pset)
    markers = np.array(rom.markers)
    markers[:, pset.marker_names.index("LASI")] = np.nan
    with pytest.raises(MocapError, match="pelvis markers"):
        select_frames(markers, pset.marker_names, 5)
    with pytest.raises(MocapError, match="missing: LPSI"):
        select_frames(markers, tuple(n if n != "LPSI" else "X" for n in pset.marker_names), 5)


def test_identify_long_reaches_the_bound_of_its_selection(pset: ParameterSet) -> None:
    exp = synthesize(SynthConfig(frames=900, motion="rom", seed=4), pset)
    qpos = np.full((900, 55), np.nan)
    res = identify_long(exp.markers, exp.times, pset, qpos, count=200, chunk=400)
    assert len(res.selection.frames) == 200
    assert res.frames_solved == 900 and np.all(np.isfinite(qpos))
    # 1 mm per-axis noise: sqrt(3) (1 - 48/117)^0.5 mm = 1.33 mm after the IK fit
    assert 1.2e-3 < res.marker_rmse < 1.45e-3
    lm = res.lm
    idf = Identifiability(pset, lm.reduced_information, lm.sigma, theta=lm.theta)
    frames = res.selection.frames
    aligned = align_truth(pset, lm.theta, exp.markers_clean[frames], exp.times[frames])
    e_obs, _ = idf.project(lm.theta - aligned)
    bk, bo = idf.bound_rms()
    k = pset.n_kappa
    # Errors are random with the bound as their RMS: 2x leaves room for one draw.
    assert np.sqrt(np.mean(e_obs[:k] ** 2)) < 2.0 * bk
    assert np.sqrt(np.mean(e_obs[k:] ** 2)) < 2.0 * bo


def test_refinement_on_every_frame_reaches_the_all_frames_bound(pset: ParameterSet) -> None:
    exp = synthesize(SynthConfig(frames=2400, motion="rom", seed=6), pset)
    qpos = np.full((2400, 55), np.nan)
    # 120 frames identified on; the refinement's sample every 3rd frame, its last step on all.
    res = identify_long(exp.markers, exp.times, pset, qpos, count=120, chunk=1000, sample=800)
    assert res.frames_solved == 2400 and np.all(np.isfinite(qpos))
    assert len(res.steps) >= 2 and res.steps[-1] < res.steps[0]
    # The bound of every frame, from their information at the truth (poses: the IK's).
    kin = Kinematics(pset)
    kin.set_theta(exp.theta_true)
    free = np.flatnonzero(~pset.frozen)
    prob = IdentificationProblem(kin, exp.markers, qpos.copy(), free)
    idf = Identifiability(pset, prob.information(prob.present.astype(float)), 1e-3)
    errors = {}
    k = pset.n_kappa
    for name, theta in (("subset", res.lm.theta), ("refined", res.theta)):
        aligned = align_truth(pset, theta, exp.markers_clean[::10], exp.times[::10])
        e, _ = idf.project(theta - aligned)
        errors[name] = (np.sqrt(np.mean(e[:k] ** 2)), np.sqrt(np.mean(e[k:] ** 2)))
    bk, bo = idf.bound_rms()
    # An efficient estimate's RMS error is the bound; 1.6x leaves room for one draw. The
    # subset's error is several bounds (it has 1/20 of the frames).
    assert errors["refined"][0] < 1.6 * bk and errors["refined"][1] < 1.6 * bo
    assert errors["subset"][0] > 2.0 * errors["refined"][0]
