"""The identify/ik outputs: a model.xml that reproduces the fit, joint_centres.csv,
segments.csv, and the uncertainty in report.md and summary.json."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import ezc3d
import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocap_mj import ParameterSet
from mocap_mj.anatomy.ranges import kappa_ranges
from mocap_mj.anatomy.segments import parameter_flag
from mocap_mj.capture.subject import StatureEstimate, Subject
from mocap_mj.cli import main
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv
from mocap_mj.outputs.fit_tables import COLUMNS
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.pipeline.robust_ik import solve_trial_loss
from mocap_mj.skeleton.joint_centre_table import joint_centre_columns
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.consistency import joint_centre_lengths
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, solver_joint_range
from mocap_synth import SynthConfig, synthesize

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

#: The thorax ball of the synthetic truth is turned this far [deg]: beyond the model's 45
#: degree cone, inside the 67.5 degrees the identification allows (ball_limit_scale 1.5).
THORAX_DEG = 55.0


def _reject_constant(name: str) -> None:
    raise ValueError(f"not strict JSON: {name}")


def test_exported_joint_ranges_reload_exactly() -> None:
    pset = ParameterSet()
    widened = solver_joint_range(pset.model, LMSettings())
    thorax = pset.model.joint("thorax").id
    assert widened[thorax, 1] == pytest.approx(np.radians(67.5))
    for rng in (None, widened):
        model = mujoco.MjModel.from_xml_string(pset.to_xml(pset.nominal, joint_range=rng))
        expected = pset.model.jnt_range if rng is None else rng
        # by name: the written model has the knees' slide joints too (mocap_mj.skeleton.exported)
        names = [pset.model.joint(j).name for j in range(pset.model.njnt)]
        ranges = np.array([model.joint(n).range for n in names])
        np.testing.assert_array_equal(ranges, expected)  # not rounded to 6 digits


def test_parameter_flags() -> None:
    assert parameter_flag(0.30, 0.20, 0.40) == ""
    assert parameter_flag(0.2001, 0.20, 0.40) == "at_lower"
    assert parameter_flag(0.3999, 0.20, 0.40) == "at_upper"
    assert parameter_flag(0.19, 0.20, 0.40) == "below_range"
    assert parameter_flag(0.41, 0.20, 0.40) == "above_range"


@pytest.fixture(scope="module")
def beyond_cone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic trial (120 frames, 1 mm noise) whose thorax ball is turned beyond the
    model's cone in every frame, as a marker file."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=120, seed=4), pset)
    qpos = np.array(exp.qpos)
    adr = int(pset.model.jnt_qposadr[pset.model.joint("thorax").id])
    a = np.linspace(0.0, np.pi, len(qpos))
    axis = np.stack([np.sin(a), 0.3 * np.ones_like(a), np.cos(a)], axis=1)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    quat = Rotation.from_rotvec(axis * np.radians(THORAX_DEG)).as_quat(scalar_first=True)
    qpos[:, adr : adr + 4] = quat
    kin = Kinematics(pset)
    kin.set_theta(exp.theta_true)
    rng = np.random.default_rng(4)
    markers = kin.marker_positions(qpos) + rng.normal(scale=1e-3, size=exp.markers.shape)
    folder = tmp_path_factory.mktemp("beyond")
    save_csv(
        folder / "markers.csv",
        MarkerTrajectory(times=exp.times, positions=markers, names=pset.marker_names, rate=100.0),
    )
    return folder


@pytest.fixture(scope="module")
def identified(beyond_cone: Path) -> tuple[Path, dict]:
    out = beyond_cone / "result"
    recipe = beyond_cone / "nominal.yaml"
    recipe.write_text("init: nominal\n")
    code = main(["identify", "--markers", str(beyond_cone / "markers.csv"),
                 "--recipe", str(recipe), "--out", str(out), "--json"])  # fmt: skip
    assert code == 0
    summary = json.loads((out / "summary.json").read_text(), parse_constant=_reject_constant)
    return out, summary


def test_exported_model_reproduces_the_fit(
    beyond_cone: Path, identified: tuple[Path, dict], capsys: pytest.CaptureFixture[str]
) -> None:
    """``ik --model RESULT/model.xml`` on the identified trial gives the identify RMSE within
    2 %, although the fit turns the thorax beyond the model's own cone."""
    out, summary = identified
    ik_out = beyond_cone / "ik"
    capsys.readouterr()
    code = main(["ik", "--markers", str(beyond_cone / "markers.csv"), "--model",
                 str(out / "model.xml"), "--out", str(ik_out), "--json"])  # fmt: skip
    assert code == 0
    ik = json.loads(capsys.readouterr().out)
    ratio = ik["marker_rmse_mm"] / summary["marker_rmse_mm"]
    assert 0.98 <= ratio <= 1.02, (ik["marker_rmse_mm"], summary["marker_rmse_mm"])
    # The fit did use the widened cone, so the model's own limits could not reproduce it.
    pset = ParameterSet()
    theta = pset.load_json(out / "theta.json")
    motion = load_motion(out / "motion.npz", pset.model)
    adr = int(pset.model.jnt_qposadr[pset.model.joint("thorax").id])
    turn = 2 * np.arccos(np.clip(np.abs(motion.qpos[:, adr]), 0.0, 1.0))
    assert np.median(np.degrees(turn)) > 50.0
    own = Kinematics(pset)  # the file's limits (45 degree thorax cone), identified theta
    own.set_theta(theta)
    markers = motion.markers
    own_rmse = IKSolver(own).solve_trial(markers).rmse() * 1e3
    assert own_rmse > 1.2 * summary["marker_rmse_mm"]
    # ik writes the joint centres of its model too.
    with open(ik_out / "joint_centres.csv") as f:
        assert next(csv.reader(f)) == joint_centre_columns()


def test_joint_centres_csv(identified: tuple[Path, dict]) -> None:
    out, _ = identified
    columns = joint_centre_columns()
    assert columns[:2] == ["frame", "time_s"]
    assert columns[2:5] == [f"{JOINT_CENTRE_NAMES[0]}_{a}_mm" for a in "xyz"]
    assert "knee_l_x_mm" in columns and len(columns) == 2 + 3 * len(JOINT_CENTRE_NAMES)
    table = np.genfromtxt(out / "joint_centres.csv", delimiter=",", names=True)
    exported = ParameterSet(out / "model.xml")
    motion = load_motion(out / "motion.npz", exported.model)
    expected = joint_centre_trajectories(exported.model, motion.qpos) * 1e3  # (T, J, 3) mm
    assert len(table) == len(motion.qpos)
    np.testing.assert_array_equal(table["frame"], np.arange(len(table)))
    np.testing.assert_allclose(table["time_s"], motion.times, atol=1e-6)
    j = JOINT_CENTRE_NAMES.index("knee_r")
    for k, a in enumerate("xyz"):
        np.testing.assert_allclose(table[f"knee_r_{a}_mm"], expected[:, j, k], atol=1e-4)


def test_segments_csv_and_summary(identified: tuple[Path, dict]) -> None:
    out, summary = identified
    with open(out / "segments.csv") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == COLUMNS
    pset = ParameterSet()
    exported = ParameterSet(out / "model.xml")
    lengths = joint_centre_lengths(pset, exported.nominal)
    by_name = {r["name"]: r for r in rows}
    assert set(by_name) == set(lengths) | set(pset.kappa_names)
    for name, value in lengths.items():
        r = by_name[name]
        assert r["kind"] == "length"
        assert float(r["value_mm"]) == pytest.approx(value * 1e3, abs=1e-3)
        assert 0.0 < float(r["std_white_mm"]) <= float(r["std_mm"]) + 1e-9
        # The anatomical priors only add information (the weak prior is in both).
        assert 0.0 < float(r["std_priors_mm"]) <= 1.001 * float(r["std_mm"])
        assert r["lower_mm"] == r["upper_mm"] == ""
    # The anatomical ranges the fit was bounded by: about the stature it estimated.
    est = summary["stature_estimate"]
    subject = Subject().with_stature_estimate(
        StatureEstimate(est["value"], est["sd"], est["source"])
    )
    lower, upper = kappa_ranges(pset, subject)
    for i, name in enumerate(pset.kappa_names):
        r = by_name[name]
        assert r["kind"] == "kappa"
        assert float(r["nominal_mm"]) == pytest.approx(pset.nominal[i] * 1e3, abs=1e-3)
        assert float(r["lower_mm"]) == pytest.approx(lower[i] * 1e3, abs=1e-3)
        assert float(r["upper_mm"]) == pytest.approx(upper[i] * 1e3, abs=1e-3)
        assert r["flag"] == summary["parameters_flagged"].get(name, "")
    # White synthetic noise: the thigh is determined, to about the CRLB, well below the prior.
    thigh = summary["segments"]["thigh_r:shank_r"]
    assert thigh["std_mm"] < 5.0
    assert summary["correlation_time_frames"] < 2.0
    assert thigh["std_mm"] == pytest.approx(
        thigh["std_white_mm"] * math.sqrt(summary["correlation_time_frames"]), rel=0.05
    )
    # The motion determines the thigh: its priors (10 mm rows and wider) change little.
    assert thigh["std_priors_mm"] == pytest.approx(thigh["std_mm"], rel=0.2)
    assert len(summary["worst_markers_mm"]) == 5
    report = (out / "report.md").read_text()
    assert "## Segment lengths and their uncertainty" in report
    assert "| thigh_r:shank_r |" in report
    assert "### Worst-fitting markers" in report


REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


def test_exported_model_reproduces_a_real_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Movement_trial (a jump; its fit turns the thorax past the model's 45 degree cone):
    ``ik --model RESULT/model.xml`` on the same frames gives the identify RMSE within 2 %,
    weighing the knee markers as the fit did."""
    path = REAL / "Movement_trial.c3d"
    if not path.is_file():
        pytest.skip("../shared/data/real not present: real-data checks need the shared folder")
    frames = ["--frames", "10:130"]
    assert main(["identify", "--markers", str(path), "--out", str(tmp_path / "r"), *frames,
                 "--json"]) == 0  # fmt: skip
    fit = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert main(["ik", "--markers", str(path), "--model", str(tmp_path / "r" / "model.xml"),
                 "--out", str(tmp_path / "ik"), *frames, "--json"]) == 0  # fmt: skip
    ik = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert ik["frames"] == fit["frames_used"] == 120
    assert ik["marker_rmse_mm"] <= 1.02 * fit["marker_rmse_mm"]
    assert ik["marker_rmse_mm"] >= 0.98 * fit["marker_rmse_mm"]
    # The fit weighed the knee markers down in flexion (the default), recorded in model.xml;
    # ik weighs them alike. Weighing every marker alike fits the same frames lower (the KNE
    # samples the fit let slide are pulled in): the weights are what reproduces the fit.
    assert fit["sliding_landmarks"] == ik["sliding_landmarks"] == ["KNE"]
    assert main(["ik", "--markers", str(path), "--model", str(tmp_path / "r" / "model.xml"),
                 "--out", str(tmp_path / "ik0"), *frames, "--no-sliding-landmarks",
                 "--json"]) == 0  # fmt: skip
    alike = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert alike["sliding_landmarks"] is None
    assert alike["marker_rmse_mm"] < 0.98 * fit["marker_rmse_mm"]
    # Rows carry the recording's own frame numbers and times (the C3D header's first frame,
    # here 695, plus the --frames start).
    first = load_markers(path).first_frame
    assert first == 695
    for table in (tmp_path / "r" / "joint_centres.csv", tmp_path / "ik" / "joint_centres.csv",
                  tmp_path / "ik" / "motion.csv"):  # fmt: skip
        frame = np.genfromtxt(table, delimiter=",", names=True)["frame"]
        np.testing.assert_array_equal(frame, first + np.arange(10, 130))
        times = np.genfromtxt(table, delimiter=",", names=True)["time_s"]
        np.testing.assert_allclose(times, (frame - 1) / 120.0, atol=1e-6)
    # ... and so does every export of the result.
    assert main(["export", str(tmp_path / "r"), "--to", "all", "--out", str(tmp_path / "x")]) == 0
    for name in ("angles.csv", "residuals.csv"):
        rows = np.genfromtxt(tmp_path / "x" / name, delimiter=",", names=True)
        np.testing.assert_array_equal(rows["frame"], first + np.arange(10, 130))
        np.testing.assert_allclose(rows["time_s"], (rows["frame"] - 1) / 120.0, atol=1e-6)
    trc = (tmp_path / "x" / "markers.trc").read_text().splitlines()
    assert trc[2].split("\t")[6] == str(first + 10)  # OrigDataStartFrame
    assert trc[6].split("\t")[:2] == [str(first + 10), f"{(first + 9) / 120.0:.9f}"]
    c3d = ezc3d.c3d(str(tmp_path / "x" / "result.c3d"))
    assert int(c3d["header"]["points"]["first_frame"]) + 1 == first + 10  # ezc3d counts from 0


def test_ik_under_a_robust_loss_resists_outliers() -> None:
    """``ik --loss cauchy`` (the loss of ``identify --loss cauchy``): with the true model and 3 %
    of the samples displaced by 50 mm, the poses put the model markers nearer their clean
    positions than least squares does, and the reported RMSE is the unweighted one."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=60, seed=5, outliers=0.03, outlier_mm=50.0), pset)
    kin = Kinematics(pset)
    kin.set_theta(exp.theta_true)
    solver = IKSolver(kin)
    markers = np.asarray(exp.markers)
    l2 = solve_trial_loss(solver, markers, "l2")
    robust = solve_trial_loss(solver, markers, "cauchy")

    def error(qpos: np.ndarray) -> float:
        d = kin.marker_positions(qpos) - np.asarray(exp.markers_clean)
        return float(np.sqrt(np.mean(np.sum(d**2, axis=2))))

    assert error(robust.qpos) < 0.7 * error(l2.qpos)
    d = np.linalg.norm(kin.marker_positions(robust.qpos) - markers, axis=2)
    np.testing.assert_allclose(robust.marker_rmse, np.sqrt(np.nanmean(d**2, axis=1)), rtol=1e-9)


def test_parameter_covariance_with_priors_is_the_posterior() -> None:
    """``std_priors``' covariance: (S / (tau sigma^2) + prior information)^-1 over the free
    parameters, the priors' information not divided by tau; a frozen parameter keeps zero."""
    from types import SimpleNamespace

    from mocap_mj.solve.consistency import parameter_covariance

    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 3))
    s_info = a.T @ a  # unit-weight information of 3 parameters [1/m^2 x m^2 noise]
    info = np.zeros((4, 4))
    info[:3, :3] = s_info
    free = np.array([True, True, True, False])
    result = SimpleNamespace(free=free, reduced_information=info, sigma=0.002)
    prior = np.diag([1e4, 0.0, 4e4, 1e6])  # rows of 10 mm, none, 5 mm, frozen [1/m^2]
    tau = 3.0
    cov = parameter_covariance(result, tau=tau, prior_information=prior)  # type: ignore[arg-type]
    expected = np.linalg.inv(s_info / (tau * 0.002**2) + prior[:3, :3])
    np.testing.assert_allclose(cov[:3, :3], expected, rtol=1e-12)
    assert np.all(cov[3] == 0.0) and np.all(cov[:, 3] == 0.0)
