"""Force plates: the shared recordings' plates (loads, centres of pressure under the feet,
Nexus's own ground reactions) and synthetic plates written from a known force and centre of
pressure (C3D type 2, OpenSim .mot), read back."""

from __future__ import annotations

import logging
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.capture.contacts import PIG_FEET, as_recorded, assign_feet, contacts
from mocap_mj.errors import InputFileError
from mocap_mj.io import MarkerTrajectory, load_markers
from mocap_mj.io.plates import (
    PlateRecord,
    read_grf_mot,
    read_plates,
    recorded_ground_reactions,
)

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
REAL, VENDORS = SHARED / "real", SHARED / "vendors"
SKIP = "../shared/data not present: the force-plate checks on real files need the shared folder"
G = 9.80665  # [m/s^2]
#: Qualisys.c3d's foot markers (no toe marker: the first and fifth metatarsal heads).
QUALISYS_FEET = {"left": ("LHEE", "LANK", "L_FM1", "L_FM5"),
                 "right": ("RHEE", "RANK", "R_FM1", "R_FM5")}  # fmt: skip
#: file -> (plates, mass [kg] or None)
READABLE = {
    REAL / "Movement_trial.c3d": (4, 85.0),  # PROCESSING:Bodymass
    VENDORS / "Qualisys.c3d": (2, None),
    VENDORS / "FP_Type3.c3d": (2, None),
    VENDORS / "Kistler.c3d": (2, None),
    VENDORS / "BTS.c3d": (6, None),
}


def _need(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(SKIP)
    return path


@pytest.mark.slow
@pytest.mark.parametrize("path", list(READABLE), ids=[p.name for p in READABLE])
def test_every_plate_read_with_a_plausible_peak_and_its_cop_on_the_plate(path: Path) -> None:
    n_plates, mass = READABLE[_need(path)]
    plates = read_plates(path)
    assert len(plates) == n_plates
    loaded = [p for p in plates if p.loaded.any()]
    assert loaded, "no plate of the file is loaded"
    for plate in plates:
        assert plate.force.shape == plate.cop.shape == plate.free_moment.shape
        assert plate.corners.shape == (4, 3)
        assert np.all(plate.free_moment[~plate.loaded] == 0)
    for plate in loaded:
        peak = float(plate.force[:, 2].max())
        if mass is not None:
            assert 0.8 <= peak / (mass * G) <= 3.0, (plate.name, peak)
        else:
            assert 200.0 <= peak <= 3000.0, (plate.name, peak)
        # the centre of pressure lies on the plate (3 cm margin: at touch-down and lift-off
        # the centre of pressure of a few tens of newtons is uncertain by a centimetre or two)
        lo, hi = plate.corners.min(axis=0) - 0.03, plate.corners.max(axis=0) + 0.03
        cop = plate.cop[plate.loaded]
        assert np.all((cop[:, :2] >= lo[:2]) & (cop[:, :2] <= hi[:2])), plate.name
        # on the surface's plane (FP_Type3.c3d's corners tilt by a millimetre)
        np.testing.assert_allclose(cop[:, 2], plate.corners[:, 2].mean(), atol=0.002)


class _Lines(logging.Handler):
    """The messages a logger emits (whatever the command line did to its propagation)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


def test_fp_type1_reads_plate_1_and_skips_the_plates_with_corrupt_corners() -> None:
    # FP_Type1.c3d's plates 2-4 hold corners of 1e-38 .. 1e24 m: not a plate's rectangle;
    # plate 1's are a 0.40 x 0.60 m plate, never loaded in this file (under 7 N throughout)
    path = _need(VENDORS / "FP_Type1.c3d")
    logger, seen = logging.getLogger("mocap_mj.io.plates"), _Lines()
    # a logging configuration run earlier in this process (import-linter's, by test_layers)
    # disables the loggers that existed then
    disabled, logger.disabled = logger.disabled, False
    logger.addHandler(seen)
    try:
        plates = read_plates(path)
    finally:
        logger.removeHandler(seen)
        logger.disabled = disabled
    assert [p.name for p in plates] == ["plate 1"]
    sides = np.linalg.norm(plates[0].corners - np.roll(plates[0].corners, -1, axis=0), axis=1)
    np.testing.assert_allclose(sorted(sides), [0.40, 0.40, 0.60, 0.60], atol=0.01)
    assert plates[0].force.shape == (634, 3) and np.isfinite(plates[0].force).all()
    lines = seen.lines
    assert len(lines) == 3, lines  # one line per skipped plate
    for k, line in zip((2, 3, 4), lines, strict=True):
        assert "FP_Type1.c3d" in line and f"plate {k}:" in line and "CORNERS" in line, line
        assert "skipped" in line and "\n" not in line


def test_a_file_none_of_whose_plates_can_be_read_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bad_corners.c3d"
    _write_plate(path, 2, corners_mm=np.full((4, 3), 1e-20))
    with pytest.raises(
        InputFileError, match=r"bad_corners\.c3d: group FORCE_PLATFORM:CORNERS: plate 1"
    ):
        read_plates(path)


@pytest.mark.parametrize(
    ("path", "feet"),
    [
        (REAL / "Movement_trial.c3d", PIG_FEET),
        (VENDORS / "Qualisys.c3d", QUALISYS_FEET),
        (VENDORS / "BTS.c3d", {"left": ("LHEE", "l met"), "right": ("RHEE", "r met")}),  # Y up
    ],
    ids=["Movement_trial", "Qualisys", "BTS"],
)
@pytest.mark.slow
def test_cop_lies_under_the_assigned_foot(path: Path, feet: dict[str, tuple[str, ...]]) -> None:
    """The plates come out in the markers' frame: every counted contact's centre of pressure
    lies within 5 cm of its foot markers' horizontal outline, at every frame, and at least
    10 cm from the other foot's."""
    traj = load_markers(_need(path))
    plates = read_plates(path)
    found = contacts(plates, traj, feet=feet)
    counted = [c for c in found if c.reason is None]
    # each loaded plate: one stance of one foot, alone on it
    assert len(counted) == sum(p.loaded.any() for p in plates)
    for c in counted:
        assert c.side is not None
        frames = slice(c.start, c.stop)
        cop = plates[c.plate].cop[frames, :2]
        foot = traj.select(list(feet[c.side]))[frames, :, :2]
        lo, hi = np.nanmin(foot, axis=1) - 0.05, np.nanmax(foot, axis=1) + 0.05
        inside = np.all((cop >= lo) & (cop <= hi), axis=1)
        assert inside.mean() >= 0.98, (plates[c.plate].name, inside.mean())
        other = traj.select(list(feet["right" if c.side == "left" else "left"]))[frames]
        gap = np.nanmin(np.linalg.norm(cop[:, None] - other[:, :, :2], axis=2))
        assert gap >= 0.10, (plates[c.plate].name, gap)


def test_movement_trial_sides_alternate_down_the_stairs() -> None:
    """Movement_trial descends four instrumented steps: right on plate 4, left on 3, right
    on 2, left on 1 (the feet's markers say so)."""
    path = _need(REAL / "Movement_trial.c3d")
    found = contacts(read_plates(path), load_markers(path))
    assert [(c.plate + 1, c.side) for c in found] == [
        (1, "left"), (2, "right"), (3, "left"), (4, "right"),
    ]  # fmt: skip


def _nexus_point(path: Path, name: str) -> np.ndarray:
    c3d = ezc3d.c3d(str(path))
    point = c3d["parameters"]["POINT"]
    labels = [
        s.strip() for s in point["LABELS"]["value"] + point.get("LABELS2", {}).get("value", [])
    ]
    k = labels.index(name)
    values = np.asarray(c3d["data"]["points"][:3, k].T, dtype=float)
    values[c3d["data"]["meta_points"]["residuals"][0, k] < 0] = np.nan
    return values


def test_ground_reaction_agrees_with_nexus() -> None:
    """Nexus's LGroundReactionForce / RGroundReactionForce of Movement_trial.c3d are the
    force on the foot in the lab frame divided by the body mass (N/kg, although
    POINT:FORCE_UNITS says N), at the marker frames: a least-squares fit of them on our
    force / mass gives a near-identity map. Measured RMS differences: 0.21 / 0.25 N/kg
    vertical (1.5 % of the 13-14 N/kg peaks), 0.05-0.07 N/kg horizontal; Nexus takes the
    first analog sample of each frame (RMS 0.11 N/kg against it) where we average the
    frame's nine samples."""
    path = _need(REAL / "Movement_trial.c3d")
    mass = 85.0
    left, right = assign_feet(read_plates(path), load_markers(path))
    for foot, name in ((left, "LGroundReactionForce"), (right, "RGroundReactionForce")):
        nexus = _nexus_point(path, name)
        both = np.isfinite(nexus).all(axis=1) & foot.on_plate
        assert both.sum() >= 60
        ours = foot.force[both] / mass
        rms = np.sqrt(np.mean((nexus[both] - ours) ** 2, axis=0))
        assert rms[2] < 0.35 and np.all(rms[:2] < 0.12), (name, rms)
        peak_ratio = nexus[both, 2].max() / ours[:, 2].max()
        assert abs(peak_ratio - 1.0) < 0.03, (name, peak_ratio)


# --- synthetic plates -----------------------------------------------------------------------

RATE, ANALOG_RATE, FRAMES = 100.0, 1000.0, 120
PER = int(ANALOG_RATE / RATE)
#: Movement_trial's corner order (C3D: plate x = c1 - c2, y = c1 - c4, z into the plate)
CORNERS_MM = np.array([[900.0, 700.0, 0.0], [900.0, 100.0, 0.0], [500.0, 100.0, 0.0],
                       [500.0, 700.0, 0.0]])  # fmt: skip
ORIGIN_MM = np.array([1.5, -0.8, -40.0])  # sensor origin -> surface centre, plate axes


def _truth() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Force on the subject (T, 3) [N], its centre of pressure (T, 3) [m], free moment
    (T,) [N m] and the loaded frames (T,): unloaded for 0.3 s, then a stance."""
    t = np.arange(FRAMES) / RATE
    s = np.clip((t - 0.3) / 0.8, 0.0, 1.0)
    on = (s > 0) & (s < 1)
    bump = np.sin(np.pi * s) * on
    force = np.stack([60 * np.sin(2 * np.pi * s), -25 * bump, 900 * bump + 1e-12], axis=1)
    force[~on] = 0.0
    cop = np.stack([0.60 + 0.25 * s, 0.35 + 0.05 * s, np.zeros_like(s)], axis=1)
    free = 4.0 * np.sin(2 * np.pi * s) * on
    return force, cop, free, on


def _int_parameter(c3d: ezc3d.c3d, name: str, values: list[int], shape: list[int]) -> None:
    """An integer FORCE_PLATFORM parameter (ezc3d's ``add_parameter`` stores numbers as
    floats; its plate reader wants integers), ``values`` in Fortran order."""
    param = ezc3d.ezc3d.Parameter(name, "")
    param.set(ezc3d.ezc3d.VecInt(values), ezc3d.ezc3d.VecUInt(shape))
    c3d["parameters"].add_parameter("FORCE_PLATFORM", param)


#: Type 3's sensor offsets a, b and the surface's height above the sensors [mm] (Kistler's)
KISTLER_ORIGIN_MM = np.array([210.0, 260.0, -41.0])
#: Type 4's calibration matrix (channels -> forces and moments), away from the identity
CAL = np.eye(6) + 0.02 * np.arange(36).reshape(6, 6) / 36.0


def _channels(plate_type: int, f_p: np.ndarray, m_c: np.ndarray) -> np.ndarray:
    """The analog channels (T, 6 or 8) [N, N mm; type 1: N, mm, N mm] of a plate of
    ``plate_type`` that measures the force ``f_p`` (T, 3) [N] and moment ``m_c`` (T, 3)
    [N m] about its surface centre, in plate axes, as ezc3d decodes them."""
    if plate_type == 1:  # Fx Fy Fz, the centre of pressure's x y, the free moment
        fz = np.where(np.abs(f_p[:, 2]) > 1e-6, f_p[:, 2], np.inf)
        x, y = -m_c[:, 1] / fz, m_c[:, 0] / fz  # on the surface (plate z = 0)
        tz = m_c[:, 2] - (x * f_p[:, 1] - y * f_p[:, 0])
        return np.column_stack([f_p, x * 1e3, y * 1e3, tz * 1e3])
    if plate_type == 3:
        a, b, c = KISTLER_ORIGIN_MM * 1e-3
        m_s = m_c - np.cross(f_p, [0.0, 0.0, c])  # about the sensors' plane
        fz = np.linalg.solve(
            np.array([[1, 1, 1, 1], [b, b, -b, -b], [-a, a, a, -a], [1, -1, 1, -1.0]]),
            np.stack([f_p[:, 2], m_s[:, 0], m_s[:, 1], np.zeros(len(f_p))]),
        ).T
        fx34_minus_fx12 = m_s[:, 2] / b
        fx12 = (f_p[:, 0] - fx34_minus_fx12) / 2
        fy = f_p[:, 1] / 2
        return np.column_stack([fx12, fx12 + fx34_minus_fx12, fy, fy, fz])
    m_o = m_c + np.cross(ORIGIN_MM * 1e-3, f_p)  # about the sensor origin
    six = np.concatenate([f_p, m_o * 1e3], axis=1)  # N, N mm
    return six @ np.linalg.inv(CAL).T if plate_type == 4 else six


def _write_plate(
    path: Path,
    plate_type: int = 2,
    *,
    on_subject: bool = False,
    corners_mm: np.ndarray = CORNERS_MM,
) -> None:
    """A C3D with one plate of ``plate_type`` whose channels measure the force on the plate
    (on the subject with ``on_subject``; :func:`_channels`), with offsets, constant within
    each marker frame; ``corners_mm`` (4, 3) [mm]: the corners declared."""
    force, cop, free, _ = _truth()
    corners = CORNERS_MM * 1e-3
    centre = corners.mean(axis=0)
    x, y = corners[0] - corners[1], corners[0] - corners[3]
    rot = np.stack([x / np.linalg.norm(x), y / np.linalg.norm(y)], axis=1)
    rot = np.column_stack([rot, np.cross(rot[:, 0], rot[:, 1])])  # columns: plate axes in lab
    sign = 1.0 if on_subject else -1.0  # on the plate, as most vendors write it
    action = sign * force
    moment_c = np.cross(cop - centre, action) + sign * free[:, None] * np.array([0.0, 0.0, 1.0])
    channels = _channels(plate_type, action @ rot, moment_c @ rot)
    n_channels = channels.shape[1]
    offsets = np.linspace(-12.0, 15.0, n_channels)  # amplifier offsets
    if plate_type == 1:
        offsets[3:5] = 0.0  # a position channel has none
    channels = channels + offsets
    analogs = np.repeat(channels, PER, axis=0).T  # (channels, N)
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = np.array([RATE])
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ["M1"]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, 1, FRAMES))
    points[:3, 0] = np.array([[500.0], [500.0], [1000.0]])
    c3d["data"]["points"] = points
    c3d["parameters"]["ANALOG"]["RATE"]["value"] = np.array([ANALOG_RATE])
    c3d["parameters"]["ANALOG"]["LABELS"]["value"] = [f"ch{k + 1}" for k in range(n_channels)]
    units = ["N"] * n_channels if plate_type == 3 else ["N", "N", "N", "Nmm", "Nmm", "Nmm"]
    if plate_type == 1:
        units = ["N", "N", "N", "mm", "mm", "Nmm"]
    c3d["parameters"]["ANALOG"]["UNITS"]["value"] = units
    c3d["data"]["analogs"] = analogs[np.newaxis]
    _int_parameter(c3d, "USED", [1], [1])
    _int_parameter(c3d, "TYPE", [plate_type], [1])
    _int_parameter(c3d, "ZERO", [1, 0], [2])
    c3d.add_parameter("FORCE_PLATFORM", "CORNERS", corners_mm.T.reshape(3, 4, 1))
    origin = KISTLER_ORIGIN_MM if plate_type == 3 else ORIGIN_MM
    c3d.add_parameter("FORCE_PLATFORM", "ORIGIN", origin.reshape(3, 1))
    _int_parameter(c3d, "CHANNEL", list(range(1, n_channels + 1)), [n_channels, 1])
    if plate_type == 4:
        c3d.add_parameter("FORCE_PLATFORM", "CAL_MATRIX", CAL.reshape(6, 6, 1))
    c3d.write(str(path))


@pytest.mark.parametrize("plate_type", [1, 2, 3, 4])
def test_synthetic_plate_reads_back_its_force_and_cop(tmp_path: Path, plate_type: int) -> None:
    """Types 1 (force, centre of pressure, free moment), 2 (six channels), 3 (Kistler's
    eight) and 4 (six through a calibration matrix), written from a known force, centre of
    pressure and free moment."""
    path = tmp_path / "plate.c3d"
    _write_plate(path, plate_type)
    before = path.read_bytes()
    (plate,) = read_plates(path, up="z")
    assert path.read_bytes() == before  # the file is only read
    force, cop, free, _ = _truth()
    assert plate.name == "plate 1" and plate.plate_type == plate_type and plate.rate == RATE
    np.testing.assert_allclose(plate.corners, CORNERS_MM * 1e-3, atol=1e-9)
    strong = force[:, 2] > 100.0
    # force and centre of pressure within 0.5 % of the truth (of the peak force, of the
    # plate's size), offsets removed from the unloaded start
    np.testing.assert_allclose(plate.force, force, atol=0.005 * 900.0)
    size = 0.6
    np.testing.assert_allclose(plate.cop[strong], cop[strong], atol=0.005 * size)
    np.testing.assert_allclose(plate.free_moment[strong, 2], free[strong], atol=0.005 * 4.0 + 1e-3)
    assert np.array_equal(plate.loaded, force[:, 2] > 20.0)


def test_a_plate_written_as_the_force_on_the_subject_reads_the_same(tmp_path: Path) -> None:
    """Vendors write either the force on the plate or on the subject: a plate pushes, so
    both read as the force on the subject."""
    _write_plate(tmp_path / "on_plate.c3d")
    _write_plate(tmp_path / "on_subject.c3d", on_subject=True)
    (a,) = read_plates(tmp_path / "on_plate.c3d", up="z")
    (b,) = read_plates(tmp_path / "on_subject.c3d", up="z")
    np.testing.assert_allclose(b.force, a.force, atol=1e-3)
    np.testing.assert_allclose(b.cop, a.cop, atol=1e-6)
    np.testing.assert_allclose(b.free_moment, a.free_moment, atol=1e-5)
    assert b.force[:, 2].max() > 800.0


def test_synthetic_plate_at_another_marker_rate_averages_its_frames(tmp_path: Path) -> None:
    path = tmp_path / "plate.c3d"
    _write_plate(path)
    (plate,) = read_plates(path, up="z", marker_rate=50.0)
    force = _truth()[0]
    assert plate.force.shape == (FRAMES // 2, 3) and plate.rate == 50.0
    np.testing.assert_allclose(plate.force, (force[0::2] + force[1::2]) / 2, atol=4.5)


def test_plate_of_a_type_ezc3d_does_not_read_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "plate.c3d"
    _write_plate(path, plate_type=5)
    with pytest.raises(
        InputFileError, match=r"plate\.c3d: group FORCE_PLATFORM:TYPE: plate 1: .*got type 5"
    ):
        read_plates(path, up="z")


def test_grf_mot_reads_opensim_forces_into_the_z_up_frame(tmp_path: Path) -> None:
    """An OpenSim ground-reaction file (Y up, N, m, N m): the force, centre of pressure and
    free moment come out rotated onto +Z (x, y, z) -> (x, -z, y), as the marker loader
    rotates a Y-up file."""
    force, cop, free, _ = _truth()
    rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # z-up -> y-up: inverse of the loader's
    f_y, p_y = force @ rot, cop @ rot  # rows: R^T p
    torque = np.outer(free, [0.0, 1.0, 0.0])
    names = [f"1_ground_force_v{a}" for a in "xyz"] + [f"1_ground_force_p{a}" for a in "xyz"]
    names += [f"1_ground_torque_{a}" for a in "xyz"]
    rows = np.column_stack([np.arange(FRAMES) / RATE, f_y, p_y, torque])
    text = f"grf.mot\nversion=1\nnRows={FRAMES}\nnColumns=10\ninDegrees=no\nendheader\n"
    text += "\t".join(["time", *names]) + "\n"
    text += "\n".join("\t".join(f"{v:.9f}" for v in row) for row in rows) + "\n"
    path = tmp_path / "grf.mot"
    path.write_text(text)
    (plate,) = read_grf_mot(path)
    strong = force[:, 2] > 100.0
    assert plate.plate_type == 0 and np.isnan(plate.corners).all()
    np.testing.assert_allclose(plate.force, force, atol=1e-6)
    np.testing.assert_allclose(plate.cop[strong], cop[strong], atol=1e-6)
    np.testing.assert_allclose(plate.free_moment[strong, 2], free[strong], atol=1e-6)
    assert np.isnan(plate.cop[~(force[:, 2] > 20.0)]).all()


def test_grf_mot_without_its_nine_columns_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "grf.mot"
    path.write_text("grf\nendheader\ntime\tground_force_vx\tground_force_vy\n0\t1\t2\n")
    with pytest.raises(InputFileError, match=r"grf\.mot: column names: .*missing ground_force_vz"):
        read_grf_mot(path)


# --- feet on plates (synthetic) -------------------------------------------------------------

T_FEET = 50
LOADED = slice(10, 40)


def _feet(left: tuple[float, float], right: tuple[float, float]) -> MarkerTrajectory:
    """Both feet standing still (heel at the given (x, y) [m], toe 0.2 m ahead along +x,
    ankle 5 cm above the heel), 100 Hz."""
    names, columns = [], []
    for side, (x, y) in (("L", left), ("R", right)):
        for marker, offset in (("HEE", (0.0, 0.0, 0.05)), ("TOE", (0.2, 0.0, 0.04)),
                               ("ANK", (0.05, 0.03, 0.09))):  # fmt: skip
            names.append(side + marker)
            columns.append(np.array([x, y, 0.0]) + offset)
    positions = np.broadcast_to(np.array(columns), (T_FEET, len(names), 3))
    return MarkerTrajectory(np.arange(T_FEET) / 100.0, positions, tuple(names), 100.0)


def _plate(name: str, x0: float, cop_xy: tuple[float, float], fz: float = 700.0) -> PlateRecord:
    """A 0.5 x 0.5 m plate from x0 along x, loaded by ``fz`` [N] at ``cop_xy`` in LOADED."""
    corners = np.array([[x0 + 0.5, 0.5, 0], [x0 + 0.5, 0, 0], [x0, 0, 0], [x0, 0.5, 0.0]])
    force = np.zeros((T_FEET, 3))
    force[LOADED, 2] = fz
    cop = np.full((T_FEET, 3), np.nan)
    if fz > 20.0:
        cop[LOADED] = [*cop_xy, 0.0]
    return PlateRecord(name, 2, corners, force, cop, np.zeros((T_FEET, 3)), 100.0)


def test_a_foot_alone_on_a_plate_takes_its_load() -> None:
    traj = _feet(left=(0.1, 0.1), right=(1.2, 0.3))
    plates = [_plate("plate 1", 0.0, (0.2, 0.1)), _plate("plate 2", 0.5, (0.0, 0.0), fz=0.0)]
    left, right = assign_feet(plates, traj)
    assert left.on_plate[LOADED].all() and left.on_plate.sum() == 30
    np.testing.assert_array_equal(left.force, plates[0].force)
    assert not right.on_plate.any() and np.all(right.force == 0) and np.isnan(right.cop).all()
    assert left.excluded == right.excluded == ()


def test_two_feet_on_one_plate_are_left_out() -> None:
    traj = _feet(left=(0.05, 0.1), right=(0.1, 0.35))
    left, right = assign_feet([_plate("plate 1", 0.0, (0.15, 0.2))], traj)
    assert not left.on_plate.any() and not right.on_plate.any()
    assert left.excluded == ("plate 1, frames 11-40: both feet on the plate",)


def test_a_foot_straddling_two_plates_is_left_out_on_both() -> None:
    traj = _feet(left=(0.4, 0.2), right=(2.0, 0.2))  # heel on plate 1, toe on plate 2
    plates = [
        _plate("plate 1", 0.0, (0.45, 0.2), 400.0),
        _plate("plate 2", 0.5, (0.58, 0.2), 300.0),
    ]
    left, _ = assign_feet(plates, traj)
    assert not left.on_plate.any()
    assert len(left.excluded) == 2
    assert all(
        "the left foot straddles plate 1 and plate 2 (frames 11-40)" in r for r in left.excluded
    )


def test_a_load_no_foot_is_near_is_left_out() -> None:
    traj = _feet(left=(1.5, 0.1), right=(1.5, 0.4))
    left, right = assign_feet([_plate("plate 1", 0.0, (0.25, 0.25))], traj)
    assert not left.on_plate.any() and not right.on_plate.any()
    reason = "plate 1, frames 11-40: no foot's markers within 0.1 m of the centre of pressure"
    assert left.excluded == right.excluded == (reason,)


def _two_contacts() -> tuple[list[PlateRecord], list]:
    """The left foot alone on plate 1, the right alone on plate 2 (700 N each)."""
    traj = _feet(left=(0.1, 0.1), right=(0.6, 0.3))
    plates = [_plate("plate 1", 0.0, (0.2, 0.1)), _plate("plate 2", 0.5, (0.7, 0.3))]
    found = contacts(plates, traj)
    assert [(c.side, c.reason) for c in found] == [("left", None), ("right", None)]
    return plates, found


def test_the_recording_s_own_choice_of_contacts_applies() -> None:
    """A recording whose ground reaction of the right foot is empty over the right's
    contact leaves it out; one whose left ground reaction equals the plate's (per kg) keeps
    the left's."""
    plates, found = _two_contacts()
    mass = 70.0
    recorded = {"left": plates[0].force / mass, "right": np.full((T_FEET, 3), np.nan)}
    out, notes = as_recorded(found, plates, recorded, body_mass=mass)
    assert out[0].reason is None and notes == []
    assert out[1].reason == (
        "plate 2, frames 11-40: the recording's own ground reaction of the right foot leaves it out"
    )


def test_a_recorded_ground_reaction_that_differs_leaves_the_rules_to_decide() -> None:
    """A recorded ground reaction 20 % off the plate's (another plate combined, another
    filter) does not decide: the rules' verdict stays, with a note naming the plate."""
    plates, found = _two_contacts()
    recorded = {"left": plates[0].force * 1.2, "right": plates[1].force}  # in N
    out, notes = as_recorded(found, plates, recorded, body_mass=70.0)
    assert [c.reason for c in out] == [None, None]
    assert len(notes) == 1 and notes[0].startswith("plate 1, frames 11-40: the recording's")
    assert "20 % of its peak" in notes[0]


def test_recorded_ground_reactions_of_other_frames_decide_nothing() -> None:
    plates, found = _two_contacts()
    out, notes = as_recorded(found, plates, {"left": np.zeros((T_FEET - 3, 3))}, body_mass=70.0)
    assert out == found
    assert notes == [f"the recording's ground reactions hold {T_FEET - 3} frames, the plates "
                     f"{T_FEET}: the rules decide"]  # fmt: skip


def test_movement_trial_s_recorded_choice_is_plates_1_and_4() -> None:
    """Nexus counted plates 1 (left) and 4 (right) of Movement_trial's four; its ground
    reactions in the file say so, and they match the plates' forces."""
    path = _need(REAL / "Movement_trial.c3d")
    plates, traj = read_plates(path, window="centred", offsets="none"), load_markers(path)
    recorded = recorded_ground_reactions(path)
    assert set(recorded) == {"left", "right"}
    out, notes = as_recorded(contacts(plates, traj), plates, recorded, body_mass=85.0)
    assert notes == []
    assert sorted((c.plate + 1, c.side) for c in out if c.reason is None) == [
        (1, "left"),
        (4, "right"),
    ]


def test_a_file_without_ground_reactions_records_no_choice() -> None:
    assert recorded_ground_reactions(_need(VENDORS / "Qualisys.c3d")) == {}


def test_a_file_that_is_not_a_c3d_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "walk.c3d"
    path.write_text("PathFileType\t4\t(X/Y/Z)\twalk.trc\n")
    with pytest.raises(InputFileError, match=r"walk\.c3d: ezc3d could not read it") as err:
        read_plates(path)
    assert "\n" not in str(err.value)
    with pytest.raises(InputFileError, match=r"absent\.c3d: no such file"):
        read_plates(tmp_path / "absent.c3d")
