"""The 3D solid check (updating.solid) against beam theory, and the shear coefficients."""

import numpy as np
import pytest

from updating.model.material import Material
from updating.model.profile import make_profile
from updating.model.sections import cowper_k, hutchinson_k, shear_k
from updating.solid.compare import beam_hz
from updating.solid.elastic import OrthotropicWood, isotropic
from updating.solid.mesh import bat_mesh
from updating.solid.modes import solid_modes

STEEL = (200e9, 7800.0, 0.3)
CYLINDER = make_profile(np.array([0.0, 0.8]), np.array([0.06, 0.06]))


def test_shear_coefficients_closed_forms():
    nu = 0.3
    assert hutchinson_k(0.0, nu) == pytest.approx(6 * (1 + nu) ** 2 / (7 + 12 * nu + 4 * nu**2))
    assert cowper_k(0.0, nu) == pytest.approx(6 * (1 + nu) / (7 + 6 * nu))
    # thin-walled tube limit (m -> 1): Hutchinson 2 (1+nu)^2 / (4 + 6 nu + 2 nu^2)... both
    # formulas tend to about 0.5; a hollow section is always below the solid one
    m = np.linspace(0, 0.99, 50)
    for f in (cowper_k, hutchinson_k):
        k = f(m, nu)
        assert np.all(np.diff(k) < 0) and 0.45 < k[-1] < 0.6
    assert shear_k(0.5, nu, "hutchinson") == hutchinson_k(0.5, nu)
    with pytest.raises(ValueError, match="unknown shear coefficient"):
        shear_k(0.5, nu, "timoshenko")


def test_mesh_is_a_solid_of_revolution():
    """Volume and second moment of the curved quadratic mesh converge to pi r^2 L, pi r^4/4."""
    from skfem import CellBasis, ElementHex2

    errs = []
    for n_sec, n_ring in ((2, 1), (4, 2)):
        b = CellBasis(bat_mesh(CYLINDER, 4, n_sec, n_ring), ElementHex2())
        y = b.mapping.F(b.quadrature[0])[1]
        assert b.dx.min() > 0
        errs.append((abs(b.dx.sum() / (np.pi * 0.03**2 * 0.8) - 1),
                     abs((b.dx * y**2).sum() / (np.pi * 0.03**4 / 4 * 0.8) - 1)))
    assert errs[0][0] < 1e-3 and errs[0][1] < 2e-3
    assert errs[1][0] < errs[0][0] / 10 and errs[1][1] < errs[0][1] / 10


@pytest.fixture(scope="module")
def cylinder_modes():
    return solid_modes(bat_mesh(CYLINDER, 16, 2, 1), isotropic(*STEEL), 14)


def test_cylinder_against_timoshenko(cylinder_modes):
    """An isotropic cylinder (L/D = 13): the solid's bending modes agree with the 1D
    Timoshenko beam with Hutchinson's coefficient within 0.5 % (coarse 16 x 12-cell mesh;
    converged meshes: 0.02 %, docs/model.md), better than with Cowper's; torsion and
    extension at the rod formulas c / 2L."""
    E, rho, nu = STEEL
    f3 = np.sort(np.concatenate([cylinder_modes.bending_hz("y"), cylinder_modes.bending_hz("z")]))
    f3 = f3[::2][:4]  # one of each degenerate pair
    errs = {}
    for k in ("cowper", "hutchinson"):
        f1 = beam_hz(CYLINDER, Material(E, rho, 2 * (1 + nu), nu, k), 4)
        errs[k] = f1 / f3 - 1
    assert np.max(np.abs(errs["hutchinson"])) < 5e-3
    assert np.sqrt(np.mean(errs["hutchinson"] ** 2)) < np.sqrt(np.mean(errs["cowper"] ** 2))
    axial = cylinder_modes.freq_hz[cylinder_modes.kind == "axial"][0]
    assert axial == pytest.approx(np.sqrt(E / rho) / 1.6, rel=2e-3)
    torsion = cylinder_modes.freq_hz[cylinder_modes.kind == "other"][0]
    assert torsion == pytest.approx(np.sqrt(E / (2 * (1 + nu)) / rho) / 1.6, rel=2e-3)


def test_planar_grain_splits_the_bending_planes():
    """Planar grain with G_LR > G_LT: bending in the L-R plane (y) is stiffer, and each plane
    follows the 1D beam with its own E/G; cylindrical grain gives degenerate pairs."""
    wood = OrthotropicWood(12e9, 650.0, e_over_g_lr=10.0, e_over_g_lt=16.0)
    mesh = bat_mesh(CYLINDER, 16, 2, 1)
    planar = solid_modes(mesh, wood, 14, "planar")
    fy, fz = planar.bending_hz("y")[:3], planar.bending_hz("z")[:3]
    assert np.all(fy > fz * 1.001)
    for f3, eg in ((fy, 10.0), (fz, 16.0)):
        f1 = beam_hz(CYLINDER, Material(12e9, 650.0, eg, 0.3, "hutchinson"), 3)
        assert np.max(np.abs(f1 / f3 - 1)) < 0.01
    cyl = solid_modes(mesh, wood, 10, "cylindrical")
    f = np.sort(cyl.freq_hz[np.char.startswith(cyl.kind.astype(str), "bend")])[:4]
    assert f[1] == pytest.approx(f[0], rel=1e-6) and f[3] == pytest.approx(f[2], rel=1e-6)
    assert np.allclose(cyl.one_plane().bending_hz("y")[:2], f[::2])


def test_rigid_body_of_the_solid(cylinder_modes):
    """Mass, centre of mass and pitch inertia from the solid's mass matrix: the cylinder's
    rho pi r^2 L, L / 2 and m (L^2 / 12 + r^2 / 4) (mesh accuracy, as the volume above)."""
    mass, cg, inertia = cylinder_modes.rigid
    m = STEEL[1] * np.pi * 0.03**2 * 0.8
    assert mass == pytest.approx(m, rel=1e-3)
    assert cg == pytest.approx(0.4, rel=1e-9)
    assert inertia == pytest.approx(m * (0.8**2 / 12 + 0.03**2 / 4), rel=1e-3)


@pytest.mark.parametrize("amplitude", [-0.03, 0.05])
def test_a_density_gradient_moves_the_solids_mass_as_integrated(amplitude):
    """A billet's density factor 1 + a cos(pi x / L) on the cylinder: the same mass (the
    half-wave averages to 0), the centre of mass at L/2 - 2 a L / pi^2 and the pitch inertia
    about the knob end m L^2 / 3 + m r^2 / 4 - 2 a m L^2 / pi^2, integrated by hand."""
    from updating.solid.modes import assemble_solid, rigid_body

    length, r = 0.8, 0.03

    def factor(x):
        return 1.0 + amplitude * np.cos(np.pi * x / length)

    _, M, basis = assemble_solid(bat_mesh(CYLINDER, 16, 2, 1), isotropic(*STEEL),
                                 density_factor=factor)
    mass, cg, inertia = rigid_body(M, basis.doflocs)
    m = STEEL[1] * np.pi * r**2 * length
    assert mass == pytest.approx(m, rel=1e-3)
    assert cg == pytest.approx(length / 2 - 2 * amplitude * length / np.pi**2, rel=1e-4)
    i_knob = m * length**2 / 3 + m * r**2 / 4 - 2 * amplitude * m * length**2 / np.pi**2
    assert inertia + mass * cg**2 == pytest.approx(i_knob, rel=1e-3)


def test_frf_test_of_the_solid_carries_its_modes_and_mass_line(cylinder_modes):
    """3D-simulated roving-hammer FRFs (updating.simulate.solid_test) through the real modal
    fit: the bending frequencies of the solid and its exact mass line
    1/M + (x - x_c)(x_d - x_c)/I come back (0.5 % noise, bungees)."""
    from ema.modal_fit import fit_test
    from updating.simulate.solid_test import tap_test_frf

    x = np.linspace(0.02, 0.78, 13)
    test = tap_test_frf(cylinder_modes, x, 12, 30.0, bungee_k_n_per_m=400.0, seed=3)
    fit = fit_test(test)
    bend = np.unique(np.round(cylinder_modes.bending_hz("y"), 3))
    bend = bend[bend < 3100]
    assert fit.freq_hz.size == bend.size
    np.testing.assert_allclose(fit.freq_hz, bend, rtol=2e-4)
    mass, cg, inertia = cylinder_modes.rigid
    truth = 1 / mass + (x - cg) * (x[12] - cg) / inertia
    c1, c0 = np.polyfit(x, fit.mass_line[0], 1)
    assert (c0 + c1 * x[12]) / truth[12] - 1 == pytest.approx(0.0, abs=2e-3)
