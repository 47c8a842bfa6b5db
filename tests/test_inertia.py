"""Segment inertial parameters (mocap_mj/anatomy/inertia.py): de Leva's tables on the humanoid.

The masses sum to the body mass, every centre of mass lies on its segment at de Leva's
fraction, every inertia is physically consistent (symmetric, positive definite, its principal
moments obey the triangle inequality), the figures scale with the identified lengths, and the
model MuJoCo compiles (from MjSpec or from the written MJCF) holds them.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy import inertia as ina
from mocap_mj.errors import MocapError
from mocap_mj.skeleton.mjcf import load_model, model_path

MASS = 72.5  # [kg]


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_model()


@pytest.mark.parametrize("sex", ["male", "female"])
def test_masses_sum_to_the_body_mass(model: mujoco.MjModel, sex: ina.Sex) -> None:
    bi = ina.segment_inertia(model, MASS, sex=sex)
    assert bi.mass.sum() == pytest.approx(MASS, rel=1e-12)
    assert np.all(bi.mass > 0)
    # the printed percentages: 100.00 % for the men, 99.99 % for the women (rounding)
    assert ina.mass_total(ina.TABLES[sex]) == pytest.approx(1.0, abs=1.5e-4)


def test_thigh_figures_equal_de_levas_arithmetic(model: mujoco.MjModel) -> None:
    """The 430 mm thigh of a 72.5 kg man: 14.16 % of the mass, its centre of mass 40.95 % of
    the way to the knee, radii 32.9 / 32.9 / 14.9 % of its length (de Leva's Table 4)."""
    bi = ina.segment_inertia(model, MASS, sex="male")
    i = bi.bodies.index("thigh_l")
    length = 0.43
    m = 0.1416 * MASS
    assert bi.mass[i] == pytest.approx(m, rel=1e-12)
    np.testing.assert_allclose(bi.com[i], [0, 0, -0.4095 * length], atol=1e-12)
    expected = m * np.diag([(0.329 * length) ** 2, (0.329 * length) ** 2, (0.149 * length) ** 2])
    np.testing.assert_allclose(bi.inertia[i], expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("sex", ["male", "female"])
def test_every_com_lies_on_its_segment(model: mujoco.MjModel, sex: ina.Sex) -> None:
    bi = ina.segment_inertia(model, MASS, sex=sex)
    table = ina.TABLES[sex]
    for i, name in enumerate(bi.bodies):
        a, b = bi.ends[i]
        if name in ina.CARRIER_SEGMENTS:
            np.testing.assert_allclose(bi.com[i], 0.0, atol=1e-15)
            continue
        axis = b - a
        s = float((bi.com[i] - a) @ axis / (axis @ axis))
        off_line = np.linalg.norm(bi.com[i] - (a + s * axis))
        assert off_line < 1e-12, name
        assert s == pytest.approx(table[bi.segments[i]].com, abs=1e-12), name
        assert 0.0 < s < 1.0, name


@pytest.mark.parametrize("sex", ["male", "female"])
def test_inertia_is_physically_consistent(model: mujoco.MjModel, sex: ina.Sex) -> None:
    bi = ina.segment_inertia(model, MASS, sex=sex)
    for i, name in enumerate(bi.bodies):
        tensor = bi.inertia[i]
        np.testing.assert_allclose(tensor, tensor.T, atol=1e-15)
        moments = np.linalg.eigvalsh(tensor)
        assert moments[0] > 0, name
        # each principal moment at most the sum of the other two (a real mass distribution)
        assert moments[2] <= moments[0] + moments[1] + 1e-15, name


def test_figures_scale_with_the_identified_lengths(model: mujoco.MjModel) -> None:
    """A thigh 20 % longer: its centre of mass 20 % further, its inertia 44 % larger, its
    mass and the shank's figures unchanged."""
    pset = ParameterSet()
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_l")] *= 1.2
    longer = ina.segment_inertia(pset.model_for(theta), MASS)
    base = ina.segment_inertia(model, MASS)
    i = base.bodies.index("thigh_l")
    assert longer.mass[i] == pytest.approx(base.mass[i])
    np.testing.assert_allclose(longer.com[i], 1.2 * base.com[i], rtol=1e-12)
    np.testing.assert_allclose(longer.inertia[i], 1.44 * base.inertia[i], rtol=1e-12)
    k = base.bodies.index("shank_l")
    np.testing.assert_allclose(longer.inertia[k], base.inertia[k], rtol=1e-12)


def _check_compiled(compiled: mujoco.MjModel, bi: ina.BodyInertia) -> None:
    for i, name in enumerate(bi.bodies):
        b = compiled.body(name).id
        assert compiled.body_mass[b] == pytest.approx(bi.mass[i], rel=1e-12)
        np.testing.assert_allclose(compiled.body_ipos[b], bi.com[i], atol=1e-12)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, compiled.body_iquat[b])
        r = rot.reshape(3, 3)
        tensor = r @ np.diag(compiled.body_inertia[b]) @ r.T
        np.testing.assert_allclose(tensor, bi.inertia[i], rtol=1e-9, atol=1e-12)


def test_mjspec_model_and_written_mjcf_hold_the_figures(tmp_path: Path) -> None:
    source = tmp_path / "model.xml"
    pset = ParameterSet()
    source.write_text(pset.to_xml(pset.nominal))  # a model as the tool writes it (slides)
    before = source.read_bytes()
    bi = ina.segment_inertia(load_model(source), MASS, sex="female")
    _check_compiled(ina.inertial_model(source, MASS, sex="female"), bi)

    dest = tmp_path / "inertial.xml"
    written = ina.write_inertial_model(source, dest, MASS, sex="female")
    assert source.read_bytes() == before  # the source file is never modified
    compiled = mujoco.MjModel.from_xml_path(str(dest))
    _check_compiled(compiled, written)
    assert compiled.nq == 59  # the knees' slide joints are kept
    with pytest.raises(MocapError, match="another file"):
        ina.write_inertial_model(source, source, MASS)
    # written again from the inertial file for another mass: each body's inertial replaced
    again = tmp_path / "again.xml"
    heavier = ina.write_inertial_model(dest, again, 2 * MASS, sex="female")
    assert again.read_text().count("<inertial ") == len(heavier.bodies)
    _check_compiled(mujoco.MjModel.from_xml_path(str(again)), heavier)
    np.testing.assert_allclose(heavier.mass, 2 * written.mass, rtol=1e-12)


def test_bad_input_is_one_clear_error(model: mujoco.MjModel) -> None:
    with pytest.raises(MocapError, match="positive number of kilograms"):
        ina.segment_inertia(model, -3.0)
    with pytest.raises(MocapError, match="sex: expected one of male, female"):
        ina.segment_inertia(model, MASS, sex="robot")  # type: ignore[arg-type]
    spec = mujoco.MjSpec.from_file(str(model_path()))
    sphere = mujoco.mjtGeom.mjGEOM_SPHERE
    spec.worldbody.add_body(name="prop").add_geom(type=sphere, size=[0.05, 0, 0])
    with pytest.raises(MocapError, match="unknown: prop"):
        ina.segment_inertia(spec.compile(), MASS)
