"""mocap_viewer: playback data, scene primitives, keys, meshes, GLB export, and (in
subprocesses, with an OpenGL platform) offscreen rendering and the interactive viewer.

GL tests run the CLI in a subprocess with ``MUJOCO_GL`` defaulting to ``egl`` (MuJoCo chooses its
OpenGL platform when first imported, so the test process itself cannot switch). When rendering
is unavailable they skip with the reason, unless ``RENDER_REQUIRED=1``, which makes them fail.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from mocap_mj import Kinematics, MocapError, ParameterSet
from mocap_mj.cli import main
from mocap_mj.errors import InputFileError, ShapeError
from mocap_mj.pipeline.motion import Motion, load_motion, save_motion
from mocap_viewer import interactive as ia
from mocap_viewer.glb import export_glb, frame_node
from mocap_viewer.meshes import geom_meshes, geom_poses, primitives_mesh
from mocap_viewer.playback import (
    Playback,
    load_ghost,
    load_playback,
    parse_frame,
    parse_frames,
)
from mocap_viewer.render import camera_id
from mocap_viewer.scene import (
    Layers,
    Segment,
    Sphere,
    Style,
    add_ghost,
    add_primitives,
    frame_primitives,
    residual_rgba,
)

RENDER_REQUIRED = os.environ.get("RENDER_REQUIRED") == "1"
N_FRAMES = 30
RATE = 30.0
MISSING = (slice(4, 7), 3)  # frames 4-6 of marker 3 are not seen
N_BODY_GEOMS = 24  # the humanoid's capsules/spheres, the floor excluded


def _write_result(root: Path, theta_scale: float = 1.0) -> Path:
    """A result folder: smooth poses of the humanoid, their noisy markers, and its model."""
    root.mkdir(parents=True, exist_ok=True)
    kin = Kinematics()
    rng = np.random.default_rng(7)
    t = np.arange(N_FRAMES) / RATE
    dv = np.zeros((N_FRAMES, kin.nv))
    dv[:, 0] = 0.1 * t  # drift forward slowly
    amp = rng.uniform(-0.5, 0.5, kin.nv)
    phase = rng.uniform(0, 2 * np.pi, kin.nv)
    dv[:, 6:] = amp[6:] * np.sin(2 * np.pi * 0.8 * t[:, None] + phase[6:])
    qpos = kin.integrate(np.tile(np.array(kin.model.qpos0), (N_FRAMES, 1)), dv)
    markers = kin.marker_positions(qpos) + rng.normal(0.0, 0.004, (N_FRAMES, kin.n_markers, 3))
    markers[MISSING] = np.nan
    pset = ParameterSet()
    theta = pset.nominal.copy()
    theta[: pset.n_kappa] *= theta_scale
    pset.export_mjcf(root / "model.xml", theta)
    save_motion(root / "motion.npz", Motion(qpos, t, markers, pset.marker_names))
    return root


@pytest.fixture(scope="module")
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _write_result(tmp_path_factory.mktemp("result"))


@pytest.fixture(scope="module")
def playback(result: Path) -> Playback:
    return load_playback(result)


# ------------------------------------------------------------------------ playback
def test_playback_residuals_rmse_and_worst_frame(playback: Playback) -> None:
    assert playback.n_frames == N_FRAMES
    assert playback.rate == pytest.approx(RATE)
    res = playback.residuals
    assert res.shape == (N_FRAMES, 39)
    assert np.all(np.isnan(res[MISSING]))
    # 4 mm noise per axis: about 4 * sqrt(3) mm per marker.
    assert 0.004 < np.nanmean(playback.frame_rmse) < 0.010
    assert playback.worst_frame == int(np.nanargmax(playback.frame_rmse))
    assert playback.fitted


def test_playback_maps_markers_by_name(result: Path, tmp_path: Path, playback: Playback) -> None:
    motion = load_motion(result / "motion.npz")
    order = np.arange(len(motion.marker_names))[::-1]
    shuffled = Motion(
        motion.qpos,
        motion.times,
        motion.markers[:, order],
        tuple(motion.marker_names[i] for i in order),
    )
    save_motion(tmp_path / "motion.npz", shuffled)
    pb = load_playback(model=result / "model.xml", motion=tmp_path / "motion.npz")
    np.testing.assert_array_equal(pb.measured, playback.measured)


def test_playback_from_a_marker_file(result: Path, tmp_path: Path, playback: Playback) -> None:
    from mocap_mj.io import MarkerTrajectory, save_csv

    motion = load_motion(result / "motion.npz")
    csv = tmp_path / "markers.csv"
    save_csv(csv, MarkerTrajectory(motion.times, motion.markers, motion.marker_names, RATE))
    rest = load_playback(model=result / "model.xml", markers=csv)
    assert not rest.fitted and rest.n_frames == N_FRAMES
    np.testing.assert_allclose(rest.qpos, np.tile(rest.model.qpos0, (N_FRAMES, 1)))
    np.testing.assert_allclose(rest.measured, playback.measured, atol=1e-6)
    assert not any(isinstance(p, Segment) for p in frame_primitives(rest, 0, Layers()))
    both = load_playback(model=result / "model.xml", motion=result / "motion.npz", markers=csv)
    assert both.fitted
    np.testing.assert_allclose(both.frame_rmse, playback.frame_rmse, atol=1e-6)


def test_playback_errors(result: Path, tmp_path: Path) -> None:
    with pytest.raises(MocapError, match="not a result folder"):
        load_playback(tmp_path)
    with pytest.raises(MocapError, match="either a result folder"):
        load_playback(result, model=result / "model.xml")
    with pytest.raises(MocapError, match="nothing to show"):
        load_playback()
    (tmp_path / "small.xml").write_text(
        '<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>'
    )
    with pytest.raises(MocapError, match=r"motion\.npz: qpos has 55 columns, the model has nq = 7"):
        load_playback(model=tmp_path / "small.xml", motion=result / "motion.npz")


def test_ghost_nominal_truth_and_mismatch(playback: Playback, result: Path, tmp_path: Path) -> None:
    assert load_ghost("nominal", playback.model).model.nq == playback.model.nq
    with pytest.raises(InputFileError, match=r"truth_model\.xml"):
        load_ghost("truth", playback.model, result)
    (tmp_path / "synth").mkdir()
    shutil.copy(result / "model.xml", tmp_path / "synth" / "truth_model.xml")
    ghost = load_ghost("truth", playback.model, tmp_path)
    assert ghost.path.name == "truth_model.xml"
    (tmp_path / "small.xml").write_text(
        "<mujoco><worldbody><body><joint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    with pytest.raises(ShapeError, match="nq"):
        load_ghost(str(tmp_path / "small.xml"), playback.model)


def test_parse_frames_and_frame(playback: Playback) -> None:
    assert parse_frames("0:10:2", 30) == [0, 2, 4, 6, 8]
    assert parse_frames(":", 5) == [0, 1, 2, 3, 4]
    assert parse_frames("-3:", 10) == [7, 8, 9]
    for bad in ("a:b", "5:5", "::0", "1", "1:2:3:4"):
        with pytest.raises(MocapError):
            parse_frames(bad, 10)
    assert parse_frame("worst", playback) == playback.worst_frame
    assert parse_frame("-1", playback) == N_FRAMES - 1
    for bad in ("99", "-31", "x"):
        with pytest.raises(MocapError):
            parse_frame(bad, playback)


# --------------------------------------------------------------------------- scene
def test_frame_primitives_follow_layers(playback: Playback) -> None:
    frame = 5  # marker 3 is missing
    prims = frame_primitives(playback, frame, Layers())
    spheres = [p for p in prims if isinstance(p, Sphere)]
    segments = [p for p in prims if isinstance(p, Segment)]
    assert len(spheres) == 39 + 38
    assert len(segments) == 38
    lengths = [np.linalg.norm(s.end - s.start) for s in segments]
    seen = np.isfinite(playback.residuals[frame])
    np.testing.assert_allclose(sorted(lengths), sorted(playback.residuals[frame][seen]))
    assert frame_primitives(playback, frame, Layers(markers=False, residuals=False)) == []
    only_res = frame_primitives(playback, frame, Layers(markers=False))
    assert all(isinstance(p, Segment) for p in only_res)
    assert residual_rgba(0.0, 0.03)[:2] == (0.0, 1.0)
    assert residual_rgba(0.05, 0.03)[:2] == (1.0, 0.0)
    assert residual_rgba(0.015, 0.03)[:2] == (1.0, 1.0)


def test_add_primitives_and_ghost_to_mjv_scene(playback: Playback) -> None:
    scn = mujoco.MjvScene(playback.model, maxgeom=400)
    prims = frame_primitives(playback, 0, Layers())
    assert add_primitives(scn, prims) == len(prims) == scn.ngeom
    seg_index = next(i for i, p in enumerate(prims) if isinstance(p, Segment))
    geom, seg = scn.geoms[seg_index], prims[seg_index]
    assert geom.type == mujoco.mjtGeom.mjGEOM_CAPSULE
    np.testing.assert_allclose(geom.pos, (seg.start + seg.end) / 2, atol=1e-6)
    np.testing.assert_allclose(2 * geom.size[2], np.linalg.norm(seg.end - seg.start), atol=1e-6)
    assert scn.geoms[0].type == mujoco.mjtGeom.mjGEOM_SPHERE
    ghost = load_ghost("nominal", playback.model)
    before = scn.ngeom
    assert add_ghost(scn, ghost, playback.qpos[0]) == N_BODY_GEOMS
    assert scn.ngeom == before + N_BODY_GEOMS
    assert scn.geoms[scn.ngeom - 1].rgba[3] == pytest.approx(Style().ghost_rgba[3])
    full = mujoco.MjvScene(playback.model, maxgeom=10)
    assert add_primitives(full, prims) == 10  # the rest is dropped, no error


def test_camera_names(playback: Playback) -> None:
    assert camera_id(playback.model, None) == playback.model.camera("front").id
    assert camera_id(playback.model, "free") == -1
    with pytest.raises(MocapError, match=r"unknown camera 'top'.*front, side, free"):
        camera_id(playback.model, "top")


# ---------------------------------------------------------------------------- keys
def test_controls_keys_and_clock() -> None:
    times = np.arange(10) / 10.0
    c = ia.Controls(times, worst=7)
    assert c.playing and c.frame == 0
    c.on_key(ia.KEY_SPACE)
    assert not c.playing
    c.on_key(ia.KEY_LEFT)
    assert c.frame == 9  # wraps
    c.on_key(ia.KEY_RIGHT)
    c.on_key(ia.KEY_RIGHT)
    assert c.frame == 1 and not c.playing
    for _ in range(10):
        c.on_key(ia.KEY_UP)
    assert c.speed == ia.SPEED_MAX
    for _ in range(20):
        c.on_key(ia.KEY_DOWN)
    assert c.speed == ia.SPEED_MIN
    c.on_key(ia.KEY_W)
    assert c.frame == 7
    for key, layer in ((ia.KEY_M, "markers"), (ia.KEY_R, "residuals"), (ia.KEY_G, "ghost")):
        c.on_key(key)
        assert getattr(c.layers, layer) is False
    assert c.take_pressed()[-3:] == [ia.KEY_M, ia.KEY_R, ia.KEY_G]
    assert c.take_pressed() == []
    c.on_key(ia.KEY_SPACE)
    c.speed = 1.0
    c.advance(0.25)
    assert c.frame == 9
    c.advance(0.1)  # past the last frame: back to the start
    assert c.frame == 0


# ------------------------------------------------------------------- meshes, GLB
def test_geom_meshes_match_the_model(playback: Playback) -> None:
    model = playback.model
    meshes = geom_meshes(model)
    assert len(meshes) == N_BODY_GEOMS + 1
    floor = next(g for g in meshes if g.static)
    assert floor.texture is not None and floor.mesh.visual.uv.shape == (4, 2)
    capsule = next(g for g in meshes if g.name == "thigh_l")
    radius, half = model.geom_size[capsule.geom_id][:2]
    np.testing.assert_allclose(capsule.mesh.extents, [2 * radius, 2 * radius, 2 * (half + radius)])
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    pose = geom_poses(data, [capsule.geom_id])[0]
    np.testing.assert_allclose(pose[:3, 3], data.geom_xpos[capsule.geom_id])
    mesh = primitives_mesh(frame_primitives(playback, 0, Layers()))
    assert mesh is not None and mesh.visual.vertex_colors.shape == (len(mesh.vertices), 4)
    assert primitives_mesh([]) is None


def test_export_glb_reloads_with_one_node_set_per_frame(
    result: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import trimesh

    out = tmp_path / "scene.glb"
    assert main(["export", str(result), "--glb", str(out), "--frames", "0:6:2", "--json"]) == 0
    assert '"geometry_nodes": 72' in capsys.readouterr().out
    scene = trimesh.load(out)
    assert isinstance(scene, trimesh.Scene)
    assert len(scene.graph.nodes_geometry) == 3 * N_BODY_GEOMS
    assert len(scene.geometry) == N_BODY_GEOMS  # meshes shared by the frames
    assert scene.metadata["frames"] == [0, 2, 4]
    assert {frame_node(k) for k in (0, 2, 4)} <= set(scene.graph.nodes)
    # A node's transform is its geom's pose at that frame.
    pb = load_playback(result)
    data = mujoco.MjData(pb.model)
    data.qpos[:] = pb.qpos[4]
    mujoco.mj_kinematics(pb.model, data)
    g = pb.model.geom("head").id
    matrix, _ = scene.graph.get(f"{frame_node(4)}/head")
    np.testing.assert_allclose(matrix[:3, 3], data.geom_xpos[g], atol=1e-6)


def test_export_glb_with_markers_ghost_and_floor(playback: Playback, tmp_path: Path) -> None:
    import trimesh

    ghost = load_ghost("nominal", playback.model)
    summary = export_glb(playback, tmp_path / "a.glb", [3], markers=True, ghost=ghost, floor=True)
    assert summary["geometry_nodes"] == 2 * N_BODY_GEOMS + 2
    scene = trimesh.load(tmp_path / "a.glb")
    assert isinstance(scene, trimesh.Scene)
    assert len(scene.graph.nodes_geometry) == 2 * N_BODY_GEOMS + 2


# ----------------------------------------------------------------------- CLI errors
def test_cli_errors_are_one_line(
    result: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cases = [
        (["render", str(result), "--out", str(tmp_path / "a.txt")], "expected a .png"),
        (["render", str(result), "--out", str(tmp_path / "a.png"), "--frames", "0:3"], "one frame"),
        (["render", str(tmp_path), "--out", str(tmp_path / "a.png")], "not a result folder"),
        (["render", str(result), "--out", str(tmp_path / "a.png"), "--camera", "x"], "camera"),
        (["export", str(result), "--glb", str(tmp_path / "a.obj")], "expected a .glb"),
        (["export", str(result), "--glb", str(tmp_path / "a.glb"), "--frame", "77"], "range"),
        (["view", str(result), "--ghost", "truth", "--duration", "1"], "truth_model.xml"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert message in err and "Traceback" not in err and len(err.splitlines()) == 1, err


# ------------------------------------------------------------- GL, in subprocesses
def _gl_env() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    if env["MUJOCO_GL"] in ("egl", "osmesa"):
        env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    return env


def _cli(
    args: list[str], env: dict[str, str] | None = None, wrap: list[str] | None = None
) -> subprocess.CompletedProcess[str]:
    cmd = [*(wrap or []), sys.executable, "-m", "mocap_mj", *args]
    return subprocess.run(
        cmd, env=env or _gl_env(), capture_output=True, text=True, timeout=240, check=False
    )


def _render(args: list[str]) -> subprocess.CompletedProcess[str]:
    """Run ``mocap-mj render``; skip (or fail if RENDER_REQUIRED=1) when GL is unavailable."""
    proc = _cli(["render", *args])
    if proc.returncode == 2 and "cannot render" in proc.stderr:
        line = next(x for x in proc.stderr.splitlines() if "cannot render" in x)
        reason = f"offscreen rendering unavailable: {line}"
        if RENDER_REQUIRED:
            pytest.fail(reason)
        pytest.skip(reason)
    assert proc.returncode == 0, proc.stderr
    return proc


def _body_mask(rgb: np.ndarray) -> np.ndarray:
    """Pixels of the skin-coloured capsules (floor is blue-grey, background black)."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return (r > g) & (g > b) & (r - b > 30) & (r > 90)


def _read_png(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def _check_frame(rgb: np.ndarray, width: int, height: int, body: bool = True) -> None:
    assert rgb.shape == (height, width, 3)
    assert rgb.std() > 10 and len(np.unique(rgb.reshape(-1, 3), axis=0)) > 50  # not blank
    if not body:
        return
    mask = _body_mask(rgb)
    assert mask.mean() > 0.005, "no body pixels"
    ys, xs = np.nonzero(mask)
    # The camera tracks the body: its pixels sit around the middle of the image.
    assert 0.3 < xs.mean() / width < 0.7
    assert 0.15 < ys.mean() / height < 0.75
    assert xs.min() > 0.1 * width and xs.max() < 0.9 * width


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["mujoco", "pyrender"])
def test_render_png_shows_the_posed_body(result: Path, tmp_path: Path, backend: str) -> None:
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    common = ["--size", "320x240", "--no-text", "--backend", backend]
    _render([str(result), "--out", str(first), "--frame", "0", *common])
    _render([str(result), "--out", str(second), "--frame", "18", *common, "--ghost", "nominal"])
    a, b = _read_png(first), _read_png(second)
    _check_frame(a, 320, 240)
    _check_frame(b, 320, 240, body=False)  # the translucent ghost tints the body
    changed = np.abs(a.astype(int) - b.astype(int)).sum(axis=2) > 30
    assert changed.mean() > 0.005, "two different poses rendered the same image"


@pytest.mark.slow
def test_render_mp4_reads_back(result: Path, tmp_path: Path) -> None:
    import imageio.v2 as imageio

    out = tmp_path / "clip.mp4"
    proc = _render([str(result), "--out", str(out), "--frames", "2:14", "--fast",
                    "--size", "161x120", "--json"])  # fmt: skip
    assert '"frames": 12' in proc.stdout
    reader: Any = imageio.get_reader(out)
    try:
        frames = [frame for frame in reader.iter_data()]
        assert reader.get_meta_data()["fps"] == pytest.approx(RATE)
    finally:
        reader.close()
    assert len(frames) == 12
    assert frames[0].shape == (120, 162, 3)  # width rounded up to even for H.264
    assert frames[0].std() > 10


@pytest.mark.slow
def test_render_gif_reads_back(result: Path, tmp_path: Path) -> None:
    from PIL import Image

    out = tmp_path / "clip.gif"
    _render([str(result), "--out", str(out), "--frames", "0:20:2", "--fast",
             "--size", "160x120"])  # fmt: skip
    with Image.open(out) as im:
        assert getattr(im, "n_frames", 1) == 10 and im.size == (160, 120)
        assert im.info["duration"] == 70  # 15 fps (every other frame of 30 Hz), in 10 ms units
    assert not list(tmp_path.glob(".*tmp*")), "temporary files left behind"


@pytest.mark.slow
def test_viewer_runs_under_xvfb(result: Path) -> None:
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        if RENDER_REQUIRED:
            pytest.fail("xvfb-run not found (apt: xvfb xauth)")
        pytest.skip("xvfb-run not found (apt: xvfb xauth)")
    env = _gl_env()
    env.pop("DISPLAY", None)
    proc = _cli(
        ["view", str(result), "--duration", "2", "--ghost", "nominal", "--json"],
        env=env,
        wrap=[xvfb, "-a", "-s", "-screen 0 800x600x24"],
    )
    if proc.returncode == 2 and "viewer" in proc.stderr and not RENDER_REQUIRED:
        pytest.skip(f"the viewer cannot open a window: {proc.stderr.strip().splitlines()[-1]}")
    assert proc.returncode == 0, proc.stderr
    assert '"seconds"' in proc.stdout
