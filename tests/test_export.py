"""Exports (mocap_mj.export, ``mocap-mj export``): read back by OpenSim, ezc3d and ourselves.

OpenSim validation tests skip without the ``[opensim]`` extra.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import ezc3d
import mujoco
import numpy as np
import pytest

from mocap_mj.cli import main
from mocap_mj.clinical.angles import ANGLES
from mocap_mj.export.c3d import c3d_points, write_c3d
from mocap_mj.export.coordinates import (
    coordinate_values,
    model_coordinates,
    qpos_from_coordinates,
)
from mocap_mj.export.mot import coordinates_in_degrees, read_mot, write_mot
from mocap_mj.export.osim import up_rotation, write_osim
from mocap_mj.export.read_result import load_result
from mocap_mj.export.tables import marker_residuals, scale_table_text
from mocap_mj.export.trc import write_trc
from mocap_mj.io import load_markers
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet


def _opensim():  # type: ignore[no-untyped-def]
    pytest.importorskip("opensim", reason="OpenSim validation needs the [opensim] extra")
    from mocap_mj.export.opensim_ik import import_opensim

    return import_opensim()


def _random_qpos(model: mujoco.MjModel, n: int, seed: int, scale: float = 0.4) -> np.ndarray:
    """n random poses: hinges uniform in +-scale rad, balls and root turned by up to ~scale."""
    rng = np.random.default_rng(seed)
    qpos = np.tile(model.qpos0, (n, 1))
    for j in range(model.njnt):
        adr, typ = int(model.jnt_qposadr[j]), int(model.jnt_type[j])
        if typ == int(mujoco.mjtJoint.mjJNT_HINGE):
            qpos[:, adr] = rng.uniform(-scale, scale, n)
            continue
        if typ == int(mujoco.mjtJoint.mjJNT_FREE):
            qpos[:, adr : adr + 3] = rng.normal(size=(n, 3)) * 0.3 + [0.0, 0.0, 1.0]
            adr += 3
        for t in range(n):
            rotvec = rng.normal(size=3) * scale / 2
            mujoco.mju_axisAngle2Quat(
                qpos[t, adr : adr + 4], rotvec / np.linalg.norm(rotvec), np.linalg.norm(rotvec)
            )
    return qpos


@pytest.fixture(scope="module")
def subject() -> tuple[ParameterSet, mujoco.MjModel]:
    """A subject model away from the nominal one (lengths +-5 %, offsets +-1 cm)."""
    pset = ParameterSet()
    rng = np.random.default_rng(3)
    kappa, offsets = pset.split(pset.nominal)
    theta = pset.join(kappa * rng.uniform(0.95, 1.05, kappa.shape), offsets)
    theta[pset.n_kappa :] += rng.uniform(-0.01, 0.01, 3 * pset.n_markers)
    return pset, pset.model_for(theta)


@pytest.fixture(scope="module")
def result(
    subject: tuple[ParameterSet, mujoco.MjModel], tmp_path_factory: pytest.TempPathFactory
) -> Path:
    """A result folder: the subject model, 12 random poses, measured = model markers + 1 mm noise
    with one missing sample."""
    pset, model = subject
    root = tmp_path_factory.mktemp("result")
    rng = np.random.default_rng(5)
    qpos = _random_qpos(model, 12, seed=1)
    fitted, _ = marker_residuals(model, qpos, np.zeros((12, model.nsite, 3)))
    markers = fitted + rng.normal(scale=1e-3, size=fitted.shape)
    markers[4, 7] = np.nan
    spec = mujoco.MjSpec.from_file(str(pset.path))
    for b in range(1, model.nbody):
        spec.body(model.body(b).name).pos = model.body_pos[b]
    for s in range(model.nsite):
        spec.site(model.site(s).name).pos = model.site_pos[s]
    (root / "model.xml").write_text(spec.to_xml())
    times = np.arange(12) / 100.0
    save_motion(root / "motion.npz", Motion(qpos, times, markers, pset.marker_names))
    return root


# ------------------------------------------------------------------------ coordinates
def test_coordinates_round_trip_to_qpos(subject: tuple[ParameterSet, mujoco.MjModel]) -> None:
    _, model = subject
    qpos = _random_qpos(model, 20, seed=2)
    back = qpos_from_coordinates(model, coordinate_values(model, qpos))
    kin = Kinematics(ParameterSet())
    assert np.max(np.abs(kin.difference(qpos, back))) < 1e-12
    assert len(model_coordinates(model)) == model.nv


# ------------------------------------------------------------------------------ .osim
def test_osim_loads_without_warnings_and_markers_match_mjcf(
    subject: tuple[ParameterSet, mujoco.MjModel], tmp_path: Path
) -> None:
    osim = _opensim()
    _, model = subject
    write_osim(tmp_path / "s.osim", model, mass=70.0)
    log = tmp_path / "opensim.log"
    osim.Logger.addFileSink(str(log))
    try:
        omodel = osim.Model(str(tmp_path / "s.osim"))
        state = omodel.initSystem()
    finally:
        osim.Logger.removeFileSink()
    text = log.read_text().lower()
    assert "[warning]" not in text and "[error]" not in text and "loaded model" in text, text
    assert omodel.getTotalMass(state) == pytest.approx(70.0)
    data = mujoco.MjData(model)
    coords = model_coordinates(model)
    flexed = _random_qpos(model, 3, seed=6)
    for adr in rolling.read(model).qposadr:  # the knees' rolling, between the spline's knots
        flexed[:, adr] = np.radians([47.3, 118.9, 137.4])
    for q in [model.qpos0, *_random_qpos(model, 2, seed=4), *flexed]:
        data.qpos[:] = q
        rolling.kinematics(model, data)
        for c, v in zip(coords, coordinate_values(model, q[None])[0], strict=True):
            omodel.getCoordinateSet().get(c.name).setValue(state, float(v), False)
        omodel.realizePosition(state)
        for s in range(model.nsite):
            marker = omodel.getMarkerSet().get(model.site(s).name)
            got = marker.getLocationInGround(state).to_numpy()
            want = up_rotation("y") @ data.site_xpos[s]
            assert np.linalg.norm(got - want) < 1e-4, model.site(s).name  # 0.1 mm
        for g in range(model.ngeom):  # display geometry: OpenSim cylinders run along y
            if model.geom_bodyid[g] == 0:
                continue
            body = omodel.getBodySet().get(model.body(model.geom_bodyid[g]).name)
            frame = osim.PhysicalOffsetFrame.safeDownCast(
                body.getComponent(f"{model.geom(g).name}_frame")
            )
            pose = frame.getTransformInGround(state)
            axis = np.array([pose.R().get(i, 1) for i in range(3)])
            up = up_rotation("y")
            assert np.allclose(pose.p().to_numpy(), up @ data.geom_xpos[g], atol=1e-9)
            assert np.allclose(axis, up @ data.geom_xmat[g].reshape(3, 3)[:, 2], atol=1e-9)


def test_osim_is_written_without_opensim_and_z_up_keeps_gravity(
    subject: tuple[ParameterSet, mujoco.MjModel], tmp_path: Path
) -> None:
    _, model = subject
    write_osim(tmp_path / "z.osim", model, up="z")
    text = (tmp_path / "z.osim").read_text()
    assert "<gravity>0.0 0.0 -9.80665</gravity>" in text
    assert text.count("<Marker ") == model.nsite and text.count("<Coordinate ") == model.nv


# ------------------------------------------------------------------------ .mot, TRC
def test_mot_reads_back_in_opensim_in_degrees(result: Path, tmp_path: Path) -> None:
    src = load_result(result)
    write_mot(tmp_path / "c.mot", src.model, src.motion.times, src.motion.qpos)
    want = coordinates_in_degrees(src.model, src.motion.qpos)
    names, times, values = read_mot(tmp_path / "c.mot")
    assert names == [c.name for c in model_coordinates(src.model)]
    np.testing.assert_allclose(values, want, atol=1e-7)
    osim = _opensim()
    table = osim.TimeSeriesTable(str(tmp_path / "c.mot"))
    assert table.getTableMetaDataAsString("inDegrees") == "yes"
    assert list(table.getColumnLabels()) == names
    got = np.array([table.getDependentColumn(n).to_numpy() for n in names]).T
    np.testing.assert_allclose(got, want, atol=1e-7)
    np.testing.assert_allclose(np.array(table.getIndependentColumn()), times)


@pytest.mark.parametrize("up", ["y", "z"])
def test_trc_reads_back_in_opensim_with_its_up_axis(result: Path, tmp_path: Path, up: str) -> None:
    src = load_result(result)
    m = src.motion
    write_trc(tmp_path / "m.trc", m.marker_names, m.times, m.markers, up=up)
    want = m.markers @ up_rotation(up).T * 1e3
    osim = _opensim()
    table = osim.TimeSeriesTableVec3(str(tmp_path / "m.trc"))  # through TRCFileAdapter
    assert table.getTableMetaDataAsString("Units") == "mm"
    assert list(table.getColumnLabels()) == list(m.marker_names)
    got = np.array(
        [
            [table.getDependentColumn(n)[t].to_numpy() for n in m.marker_names]
            for t in range(len(m.times))
        ]
    )
    np.testing.assert_allclose(got, want, atol=1e-5, equal_nan=True)
    assert np.isnan(got[4, 7]).all()


# ---------------------------------------------------------------------------- C3D
def test_c3d_reads_back_with_the_same_values(result: Path, tmp_path: Path) -> None:
    src = load_result(result)
    write_c3d(tmp_path / "r.c3d", src)
    labels, _, want = c3d_points(src)
    c3d = ezc3d.c3d(str(tmp_path / "r.c3d"))
    point = c3d["parameters"]["POINT"]
    assert point["LABELS"]["value"] == labels
    assert point["RATE"]["value"][0] == pytest.approx(100.0)
    assert point["UNITS"]["value"] == ["mm"]
    assert point["ANGLE_UNITS"]["value"] == ["deg"]
    assert point["ANGLES"]["value"] == [s + n for n in ANGLES for s in "LR"]
    got = np.transpose(c3d["data"]["points"][:3], (2, 1, 0))
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-3, equal_nan=True)  # float32
    assert np.isnan(got[4, 7]).all() and np.isfinite(got[4, 8]).all()
    # Our reader takes the measured markers only (model markers, centres, angles are not).
    traj = load_markers(tmp_path / "r.c3d")
    assert traj.names == src.motion.marker_names


# ------------------------------------------------------------------ tables and CLI
def test_scale_table_reads_the_identified_lengths(tmp_path: Path) -> None:
    pset = ParameterSet()
    theta = pset.nominal.copy()
    k = pset.index("thigh_length_l")
    theta[k] *= 1.1
    rows = scale_table_text(pset.model_for(theta), pset.model).splitlines()
    table = {r.split(",")[0]: r.split(",") for r in rows[1:]}
    assert float(table["thigh_l"][5]) == pytest.approx(1.1, abs=1e-4)
    assert float(table["thigh_l"][4]) == pytest.approx(pset.nominal[k] * 1.1e3, abs=0.01)
    assert all(float(r[5]) == pytest.approx(1.0) for n, r in table.items() if n != "thigh_l")


def test_export_command_writes_every_format(result: Path, tmp_path: Path) -> None:
    assert main(["export", str(result), "--to", "all", "--out", str(tmp_path / "all")]) == 0
    files = {p.name for p in (tmp_path / "all").iterdir()}
    assert {"subject.osim", "coordinates.mot", "angles.csv", "residuals.csv"} <= files
    assert (
        "<model_file>subject.osim</model_file>" in (tmp_path / "all" / "ik_setup.xml").read_text()
    )
    src = load_result(result)
    rows = (tmp_path / "all" / "residuals.csv").read_text().splitlines()
    assert rows[0].split(",")[2] == "LASI_mm" and len(rows) == 13
    _, distance = marker_residuals(src.model, src.motion.qpos, src.motion.markers)
    cells = rows[5].split(",")[2:]
    assert cells[7] == ""  # the missing sample
    assert float(cells[0]) == pytest.approx(distance[4, 0] * 1e3, abs=1e-4)
    assert main(["export", str(result), "--out", str(tmp_path / "m.trc")]) == 0
    assert load_markers(tmp_path / "m.trc").n_frames == 12


def test_osim_masses_sum_to_the_mass_the_result_records(result: Path, tmp_path: Path) -> None:
    """The .osim's bodies sum to the subject mass in the result's summary.json (the measurement
    the identification used), and --mass overrides it."""
    folder = tmp_path / "result"
    shutil.copytree(result, folder)
    mass = {"value": 85.0, "unit": "kg", "source": "subject.yaml: mass"}
    (folder / "summary.json").write_text(json.dumps({"measurements": {"mass": mass}}))

    def total(path: Path) -> float:
        return sum(float(m) for m in re.findall(r"<mass>([^<]+)</mass>", path.read_text()))

    assert main(["export", str(folder), "--to", "osim", "--out", str(tmp_path / "a.osim")]) == 0
    assert total(tmp_path / "a.osim") == pytest.approx(85.0, rel=1e-9)
    args = ["export", str(folder), "--to", "osim", "--out", str(tmp_path / "b.osim")]
    assert main([*args, "--mass", "60"]) == 0
    assert total(tmp_path / "b.osim") == pytest.approx(60.0, rel=1e-9)


def test_ik_setup_loads_in_opensim(result: Path, tmp_path: Path) -> None:
    osim = _opensim()
    assert main(["export", str(result), "--to", "all", "--out", str(tmp_path / "all")]) == 0
    tool = osim.InverseKinematicsTool(str(tmp_path / "all" / "ik_setup.xml"))
    assert tool.get_model_file() == "subject.osim"
    assert tool.getMarkerDataFileName() == "markers.trc"
    assert tool.getIKTaskSet().getSize() == 39


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--out", "x.csv"], "cannot tell the format"),
        (["--to", "osim"], "--out: expected"),
        (["--to", "osim", "--out", "a.osim", "--mass", "-3"], "positive number of kilograms"),
        (["--to", "osim", "--out", "a.osim", "--model", "x.xml"], "--model: only for --to glb"),
    ],
)
def test_export_errors_are_one_line(
    result: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list, message: str
) -> None:
    args = [str(tmp_path / a) if a.endswith((".csv", ".osim")) else a for a in args]
    assert main(["export", str(result), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1, err


# ------------------------------------------------------------------- OpenSim IK
def test_opensim_ik_reproduces_our_joint_angles(tmp_path: Path) -> None:
    """Noise-free synthetic markers of a subject model: OpenSim's IK on the exported .osim
    returns the truth joint angles within 0.5 degree."""
    _opensim()
    from mocap_mj.capture.marker_set import marked_bodies
    from mocap_mj.export.opensim_ik import run_opensim_ik
    from mocap_synth.config import SynthConfig
    from mocap_synth.experiment import synthesize

    exp = synthesize(SynthConfig(frames=8, rate=25.0, noise_mm=0.0, seed=2))
    model = exp.pset.model_for(exp.theta_true)
    # OpenSim's IK is local, from the default pose (palms forward): keep the forearms within
    # 60 degrees of it, the branch it converges to (the ROM motion sweeps the whole
    # -160..30 degree pronation range; at -131 degrees OpenSim turns the other way).
    kin = Kinematics(exp.pset)
    kin.set_theta(exp.theta_true)
    qpos = np.array(exp.qpos, dtype=float)
    for side in "lr":
        adr = int(model.jnt_qposadr[model.joint(f"pronation_{side}").id])
        qpos[:, adr] = np.clip(qpos[:, adr], np.radians(-60), np.radians(30))
    got = run_opensim_ik(
        model, exp.marker_names, exp.times, kin.marker_positions(qpos), tmp_path, accuracy=1e-8
    )
    dv = kin.difference(qpos, got.qpos)
    # Joints no marker sees (the MTP: TOE is on the foot) are free in OpenSim's IK too.
    seen = marked_bodies(model)[model.dof_bodyid]
    assert np.degrees(np.max(np.abs(dv[:, 3:][:, seen[3:]]))) < 0.5
    assert np.max(np.abs(dv[:, :3])) < 1e-3  # root position [m]


def test_every_public_name_resolves() -> None:
    import mocap_mj.export as export

    assert all(hasattr(export, name) for name in export.__all__)


def test_unsolved_frames_are_empty_in_every_table(result: Path, tmp_path: Path) -> None:
    src = load_result(result)
    qpos = src.motion.qpos.copy()
    qpos[2] = np.nan  # a frame IK could not solve
    root = tmp_path / "r"
    root.mkdir()
    (root / "model.xml").write_text(src.model_path.read_text())
    m = src.motion
    save_motion(root / "motion.npz", Motion(qpos, m.times, m.markers, m.marker_names))
    assert main(["export", str(root), "--to", "all", "--out", str(tmp_path / "all")]) == 0
    for name in ("angles.csv", "residuals.csv"):
        row = (tmp_path / "all" / name).read_text().splitlines()[3].split(",")
        assert row[:2] == ["2", "0.020000"] and set(row[2:]) == {""}, name
    _, _, values = read_mot(tmp_path / "all" / "coordinates.mot")
    assert np.isnan(values[2]).all() and np.isfinite(values[3]).all()
    c3d = ezc3d.c3d(str(tmp_path / "all" / "result.c3d"))
    points = c3d["data"]["points"][:3, :, 2]
    n = len(m.marker_names)
    assert np.isfinite(points[:, :n]).all() and np.isnan(points[:, n:]).all()


@pytest.mark.slow
def test_export_angles_compare_reports_offset_and_correlation(result: Path, tmp_path: Path) -> None:
    """--compare against a plug-in-gait folder (frames numbered from 694) whose knee flexion
    is ours less 5 deg: RMS 5, offset +5, correlation 1 for that column, 0 elsewhere."""
    out = tmp_path / "a.csv"
    assert main(["export", str(result), "--to", "angles", "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    assert header[:2] == ["frame", "time_s"] and header[2] == "LPelvisAngles_X"
    k = header.index("LKneeAngles_X")
    rows = [r.split(",") for r in lines[1:]]
    for r in rows:  # the recording's frame numbers, as plug-in-gait writes them
        r[0] = str(int(r[0]) + 694)
        r[k] = f"{float(r[k]) - 5.0:.4f}" if r[k] else ""
    pig = tmp_path / "pig"
    pig.mkdir()
    (pig / "angles.csv").write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")
    cmd = ["export", str(result), "--to", "angles", "--out", str(tmp_path / "b.csv")]
    assert main([*cmd, "--compare", str(pig), "--json"]) == 0
    table = (tmp_path / "b_vs_plug_in_gait.md").read_text()
    assert (tmp_path / "b_vs_plug_in_gait.png").is_file()
    cells = {r.split("|")[1].strip(): r.split("|")[2:5] for r in table.splitlines()[6:]}
    rms, offset, corr = (float(v) for v in cells["LKneeAngles_X"])
    assert (rms, offset, corr) == (pytest.approx(5.0), pytest.approx(5.0), pytest.approx(1.0))
    rms, offset, corr = (float(v) for v in cells["LHipAngles_X"])
    assert abs(rms) < 0.05 and abs(offset) < 0.05 and corr == pytest.approx(1.0)


def test_export_compare_errors_are_one_line(
    result: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "a.csv")
    assert main(["export", str(result), "--to", "angles", "--out", out, "--compare", "/nope"]) != 0
    err = capsys.readouterr().err.strip()
    assert "--compare /nope: no angles.csv" in err and len(err.splitlines()) == 1
    assert main(["export", str(result), "--to", "mot", "--out", out, "--compare", "/nope"]) != 0
    assert "--compare: only for --to angles" in capsys.readouterr().err
