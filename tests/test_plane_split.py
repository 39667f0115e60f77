"""A flat read from the change of the two bending planes' split (issue 38 item 3).

Hidden flats (random depth 0.03-0.1 in, 4-14 in long ending 0.5-2 in from the barrel end,
normal within 25 deg of a grain plane) in the two-plane simulator with every pair resolved
(tapped 30-60 deg from the grain), the two planes' E/G moved apart by up to the null's
3 %, must be read: found, the normal's side (phi mod 90 deg: which member's plane it is
nearer), the region's centre within 1.5 in where the reader says the modes localise it, and
its depth (the depth with the normal in a grain plane) no deeper than the flat. Clean,
drifting, gripped bats must not be read; a flat at 45 deg is invisible to the splits and is
said to be not measurable, never a clean barrel.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

from batlab.pipeline.records import verdict_record
from batlab.registry.records import decode_modes, encode_modes
from updating.inspect.finding import Finding
from updating.inspect.plane_split import (
    RATIO_DRIFT,
    _edge_fits,
    _patterns,
    read_plane_split,
    split_model,
)
from updating.inspect.plane_split_verdict import join_plane_split
from updating.inspect.verdict import Verdict
from updating.model.local_change import LocalChange
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M
from updating.simulate.field_fleet import draw_case
from updating.simulate.plane_pairs import planes_case
from updating.simulate.virtual_bat import VirtualBat
from updating.simulate.wide import pair_frequencies

NOISE = 3e-5
"""Each member's relative frequency sd (the fits')."""


def reference_of(bat: VirtualBat) -> BatReference:
    """The bat's nominal wood as its reference (no calibration error, no wood field)."""
    w = bat.material
    return BatReference(w.E_pa, w.rho_kg_m3, w.e_over_g, beam="timoshenko",
                        rotary_inertia=True)


def two_tests(seed: int, kind: str = "none", flat: LocalChange | None = None):
    """(case, reference, baseline modes, re-test modes) of ``plane_pairs.planes_case``."""
    c = planes_case(seed, kind, flat, NOISE)
    return c.case, c.reference, c.baseline, c.retest


def hidden_flat(seed: int, length_in: float) -> LocalChange:
    """Depth 0.03-0.1 in, 4-14 in long ending 0.5-2 in from the end, normal within 25 deg of
    a grain plane (either side of either plane)."""
    rng = np.random.default_rng(500 + seed)
    x1 = length_in - rng.uniform(0.5, 2.0)
    x0 = x1 - rng.uniform(4.0, 14.0)
    angle = rng.choice([0.0, 90.0, 180.0]) + rng.uniform(-25, 25)
    return LocalChange(x0 * IN_TO_M, x1 * IN_TO_M, flat_depth_m=rng.uniform(0.03, 0.1) * IN_TO_M,
                       flat_angle_deg=angle % 180)


@pytest.mark.parametrize("seed", range(4))
def test_a_hidden_flat_is_read_from_the_splits(seed):
    case0 = draw_case(np.random.default_rng(seed), "none")
    flat = hidden_flat(seed, case0.profile.length_m / IN_TO_M)
    case, ref, mb, mr = two_tests(seed, flat=flat)
    s = read_plane_split(case.profile, ref, mb, mr)
    assert len(s.pairs) == 6 and s.significant and s.p_value < 1e-3
    # the simulator's radial plane is the upper member (E/G radial 9-12 < tangential 12-16)
    cos2 = np.cos(np.radians(2 * flat.flat_angle_deg))
    assert s.nearer_plane == ("upper" if cos2 > 0 else "lower")
    true_centre = 0.5 * (flat.x0_m + flat.x1_m)
    if s.localised:
        assert abs(s.centre_m - true_centre) <= 1.5 * IN_TO_M
    assert s.region_m[0] < flat.x1_m and s.region_m[1] > flat.x0_m
    assert s.depth_m - 2 * s.depth_sd_m <= flat.flat_depth_m * 1.1


@pytest.mark.parametrize("seed,kind", [(10, "none"), (11, "none"), (12, "none"),
                                       (13, "pine_tar"), (14, "grip_tape"), (15, "none")])
def test_clean_drifting_and_gripped_bats_are_not_read(seed, kind):
    case, ref, mb, mr = two_tests(seed, kind)
    s = read_plane_split(case.profile, ref, mb, mr)
    assert len(s.pairs) == 6
    assert not s.significant and s.statistic < s.critical
    assert any("not evidence of a clean barrel" in n for n in s.notes)


def test_a_flat_at_45_deg_is_not_measurable_and_never_a_clean_barrel():
    """cos 2 phi = 0: both members lose the same stiffness, the split does not move."""
    case0 = draw_case(np.random.default_rng(3), "none")
    L = case0.profile.length_m
    flat = LocalChange(L - 10 * IN_TO_M, L - IN_TO_M, flat_depth_m=0.08 * IN_TO_M,
                       flat_angle_deg=45.0)
    case, ref, mb, mr = two_tests(3, flat=flat)
    s = read_plane_split(case.profile, ref, mb, mr)
    assert not s.significant
    v = join_plane_split(_verdict(False), s)
    assert v.altered is False and "normal lies near 45 deg" in v.reasons[-1]
    assert "not measurable by this test" in v.reasons[-1]


def test_first_order_pattern_matches_the_two_plane_model():
    """P_k (first order, energy fractions) against the truth model's split change for a
    0.05 in flat at phi = 0, by differencing both planes' models: within 10 % per mode."""
    case = draw_case(np.random.default_rng(2), "none")
    bat = replace(case.baseline, wood=None, sensor_mass_kg=0.0, bungee_k_n_per_m=0.0)
    L = bat.profile.length_m
    region = np.array([[L - 9 * IN_TO_M, L - 2 * IN_TO_M]])
    flat = LocalChange(*region[0], flat_depth_m=0.05 * IN_TO_M)
    f0, f1 = pair_frequencies(bat, 5), pair_frequencies(replace(bat, local_changes=(flat,)), 5)
    exact = np.log(f1[0] / f1[1]) - np.log(f0[0] / f0[1])
    m, _ = split_model(bat.profile, reference_of(bat), f0.mean(axis=0))
    first = _patterns(m, region, 0.05 * IN_TO_M)[0]
    assert np.all(first < 0) and first == pytest.approx(exact, rel=0.1)


def _verdict(altered, finding=None) -> Verdict:
    x = np.linspace(0, 0.8, 5)
    return Verdict(altered, 0.6, 0.01, 1.2, None, None, None, {}, x[:-1], x[1:],
                   np.zeros(4), np.zeros(4), {}, reasons=("the modal verdict",),
                   finding=finding)


def test_a_read_flat_makes_a_clean_verdict_at_most_inconclusive_and_joins_the_calipers():
    case0 = draw_case(np.random.default_rng(1), "none")
    L = case0.profile.length_m
    flat = LocalChange(L - 9 * IN_TO_M, L - IN_TO_M, flat_depth_m=0.06 * IN_TO_M)
    case, ref, mb, mr = two_tests(1, flat=flat)
    s = read_plane_split(case.profile, ref, mb, mr)
    assert s.significant
    v = join_plane_split(_verdict(False), s)
    assert v.altered is None and v.reasons[0].startswith("a flat suspected")
    assert "measure the re-test's caliper profile" in v.reasons[0]
    assert v.reasons[1] == "vibration test: the modal verdict"
    calipers = Finding("material_removed", False, (flat.x0_m, flat.x1_m), "flat-surfaced",
                       family="calipers")
    v = join_plane_split(_verdict(True, calipers), s)
    assert v.altered is True and v.finding is calipers
    assert "agrees with the calipers' reading" in v.reasons[-1]


def test_too_few_pairs_is_not_measurable_with_what_would_measure_it():
    case, ref, mb, mr = two_tests(4)
    one = mb.select([0, 1])
    s = read_plane_split(case.profile, ref, one, mr)
    assert not s.significant and len(s.pairs) == 2
    assert "not measurable" in s.notes[0] and "tap at 45 deg to the grain" in s.notes[0]
    v = join_plane_split(_verdict(False), s)
    assert v.altered is False and v.reasons[-1] == s.notes[0]
    altered = join_plane_split(_verdict(True), s)  # altered already: its reasons kept
    assert altered.altered is True and altered.reasons == ("the modal verdict",)
    assert altered.plane_split is s


def test_the_registry_keeps_the_pairs_members():
    _, _, mb, _ = two_tests(5)
    back = decode_modes(encode_modes(mb))
    np.testing.assert_allclose(back.plane_pair_hz, mb.plane_pair_hz)
    np.testing.assert_allclose(back.plane_pair_std_hz, mb.plane_pair_std_hz)
    old = {k: v for k, v in encode_modes(mb).items() if not k.startswith("plane_pair")}
    assert decode_modes(old).plane_pair_hz is None


def test_the_registry_record_keeps_the_reading_under_details():
    case, ref, mb, mr = two_tests(4)
    s = read_plane_split(case.profile, ref, mb, mr)
    rec = verdict_record("SIM-0001", join_plane_split(_verdict(False), s),
                         {"false_alarm_rate": 0.01, "chance": None})
    stored = json.loads(json.dumps(rec, allow_nan=False))["details"]["plane_split"]
    assert len(stored["pairs"]) == len(s.pairs) and stored["level"] == 1e-3
    assert stored["significant"] is False and stored["notes"] == list(s.notes)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(4, 8), collinear=st.booleans(),
       scale=st.floats(0.5, 60.0))
def test_the_edge_fits_are_the_bounded_least_squares_optimum(seed, n, collinear, scale):
    """Where the fit without bounds leaves the planes' drift outside its square, the edge
    fits every region at once reach scipy's bounded least squares (lsq_linear) or a lower
    chi^2, with its amplitude; the two planes' shear patterns nearly collinear, as a bat's
    are, among the draws."""
    rng = np.random.default_rng(seed)
    S = scale * rng.standard_normal((n, 2))
    if collinear:
        S[:, 1] = -0.97 * S[:, 0] + 0.05 * scale * rng.standard_normal(n)
    P, d = rng.standard_normal((12, n)), rng.standard_normal(n) * rng.uniform(0.01, 10.0)
    free = np.array([np.linalg.lstsq(np.column_stack([p, S]), d, rcond=None)[0] for p in P])
    out = np.any(np.abs(free[:, 1:]) > RATIO_DRIFT, axis=1)
    chi, amp = _edge_fits(d, S, P[out], RATIO_DRIFT)
    for i, p in enumerate(P[out]):
        A = np.column_stack([p, S])
        x = lsq_linear(A, d, bounds=(np.r_[-np.inf, -RATIO_DRIFT, -RATIO_DRIFT],
                                     np.r_[np.inf, RATIO_DRIFT, RATIO_DRIFT])).x
        ref = float(np.sum((d - A @ x) ** 2))
        assert chi[i] <= ref * (1 + 1e-9) + 1e-12
        assert chi[i] >= ref * (1 - 1e-4) - 1e-12  # lsq_linear stops within its tolerance
        assert amp[i] == pytest.approx(x[0], rel=2e-3, abs=1e-9)
