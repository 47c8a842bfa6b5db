"""The nine vendors' C3D files in ../shared/data/vendors (see SOURCES.md there), against ezc3d.

ezc3d is the parser of record: every file it reads with marker points, load_markers reads,
with the same labels (less subject prefixes, plus built-in aliases), rate, units, frame count
and coordinates; a file without marker points is one clear error.
"""

from __future__ import annotations

from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers
from mocap_mj.io.formats.c3d_check import check_c3d
from mocap_mj.io.units import metres_per_unit

VENDORS = Path(__file__).resolve().parents[2] / "shared" / "data" / "vendors"
SKIP = "../shared/data/vendors not present: vendor-file checks need the shared folder"

# file -> subjects to read (None: the file has one or none)
FILES = {
    "Qualisys.c3d": [None],
    "FP_Type3.c3d": [None],
    "Vicon.c3d": ["Daphnee", "boite"],
    "BTS.c3d": [None],
    "FP_Type1.c3d": [None],
    "Optotrak.c3d": [None],
    "C3DRotationExample.c3d": [None],
    "Kistler.c3d": [None],
    "read_NOTworking2.c3d": [None],
}
CASES = [(name, subject) for name, subjects in FILES.items() for subject in subjects]


def _path(name: str) -> Path:
    path = VENDORS / name
    if not path.is_file():
        pytest.skip(SKIP)
    return path


@pytest.mark.parametrize(("name", "subject"), CASES, ids=[f"{n}-{s}" for n, s in CASES])
def test_vendor_file_reads_as_ezc3d_reads_it(name: str, subject: str | None) -> None:
    path = _path(name)
    truth = ezc3d.c3d(str(path))
    points = truth["data"]["points"]
    params = truth["parameters"]["POINT"]
    if points.shape[1] == 0:
        with pytest.raises(InputFileError, match=r"POINT:USED: expected marker points, got none"):
            load_markers(path)
        return
    traj = load_markers(path, subject=subject.lower() if subject else None)
    assert traj.rate == float(params["RATE"]["value"][0])
    assert traj.n_frames == points.shape[2]
    assert traj.source["units"] == params["UNITS"]["value"][0]
    scale = metres_per_unit(params["UNITS"]["value"][0])
    assert scale is not None
    labels = [str(v).strip() for v in params["LABELS"]["value"]]
    original = {model: lab for lab, model in traj.source["aliased"].items()}
    prefix = f"{subject}:" if subject else ""
    residuals = truth["data"]["meta_points"]["residuals"][0]
    rotation = np.asarray(traj.source["rotation"])
    for k, name_ in enumerate(traj.names):
        j = labels.index(prefix + original.get(name_, name_))
        expected = points[:3, j, :].T * scale @ rotation.T  # (T, 3) [m], Z up
        gone = (residuals[j] < 0) | np.all(points[:3, j, :] == 0, axis=0)
        np.testing.assert_allclose(traj.positions[~gone, k], expected[~gone], rtol=1e-12)
        assert np.isnan(traj.positions[gone, k]).all()
        assert traj.source["missing_samples"].get(name_, 0) == gone.sum()
    kept = {prefix + original.get(n, n) for n in traj.names}
    others = set(traj.source["dropped"]) | set(traj.source["other_subjects_markers"])
    assert kept | others == set(labels)


def test_vendor_names_get_plug_in_gait_aliases() -> None:
    qualisys = load_markers(_path("Qualisys.c3d"))
    assert {"L_IAS": "LASI", "R_IPS": "RPSI", "CV7": "C7", "L_FLE": "LKNE"}.items() <= (
        qualisys.source["aliased"].items()
    )
    assert "TV8" in qualisys.names  # not T10: no alias invents a landmark
    bts = load_markers(_path("BTS.c3d"))
    assert {"r asis": "RASI", "c7": "C7", "l heel": "LHEE"}.items() <= bts.source["aliased"].items()


def test_several_subjects_need_the_subject_flag() -> None:
    path = _path("Vicon.c3d")
    with pytest.raises(InputFileError) as info:
        load_markers(path)
    assert str(info.value) == (
        f"{path}: expected one subject, got 2 (Daphnee, boite): pass --subject NAME to choose one"
    )


def test_header_with_more_frames_than_the_file_warns_once(caplog: pytest.LogCaptureFixture) -> None:
    path = _path("Optotrak.c3d")
    traj = load_markers(path)
    assert traj.n_frames == 29
    messages = [r.getMessage() for r in caplog.records]
    assert messages == [
        f"{path}: data section: the header declares 1149 frames, the file holds 29: read the "
        "29 frames present"
    ]


def test_check_passes_every_vendor_file_ezc3d_reads() -> None:
    """The in-process check itself (not only the probe behind it) lets these through."""
    for name in FILES:
        layout = check_c3d(_path(name))
        truth = ezc3d.c3d(str(VENDORS / name))["data"]["points"]
        assert layout.n_points == truth.shape[1]
        if layout.n_points:
            assert layout.n_frames == truth.shape[2]


def test_up_axis_detected_under_a_marker_set_s_own_names() -> None:
    """Read with the ISB set's names (L_HDF, L_FCC... as the model's sites), Qualisys.c3d's
    vertical still comes from its head and foot markers (their Plug-in Gait aliases), not
    from the C3D's metadata (-z): the same axes as read with Plug-in Gait's names."""
    path = VENDORS / "Qualisys.c3d"
    if not path.is_file():
        pytest.skip(SKIP)
    from mocap_mj.capture.marker_set import load_marker_set

    root = Path(__file__).resolve().parents[1]
    names = [m.name for m in load_marker_set(root / "models/marker_sets/qualisys_isb.yaml").markers]
    own = load_markers(path, model_names=names)
    assert (own.source["up"], own.source["up_detected"]) == ("z", True)
    pig = load_markers(path)
    np.testing.assert_array_equal(own.select(["L_IAS"]), pig.select(["LASI"]))
