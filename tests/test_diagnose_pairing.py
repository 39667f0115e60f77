"""diagnose refuses to name causes from a bad pairing (issue 13): low-MAC pairs, skipped model
modes and parameters at their bounds are reported in its warnings; unreliable shapes are
paired in frequency order, and it says so."""

import numpy as np

from tests.test_diagnose import HANDBOOK, POINTS, PROFILE, meta_for
from updating.diagnose.calibration import DiagnosisFit
from updating.diagnose.model import BOUNDS, State
from updating.diagnose.pairing_check import checked_pairing, pairing_warnings, refuse_causes
from updating.diagnose.run import diagnose
from updating.model.material import Material
from updating.simulate.virtual_bat import VirtualBat, simulate_modes


def _fit(names=(), x=(), macs=(0.99, 0.98, 0.97)) -> DiagnosisFit:
    m = len(macs)
    return DiagnosisFit(frozenset(), State(1e10, 600.0, 10.0, 1e-3, 100.0), tuple(names),
               np.asarray(x, float), np.zeros((len(x), len(x))), np.ones(m),
               np.asarray(macs, float), np.ones((5, m)), 0.0, 0.0, 0.0)


def test_good_pairing_has_no_warning():
    assert pairing_warnings(_fit(["ln_E"], [np.log(1e10)]), np.arange(3), by_mac=True) == []


def test_low_mac_skipped_mode_and_bounds_are_reported_and_refuse_causes():
    hi_eg = BOUNDS["ln_e_over_g"][1]
    w = pairing_warnings(_fit(["ln_e_over_g", "sensor_g"], [hi_eg, 0.0], macs=(0.99, 0.4, 0.9)),
                         np.array([1, 2, 3]), by_mac=True)
    kinds = " | ".join(w)
    assert "low MAC pairs: measured mode 2 / model mode 3 MAC 0.40" in kinds
    assert "skipped model mode(s) 1" in kinds
    assert "e_over_g = 60 is at its upper bound" in kinds
    assert "sensor_g" not in kinds  # a massless sensor (lower bound 0) is physical
    assert refuse_causes(w)
    # with shapes declared unreliable (frequency order), low MAC is expected: not reported
    assert not any("low MAC" in s for s in pairing_warnings(
        _fit(macs=(0.2, 0.3, 0.1)), np.arange(3), by_mac=False))


def test_unreliable_shapes_fall_back_to_frequency_order():
    f = np.array([300.0, 150.0, 700.0])
    for n_points, meas, model, macs in [(2, np.arange(3), np.array([2, 0, 1]), np.ones(3)),
                                        (9, np.array([0]), np.array([4]), np.array([0.9])),
                                        (9, np.arange(3), np.array([1, 0, 2]),
                                         np.array([0.3, 0.4, 0.2]))]:
        i, k, notes = checked_pairing(f, n_points, meas, model, macs, n_model=6)
        np.testing.assert_array_equal(i, [1, 0, 2])  # ascending measured frequency
        np.testing.assert_array_equal(k, [0, 1, 2])
        assert notes and "paired in frequency order" in notes[0]
    i, k, notes = checked_pairing(f, 9, np.arange(3), np.array([1, 0, 2]), np.full(3, 0.95), 6)
    assert notes == [] and k.tolist() == [1, 0, 2]


def test_diagnose_with_a_missed_first_mode_names_no_cause():
    """The first bending mode missing from the test: MAC pairs the others correctly with
    model modes 2..5, skipping mode 1; diagnose says so and names nothing."""
    wood = Material(HANDBOOK.E_pa * 1.08, HANDBOOK.rho_kg_m3 * 0.95, 12.0)
    bat = VirtualBat(PROFILE, wood, POINTS, sensor_mass_kg=4e-3, bungee_k_n_per_m=300.0)
    meas = simulate_modes(bat, n_modes=5, seed=3, shape_noise=0.005).select(np.arange(1, 5))
    result = diagnose(PROFILE, meta_for(wood), meas)
    assert result.model_index.tolist() == [1, 2, 3, 4]
    assert result.causes == ()
    out = result.to_json_dict()
    assert out["causes"] == [] and any("skipped model mode(s) 1" in w for w in out["warnings"])
    assert out["warnings"][-1].startswith("causes not named")
