"""Plug-in Gait kinetics (mocap_mj.clinical.kinetics): the Newton-Euler recursion against
analytic loads of a known motion, and the whole pipeline against Vicon Nexus' own kinetics
on a copy of the shared Plug-in Gait trial stripped of Nexus' outputs (skipped without it)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.centre_of_mass import trunk_points, with_trunk
from mocap_mj.clinical.kinetics import (
    DEMPSTER,
    GRAVITY,
    ChainLoads,
    Load,
    PlateChoice,
    angular_velocity,
    leg_loads,
    newton_euler,
    trial_kinetics,
    trunk_kinetics,
)
from mocap_mj.clinical.segments import Segment
from mocap_mj.errors import MocapError
from mocap_mj.io.load import load_markers
from mocap_mj.io.plates import read_plates, recorded_ground_reactions

SHARED = Path(__file__).resolve().parents[2] / "shared"
TRIAL = SHARED / "data" / "real" / "Movement_trial.c3d"
STRIP = SHARED / "tools" / "strip_outputs.py"
RATE = 120.0


def _rot_y(theta: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about the lab's y by ``theta`` (T,) [rad]."""
    c, s = np.cos(theta), np.sin(theta)
    r = np.zeros((len(theta), 3, 3))
    r[:, 0, 0], r[:, 0, 2], r[:, 1, 1], r[:, 2, 0], r[:, 2, 2] = c, s, 1.0, -s, c
    return r


def _still_leg(n: int) -> tuple[dict[str, Segment], dict[str, np.ndarray]]:
    """A standing leg, the same in every frame: toe, ankle, knee, hip [m], upright frames."""
    pts = {
        "toe": np.array([0.15, 0.1, 0.03]),
        "ankle": np.array([0.0, 0.1, 0.08]),
        "knee": np.array([0.02, 0.1, 0.5]),
        "hip": np.array([0.0, 0.1, 0.92]),
    }
    eye = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    tile = {k: np.tile(v, (n, 1)) for k, v in pts.items()}
    segs = {
        "foot_l": Segment(tile["toe"], eye),
        "tibia_l": Segment(tile["ankle"], eye),
        "femur_l": Segment(tile["knee"], eye),
        "pelvis": Segment(tile["hip"], eye),
    }
    centres = {f"{j}_l": tile[j] for j in ("ankle", "knee", "hip")}
    return segs, centres


def test_static_stance_moments_are_r_cross_f() -> None:
    """A still leg: every joint's moment is minus the moment about it of the ground reaction
    and of the weights below it, exactly; the forces balance the loads."""
    n, mass = 20, 70.0
    segs, centres = _still_leg(n)
    grf = np.tile([30.0, -12.0, 650.0], (n, 1))
    cop = np.tile([0.08, 0.12, 0.0], (n, 1))
    free = np.tile([0.0, 0.0, 1.5], (n, 1))
    loads = leg_loads(
        segs, centres, "l", body_mass=mass, rate=RATE, grf=grf, cop=cop, free_moment=free
    )
    g = np.array([0.0, 0.0, -GRAVITY])
    chain = (("foot", "ankle", "toe"), ("tibia", "knee", "ankle"), ("femur", "hip", "knee"))
    pts = {k: centres[f"{k}_l"][0] for k in ("ankle", "knee", "hip")}
    pts["toe"] = segs["foot_l"].origin[0]
    weights = []  # (point, force) of every load below the joint
    for name, joint, distal in chain:
        body = DEMPSTER[name]
        com = pts[distal] + body.com * (pts[joint] - pts[distal])
        if name == "foot":  # along the foot frame's z (here the lab's) from the ankle centre
            length = np.linalg.norm(pts["ankle"] - pts["toe"])
            com = pts["ankle"] - (1.0 - body.com) * length * np.array([0.0, 0.0, 1.0])
        weights.append((com, body.mass * mass * g))
        at = pts[joint]
        moment = -(np.cross(cop[0] - at, grf[0]) + free[0])
        moment -= sum(np.cross(c - at, w) for c, w in weights)
        force = -(grf[0] + sum(w for _, w in weights))
        mid = n // 2
        np.testing.assert_allclose(loads.moment[joint][mid], moment, atol=1e-9)
        np.testing.assert_allclose(loads.force[joint][mid], force, atol=1e-9)
    # the derivatives' stencils (two five-point differences) leave four frames each end
    assert np.isnan(loads.moment["ankle"][3]).all() and np.isfinite(loads.moment["ankle"][4]).all()


def test_swinging_segment_matches_the_analytic_dynamics() -> None:
    """A segment swinging about a fixed pivot, theta = A sin(2 pi f t) about y: the pivot's
    moment is I_pivot theta'' + the weight's moment, the force m (a - g), to the finite
    differences' accuracy (five-point, 120 Hz, a 1 Hz swing)."""
    t = np.arange(240) / RATE
    amp, w = 0.6, 2 * np.pi * 1.0
    theta = amp * np.sin(w * t)
    dd = -amp * w**2 * np.sin(w * t)
    d1 = amp * w * np.cos(w * t)
    axes = _rot_y(theta)
    m, r, inertia = 4.0, 0.25, np.array([0.05, 0.05, 0.0])
    pivot = np.zeros((len(t), 3))
    com = -r * axes[:, :, 2]  # the centre of mass r below the pivot along -z of the segment
    force, moment = newton_euler(
        mass=m,
        com=com,
        inertia=inertia,
        axes=axes,
        rate=RATE,
        proximal=pivot,
        distal=Load(np.zeros_like(pivot), np.zeros_like(pivot), pivot),
    )
    ok = slice(4, -4)
    np.testing.assert_allclose(angular_velocity(axes, RATE)[ok, 1], d1[ok], atol=1e-4)
    expected_my = (inertia[1] + m * r**2) * dd + m * GRAVITY * r * np.sin(theta)
    np.testing.assert_allclose(moment[ok, 1], expected_my[ok], atol=1e-3)
    np.testing.assert_allclose(moment[ok][:, [0, 2]], 0.0, atol=1e-9)
    acc = np.stack([-r * (dd * np.cos(theta) - d1**2 * np.sin(theta)), 0 * t,
                    r * (dd * np.sin(theta) + d1**2 * np.cos(theta))], axis=1)  # fmt: skip
    np.testing.assert_allclose(force[ok], m * (acc[ok] + [0, 0, GRAVITY]), atol=2e-3)


def _nexus(path: Path) -> dict[str, np.ndarray]:
    c3d = ezc3d.c3d(str(path))
    labels = [s.strip() for s in c3d["parameters"]["POINT"]["LABELS"]["value"]]
    pts = c3d["data"]["points"][:3]
    return {n: pts[:, i, :].T.copy() for i, n in enumerate(labels)}


@pytest.fixture(scope="module")
def stripped(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not TRIAL.exists() or not STRIP.exists():
        pytest.skip(f"{TRIAL} or {STRIP} (shared real recording and tool) not present")
    out = tmp_path_factory.mktemp("kinetics") / "stripped.c3d"
    subprocess.run([sys.executable, str(STRIP), str(TRIAL), str(out)], check=True,
                   capture_output=True)  # fmt: skip
    return out


def _ours(
    path: Path, counted: set[int] | None, *, auto: bool = False, trunk: bool = False
) -> dict[str, np.ndarray]:
    traj = load_markers(path)
    subject = pig_from_c3d(path)
    result = plug_in_gait(traj, subject)
    markers = {n: traj.positions[:, i] for i, n in enumerate(traj.names)}
    centres = (with_trunk(result.segments, result.centres, markers, subject.marker_radius)
               if trunk else result.centres)  # fmt: skip
    out, _ = trial_kinetics(
        result.segments,
        centres,
        read_plates(path, window="centred", offsets="none"),
        traj,
        body_mass=subject.require("mass"),
        progression=result.progression,
        choice=PlateChoice(counted, recorded_ground_reactions(path) if auto else None),
    )
    return out


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    both = np.isfinite(a) & np.isfinite(b)
    assert both.sum() > 50
    return float(np.sqrt(np.mean((a[both] - b[both]) ** 2)))


@pytest.mark.slow
def test_movement_trial_against_nexus_kinetics(stripped: Path) -> None:
    """With the plates Nexus counted on this trial (1 and 4), on the trial stripped of
    Nexus' outputs: every moment component within 0.035 N m/kg RMS of Nexus' (the target
    0.05), every power within 0.05 W/kg (0.1), the ground reactions within 0.1 % of their
    peak (1 %); the arms' within 1e-3. Measured: legs' moments 0.001-0.028 N m/kg, powers
    0.025-0.044 W/kg, ground reactions 0 (Nexus' own samples), arms' 4e-4 at most."""
    theirs = _nexus(TRIAL)
    ours = _ours(stripped, {1, 4})
    assert not any(n.endswith(("Moment", "Power")) for n in _nexus(stripped))
    for side in "LR":
        for joint in ("Ankle", "Knee", "Hip"):
            moment = f"{side}{joint}Moment"
            for k in range(3):
                rms = _rms(ours[moment][:, k], theirs[moment][:, k] * 1e-3)
                assert rms < 0.035, (moment, "XYZ"[k], rms)
            power = f"{side}{joint}Power"
            assert _rms(ours[power][:, 2], theirs[power][:, 2]) < 0.05, power
        for joint in ("Wrist", "Elbow", "Shoulder"):  # the free arm: Nexus' to 4e-4
            for kind, scale, tol in (("Moment", 1e-3, 1e-3), ("Force", 1.0, 1e-3)):
                name = f"{side}{joint}{kind}"
                for k in range(3):
                    assert _rms(ours[name][:, k], theirs[name][:, k] * scale) < tol, (name, k)
            power = f"{side}{joint}Power"
            assert _rms(ours[power][:, 2], theirs[power][:, 2]) < 1e-3, power
        for name in (f"{side}GroundReactionForce", f"{side}NormalisedGRF"):
            peak = np.nanmax(np.abs(theirs[name][:, 2]))
            for k in range(3):
                assert _rms(ours[name][:, k], theirs[name][:, k]) < 1e-3 * peak, (name, k)


def test_default_counts_the_contacts_the_recording_counted() -> None:
    """plug-in-gait's default (--plates auto) on the trial as Nexus wrote it: the contacts
    Nexus' own ground reactions count (plates 1 and 4), so the kinetics equal those of
    --plates 1,4 and meet the targets against Nexus' (moments 0.05 N m/kg, powers 0.1
    W/kg, ground reactions 1 % of peak; measured 0.028, 0.044, 0)."""
    if not TRIAL.exists():
        pytest.skip(f"{TRIAL} (shared real recording) not present")
    theirs, auto = _nexus(TRIAL), _ours(TRIAL, None, auto=True)
    chosen = _ours(TRIAL, {1, 4})
    for name in chosen:
        np.testing.assert_array_equal(auto[name], chosen[name], err_msg=name)
    for name in (n for n in auto if n in theirs):
        if name.endswith("Moment"):
            scale, tol, axes = 1e-3, 0.05, range(3)
        elif name.endswith("Power"):
            scale, tol, axes = 1.0, 0.1, range(2, 3)
        elif name.endswith(("GroundReactionForce", "NormalisedGRF")):
            scale, tol, axes = 1.0, 0.01 * np.nanmax(np.abs(theirs[name][:, 2])), range(3)
        else:
            continue
        for k in axes:
            assert _rms(auto[name][:, k], theirs[name][:, k] * scale) < tol, (name, k)


def test_uncounted_plates_leave_no_ground_reaction(stripped: Path) -> None:
    """A plate that does not count gives no ground reaction (empty cells, not a stale
    value); an unknown plate number is a clear error."""
    ours = _ours(stripped, {1})
    assert np.isnan(ours["RGroundReactionForce"]).all()
    assert np.isfinite(ours["LGroundReactionForce"]).any()
    with pytest.raises(MocapError, match="plates \\[9\\]"):
        _ours(stripped, {9})


@pytest.mark.slow
def test_command_writes_kinetics(stripped: Path, tmp_path: Path) -> None:
    """plug-in-gait on a trial with plates writes kinetics.csv (per kg, SI) and the same
    points in result.c3d in Vicon's units; the trial is not modified; a bad --plates is a
    one-line error with a non-zero exit; --plates none writes no joint kinetics (kinetics.csv
    holds the centre of mass alone)."""
    from mocap_mj.cli import main

    before = stripped.read_bytes()
    out = tmp_path / "pig"
    args = ["plug-in-gait", "--markers", str(stripped), "--plates", "1,4"]
    assert main([*args, "--out", str(out)]) == 0
    assert stripped.read_bytes() == before
    lines = (out / "kinetics.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:2] == ["frame", "time_s"] and "LKneeMoment_X" in header
    assert {"LWaistMoment_X", "RNeckForce_Z", "LNeckPower_Z"} <= set(header)
    assert len(lines) == 1 + 323
    col = header.index("LAnkleMoment_X")
    cells = [row.split(",")[col] for row in lines[1:]]
    assert cells[:4] == [""] * 4 and cells[4] != ""  # the derivatives' four frames
    written = _nexus(out / "result.c3d")
    table = np.array([float(v) for v in cells[4:-4]])
    np.testing.assert_allclose(written["LAnkleMoment"][4:-4, 0], table * 1e3, atol=0.05)
    c3d = ezc3d.c3d(str(out / "result.c3d"))
    assert c3d["parameters"]["POINT"]["MOMENT_UNITS"]["value"] == ["Nmm/kg"]
    waist = np.array([float(row.split(",")[header.index("LWaistMoment_X")]) for row in lines[5:-4]])
    np.testing.assert_allclose(written["LWaistMoment"][4:-4, 0], waist * 1e3, atol=0.05)
    assert main([*args[:3], "--plates", "one", "--out", str(tmp_path / "bad")]) == 2
    assert main([*args[:3], "--plates", "none", "--out", str(tmp_path / "none")]) == 0
    header = (tmp_path / "none" / "kinetics.csv").read_text().splitlines()[0].split(",")
    assert not [n for n in header[2:] if not n.startswith("CentreOfMass")]


def test_missing_marker_empties_only_the_frames_it_reaches(stripped: Path) -> None:
    """LTOE missing for 5 frames: the left leg's kinetics are empty there and within the
    derivatives' reach (4 frames), never carried over from another frame; the right leg's
    are unchanged, the left's elsewhere within 1e-3 N m/kg."""
    from dataclasses import replace

    traj = load_markers(stripped)
    positions = traj.positions.copy()
    positions[100:105, traj.names.index("LTOE")] = np.nan
    gappy = replace(traj, positions=positions)
    subject = pig_from_c3d(stripped)
    plates = read_plates(stripped, window="centred", offsets="none")
    runs = []
    for tr in (traj, gappy):
        result = plug_in_gait(tr, subject)
        out, _ = trial_kinetics(result.segments, result.centres, plates, tr, body_mass=85.0,
                                progression=result.progression)  # fmt: skip
        runs.append(out)
    whole, gap = runs
    empty = np.isnan(gap["LAnkleMoment"][:, 0])
    assert empty[96:109].all() and not empty[4:96].any() and not empty[109:-4].any()
    np.testing.assert_allclose(gap["RKneeMoment"], whole["RKneeMoment"], equal_nan=True)
    # elsewhere the same but for the foot's length, a median over the frames it is seen in
    np.testing.assert_allclose(
        gap["LAnkleMoment"][~empty], whole["LAnkleMoment"][~empty], rtol=0, atol=1e-3
    )


def _static_trunk(n: int) -> tuple[dict[str, Segment], dict[str, np.ndarray], dict[str, float]]:
    """A still pelvis, thorax (z down, y right, as Plug-in Gait's) and head with the trunk's
    points, and the upper body's parts: mass fraction by name and centre of mass [m]."""
    eye = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    down = eye * np.array([1.0, -1.0, -1.0])  # columns x, -y, -z
    tile = lambda v: np.tile(np.asarray(v, dtype=float), (n, 1))  # noqa: E731
    segs = {
        "pelvis": Segment(tile([0.0, 0.0, 1.0]), eye),
        "thorax": Segment(tile([0.05, 0.0, 1.45]), down),
        "head": Segment(tile([0.1, 0.0, 1.7]), eye),
    }
    centres = {"hip_l": tile([0.0, 0.09, 0.95]), "hip_r": tile([0.0, -0.09, 0.95]),
               "shoulder_l": tile([-0.02, 0.18, 1.42]),
               "shoulder_r": tile([-0.02, -0.18, 1.42])}  # fmt: skip
    centres |= trunk_points(segs, centres, tile([-0.08, 0.0, 1.5]), 0.007)
    return segs, centres, {"pelvis": 0.142, "thorax": 0.355, "head": 0.081, "arm": 0.05}


def test_static_trunk_carries_the_upper_body() -> None:
    """A still body whose legs carry the pelvis and everything above, the humeri their arms:
    the waist's force is the upper body's weight per kg (head, thorax, arms: 0.536 g) pressing
    down on the pelvis and its moment that weight's about L5 at the upper body's centre of
    mass; the neck's the head's weight (0.081 g) about the neck point at the head's centre of
    mass, a point the recursion meets only through the loads; no power."""
    n, mass = 20, 80.0
    segs, c, part = _static_trunk(n)
    l5, neck = c["l5"][0], c["neck"][0]
    thorax = c["thorax_top"][0] + 0.63 * (c["thorax_bottom"][0] - c["thorax_top"][0])
    pelvis = 0.5 * (c["hip_l"][0] + c["hip_r"][0])
    pelvis = pelvis + 0.895 * (l5 - pelvis)
    head, arm = np.array([0.12, 0.01, 1.68]), {"l": [0.0, 0.2, 1.2], "r": [0.01, -0.2, 1.21]}
    g = np.array([0.0, 0.0, -GRAVITY * mass])
    up_mass = part["thorax"] + part["head"] + 2 * part["arm"]
    upper = (part["thorax"] * thorax + part["head"] * head
             + part["arm"] * np.add(arm["l"], arm["r"])) / up_mass  # fmt: skip
    limbs: dict[str, ChainLoads] = {}
    # the humeri hang from the shoulders: the thorax holds each arm's weight
    for s in "lr":
        lever = np.asarray(arm[s]) - c[f"shoulder_{s}"][0]
        f, m = -part["arm"] * g, -np.cross(lever, part["arm"] * g)
        limbs[f"arm_{s}"] = ChainLoads({"shoulder": np.tile(f, (n, 1))},
                                       {"shoulder": np.tile(m, (n, 1))}, {})  # fmt: skip
    # the femurs hold the rest: the hip loads that keep pelvis and upper body still
    total = -(part["pelvis"] + up_mass) * g
    about_l5 = np.cross(pelvis - l5, part["pelvis"] * g) + np.cross(upper - l5, up_mass * g)
    for s in "lr":
        hip = c[f"hip_{s}"][0]
        m_hip = 0.5 * about_l5 + np.cross(hip - l5, 0.5 * total)  # pelvis on femur, about the hip
        limbs[f"leg_{s}"] = ChainLoads({"hip": np.tile(-0.5 * total, (n, 1))},
                                       {"hip": np.tile(m_hip, (n, 1))}, {})  # fmt: skip
    out = trunk_kinetics(segs, c, limbs, body_mass=mass, rate=RATE)
    rows = slice(4, -4)
    np.testing.assert_allclose(out["LWaistForce"][rows], np.tile([0, 0, -up_mass * GRAVITY],
                               (n - 8, 1)), atol=1e-9)  # fmt: skip
    waist = np.cross(upper - l5, up_mass * g) / mass  # the pelvis frame is the lab's
    np.testing.assert_allclose(out["LWaistMoment"][rows], np.tile([waist[1], waist[0], -waist[2]],
                               (n - 8, 1)), atol=1e-9)  # fmt: skip
    head_m = np.cross(head - neck, part["head"] * g) / mass  # the upright thorax frame: the lab
    np.testing.assert_allclose(out["LNeckForce"][rows], np.tile([0, 0, -part["head"] * GRAVITY],
                               (n - 8, 1)), atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(out["RNeckMoment"][rows], np.tile(
        [head_m[1], -head_m[0], head_m[2]], (n - 8, 1)), atol=1e-9)  # fmt: skip
    assert np.abs(out["LWaistPower"][rows]).max() < 1e-12 and np.isnan(out["LNeckPower"][:4]).all()


def test_trunk_against_nexus() -> None:
    """The waist's and neck's kinetics on the trial as Nexus wrote it, its plates (1 and 4),
    against Nexus' own: moments within 0.04 N m/kg RMS (the neck's frontal Y 0.065),
    forces 0.05 N/kg, powers 0.025 W/kg. Measured: waist moments 0.027, 0.024, 0.011,
    forces 0.008-0.040, power 0.014; neck moments 0.037, 0.055, 0.011, forces 0.021-0.033,
    power 0.017 (the legs' hip differences carried up)."""
    if not TRIAL.exists():
        pytest.skip(f"{TRIAL} (shared real recording) not present")
    theirs, ours = _nexus(TRIAL), _ours(TRIAL, None, auto=True, trunk=True)
    for side in "LR":
        for joint in ("Waist", "Neck"):
            for k in range(3):
                tol = 0.065 if (joint, k) == ("Neck", 1) else 0.04
                name = f"{side}{joint}Moment"
                assert _rms(ours[name][:, k], theirs[name][:, k] * 1e-3) < tol, (name, k)
                name = f"{side}{joint}Force"
                assert _rms(ours[name][:, k], theirs[name][:, k]) < 0.05, (name, k)
            name = f"{side}{joint}Power"
            assert _rms(ours[name][:, 2], theirs[name][:, 2]) < 0.025, name
            assert np.nanmax(np.abs(ours[name][:, :2])) == 0.0


def test_missing_c7_empties_the_trunk_only_where_it_reaches() -> None:
    """C7 missing for 5 frames (the thorax frame with it): the neck's outputs and the waist's
    power (the thorax' angular velocity) are empty there and within the derivatives' reach (4
    frames, 2 for an angular velocity alone), never carried over; the waist's moment and force
    (the pelvis' and legs') and the legs' unchanged."""
    from dataclasses import replace

    if not TRIAL.exists():
        pytest.skip(f"{TRIAL} (shared real recording) not present")
    traj, subject = load_markers(TRIAL), pig_from_c3d(TRIAL)
    positions = traj.positions.copy()
    positions[100:105, traj.names.index("C7")] = np.nan
    runs = []
    for tr in (traj, replace(traj, positions=positions)):
        result = plug_in_gait(tr, subject)
        markers = {n: tr.positions[:, i] for i, n in enumerate(tr.names)}
        centres = with_trunk(result.segments, result.centres, markers, subject.marker_radius)
        out, _ = trial_kinetics(result.segments, centres, read_plates(TRIAL, window="centred",
                                offsets="none"), tr, body_mass=85.0,
                                progression=result.progression)  # fmt: skip
        runs.append(out)
    whole, gap = runs
    for name, reach in (("LNeckMoment", 4), ("RNeckForce", 4), ("LNeckPower", 4),
                        ("RWaistPower", 2)):  # fmt: skip
        empty = np.isnan(gap[name][:, 2])
        first, stop = 100 - reach, 105 + reach
        assert empty[first:stop].all() and not empty[4:first].any(), name
        assert not empty[stop:-4].any(), name
    for name in ("LHipMoment", "LWaistMoment", "RWaistForce"):
        np.testing.assert_array_equal(gap[name], whole[name], err_msg=name)
