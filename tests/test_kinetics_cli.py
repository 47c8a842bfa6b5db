"""The kinetics of ``ik`` and ``identify`` on a real recording with force plates.

Movement_trial.c3d (../shared/data/real): Vicon Nexus Plug-in Gait, four plates on a
staircase, body mass 85 kg (PROCESSING:Bodymass) and Nexus's own kinetics (LAnkleMoment ...,
POINT:MOMENT_UNITS N mm/kg; LGroundReactionForce ... present on the frames Nexus assigned a
plate to the foot).

Bounds, as measured (the commands' output; docs/dynamics.md):

- residual force RMS over stance: 4.2 % of the peak ground reaction with ``ik`` on the bundled
  humanoid (marker RMSE 46 mm: not the subject's model), 3.2 % with ``identify``'s model;
  asserted below 5 %, the largest peak residual force OpenSim's guidelines accept (Hicks et
  al. 2015), here of the RMS without any residual reduction; it catches a plate on the wrong
  foot, a wrong sign or frame offset (each puts the RMS above 30 %) and a foot loaded on an
  unmeasured surface counted as stance (6.9-7.7 %).
- the sagittal ankle moment per kg against Nexus's ``<S>AnkleMoment`` X over Nexus's stance
  frames: r = -0.99 (left) and -0.95 (right) with ``ik``, -0.97 and -0.94 with ``identify``;
  asserted below -0.9 and the magnitudes' correlation above 0.9. The signs are opposite by
  convention: Plug-in Gait's ankle X is positive for a plantarflexor moment, the model's
  ``ankle_<s>`` hinge (axis -y, range -50 to 30 deg) for a dorsiflexor one.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import ezc3d
import numpy as np
import pytest

from mocap_mj.capture.events import GaitEvent, events_csv, events_from_c3d, read_events_csv
from mocap_mj.errors import InputFileError

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

MOVEMENT = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "Movement_trial.c3d"
SKIP = "../shared/data/real/Movement_trial.c3d absent: the kinetics checks need the shared data"
needs_data = pytest.mark.skipif(not MOVEMENT.is_file(), reason=SKIP)
TABLES = ("dynamics.csv", "grf.csv", "root_residuals.csv", "events.csv")
MASS = 85.0  # [kg] the file's PROCESSING:Bodymass
#: Residual force RMS over stance, per cent of the peak ground reaction, at most.
RESIDUAL_PCT_PEAK_GRF = 5.0


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True, timeout=900
    )


def table(path: Path) -> Any:
    return np.genfromtxt(path, delimiter=",", names=True)


@pytest.fixture(scope="module")
def ik_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not MOVEMENT.is_file():
        pytest.skip(SKIP)
    out = tmp_path_factory.mktemp("kinetics") / "ik"
    proc = run("ik", "--markers", str(MOVEMENT), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out


def nexus_ankle(side: str, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Nexus's ankle moment X [N m/kg] (T,) and its stance frames (T,) bool."""
    c3d = ezc3d.c3d(str(MOVEMENT))
    assert [str(u) for u in c3d["parameters"]["POINT"]["MOMENT_UNITS"]["value"]] == ["Nmm"]
    labels = list(c3d["parameters"]["POINT"]["LABELS"]["value"])
    points = np.asarray(c3d["data"]["points"][:3], dtype=float)[:, :, :frames]
    s = side[0].upper()
    moment = points[0, labels.index(f"{s}AnkleMoment")] / 1000.0  # [N mm/kg] -> [N m/kg]
    stance = np.isfinite(points[2, labels.index(f"{s}GroundReactionForce")])
    return moment, stance


def check_kinetics(out: Path) -> dict[str, Any]:
    """The tables exist, the summary's figures match them, the residual is within bound and
    the ankle moments follow Nexus's; the summary's kinetics entry."""
    for name in TABLES:
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    (entry,) = summary["kinetics"]["trials"]
    assert entry["plates_per_foot"] == {
        "left": ["plate 1", "plate 3"],
        "right": ["plate 2", "plate 4"],
    }
    assert entry["smoothing"] == {
        "filter": "Butterworth low-pass, zero lag (forward and backward)",
        "order": 4,
        "cutoff_hz": 6.0,
    }
    assert entry["body_mass_kg"] == MASS
    # the summary's RMS is the table's, over the stance frames it counts
    residuals = table(out / "root_residuals.csv")
    force = np.stack([residuals[f"force_{a}_N"] for a in "XYZ"], axis=1)
    assert entry["stance_frames"] > 200
    assert entry["residual_force_rms_pct_peak_grf"] < RESIDUAL_PCT_PEAK_GRF
    assert entry["residual_force_rms_pct_bw"] == pytest.approx(
        100 * entry["residual_force_rms_n"] / (MASS * 9.80665)
    )
    grf = table(out / "grf.csv")
    total = np.stack([grf[f"left_force_{a}_N"] + grf[f"right_force_{a}_N"] for a in "XYZ"], axis=1)
    assert entry["peak_grf_n"] == pytest.approx(np.linalg.norm(total, axis=1).max(), rel=1e-5)
    assert 1.2 * MASS * 9.80665 < entry["peak_grf_n"] < 2.5 * MASS * 9.80665
    assert np.nanmax(np.linalg.norm(force, axis=1)) >= entry["residual_force_rms_n"]
    dynamics = table(out / "dynamics.csv")
    for side in ("left", "right"):
        ours = dynamics[f"ankle_{side[0]}_Nm_per_kg"]
        theirs, stance = nexus_ankle(side, len(ours))
        ok = stance & np.isfinite(ours) & np.isfinite(theirs)
        assert ok.sum() > 80, side
        r = np.corrcoef(ours[ok], theirs[ok])[0, 1]
        r_abs = np.corrcoef(np.abs(ours[ok]), np.abs(theirs[ok]))[0, 1]
        assert r < -0.9, (side, r)  # opposite signs by convention (module docstring)
        assert r_abs > 0.9, (side, r_abs)
    return dict(entry)


@needs_data
def test_ik_writes_the_kinetics_of_the_plates(ik_out: Path) -> None:
    check_kinetics(ik_out)
    grf = table(ik_out / "grf.csv")
    # a foot's centre of pressure is given exactly on its counted frames
    for side in ("left", "right"):
        on = grf[f"{side}_on_plate"] == 1
        assert np.isfinite(grf[f"{side}_cop_X_m"][on]).all()
        assert np.isnan(grf[f"{side}_cop_X_m"][~on]).all()
        assert (grf[f"{side}_force_Z_N"][on] > 20.0).all()
    events = read_events_csv(ik_out / "events.csv")
    # the plates' events: a strike at the first frame of each counted contact
    assert [(e.side, e.kind) for e in events if e.kind == "foot_strike"] == [
        ("right", "foot_strike"),
        ("left", "foot_strike"),
        ("right", "foot_strike"),
        ("left", "foot_strike"),
    ]
    assert all(e.source == "force plate" for e in events)
    on = np.flatnonzero(grf["right_on_plate"] == 1)
    assert events[0].time == pytest.approx(grf["time_s"][on[0]], abs=1e-6)


@needs_data
def test_forces_none_writes_no_kinetics(tmp_path: Path) -> None:
    out = tmp_path / "r"
    proc = run("ik", "--markers", str(MOVEMENT), "--out", str(out), "--forces", "none")
    assert proc.returncode == 0, proc.stderr
    assert not (out / "dynamics.csv").exists() and not (out / "grf.csv").exists()
    assert (out / "events.csv").is_file()  # the kinematic events (Zeni) all the same
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kinetics"]["trials"] == []
    assert summary["kinetics"]["refused"] == "--forces none"


@needs_data
def test_forces_of_the_wrong_count_are_one_line_and_no_output(tmp_path: Path) -> None:
    out = tmp_path / "r"
    proc = run(
        "ik", "--markers", str(MOVEMENT), "--out", str(out), "--forces", str(MOVEMENT),
        str(MOVEMENT),
    )  # fmt: skip
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if "--forces" in ln]
    assert len(lines) == 1 and "expected one file per marker file (1), got 2" in lines[0]
    assert not out.exists()


@needs_data
@pytest.mark.slow
def test_identify_writes_kinetics_and_a_dynamic_model(tmp_path: Path) -> None:
    out = tmp_path / "id"
    proc = run("identify", "--markers", str(MOVEMENT), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    entry = check_kinetics(out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kinetics"]["inertials_in_model"] is True
    assert "## Kinetics" in (out / "report.md").read_text()
    model_text = (out / "model.xml").read_text()
    assert model_text.count("<inertial ") >= 20
    # the model with its inertials reproduces the fit, and its kinetics
    again = tmp_path / "again"
    proc = run("ik", "--markers", str(MOVEMENT), "--model", str(out / "model.xml"), "--out",
               str(again))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    ik_summary = json.loads((again / "summary.json").read_text())
    assert ik_summary["marker_rmse_mm"] == pytest.approx(summary["marker_rmse_mm"], abs=0.05)
    (ik_entry,) = ik_summary["kinetics"]["trials"]
    assert ik_entry["residual_force_rms_n"] == pytest.approx(
        entry["residual_force_rms_n"], rel=0.02
    )
    # without a mass in the recording, ik takes the identified model's
    proc = run("ik", "--markers", str(without_mass(tmp_path)), "--model",
               str(out / "model.xml"), "--out", str(tmp_path / "model_mass"))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "model_mass" / "summary.json").read_text())
    assert summary["kinetics"]["trials"][0]["body_mass_kg"] == pytest.approx(MASS, rel=1e-9)


@needs_data
def test_export_c3d_holds_the_results_events(ik_out: Path, tmp_path: Path) -> None:
    path = tmp_path / "result.c3d"
    proc = run("export", str(ik_out), "--to", "c3d", "--out", str(path))
    assert proc.returncode == 0, proc.stderr
    ours = read_events_csv(ik_out / "events.csv")
    back = events_from_c3d(path)
    assert len(ours) >= 4
    assert [(e.side, e.kind, e.frame) for e in back] == [(e.side, e.kind, e.frame) for e in ours]


@needs_data
def test_export_grf_and_osim_carry_the_loads_and_the_masses(ik_out: Path, tmp_path: Path) -> None:
    """export --to grf: the .mot of grf.csv's loads in OpenSim's y-up ground and the
    ExternalLoads beside it; --to osim: de Leva's bodies summing to the 85 kg the kinetics
    used; a result without grf.csv is refused in one line, exit 2."""
    import xml.etree.ElementTree as ET

    from mocap_mj.export.mot import read_mot

    mot = tmp_path / "walk.mot"
    proc = run("export", str(ik_out), "--to", "grf", "--out", str(mot))
    assert proc.returncode == 0, proc.stderr
    assert "<datafile>walk.mot</datafile>" in (tmp_path / "walk_loads.xml").read_text()
    names, times, values = read_mot(mot)
    grf = table(ik_out / "grf.csv")
    np.testing.assert_allclose(times, grf["time_s"], atol=1e-6)
    vertical = values[:, names.index("ground_force_l_vy")]  # OpenSim's y is the lab's z
    np.testing.assert_allclose(vertical, np.nan_to_num(grf["left_force_Z_N"]), rtol=1e-6)
    osim = tmp_path / "subject.osim"
    assert run("export", str(ik_out), "--to", "osim", "--out", str(osim)).returncode == 0
    masses = [float(m.text or 0) for m in ET.parse(osim).iter("mass")]
    assert sum(masses) == pytest.approx(MASS, rel=1e-6)
    bare = tmp_path / "bare"
    bare.mkdir()
    for name in ("model.xml", "motion.npz"):
        (bare / name).write_bytes((ik_out / name).read_bytes())
    proc = run("export", str(bare), "--to", "grf", "--out", str(tmp_path / "none.mot"))
    assert proc.returncode == 2 and "no ground reactions" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "none.mot").exists()


@needs_data
def test_export_all_gives_an_inverse_dynamics_setup_opensim_runs(
    ik_out: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """export --to all of a result with ground reactions: grf.mot, grf_loads.xml and
    id_setup.xml, which OpenSim's InverseDynamicsTool runs in that folder (its ankle
    moments then follow ours: r > 0.95; the exact agreement: tests/test_opensim_id.py)."""
    osim = pytest.importorskip("opensim", reason="the [opensim] extra is not installed")
    from mocap_mj.export.mot import read_mot

    out = tmp_path / "all"
    proc = run("export", str(ik_out), "--to", "all", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    files = json.loads((out / "summary.json").read_text())["files"]
    assert {"grf.mot", "grf_loads.xml", "id_setup.xml"} <= set(files)
    monkeypatch.chdir(out)
    assert osim.InverseDynamicsTool("id_setup.xml").run()
    names, times, values = read_mot(out / "id.sto")
    ours = table(ik_out / "dynamics.csv")
    assert len(times) == len(ours)
    for side in "lr":
        theirs = values[:, names.index(f"ankle_{side}_moment")]
        mine = ours[f"ankle_{side}_Nm"]
        ok = np.isfinite(mine)
        assert np.corrcoef(mine[ok][10:-10], theirs[ok][10:-10])[0, 1] > 0.95, side


def test_events_csv_reads_back_and_refuses_a_bad_row(tmp_path: Path) -> None:
    events = [
        GaitEvent("left", "foot_strike", 1.25, 31, "force plate"),
        GaitEvent("right", "foot_off", 1.5, 37, "kinematics (Zeni et al. 2008)"),
    ]
    path = tmp_path / "events.csv"
    path.write_text(events_csv(events))
    assert read_events_csv(path) == events
    path.write_text(events_csv(events) + "left,heel_rise,40,1.6,force plate\n")
    with pytest.raises(InputFileError, match=r"events\.csv: line 4: expected side"):
        read_events_csv(path)


def without_mass(folder: Path) -> Path:
    """A copy of Movement_trial.c3d whose PROCESSING:Bodymass is 0 (Nexus: not entered)."""
    c3d = ezc3d.c3d(str(MOVEMENT))
    c3d["parameters"]["PROCESSING"]["Bodymass"]["value"] = np.array([0.0])
    path = folder / "no_mass.c3d"
    c3d.write(str(path))
    return path


@needs_data
def test_without_a_mass_kinetics_are_refused_with_one_warning(tmp_path: Path) -> None:
    path = without_mass(tmp_path)
    out = tmp_path / "r"
    proc = run("ik", "--markers", str(path), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    warned = [ln for ln in proc.stderr.splitlines() if "no body mass" in ln]
    assert len(warned) == 1 and "PROCESSING Bodymass" in warned[0], proc.stderr
    assert not (out / "dynamics.csv").exists() and not (out / "grf.csv").exists()
    assert (out / "motion.npz").is_file() and (out / "events.csv").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kinetics"]["trials"] == [] and "no body mass" in summary["kinetics"]["refused"]


def write_grf_mot(path: Path, plates: list[Any], times: np.ndarray) -> None:
    """An OpenSim ground-reaction .mot of ``plates`` (PlateRecords, Z up) at ``times`` [s]:
    OpenSim's Y up, force on the subject, its point the centre of pressure and the torque
    the free moment there (zeros where unloaded)."""
    from mocap_mj.io.orientation import rotation_to_z_up

    to_z_up = rotation_to_z_up("y")  # the reader's: z_up = y_up @ to_z_up.T
    columns = ["time"]
    blocks = [times[:, None]]
    for k, p in enumerate(plates):
        prefix = f"{k + 1}_ground_"
        for stem, values in (("force_v", p.force), ("force_p", np.nan_to_num(p.cop)),
                             ("torque_", p.free_moment)):  # fmt: skip
            columns += [f"{prefix}{stem}{a}" for a in "xyz"]
            blocks.append(values @ to_z_up)
    rows = np.concatenate(blocks, axis=1)
    header = f"grf\nversion=1\nnRows={len(rows)}\nnColumns={len(columns)}\nendheader\n"
    body = "\n".join("\t".join(f"{v:.9g}" for v in row) for row in rows)
    path.write_text(header + "\t".join(columns) + "\n" + body + "\n")


@needs_data
def test_forces_from_a_grf_mot_give_the_c3d_plates_kinetics(ik_out: Path, tmp_path: Path) -> None:
    from mocap_mj.io import load_markers
    from mocap_mj.io.plates import read_plates

    traj = load_markers(MOVEMENT)
    mot = tmp_path / "grf.mot"
    write_grf_mot(mot, read_plates(MOVEMENT), traj.times)
    out = tmp_path / "r"
    proc = run("ik", "--markers", str(MOVEMENT), "--out", str(out), "--forces", str(mot))
    assert proc.returncode == 0, proc.stderr
    (ours,) = json.loads((out / "summary.json").read_text())["kinetics"]["trials"]
    (c3d,) = json.loads((ik_out / "summary.json").read_text())["kinetics"]["trials"]
    assert ours["forces_file"] == str(mot)
    assert ours["plates_per_foot"] == c3d["plates_per_foot"]
    for key in ("residual_force_rms_n", "residual_moment_rms_nm", "peak_grf_n"):
        assert ours[key] == pytest.approx(c3d[key], rel=1e-4), key


STATIC = MOVEMENT.with_name("Static_trial.c3d")


@pytest.mark.skipif(not STATIC.is_file(), reason=SKIP)
def test_plates_no_foot_stands_on_give_a_note_and_no_tables(tmp_path: Path) -> None:
    # Static_trial.c3d declares plates, but the subject stands beside them
    out = tmp_path / "r"
    proc = run("ik", "--markers", str(STATIC), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    (entry,) = json.loads((out / "summary.json").read_text())["kinetics"]["trials"]
    assert entry["stance_frames"] == 0 and "no foot stands alone on a plate" in entry["note"]
    assert not (out / "dynamics.csv").exists() and (out / "events.csv").is_file()
    assert "no joint moments" in proc.stdout


@needs_data
def test_frames_take_the_plates_of_those_frames(ik_out: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"
    proc = run("ik", "--markers", str(MOVEMENT), "--out", str(out), "--frames", "100:250")
    assert proc.returncode == 0, proc.stderr
    part, whole = table(out / "grf.csv"), table(ik_out / "grf.csv")
    assert len(part) == 150
    np.testing.assert_allclose(part["time_s"], whole["time_s"][100:250])
    for column in ("left_force_Z_N", "right_force_Z_N", "left_on_plate", "right_on_plate"):
        np.testing.assert_array_equal(part[column], whole[column][100:250])
    times = [e.time for e in read_events_csv(out / "events.csv")]
    assert times and all(whole["time_s"][100] <= t <= whole["time_s"][249] for t in times)
