"""The flexible structure: cantilever tip stiffness, tip mass, modal damping, frequencies."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from campaign.core.errors import InputError
from campaign.rig.beam import (
    Beam,
    cantilever_flexibility,
    exact_first_frequency,
    rayleigh_first_frequency,
)
from campaign.scene.description import make_scene

EI, L, M_BEAM = 2.5e8, 20.0, 200.0


@pytest.fixture(scope="module")
def beam() -> Beam:
    """The beam of the default rig file."""
    return Beam.from_scene(make_scene(base="flexible"))


def test_from_scene_reads_the_rig_file(beam):
    scene = make_scene(base="flexible")
    assert beam.EI == scene.p("flexible.beam_EI") == 2.5e8  # paper section 4.2
    assert beam.length == scene.p("flexible.beam_length")
    assert beam.mass == scene.p("flexible.beam_mass")
    assert beam.damping_ratio == scene.p("flexible.damping_ratio")
    assert beam.platform_mass == scene.p("flexible.platform_mass")


@pytest.mark.parametrize("axis", [0, 1])
def test_static_tip_deflection_under_tip_force(beam, axis):
    """A tip force alone deflects the tip by F L^3 / (3 EI) (within 0.1 %; exact here), and
    tilts it by F L^2 / (2 EI) towards the force."""
    F = 250.0
    w = np.zeros(6)
    w[axis] = F
    x = beam.deflection(w)
    expected = F * beam.length**3 / (3.0 * beam.EI)
    assert x[axis] == pytest.approx(expected, rel=1e-3)
    assert x[axis] == pytest.approx(expected, rel=1e-12)
    slope = F * beam.length**2 / (2.0 * beam.EI)
    # +x force bends the beam towards +x: rotation +theta_y; +y force: rotation -theta_x
    if axis == 0:
        assert x[4] == pytest.approx(slope, rel=1e-12)
        assert x[3] == 0.0
    else:
        assert x[3] == pytest.approx(-slope, rel=1e-12)
        assert x[4] == 0.0
    assert x[2] == 0.0 and x[5] == 0.0


def test_tip_moment_axial_and_torsion_closed_forms(beam):
    Lb, EIb = beam.length, beam.EI
    Mm = 40.0
    x = beam.deflection([0, 0, 0, 0, Mm, 0])       # moment about y
    assert x[4] == pytest.approx(Mm * Lb / EIb, rel=1e-12)
    assert x[0] == pytest.approx(Mm * Lb**2 / (2 * EIb), rel=1e-12)
    x = beam.deflection([0, 0, 0, Mm, 0, 0])       # moment about x bends towards -y
    assert x[3] == pytest.approx(Mm * Lb / EIb, rel=1e-12)
    assert x[1] == pytest.approx(-Mm * Lb**2 / (2 * EIb), rel=1e-12)
    assert beam.deflection([0, 0, 1e3, 0, 0, 0])[2] == pytest.approx(1e3 * Lb / beam.EA, rel=1e-12)
    assert beam.deflection([0, 0, 0, 0, 0, 7.0])[5] == pytest.approx(7.0 * Lb / beam.GJ, rel=1e-12)


def test_stiffness_is_the_inverse_of_the_cantilever_flexibility(beam):
    K = beam.stiffness
    np.testing.assert_allclose(K, K.T, rtol=0, atol=0)
    assert np.all(np.linalg.eigvalsh(K) > 0)
    C = cantilever_flexibility(beam.EI, beam.length)
    # x-z plane in (u_x, theta_y) is exactly the flexibility's inverse
    np.testing.assert_allclose(K[np.ix_([0, 4], [0, 4])], np.linalg.inv(C), rtol=1e-12)
    assert K[0, 0] == pytest.approx(12 * beam.EI / beam.length**3)
    assert K[1, 3] == -K[0, 4] == pytest.approx(6 * beam.EI / beam.length**2)


def test_beam_tip_mass_is_the_hermite_consistent_mass():
    b = Beam(EI, L, M_BEAM)
    Mb = b.beam_inertia.matrix()
    m = M_BEAM
    assert Mb[0, 0] == Mb[1, 1] == pytest.approx(156 / 420 * m)
    assert Mb[0, 4] == pytest.approx(-22 * L * m / 420)
    assert Mb[1, 3] == pytest.approx(+22 * L * m / 420)
    assert Mb[3, 3] == Mb[4, 4] == pytest.approx(4 * L**2 * m / 420)
    # along the static tip-load shape (phi = 3u / 2L) its effective mass is the classical 33/140 m
    shape = np.array([1.0, 0, 0, 0, 1.5 / L, 0])
    assert shape @ Mb @ shape == pytest.approx(33 / 140 * m, rel=1e-12)
    # torsion: a uniform shaft's tip share m r_p^2 / 3, r_p^2 = 2 EI / EA
    assert Mb[5, 5] == pytest.approx(m * 2.0 / b.EA_ratio / 3.0)
    # the emulated base is beam share + platform, one rigid body
    np.testing.assert_allclose(b.mass_matrix, Mb + b.platform_body.matrix(), rtol=1e-12)


def test_base_body_is_the_emulated_base(beam):
    body = beam.base_body()
    assert body.mass == pytest.approx(beam.mass_matrix[0, 0])
    np.testing.assert_allclose(body.spatial_inertia.matrix(), beam.mass_matrix, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(body.mount.translation, [0, 0, beam.mount_height])


@pytest.mark.parametrize("alpha, lam", [(0.0, 1.87510407), (0.2, 1.61640), (0.5, 1.41996), (1.0, 1.24792),
                                        (2.0, 1.07620), (5.0, 0.87002)])
def test_exact_frequency_equation_matches_tabulated_roots(alpha, lam):
    """First root of the cantilever-with-tip-mass equation vs the tabulated lambda_1
    (Blevins table 8-8 / Laura et al. 1974) for tip mass ratios M/m."""
    f = exact_first_frequency(EI, L, M_BEAM, alpha * M_BEAM)
    lam_f = math.sqrt(2 * math.pi * f * L**2 / math.sqrt(EI * L / M_BEAM))
    assert lam_f == pytest.approx(lam, abs=2e-5)


@pytest.mark.parametrize("tip_mass, tip_inertia, com", [
    (0.0, 0.0, 0.0),          # platform only (rig file)
    (23.45, 2.7, 0.0),        # a PUMA-sized arm on top
    (23.45, 2.7, 0.45),       # ... with its centre of mass above the tip
    (500.0, 50.0, 0.0),       # heavy tip
])
def test_first_mode_within_1_percent_of_the_exact_frequency(beam, tip_mass, tip_inertia, com):
    """The tip model's first mode vs the continuous beam's exact frequency equation."""
    tip = pin.Inertia(tip_mass, np.array([0.0, 0.0, com]), np.diag([tip_inertia, tip_inertia, tip_inertia]))
    f_model = beam.first_mode_frequency(tip=tip)
    f_exact = beam.exact_first_frequency(tip_mass, tip_inertia, com)
    assert f_model == pytest.approx(f_exact, rel=0.01)
    # the Hermite reduction is stiff by construction (Rayleigh-Ritz): never below the exact value
    assert f_model >= f_exact * (1 - 1e-12)
    assert f_model == pytest.approx(f_exact, rel=0.005)


def test_bare_beam_frequency_and_rayleigh():
    tiny = Beam(EI, L, M_BEAM, platform_mass=1e-9, platform_inertia=(1e-12,) * 3)
    f_exact = exact_first_frequency(EI, L, M_BEAM)
    assert f_exact == pytest.approx(1.8751040687**2 / (2 * math.pi * L**2) * math.sqrt(EI * L / M_BEAM), rel=1e-9)
    assert tiny.first_mode_frequency() == pytest.approx(f_exact, rel=0.005)   # worst case, 0.48 %
    # Rayleigh's 33/140 formula: good for heavy tips, 1.5 % high for a bare beam
    assert rayleigh_first_frequency(EI, L, M_BEAM, 2000.0) == pytest.approx(
        exact_first_frequency(EI, L, M_BEAM, 2000.0), rel=1e-3)
    assert rayleigh_first_frequency(EI, L, M_BEAM, 0.0) == pytest.approx(f_exact, rel=0.02)


def test_default_modes_ascend_and_bending_pairs_are_equal(beam):
    freq, _ = beam.modes()
    assert np.all(np.diff(freq) >= 0)
    assert freq[0] == pytest.approx(freq[1], rel=1e-9)   # axisymmetric: two equal bending modes


def _arm_on_top(beam, config):
    """Composite inertia of the locked arm in a paper configuration, at the beam tip."""
    import pinocchio as pin

    from campaign.model.paper import configuration_q
    from campaign.model.robot import load_robot

    robot = load_robot()
    data = robot.model.createData()
    pin.ccrba(robot.model, data, configuration_q(config), np.zeros(robot.nv))
    return beam.base_body().mount.act(data.oYcrb[0])


@pytest.mark.parametrize("config", [1, 2])
def test_named_structures_first_modes_with_the_arm_on_top(config):
    """The stiff mast's first mode is a few hertz; the space-class structure's lies in the
    0.3-1 Hz of published long-reach manipulators (Shuttle RMS unloaded ~0.35-0.71 Hz), with
    the paper's EI, and the rig's default is the space-class one."""
    f1 = {}
    for name in ("stiff_mast", "space_class"):
        beam = Beam.from_scene(make_scene(base="flexible", config=config, params={"flexible.structure": name}))
        assert beam.EI == 2.5e8
        f1[name] = float(beam.modes(tip=_arm_on_top(beam, config))[0][0])
    assert 3.0 < f1["stiff_mast"] < 6.0
    assert 0.3 < f1["space_class"] < 1.0
    assert make_scene(base="flexible").p("flexible.structure") == "space_class"


def test_stiff_mast_is_the_flexible_leaves_of_the_rig_file():
    from campaign.scene.description import load_rig, load_structures

    values, _ = load_rig()
    scene = make_scene(base="flexible", params={"flexible.structure": "stiff_mast"})
    assert load_structures()["stiff_mast"] == {}
    for key, value in values.items():
        if key != "flexible.structure":
            assert scene.p(key) == value, key


def test_structure_selection_and_its_bad_input():
    # an explicit override wins over the structure's value
    scene = make_scene(base="flexible", params={"flexible.structure": "space_class", "flexible.beam_length": 40.0})
    assert scene.p("flexible.beam_length") == 40.0
    with pytest.raises(InputError, match="flexible.structure 'tower'"):
        make_scene(base="flexible", params={"flexible.structure": "tower"})
    with pytest.raises(InputError, match="flexible.structure"):
        scene.replace(params={"flexible.structure": "stiff_mast"})


def test_modal_damping_gives_every_mode_the_damping_ratio(beam):
    freq, phi = beam.modes()
    modal = phi.T @ beam.damping @ phi
    omega = 2 * math.pi * freq
    np.testing.assert_allclose(np.diag(modal), 2 * beam.damping_ratio * omega, rtol=1e-9)
    off = modal - np.diag(np.diag(modal))
    assert np.max(np.abs(off)) < 1e-9 * np.max(np.abs(modal))
    assert np.all(np.linalg.eigvalsh(beam.damping) > -1e-9 * np.max(np.abs(beam.damping)))


def test_matrices_are_read_only(beam):
    with pytest.raises(ValueError):
        beam.stiffness[0, 0] = 1.0
    with pytest.raises(ValueError):
        beam.damping[0, 0] = 1.0


@pytest.mark.parametrize("field, value, key", [
    ("EI", -2.5e8, "flexible.beam_EI"),
    ("EI", 0.0, "flexible.beam_EI"),
    ("length", -20.0, "flexible.beam_length"),
    ("length", 0.0, "flexible.beam_length"),
    ("mass", -1.0, "flexible.beam_mass"),
    ("mass", 0.0, "flexible.beam_mass"),
    ("mass", float("nan"), "flexible.beam_mass"),
    ("platform_mass", 0.0, "flexible.platform_mass"),
    ("EI", "stiff", "flexible.beam_EI"),
])
def test_bad_beam_values_are_input_errors_naming_the_value(field, value, key):
    kwargs = dict(EI=EI, length=L, mass=M_BEAM)
    kwargs[field] = value
    with pytest.raises(InputError) as err:
        Beam(**kwargs)
    msg = str(err.value)
    assert field in msg and key in msg and repr(value) in msg


def test_bad_damping_and_platform_inertia():
    with pytest.raises(InputError, match="damping_ratio"):
        Beam(EI, L, M_BEAM, damping_ratio=-0.1)
    with pytest.raises(InputError, match="damping_ratio"):
        Beam(EI, L, M_BEAM, damping_ratio=1.5)
    with pytest.raises(InputError, match="platform_inertia"):
        Beam(EI, L, M_BEAM, platform_inertia=(5.0, -1.0, 5.0))
    with pytest.raises(InputError, match="EI"):
        exact_first_frequency(-1.0, L, M_BEAM)
