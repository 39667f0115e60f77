"""Beyond one MSSO pass: iterated expansion, refinement, reading the core, hidden alterations."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.correlate.measured import dofs_at, sampled_modes, with_noise
from updating.model.assembly import build_model
from updating.model.mass_properties import mass_properties
from updating.model.material import Material, paper_material
from updating.model.modes import model_modes
from updating.model.profile import paper_profile
from updating.model.sections import Core, cowper_k
from updating.model.units import IN_TO_M
from updating.msso.core_reading import read_core
from updating.msso.expansion import expansion_pass, iterate_expansion
from updating.msso.factors import zero_factors
from updating.msso.update import update_elements

ALPHA = -(2 / 3) / 2.7**2
BETA = -(1 / 2.7) ** 4
CORE = slice(23, 32)
EXACT = {"shape_sigma": 1e-6, "freq_sigma": 1e-7, "prior_sigma": None}


def cork(d_in=1.0, depth_in=10.0, ratio=1 / 3, plug_in=1.0):
    return Core(d_in * IN_TO_M, depth_in * IN_TO_M, ratio, 0.0, plug_in * IN_TO_M)


@pytest.fixture(scope="module")
def paper():
    ref = build_model(paper_profile(), paper_material())
    corked = build_model(paper_profile(), paper_material(), core=cork())
    return ref, corked, model_modes(corked, 10).elastic()


def test_exact_data_at_translational_dofs_gives_the_paper_cork(paper):
    """Fewest that pass: 4 elastic modes with all 34 translational DOFs (3 modes miss alpha by
    ~1.7 %)."""
    ref, _, t = paper
    a = ref.translational_dofs
    u = update_elements(ref, t.freq_hz[:4], t.shapes[a, :4], a, **EXACT)
    assert u.alpha_trans[CORE].mean() == pytest.approx(ALPHA, rel=0.01)
    assert u.beta_bend[CORE].mean() == pytest.approx(BETA, rel=0.02)
    c = read_core(ref, u)
    assert c.found and c.start_m == pytest.approx(23 * IN_TO_M) and \
        c.end_m == pytest.approx(32 * IN_TO_M)
    assert c.diameter_m == pytest.approx(IN_TO_M, rel=0.01)
    assert c.fill_ratio == pytest.approx(1 / 3, rel=0.02)
    # the single pass is what the paper had: clearly worse
    assert abs(u.one_pass.beta_bend[CORE].mean() / BETA - 1) > 0.2
    assert u.refinement.converged and u.rank == 66


def test_true_factors_are_a_fixed_point_of_iterated_expansion(paper):
    """Expanding with the true model's modes is exact, so a further pass changes nothing;
    from zero the passes move the factors (the one-pass expansion error)."""
    ref, corked, t = paper
    a = ref.translational_dofs
    test = sampled_modes(t, a, ref.node_x_m).select(np.arange(6))
    truth = zero_factors(33)
    truth.alpha_trans[CORE] = ALPHA
    truth.alpha_rot[CORE] = ALPHA
    truth.beta_bend[CORE] = BETA
    truth.beta_shear[CORE] = BETA
    again, res, cond = expansion_pass(ref, test, truth, regularisation=None)
    np.testing.assert_allclose(again.beta_bend, truth.beta_bend, atol=1e-6)
    np.testing.assert_allclose(again.alpha_trans, truth.alpha_trans, atol=1e-6)
    assert cond < 100 and res.rank == 66
    f, results = iterate_expansion(ref, test, n_iter=3)
    assert len(results) == 3 and np.abs(f.beta_bend[CORE]).min() > 0


def test_unscaled_shapes_with_a_weighed_mass(paper):
    ref, corked, t = paper
    a = dofs_at(ref, ref.node_x_m)  # every node's translation
    shapes = t.shapes[a, :4] * np.array([3.0, -0.5, 2.0, 7.0])
    u = update_elements(ref, t.freq_hz[:4], shapes, a, mass_normalised=False,
                        weighed_mass_kg=mass_properties(corked).mass_kg, **EXACT)
    assert u.alpha_trans[CORE].mean() == pytest.approx(ALPHA, rel=0.01)
    assert u.beta_bend[CORE].mean() == pytest.approx(BETA, rel=0.02)
    np.testing.assert_allclose(np.abs(u.refinement.scales), [3.0, 0.5, 2.0, 7.0], rtol=1e-3)


def test_measured_points_must_be_nodes(paper):
    ref, _, _ = paper
    with pytest.raises(ValueError, match="not a mesh node"):
        dofs_at(ref, [0.0101])


def _timoshenko_update():
    """Wood-like shear (E/G = 14), rotary inertia off so the three separable parts are the
    whole change: the shear factor (Cowper's k of a tube) and the mass are recovered; the
    bending factor is not yet (xfail below)."""
    pm = paper_material()
    mat = Material(pm.E_pa, pm.rho_kg_m3, 14.0)
    kw = {"beam": "timoshenko", "rotary_inertia": False}
    ref = build_model(paper_profile(), mat, **kw)
    corked = build_model(paper_profile(), mat, core=cork(), **kw)
    t = model_modes(corked, 8).elastic()
    a = ref.translational_dofs
    return update_elements(ref, t.freq_hz[:6], t.shapes[a, :6], a, stiffness="separate",
                           mass="trans", **EXACT)


def test_timoshenko_core_with_separate_bending_and_shear():
    u = _timoshenko_update()
    m = 1 / 2.7
    shear = cowper_k(m, 0.3) / cowper_k(0.0, 0.3) * (1 - m**2) - 1
    assert u.groups == ("bend", "shear", "trans")
    assert u.beta_shear[CORE].mean() == pytest.approx(shear, rel=0.02)
    assert u.alpha_trans[CORE].mean() == pytest.approx(ALPHA, rel=0.02)


@pytest.mark.xfail(reason="separable refinement stalls: bending factor of a Timoshenko core "
                   "not recovered (open issue, docs/msso.md)", strict=True)
def test_timoshenko_bending_factor():
    u = _timoshenko_update()
    assert u.beta_bend[CORE].mean() == pytest.approx(BETA, rel=0.05)


def test_noisy_data_find_the_core(paper):
    ref, _, t = paper
    a = ref.translational_dofs
    test = with_noise(sampled_modes(t, a, ref.node_x_m).select(np.arange(6)), 1e-3, 5e-4,
                      np.random.default_rng(7))
    u = update_elements(ref, test.freq_hz, test.shapes, a, shape_sigma=1e-3)
    c = read_core(ref, u)
    assert c.found
    assert abs(c.start_m / IN_TO_M - 23) <= 1 and abs(c.end_m / IN_TO_M - 32) <= 1
    assert c.diameter_m == pytest.approx(IN_TO_M, rel=0.10)


def test_unaltered_bat_gives_factors_within_the_noise(paper):
    ref, _, _ = paper
    t = model_modes(ref, 8).elastic()
    a = ref.translational_dofs
    test = with_noise(sampled_modes(t, a, ref.node_x_m).select(np.arange(5)), 1e-3, 5e-4,
                      np.random.default_rng(2))
    u = update_elements(ref, test.freq_hz, test.shapes, a, shape_sigma=1e-3, n_resample=3,
                        rng=np.random.default_rng(5))
    assert np.max(np.abs(u.beta_bend)) < 0.01 and np.max(np.abs(u.alpha_trans)) < 0.01
    assert np.all(np.abs(u.beta_bend) < 4 * u.std.beta_bend + 1e-3)
    assert not read_core(ref, u).found


@settings(max_examples=4, deadline=None)
@given(d_in=st.floats(0.75, 1.25), depth_in=st.integers(6, 12), plug_in=st.integers(1, 2),
       ratio=st.sampled_from([0.0, 0.3, 1.8]))
def test_hidden_alteration_is_recovered(d_in, depth_in, plug_in, ratio):
    ref = build_model(paper_profile(), paper_material())
    core = cork(d_in, float(depth_in), ratio, float(plug_in))
    t = model_modes(build_model(paper_profile(), paper_material(), core=core), 8).elastic()
    a = ref.translational_dofs
    u = update_elements(ref, t.freq_hz[:5], t.shapes[a, :5], a, **EXACT)
    c = read_core(ref, u)
    assert c.found
    assert abs(c.start_m / IN_TO_M - (33 - depth_in)) <= 1
    assert abs(c.end_m / IN_TO_M - (33 - plug_in)) <= 1
    assert c.diameter_m == pytest.approx(d_in * IN_TO_M, rel=0.05)
    assert c.fill_ratio == pytest.approx(ratio, abs=0.1)
