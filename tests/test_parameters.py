"""theta: names, bounds, maps onto the model, and round trips (vector, JSON, MJCF)."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from mocap_mj import Kinematics, MocapError, ParameterSet, ShapeError, UnknownNameError


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def random_theta(pset: ParameterSet, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    kappa, offsets = pset.split(pset.nominal)
    kappa = kappa * rng.uniform(0.9, 1.1, kappa.shape)
    offsets = offsets + rng.uniform(-0.02, 0.02, offsets.shape)
    return pset.join(kappa, offsets)


def test_layout(pset: ParameterSet) -> None:
    assert pset.n_kappa == 34 and pset.size == 151
    assert len(set(pset.names)) == 151
    assert pset.names[34:37] == ("LASI.x", "LASI.y", "LASI.z")
    assert np.all(pset.lower < pset.nominal) and np.all(pset.nominal < pset.upper)
    assert pset.within_bounds(random_theta(pset))
    # Every kappa moves at least one body, each direction is a unit vector.
    for k in range(pset.n_kappa):
        norms = np.linalg.norm(pset.direction[k], axis=1)
        assert np.any(norms > 0)
        np.testing.assert_allclose(norms[norms > 0], 1.0)


def test_kappa_is_a_length(pset: ParameterSet) -> None:
    """Nominal lengths are positive and anatomically sized (1.75 m adult)."""
    kappa, _ = pset.split(pset.nominal)
    named = dict(zip(pset.kappa_names, kappa, strict=True))
    assert 0.40 < named["thigh_length_l"] < 0.46
    assert 0.40 < named["shank_length_r"] < 0.46
    assert 0.27 < named["upperarm_length_l"] < 0.34
    assert 0.15 < named["hip_width_l"] + named["hip_width_r"] < 0.22
    # The alignment parameters are signed offsets, nominally 0 (neutral alignment).
    aligned = {n for n in named if n.startswith(("knee_lateral", "ankle_lateral"))}
    assert len(aligned) == 4 and all(named[n] == 0.0 for n in aligned)
    assert all(v > 0 for n, v in named.items() if n not in aligned)


def test_apply_moves_only_what_the_map_says(pset: ParameterSet) -> None:
    model = mujoco.MjModel.from_xml_path(str(pset.path))
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_l")] += 0.05
    pset.apply(model, theta)
    moved = np.flatnonzero(np.any(model.body_pos != pset.body_pos_nominal, axis=1))
    assert [model.body(b).name for b in moved] == ["shank_l"]
    np.testing.assert_allclose(model.body_pos[moved[0]] - pset.body_pos_nominal[moved[0]],
                               [0, 0, -0.05])  # fmt: skip
    theta[pset.index("LTOE.y")] = 0.011
    pset.apply(model, theta)
    assert model.site_pos[model.site("LTOE").id][1] == 0.011


def test_vector_round_trip(pset: ParameterSet) -> None:
    theta = random_theta(pset, 1)
    kappa, offsets = pset.split(theta)
    np.testing.assert_array_equal(pset.join(kappa, offsets), theta)
    model = mujoco.MjModel.from_xml_path(str(pset.path))
    pset.apply(model, theta)
    np.testing.assert_allclose(pset.read(model), theta, atol=1e-15)


def test_json_round_trip(pset: ParameterSet, tmp_path) -> None:  # type: ignore[no-untyped-def]
    theta = random_theta(pset, 2)
    path = tmp_path / "theta.json"
    pset.save_json(path, theta, extra={"note": "test"})
    data = json.loads(path.read_text())
    assert data["note"] == "test" and data["units"] == "m"
    np.testing.assert_array_equal(pset.load_json(path), theta)


def test_mjcf_export_reloads_to_identical_kinematics(pset: ParameterSet, tmp_path) -> None:  # type: ignore[no-untyped-def]
    theta = random_theta(pset, 3)
    path = tmp_path / "subject.xml"
    pset.export_mjcf(path, theta)
    reloaded = ParameterSet(path)
    np.testing.assert_allclose(reloaded.nominal, theta, rtol=0, atol=1e-15)
    a, b = Kinematics(pset), Kinematics(reloaded)
    a.set_theta(theta)
    rng = np.random.default_rng(0)
    qpos = a.integrate(np.tile(a.model.qpos0, (30, 1)), rng.normal(0, 0.4, (30, a.nv)))
    np.testing.assert_array_equal(a.marker_positions(qpos), b.marker_positions(qpos))


def test_bad_input(pset: ParameterSet, tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(UnknownNameError, match="LASI, RASI"):
        pset.marker_index("LKNEE")
    with pytest.raises(UnknownNameError, match="thigh_length_l"):
        pset.index("femur")
    with pytest.raises(ShapeError, match=r"theta: expected shape \(151,\), got \(150,\)"):
        pset.check(np.zeros(150))
    with pytest.raises(ShapeError, match="offsets"):
        pset.join(np.zeros(pset.n_kappa), np.zeros((38, 3)))
    bad = tmp_path / "theta.json"
    bad.write_text('{"kappa": {}, "offsets": {}}')
    with pytest.raises(MocapError, match="missing names"):
        pset.load_json(bad)
