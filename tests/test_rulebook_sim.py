"""The rulebook's changes on the virtual rig (updating/model/local_change.py,
updating/simulate/rulebook.py): the physics of each change, its consistency with the FE
mesh, and the fleet's draws of them."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.model.assembly import assemble, build_model, displacement_at
from updating.model.local_change import (
    LocalChange,
    apply_local_changes,
    change_stations_m,
    flat_section,
    section_factors,
)
from updating.model.mass_properties import mass_properties
from updating.model.material import Material
from updating.model.modes import model_modes
from updating.model.profile import make_profile
from updating.model.units import IN_TO_M, LB_TO_KG
from updating.simulate import nuisances as nz
from updating.simulate.field_fleet import bare, draw_case, scale_reading
from updating.simulate.fleet import pro_profile
from updating.simulate.rulebook import (
    HANDLE_LIMIT_IN,
    LEGAL_KINDS,
    RULEBOOK_KINDS,
    draw_change,
)

WOOD = Material(E_pa=12e9, rho_kg_m3=650.0, e_over_g=14.0)
PROFILE = pro_profile(np.random.default_rng(7))
L_IN = PROFILE.length_m / IN_TO_M


def model_with(changes=(), element_in=0.5, plane="radial", apply=True):
    """A Timoshenko model of PROFILE with nodes at the changes' ends, the changes applied
    (or not: the same mesh without them)."""
    model = build_model(PROFILE, WOOD, beam="timoshenko", element_length_m=element_in * IN_TO_M,
                        stations_m=change_stations_m(changes, PROFILE.length_m))
    return apply_local_changes(model, changes if apply else (), plane)


def elastic_hz(model, n=5):
    return model_modes(model, n_modes=n + 2).freq_hz[2:n + 2]


@settings(max_examples=10, deadline=None)
@given(mass_g=st.floats(0.5, 30.0), x0_in=st.floats(0.5, 30.0), span_in=st.floats(0.3, 8.0),
       surface=st.booleans())
def test_added_mass_adds_its_grams_and_lowers_each_mode_as_rayleigh_says(
        mass_g, x0_in, span_in, surface):
    x1_in = min(x0_in + span_in, L_IN)
    change = LocalChange(x0_in * IN_TO_M, x1_in * IN_TO_M, added_mass_kg=1e-3 * mass_g,
                         mass_at_surface=surface)
    m0, m1 = model_with((change,), apply=False), model_with((change,))
    dm = mass_properties(m1).mass_kg - mass_properties(m0).mass_kg
    assert dm == pytest.approx(1e-3 * mass_g, rel=1e-9)
    K0, M0 = assemble(m0)
    K1, M1 = assemble(m1)
    np.testing.assert_allclose(K1, K0, rtol=0, atol=1e-9 * np.abs(K0).max())  # no stiffness
    modes = model_modes(m0, n_modes=7)
    assert np.all(elastic_hz(m1) < modes.freq_hz[2:])
    # Rayleigh, first order (a hundredth of the mass, so that first order holds): df/f =
    # -1/2 phi^T dM phi with mass-normalised phi: each mode moves by the mass it carries there
    small = model_with((replace(change, added_mass_kg=1e-5 * mass_g),))
    phi = modes.shapes[:, 2:]
    predicted = -0.5 * np.einsum("im,ij,jm->m", phi, assemble(small)[1] - M0, phi)
    actual = elastic_hz(small) / modes.freq_hz[2:] - 1
    np.testing.assert_allclose(actual, predicted, rtol=0.03, atol=1e-8)


def test_a_mass_at_the_barrel_end_moves_modes_more_than_one_at_a_node():
    modes = model_modes(model_with(), n_modes=3)
    x = np.linspace(10.0, L_IN - 0.5, 400)
    w1 = np.abs(displacement_at(model_with(), modes.shapes[:, 2:3], x * IN_TO_M))[:, 0]
    node_in, anti_in = x[np.argmin(w1)], L_IN - 0.5
    shift = []
    for at in (node_in, anti_in):
        c = LocalChange((at - 0.25) * IN_TO_M, (at + 0.25) * IN_TO_M, added_mass_kg=0.01,
                        mass_at_surface=False)
        shift.append(elastic_hz(model_with((c,)), 1)[0] / modes.freq_hz[2] - 1)
    assert shift[1] < 20 * shift[0] <= 0.0


@settings(max_examples=10, deadline=None)
@given(cut_in=st.floats(0.002, 0.1), x0_in=st.floats(20.0, 28.0), span_in=st.floats(1.0, 6.0))
def test_shaving_lowers_stiffness_twice_as_fast_as_mass(cut_in, x0_in, span_in):
    change = LocalChange(x0_in * IN_TO_M, (x0_in + span_in) * IN_TO_M,
                         diameter_loss_m=cut_in * IN_TO_M)
    m0, m1 = model_with((change,), apply=False), model_with((change,))
    inside = (m0.samples.x_m > change.x0_m) & (m0.samples.x_m < change.x1_m)
    dD = cut_in * IN_TO_M / PROFILE.diameter_at(m0.samples.x_m[inside])
    d_ei = 1 - m1.samples.props.ei[inside] / m0.samples.props.ei[inside]
    d_m = 1 - m1.samples.props.rhoa[inside] / m0.samples.props.rhoa[inside]
    np.testing.assert_allclose(d_ei, 4 * dD, rtol=2 * dD.max() + 1e-9)  # 1-(1-e)^4 = 4e+O(e^2)
    np.testing.assert_allclose(d_m, 2 * dD, rtol=dD.max() + 1e-9)
    np.testing.assert_allclose(d_ei / d_m, 2.0, rtol=1.5 * dD.max() + 1e-9)
    assert np.all(m1.samples.props.ei[~inside] == m0.samples.props.ei[~inside])


def test_a_local_diameter_loss_is_the_model_of_the_turned_down_profile():
    x0, x1, cut = 22.3 * IN_TO_M, 30.1 * IN_TO_M, 0.07 * IN_TO_M
    change = LocalChange(x0, x1, diameter_loss_m=cut)
    x = PROFILE.x_m
    inner = x[(x > x0) & (x < x1)]
    xs = np.concatenate([x[x <= x0], [x0, x0], inner, [x1, x1], x[x >= x1]])
    d = PROFILE.diameter_at(xs)
    d[np.searchsorted(xs, x0) + 1: np.searchsorted(xs, x1, side="right") - 1] -= cut
    turned = make_profile(xs, d)
    stations = change_stations_m((change,), PROFILE.length_m)
    direct = build_model(turned, WOOD, beam="timoshenko", element_length_m=0.5 * IN_TO_M,
                         stations_m=stations)
    K0, M0 = assemble(direct)
    K1, M1 = assemble(model_with((change,)))
    np.testing.assert_allclose(K1, K0, rtol=1e-9, atol=1e-9 * np.abs(K0).max())
    np.testing.assert_allclose(M1, M0, rtol=1e-9, atol=1e-9 * np.abs(M0).max())


def test_changed_frequencies_converge_with_the_mesh():
    changes = (LocalChange(29.0 * IN_TO_M, 31.5 * IN_TO_M, added_mass_kg=0.02,
                           mass_at_surface=False),
               LocalChange(20.0 * IN_TO_M, 30.0 * IN_TO_M, diameter_loss_m=0.05 * IN_TO_M))
    sizes = (1.0, 0.5, 0.25, 0.125)
    f = np.array([elastic_hz(model_with(changes, h), 4) for h in sizes])
    f0 = np.array([elastic_hz(model_with(changes, h, apply=False), 4) for h in sizes])
    steps = np.abs(f[1:] / f[:-1] - 1)
    assert np.all(steps[:-1] / steps[1:] > 3.0)  # second order in h, as the clean model
    shift = f / f0 - 1  # the change's own effect hardly depends on the mesh
    np.testing.assert_allclose(shift[1], shift[-1], rtol=0.01)
    assert np.all(np.abs(shift[-1]) > 1e-3)
    weights = [mass_properties(model_with(changes, h)).mass_kg for h in (1.0, 0.25)]
    assert weights[0] == pytest.approx(weights[1], rel=1e-12)


@given(r_m=st.floats(0.005, 0.04), frac=st.floats(0.0, 0.6))
@settings(max_examples=20, deadline=None)
def test_a_flat_section_matches_a_fine_grid_of_the_cut_circle(r_m, frac):
    h = frac * r_m
    n = 801
    y, z = np.meshgrid(np.linspace(-r_m, r_m, n), np.linspace(-r_m, r_m, n), indexing="ij")
    cell = (2 * r_m / (n - 1)) ** 2
    keep = (y**2 + z**2 <= r_m**2) & (y <= r_m - h)
    area_grid = keep.sum() * cell
    yc = (y * keep).sum() * cell / area_grid
    area, i_n, i_p = flat_section(np.array([r_m]), h)
    assert area[0] == pytest.approx(area_grid, rel=5e-3)
    assert i_n[0] == pytest.approx((((y - yc) ** 2) * keep).sum() * cell, rel=1e-2)
    assert i_p[0] == pytest.approx(((z**2) * keep).sum() * cell, rel=1e-2)


def test_a_flat_changes_the_plane_towards_it_more_and_its_area_in_both():
    D = np.array([0.065])
    flat = LocalChange(0.0, 1.0, flat_depth_m=0.002, flat_angle_deg=0.0)
    a_r, i_r = section_factors(D, flat, "radial")
    a_t, i_t = section_factors(D, flat, "tangential")
    assert a_r == a_t < 1 and i_r < i_t < 1
    turned = replace(flat, flat_angle_deg=90.0)
    np.testing.assert_allclose(section_factors(D, turned, "radial")[1], i_t)


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10**6), kind=st.sampled_from(RULEBOOK_KINDS))
def test_each_draw_weighs_what_its_truth_reads_and_keeps_the_handle_rule(seed, kind):
    case = draw_case(np.random.default_rng(seed), kind, nuisances=())
    truth = case.truth
    finding = truth["finding"]
    start, end = finding["region_in"]
    assert 0.0 < start < end <= case.profile.length_m / IN_TO_M + 1e-3  # rounded
    clean = replace(case.retest, local_changes=())
    dw_g = 1e3 * LB_TO_KG * (scale_reading(bare(case.retest))[0]
                             - scale_reading(bare(clean))[0])
    reading = finding["reading"]
    expected_g = (reading.get("net_added_mass_g") or reading.get("added_mass_g")
                  or -reading["removed_mass_g"])
    assert dw_g == pytest.approx(expected_g, rel=2e-3, abs=2e-3)
    assert truth["altered"] == (finding["kind"] != "handle_substance")
    assert finding["legal"] == (kind in LEGAL_KINDS)
    if finding["kind"] == "handle_substance":
        assert truth["expected"] == "not_altered" and truth["region_in"] is None
        assert (end <= HANDLE_LIMIT_IN) == finding["legal"] == (not truth["needs_cleaning"])
    else:
        assert truth["expected"] == "altered" and truth["region_in"] == finding["region_in"]
        assert end > HANDLE_LIMIT_IN + 10.0  # every alteration here reaches into the barrel


@pytest.mark.parametrize("kind", ["nails", "flattened", "pine_tar"])
def test_the_fleet_gives_rulebook_bats_every_nuisance_and_the_retest_only_the_change(kind):
    seed = 11
    plain = draw_case(np.random.default_rng(seed), "none")
    case = draw_case(np.random.default_rng(seed), kind, integrity=None)
    assert case.truth["drawn"] == plain.truth["drawn"]  # nuisances drawn before the change
    assert set(case.truth["nuisances"]) == set(nz.NUISANCES)
    assert case.baseline.local_changes == () and case.retest.local_changes
    assert case.retest.e_over_g_t is not None  # two planes
    slip = draw_case(np.random.default_rng(seed), kind, integrity="g_per_n_as_si")
    assert slip.truth["expected"] == "inconclusive"


def test_a_flattened_bat_differs_by_plane_and_an_unknown_kind_is_refused():
    case = draw_case(np.random.default_rng(5), "flattened")
    f_r = elastic_hz(bare(case.retest).truth_model("radial"), 3)
    f_t = elastic_hz(bare(case.retest).truth_model("tangential"), 3)
    clean = replace(bare(case.retest), local_changes=())
    g_r = elastic_hz(clean.truth_model("radial"), 3)
    g_t = elastic_hz(clean.truth_model("tangential"), 3)
    assert not np.allclose(f_r / g_r, f_t / g_t, rtol=1e-6)
    with pytest.raises(ValueError, match="unknown rulebook change 'glue'"):
        draw_change(np.random.default_rng(0), "glue", PROFILE, 650.0)
