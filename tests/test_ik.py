"""IK: exactness on clean data, the noise floor on noisy data, gaps, limits, bad input."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ShapeError, UnknownNameError
from mocap_mj.solve.ik import IKSettings, IKSolver, Status, weights_from_names

SIGMA = 1e-3  # [m] per axis
#: Tolerances for tests of what the solver converges to (the defaults stop at 0.1 % RMSE
#: change per step, which is plenty for data with noise but not for exactness checks).
TIGHT = IKSettings(tol_rmse=1e-9)


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    return Kinematics()


#: Joints no marker sees (TOE is on the foot): the IK leaves them where they start (0).
UNSEEN = ("mtp_l", "mtp_r")


def _unseen_adr(kin: Kinematics) -> list[int]:
    return [int(kin.model.jnt_qposadr[kin.model.joint(n).id]) for n in UNSEEN]


@pytest.fixture(scope="module")
def truth(kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    qpos = smooth_motion(kin, 300, seed=3)
    qpos[:, _unseen_adr(kin)] = 0.0
    return qpos, kin.marker_positions(qpos)


def test_unseen_joints_stay_at_zero(kin: Kinematics) -> None:
    """A joint no marker sees (the MTP: no marker on the toes) has no information in the
    data: the IK leaves it at 0 whatever the truth did, and fits every other joint exactly."""
    qpos = smooth_motion(kin, 20, seed=4)
    adr = _unseen_adr(kin)
    assert np.abs(qpos[:, adr]).max() > 0.05
    result = IKSolver(kin, TIGHT).solve_trial(kin.marker_positions(qpos))
    assert np.all(result.qpos[:, adr] == 0.0)
    assert result.rmse() < 1e-6


def away_from_limits(kin: Kinematics, qpos: np.ndarray, margin: float = 0.02) -> np.ndarray:
    """(T,) bool: frames where no hinge is within ``margin`` rad of a limit (identifiable)."""
    m = kin.model
    hinge = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    q = qpos[:, m.jnt_qposadr[hinge]]
    lo, hi = m.jnt_range[hinge, 0], m.jnt_range[hinge, 1]
    return np.all((q > lo + margin) & (q < hi - margin), axis=1)


def assert_within_limits(kin: Kinematics, qpos: np.ndarray) -> None:
    m = kin.model
    for j in range(1, m.njnt):
        adr = m.jnt_qposadr[j]
        lo, hi = m.jnt_range[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            assert np.all(qpos[:, adr] >= lo - 1e-12) and np.all(qpos[:, adr] <= hi + 1e-12)
        else:
            quat = qpos[:, adr : adr + 4]
            angle = 2 * np.arctan2(np.linalg.norm(quat[:, 1:], axis=1), np.abs(quat[:, 0]))
            assert np.all(angle <= hi + 1e-9), m.joint(j).name


@pytest.mark.parametrize("damping", ["adaptive", "sugihara"])
def test_noise_free_is_exact(kin: Kinematics, truth, damping: str) -> None:  # type: ignore[no-untyped-def]
    qpos, markers = truth
    result = IKSolver(kin, IKSettings(damping=damping)).solve_trial(markers)
    assert np.all(result.status == Status.CONVERGED)
    assert result.rmse() < 1e-6  # 1e-3 mm
    err = kin.difference(qpos, result.qpos)
    ok = away_from_limits(kin, qpos)
    assert ok.sum() > 50
    assert np.abs(err[ok]).max() < 1e-4  # rad (and m for the root)
    assert_within_limits(kin, result.qpos)


def test_noise_floor(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    """RMSE of the 3D residual = sqrt(3) sigma sqrt(1 - nv / 3M) at the least-squares pose."""
    _, markers = truth
    noisy = markers + np.random.default_rng(0).normal(0, SIGMA, markers.shape)
    result = IKSolver(kin).solve_trial(noisy)
    expected = np.sqrt(3) * SIGMA * np.sqrt(1 - 48 / 117)
    assert result.rmse() == pytest.approx(expected, rel=0.05)
    assert np.mean(result.status == Status.CONVERGED) > 0.98
    assert_within_limits(kin, result.qpos)


def test_gaps_of_30_percent(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    qpos, markers = truth
    rng = np.random.default_rng(1)
    gappy = markers.copy()
    for t in range(len(gappy)):
        gappy[t, rng.choice(39, size=12, replace=False)] = np.nan  # 31% missing
    result = IKSolver(kin, TIGHT).solve_trial(gappy)
    assert np.all(result.n_markers == 27)
    assert np.mean(result.status == Status.CONVERGED) > 0.98
    # Exact in nearly every frame; a frame that loses most of one arm's markers (e.g. SHO,
    # UPA, FRM, WRA) may settle in a local minimum of that arm (the forearm's 190-degree
    # pronation range).
    res = np.linalg.norm(kin.marker_positions(result.qpos) - gappy, axis=2)
    per_frame = np.sqrt(np.nanmean(res**2, axis=1))
    assert np.mean(per_frame < 1e-6) > 0.98
    # The pelvis pose is exact wherever three of its four markers are seen.
    pelvis = [kin.pset.marker_index(n) for n in ("LASI", "RASI", "LPSI", "RPSI")]
    seen = np.isfinite(gappy[:, pelvis, 0]).sum(axis=1) >= 3
    err = kin.difference(qpos[seen], result.qpos[seen])
    assert np.abs(err[:, :6]).max() < 1e-4  # m and rad


def test_unreachable_target_gives_least_squares(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    _, markers = truth
    centre = markers[:20].mean(axis=1, keepdims=True)
    stretched = centre + 1.3 * (markers[:20] - centre)  # a body 30% too large
    solver = IKSolver(kin, TIGHT)
    result = solver.solve_trial(stretched)
    assert np.all(np.isfinite(result.qpos))
    assert result.rmse() > 0.01
    assert_within_limits(kin, result.qpos)
    # Near the least-squares pose: a much longer, tighter solve from there gains < 0.3%
    # (large-residual problems converge linearly; the default stop is a relative cost change).
    tight = IKSolver(kin, IKSettings(tol_cost=1e-15, tol_step=1e-13, max_iterations=500))
    refined = tight.solve_frames(stretched, result.qpos)
    assert np.all(refined.marker_rmse <= result.marker_rmse * (1 + 1e-9))
    assert np.all(refined.marker_rmse >= result.marker_rmse * (1 - 3e-3))


def test_root_from_pelvis_places_subject_anywhere(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    _, markers = truth
    rot = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])  # 90 deg about z
    moved = markers[:30] @ rot.T + np.array([3.0, -2.0, 0.1])
    result = IKSolver(kin).solve_trial(moved)
    assert result.rmse() < 1e-6


def test_few_markers_reported_not_filled(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    _, markers = truth
    data = markers[:40].copy()
    data[5] = np.nan
    data[6, :30] = np.nan  # 9 markers left
    result = IKSolver(kin).solve_trial(data)
    assert result.status[5] == Status.TOO_FEW_MARKERS
    assert result.status[6] == Status.TOO_FEW_MARKERS
    assert np.all(np.isnan(result.qpos[[5, 6]]))
    others = np.setdiff1d(np.arange(40), [5, 6])
    assert np.all(result.status[others] == Status.CONVERGED)
    assert result.rmse() < 1e-6


def test_weights(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    _, markers = truth
    w = weights_from_names(kin.pset.marker_names, {"LFIN": 0.0, "RFIN": 0.5})
    assert w[kin.pset.marker_index("LFIN")] == 0 and w.sum() == 37.5
    with pytest.raises(UnknownNameError, match="unknown marker 'LFINGER'; the model has: LASI"):
        weights_from_names(kin.pset.marker_names, {"LFINGER": 1.0})
    result = IKSolver(kin).solve_trial(markers[:10], w)
    assert np.all(result.n_markers == 38)


def test_bad_shapes(kin: Kinematics) -> None:
    solver = IKSolver(kin)
    with pytest.raises(
        ShapeError, match=r"markers: expected shape \(\*, 39, 3\), got \(5, 38, 3\)"
    ):
        solver.solve_trial(np.zeros((5, 38, 3)))
    with pytest.raises(ShapeError, match="weights"):
        solver.solve_trial(np.zeros((5, 39, 3)), np.ones(12))


def test_static_poses_with_arms_raised(kin: Kinematics, monkeypatch: pytest.MonkeyPatch) -> None:
    """Static trials with the arms abducted 60-110 degrees (T-pose-like), random arm rotation,
    elbow and forearm: one pose in every frame, so a chain head that settles with an arm
    twisted in a wrong minimum leaves the whole trial there. The heads also start from the
    arm configurations of ARM_STARTS: every trial fits to the noise. Without them
    (monkeypatched away) some of these trials do not."""
    from scipy.spatial.transform import Rotation

    import mocap_mj.solve.ik as ik_module

    m = kin.model
    rng = np.random.default_rng(0)
    trials = []
    for _ in range(13):
        q = np.array(m.qpos0, dtype=float)
        q[2] = 1.0
        for name, sign in (("shoulder_l", 1.0), ("shoulder_r", -1.0)):
            adr = int(m.jnt_qposadr[m.joint(name).id])
            ab, twist, flex = np.radians([rng.uniform(60, 110), rng.uniform(-80, 80),
                                          rng.uniform(-30, 30)])  # fmt: skip
            rot = (
                Rotation.from_rotvec([sign * ab, 0, 0])
                * Rotation.from_rotvec([0, flex, 0])
                * Rotation.from_rotvec([0, 0, twist])
            )
            q[adr : adr + 4] = rot.as_quat(scalar_first=True)
        for joint, lo, hi in (("elbow", 0, 90), ("pronation", -130, 20)):
            for side in "lr":
                q[int(m.jnt_qposadr[m.joint(f"{joint}_{side}").id])] = np.radians(
                    rng.uniform(lo, hi)
                )
        qpos = np.tile(q, (8, 1))
        trials.append(kin.marker_positions(qpos) + rng.normal(0, 5e-4, (8, kin.n_markers, 3)))
    solved = [IKSolver(kin).solve_trial(markers).rmse() for markers in trials]
    assert max(solved) < 1.5e-3  # 0.5 mm per-axis noise: about 0.85 mm
    monkeypatch.setattr(ik_module, "ARM_STARTS", ())
    stuck = [IKSolver(kin).solve_trial(markers).rmse() for markers in trials]
    assert max(stuck) > 5e-3


def test_chains_from_known_heads(kin: Kinematics, truth) -> None:  # type: ignore[no-untyped-def]
    """solve_from_heads: every frame solved from every 7th frame's pose (the cold chains'
    arm starts not needed), one head unknown and a frame without markers in a chain: the
    same solution as the cold chained solve."""
    _, markers = truth
    data = markers[:120].copy()
    data[30] = np.nan  # unsolved: the next frame starts from the pelvis fit
    solver = IKSolver(kin, TIGHT)
    cold = solver.solve_trial(data)
    heads = np.full_like(cold.qpos, np.nan)
    heads[::7] = cold.qpos[::7]
    heads[14] = np.nan  # a head without a pose: the pelvis fit
    r = solver.solve_from_heads(data, heads)
    assert r.status[30] == Status.TOO_FEW_MARKERS and np.all(np.isnan(r.qpos[30]))
    ok = r.solved
    assert np.array_equal(ok, cold.solved)
    assert np.max(r.marker_rmse[ok]) < 1e-7
    assert np.max(np.abs(kin.marker_positions(r.qpos[ok]) - data[ok])) < 1e-6


def test_a_chain_that_changes_basin_is_resolved_from_its_better_side(
    kin: Kinematics, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Trials that start with the arms abducted and twisted (as in the static test) and then
    lower them, solved as one chain without the arm starts: the head can settle in a wrong
    minimum that disappears as the arm comes down, so the chain jumps into the right basin
    mid-trial. The frames before the jump are then re-solved backwards from the frames after
    it (ik.JUMP): every such trial fits its first frames to the noise. With the jump seams
    switched off (JUMP = inf) at least three of them do not, and no trial fits better."""
    from scipy.spatial.transform import Rotation

    import mocap_mj.solve.ik as ik_module

    m = kin.model
    rng = np.random.default_rng(0)
    monkeypatch.setattr(ik_module, "ARM_STARTS", ())

    def pose(ab: float, twist: float, flex: float, elbow: float, pro: float) -> np.ndarray:
        q = np.array(m.qpos0, dtype=float)
        q[2] = 1.0
        for name, sign in (("shoulder_l", 1.0), ("shoulder_r", -1.0)):
            adr = int(m.jnt_qposadr[m.joint(name).id])
            rot = (Rotation.from_rotvec([sign * ab, 0, 0]) * Rotation.from_rotvec([0, flex, 0])
                   * Rotation.from_rotvec([0, 0, twist]))  # fmt: skip
            q[adr : adr + 4] = rot.as_quat(scalar_first=True)
        for joint, value in (("elbow", elbow), ("pronation", pro)):
            for side in "lr":
                q[int(m.jnt_qposadr[m.joint(f"{joint}_{side}").id])] = value
        return q

    n = 60
    lowered = np.clip((np.arange(n) - 20) / 30, 0, 1)  # abducted for 20 frames, then down
    default = ik_module.JUMP
    first: dict[float, list[float]] = {default: [], np.inf: []}
    for _ in range(30):
        ab, twist, flex, elbow = np.radians(
            [rng.uniform(60, 110), rng.uniform(-80, 80), rng.uniform(-30, 30), rng.uniform(0, 90)]
        )
        pro = np.radians(rng.uniform(-130, 20))
        qpos = np.array([pose(ab * (1 - a) + 0.3 * a, twist * (1 - a), flex * (1 - a),
                              elbow * (1 - a) + 0.3 * a, pro * (1 - a) - 0.5 * a)
                         for a in lowered])  # fmt: skip
        markers = kin.marker_positions(qpos) + rng.normal(0, 5e-4, (n, kin.n_markers, 3))
        for jump in first:
            monkeypatch.setattr(ik_module, "JUMP", jump)
            r = IKSolver(kin, IKSettings(chain_length=n)).solve_trial(markers)
            first[jump].append(float(np.max(r.marker_rmse[:20])))
    cut, uncut = np.array(first[default]), np.array(first[np.inf])
    noise = 1.5e-3  # 0.5 mm per-axis noise: about 0.85 mm
    assert np.count_nonzero(uncut > 3 * noise) >= 3
    assert np.all(cut <= uncut * (1 + 1e-9))
    freed = (uncut > 3 * noise) & (cut < noise)
    assert np.count_nonzero(freed) >= 3
