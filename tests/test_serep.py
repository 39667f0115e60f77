"""MAC pairing, SEREP expansion and the pseudo-orthogonality check of test-shape scaling."""

import numpy as np
import pytest

from updating.correlate.pairing import mac, pair_modes, pseudo_orthogonality
from updating.correlate.serep import serep
from updating.model.assembly import assemble, build_model
from updating.model.material import paper_material
from updating.model.modes import model_modes
from updating.model.profile import paper_profile
from updating.model.sections import Core
from updating.model.units import IN_TO_M


@pytest.fixture(scope="module")
def bats():
    ref = build_model(paper_profile(), paper_material())
    cork = build_model(paper_profile(), paper_material(),
                       core=Core(IN_TO_M, 10 * IN_TO_M, 1 / 3, 0.0, IN_TO_M))
    return ref, cork


def test_mac_is_one_for_scaled_copies_and_zero_for_orthogonal():
    a = np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 3.0]])
    m = mac(a, np.column_stack([-5 * a[:, 0], a[:, 1]]))
    np.testing.assert_allclose(m, np.eye(2), atol=1e-15)


def test_pairing_recovers_a_permutation_of_sign_flipped_modes(bats):
    ref, cork = bats
    a = ref.translational_dofs
    r = model_modes(ref, 8).elastic().shapes[a]
    t = model_modes(cork, 8).elastic().shapes[a][:, [2, 0, 3, 1]] * [1, -1, -1, 1]
    p = pair_modes(t, r, weak="raise")
    np.testing.assert_array_equal(p.index_b, [2, 0, 3, 1])
    assert np.all(p.mac > 0.95)
    with pytest.raises(ValueError, match="pairs with no model mode"):
        pair_modes(t[:, :1] + np.roll(t[:, :1], 7) * 3, r[:, :1], min_mac=0.99, weak="raise")


def test_serep_expands_basis_shapes_exactly_and_reports_conditioning(bats):
    ref, _ = bats
    modes = model_modes(ref, 8)  # 2 rigid + 6 elastic
    a = ref.translational_dofs[::3]  # 12 sensors
    T = serep(modes.shapes, a)
    combo = modes.shapes @ np.linspace(1, 2, 8)
    np.testing.assert_allclose(T.expand(combo[a]), combo, atol=1e-10 * np.abs(combo).max())
    assert 1 <= T.cond < 1e4
    with pytest.raises(ValueError, match="at least 8 measured DOFs"):
        serep(modes.shapes, a[:7])


def test_pseudo_orthogonality_checks_the_scaling(bats):
    ref, cork = bats
    a = ref.translational_dofs
    M = assemble(ref)[1]
    rm = model_modes(ref, 6)
    T = serep(rm.shapes, a)
    exact = pseudo_orthogonality(rm.shapes[a, 2:], T.reduce(M))
    assert exact.max_offdiag < 1e-10 and exact.max_diag_error < 1e-10
    # corked bat's modes, mass-normalised to the corked bat: close to I, not exactly
    tm = model_modes(cork, 6)
    near = pseudo_orthogonality(tm.shapes[a, 2:], T.reduce(M))
    assert 1e-4 < near.max_offdiag < 0.05 and near.max_diag_error < 0.1
    scaled = pseudo_orthogonality(1.2 * rm.shapes[a, 2:], T.reduce(M))
    assert scaled.max_diag_error == pytest.approx(0.44, rel=1e-6)
