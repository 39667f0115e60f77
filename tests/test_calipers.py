"""The re-test's caliper profile against the registration's (issue 38): flats, grooves and
shaving hidden in the project's simulator (``field_fleet`` bats, the rulebook's changes,
``simulate.calipers``: four orientations, 0.002 in noise, a few thousandths of ovality,
placement) are found with their kind and region; clean and pine-tarred bats' surveys never
read a removal, however the registration was read.

A flat "the survey shows" is one whose statistic, read on the noise-free survey of the same
bat (the loss it makes against the registration's noise and the null's variances), clears
the scan's bound by two: the re-test's own noise then leaves it above the bound but in a
few hundredths of the draws (fixed draws: ``derandomize``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.special import ndtri

from updating.inspect.calipers import compare_profiles, hidden_flat_depth_m
from updating.inspect.calipers.null import estimate_null, station_basis, station_table
from updating.inspect.calipers.scan import (
    WINDOW_LENGTHS,
    bonferroni_z,
    critical_z,
    patterns_for,
    station_terms,
)
from updating.model.local_change import LocalChange
from updating.model.profile import Profile
from updating.model.units import IN_TO_M
from updating.simulate.calipers import (
    Ovality,
    draw_ovality,
    orientations_deg,
    read_bat,
    retest_survey,
)
from updating.simulate.field_fleet import draw_case
from updating.simulate.fleet import pro_profile
from updating.simulate.rulebook import removed_mass_kg

SIGMA = 0.002 * IN_TO_M


def _bat(seed: int, kind: str = "none"):
    """A nuisance-rich field bat: its lab profile (registration), re-test truth, wood."""
    case = draw_case(np.random.default_rng(seed), kind)
    return case, case.retest, case.baseline.material.rho_kg_m3


def _with(case, changes):
    """The case's re-test with ``changes`` instead of its own."""
    return replace(case.retest, local_changes=tuple(changes))


def _noise_free(bat, mark_deg, truth):
    """The survey the bat gives without noise or placement error (its ovality kept)."""
    x = np.unique(bat.profile.x_m)
    ov = truth["ovality_in"]
    ovality = Ovality(ov["amplitude"] * IN_TO_M, ov["theta0_deg"], ov["drift_deg"])
    return read_bat(np.random.default_rng(0), bat.profile, tuple(bat.local_changes), x,
                    orientations_deg(4), ovality, mark_deg, 0.0, 0.0)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), depth_in=st.floats(0.02, 0.1), span_in=st.floats(4.0, 14.0),
       angle_deg=st.floats(0.0, 180.0), end_in=st.floats(0.5, 2.0))
def test_a_hidden_flat_the_survey_shows_is_found(seed, depth_in, span_in, angle_deg, end_in):
    case, _, rho = _bat(seed)
    length_in = case.retest.profile.length_m / IN_TO_M
    x1 = length_in - end_in
    flat = LocalChange((x1 - span_in) * IN_TO_M, x1 * IN_TO_M, flat_depth_m=depth_in * IN_TO_M,
                       flat_angle_deg=angle_deg)
    bat = _with(case, [flat])
    mark = case.baseline.theta_deg
    survey, truth = retest_survey(np.random.default_rng(seed + 1), bat, 4, mark_deg=mark)
    result = compare_profiles(case.profile, survey, rho)
    shown = compare_profiles(case.profile, _noise_free(bat, mark, truth), rho)
    if shown.statistic < shown.critical + 2:
        return  # the survey cannot show it: blind_spots says so (test below)
    assert result.changes, (shown.statistic, result.statistic, result.critical)
    c = max(result.changes, key=lambda c: c.statistic)
    assert c.kind in ("flat", "shaved")  # a flat between two orientations reads as both
    assert abs(c.region_m[0] / IN_TO_M - (x1 - span_in)) <= 1.5
    assert c.region_m[1] / IN_TO_M == pytest.approx(x1, abs=1.5)
    if c.kind == "flat":
        normal = truth["flat_normal_deg"][0]
        off = abs((c.flat_angle_deg - normal + 90) % 180 - 90)
        assert off <= 3 * c.flat_angle_sd_deg + 10
        assert abs(c.diameter_lost_m / IN_TO_M - depth_in) <= 3 * c.diameter_lost_sd_m / IN_TO_M


def test_a_flat_facing_an_orientation_is_read_with_its_depth_normal_and_wood():
    """A 0.06 in flat over 8 in facing 45 deg: depth, normal, region and grams within their
    stated uncertainties (three sigmas)."""
    case, _, rho = _bat(5)
    length = case.retest.profile.length_m
    flat = LocalChange(length - 9.5 * IN_TO_M, length - 1.5 * IN_TO_M,
                       flat_depth_m=0.06 * IN_TO_M, flat_angle_deg=45.0 + case.baseline.theta_deg)
    bat = _with(case, [flat])
    survey, _ = retest_survey(np.random.default_rng(3), bat, 4, mark_deg=case.baseline.theta_deg)
    (c,) = compare_profiles(case.profile, survey, rho).changes
    assert c.kind == "flat"
    assert abs(c.flat_angle_deg - 45.0) <= 3 * c.flat_angle_sd_deg + 2
    assert abs(c.diameter_lost_m - 0.06 * IN_TO_M) <= 3 * c.diameter_lost_sd_m
    grams = removed_mass_kg(case.retest.profile, rho, flat)
    assert abs(c.removed_mass_kg - grams) <= 3 * c.removed_mass_sd_kg
    assert abs(c.region_m[0] - flat.x0_m) <= 3 * c.region_start_sd_m + 1e-9


def _shown_loss_in(seed, bat, mark_deg=None):
    """The largest loss the bat's changes make in one reading of its survey, in: the survey
    less the same survey (placement, ovality, noise) of the bat without them."""
    changed, _ = retest_survey(np.random.default_rng(seed), bat, 4, mark_deg=mark_deg)
    clean, _ = retest_survey(np.random.default_rng(seed), replace(bat, local_changes=()), 4,
                             mark_deg=mark_deg)
    return float(np.max(clean.diameter_m - changed.diameter_m)) / IN_TO_M


@settings(max_examples=15, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), depth_in=st.floats(0.02, 0.06), width_in=st.floats(0.1, 0.25),
       pitch_in=st.floats(0.5, 1.5), n=st.integers(3, 8), end_in=st.floats(1.0, 3.0))
def test_hidden_grooves_with_a_station_in_a_ring_are_found(seed, depth_in, width_in, pitch_in,
                                                           n, end_in):
    case, _, rho = _bat(seed)
    length_in = case.retest.profile.length_m / IN_TO_M
    starts = length_in - end_in - width_in - pitch_in * np.arange(n)[::-1]
    rings = [LocalChange(a * IN_TO_M, (a + width_in) * IN_TO_M,
                         diameter_loss_m=2 * depth_in * IN_TO_M) for a in starts]
    bat = _with(case, rings)
    survey, _ = retest_survey(np.random.default_rng(seed + 1), bat, 4)
    result = compare_profiles(case.profile, survey, rho)
    shown = _shown_loss_in(seed + 1, bat) > 3 * 0.002  # a reading short by > 3 sigma
    region = (starts[0] - 1.5, starts[-1] + width_in + 1.5)
    for c in result.changes:  # whatever is found lies among the rings
        assert region[0] <= c.region_m[0] / IN_TO_M and c.region_m[1] / IN_TO_M <= region[1]
    if shown:
        assert result.changes
        assert any(c.kind == "grooves" for c in result.changes) or pitch_in < 0.55
        g = [c for c in result.changes if c.kind == "grooves"]
        for c in g:
            assert abs(c.diameter_lost_m / IN_TO_M - 2 * depth_in) <= max(
                3 * c.diameter_lost_sd_m / IN_TO_M, 0.005)


@settings(max_examples=10, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6))
def test_a_shaved_barrel_is_found_with_its_depth_and_stretch(seed):
    case, bat, rho = _bat(seed, "shaved")
    survey, _ = retest_survey(np.random.default_rng(seed + 1), bat, 4)
    result = compare_profiles(case.profile, survey, rho)
    (c,) = result.changes
    truth = case.truth["finding"]
    assert c.kind == "shaved"
    assert abs(c.region_m[0] / IN_TO_M - truth["region_in"][0]) <= 1.5
    depth = truth["reading"]["diameter_lost_in"] * IN_TO_M
    assert abs(c.diameter_lost_m - depth) <= 3 * c.diameter_lost_sd_m + 0.002 * IN_TO_M
    assert abs(c.removed_mass_kg - 1e-3 * truth["reading"]["removed_mass_g"]) <= \
        3 * c.removed_mass_sd_kg + 0.05 * c.removed_mass_kg


@settings(max_examples=6, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), start_in=st.floats(17.0, 20.0), depth_in=st.floats(0.05, 0.1))
@example(seed=2406, start_in=18.089, depth_in=0.0881)  # its taper was once read as grooves
def test_a_shave_that_begins_on_the_taper_is_one_shaving_from_its_start(seed, start_in,
                                                                       depth_in):
    """The taper, where the caliper's placement is noisiest, may be taken as a run of its
    own; read beside the shaving with the same depth, it is the shaving's start."""
    case, _, rho = _bat(seed)
    length_in = case.retest.profile.length_m / IN_TO_M
    shave = LocalChange(start_in * IN_TO_M, (length_in - 1.0) * IN_TO_M,
                        diameter_loss_m=depth_in * IN_TO_M)
    bat = _with(case, [shave])
    survey, _ = retest_survey(np.random.default_rng([seed, 38]), bat, 4,
                              mark_deg=case.baseline.theta_deg)
    (c,) = compare_profiles(case.profile, survey, rho).changes
    assert c.kind == "shaved"
    assert abs(c.region_m[0] / IN_TO_M - start_in) <= 1.5


@pytest.mark.parametrize("seed", [510125, 510199])
def test_a_shaving_found_at_one_orientation_reads_as_shaving_to_its_end(seed):
    """Field bats whose shaving the scan first took at one orientation, its last station
    past the shaving's end (bench_calipers --seed 500000): read as shaving, not grooves,
    over its own stretch."""
    case, bat, rho = _bat(seed, "shaved")
    survey, _ = retest_survey(np.random.default_rng([seed, 38]), bat, 4,
                              mark_deg=case.baseline.theta_deg)
    (c,) = compare_profiles(case.profile, survey, rho).changes
    start, end = case.truth["region_in"]
    assert c.kind == "shaved"
    assert abs(c.region_m[0] / IN_TO_M - start) <= 1.5
    assert abs(c.region_m[1] / IN_TO_M - end) <= 1.5


REGISTRATIONS = ("mean", "one_orientation", "any_orientation", "averaged")


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), kind=st.sampled_from(("none", "pine_tar")),
       orientations=st.integers(1, 4), noise_in=st.floats(0.001, 0.003),
       registration=st.sampled_from(REGISTRATIONS))
def test_clean_and_pine_tarred_surveys_never_read_a_removal(seed, kind, orientations,
                                                            noise_in, registration):
    """Noise (up to 0.003 in: a worse caliper than the contract's), ovality (0.001-0.004 in,
    its axis turning along the bat) and the caliper's placement never read as a flat, a
    groove or shaving -- whether the registration read the mean diameter, one orientation,
    a random one at every station, or the mean of four."""
    case, bat, rho = _bat(seed, kind)
    rng = np.random.default_rng(seed + 1)
    ov = draw_ovality(rng)
    x, d = bat.profile.x_m, bat.profile.diameter_m
    if registration == "mean":
        registered = case.profile  # the field fleet's: 0.003 in of noise
    else:
        angle = {"one_orientation": np.full(x.size, rng.uniform(0, 180)),
                 "any_orientation": rng.uniform(0, 180, x.size)}.get(registration)
        if angle is None:
            read = read_bat(rng, bat.profile, (), np.unique(x), orientations_deg(4), ov)
            registered = read.mean_profile()
        else:
            registered = Profile(x, d + ov.width_m(x, d, bat.profile.length_m, angle)
                                 + 0.002 * IN_TO_M * rng.standard_normal(x.size))
    survey = read_bat(rng, bat.profile, tuple(bat.local_changes), np.unique(x),
                      orientations_deg(orientations), ov, case.baseline.theta_deg, noise_in)
    result = compare_profiles(registered, survey, rho)
    assert result.changes == (), (result.statistic, result.critical, result.changes)


def test_what_the_survey_cannot_see_is_said_with_what_would_measure_it():
    """Four orientations: a flat up to ~0.15 in deep with its normal mid-gap hides (BAT_PHYSICS:
    +-16 deg for 0.05 in); eight show from ~0.05 in; grooves narrower than 0.5 in stations."""
    R = 1.28 * IN_TO_M
    four = hidden_flat_depth_m(orientations_deg(4), R, SIGMA) / IN_TO_M
    eight = hidden_flat_depth_m(orientations_deg(8), R, SIGMA) / IN_TO_M
    assert 0.12 < four < 0.17 and 0.04 < eight < 0.07
    rng = np.random.default_rng(2)
    truth = pro_profile(rng)
    survey = read_bat(rng, truth, (), np.unique(truth.x_m), orientations_deg(4),
                      draw_ovality(rng))
    result = compare_profiles(Profile(truth.x_m, truth.diameter_m), survey, 600.0)
    words = " ".join(result.unseen)
    assert "not measurable by this survey" in words and "22.5 deg" in words
    assert "station spacing (0.50 in" in words and "every 0.1 in" in words
    assert result.station_spacing_m == pytest.approx(0.5 * IN_TO_M)


def test_a_removal_the_survey_reads_is_not_shrinkage_and_shrinkage_is_not_a_removal():
    """A bat dried by two points (its diameter 0.5 % smaller everywhere) reads no removal; a
    0.03 in shave on it still reads 0.03 in."""
    rng = np.random.default_rng(4)
    truth = pro_profile(rng)
    dry = Profile(truth.x_m, truth.diameter_m * 0.995)
    x = np.unique(truth.x_m)
    registered = Profile(truth.x_m, truth.diameter_m)
    clean = read_bat(rng, dry, (), x, orientations_deg(4), draw_ovality(rng))
    assert compare_profiles(registered, clean, 600.0).changes == ()
    length = truth.length_m
    shave = LocalChange(length - 9 * IN_TO_M, length - 1 * IN_TO_M,
                        diameter_loss_m=0.03 * IN_TO_M)
    shaved = read_bat(rng, dry, (shave,), x, orientations_deg(4), draw_ovality(rng))
    (c,) = compare_profiles(registered, shaved, 600.0).changes
    assert c.kind == "shaved"
    assert c.diameter_lost_m == pytest.approx(0.03 * IN_TO_M, abs=0.004 * IN_TO_M)


def _scan_null_max(terms, n, rng):
    """The scan's largest z on ``n`` draws of its own null: each station's ``a`` normal with
    the patterns' cross-information ``bx`` as covariance, plus the common offsets."""
    P, N = terms.a.shape
    a = np.zeros((n, P, N))
    for i in range(N):
        w, V = np.linalg.eigh(terms.bx[:, :, i])
        a[:, :, i] = (rng.standard_normal((n, P)) * np.sqrt(np.clip(w, 0, None))) @ V.T
    ov = np.sqrt(terms.tau_ov2) * rng.standard_normal((n, 1, 1))
    sh = np.sqrt(terms.tau_s2) * rng.standard_normal((n, 1, 1))
    a += terms.c * (ov + sh * terms.g_m)
    cum = np.concatenate([np.zeros((n, P, 1)), np.cumsum(a, axis=2)], axis=2)
    cb, cc, cg = (np.concatenate([np.zeros((P, 1)), np.cumsum(x, axis=1)], axis=1)
                  for x in (terms.b, terms.c, terms.c * terms.g_m))
    zmax = np.full(n, -np.inf)
    for L in (L for L in WINDOW_LENGTHS if L <= N):
        B, C, Cg = (x[:, L:] - x[:, :-L] for x in (cb, cc, cg))
        var = B + terms.tau_ov2 * C**2 + terms.tau_s2 * Cg**2
        z = (cum[:, :, L:] - cum[:, :, :-L]) / np.sqrt(np.where(var > 0, var, 1.0))
        zmax = np.maximum(zmax, np.where(B > 0, z, -np.inf).reshape(n, -1).max(axis=1))
    return zmax


@pytest.mark.parametrize("orientations", [1, 4])
def test_the_scans_bound_holds_its_level_and_is_below_bonferronis(orientations):
    """Hunter's bound over the overlapping runs: on 20,000 draws of a clean survey's own null
    the scan exceeds it at most at the stated level (here 0.01, within three binomial sds),
    and it is below Bonferroni's bound over the same runs."""
    rng = np.random.default_rng(orientations)
    truth = pro_profile(rng)
    survey = read_bat(rng, truth, (), np.unique(truth.x_m), orientations_deg(orientations),
                      draw_ovality(rng))
    registered = Profile(truth.x_m, truth.diameter_m + 0.003 * IN_TO_M
                         * rng.standard_normal(truth.x_m.size))
    stations = station_table(survey, registered)
    bases = [station_basis(a) for a in stations.angles_deg]
    null = estimate_null(stations, registered, bases, np.ones(stations.n, dtype=bool))
    patterns = patterns_for(stations, bases)
    terms = station_terms(stations, bases, null, patterns)
    level, n = 0.01, 20000
    bound = critical_z(terms, level)
    assert bound < bonferroni_z(stations.n, len(patterns), level) - 0.1
    rate = (_scan_null_max(terms, n, rng) > bound).mean()
    assert rate <= level + 3 * np.sqrt(level / n)
    assert rate >= 0.2 * level  # a bound, not a wall: the runs' overlap is used


def test_a_stretch_named_beforehand_holds_its_level_and_finds_what_the_scan_cannot():
    """``compare_profiles(..., region_m)``'s region check: on clean and pine-tarred surveys, any
    stretch of the barrel asked about passes at most about its level (0.001; 0 of 160 here, and its
    z stays below the bound); a 0.02 in flat over 6 in at 4 deg from an orientation read, which the
    whole scan's bound misses on some bats (3 of these 8), passes on every bat where the vibration
    test would name it, its start within 1.5 in."""
    clean_z, found, missed_by_scan = [], 0, 0
    for seed in range(40):
        for kind in ("none", "pine_tar"):
            case, bat, rho = _bat(1000 + seed, kind)
            survey, _ = retest_survey(np.random.default_rng(seed), bat, 4,
                                      mark_deg=case.baseline.theta_deg)
            n = case.profile.length_m / IN_TO_M
            for a, b in ((n - 8, n - 1), (n - 14, n - 4)):
                r = compare_profiles(case.profile, survey, rho,
                                     region_m=(a * IN_TO_M, b * IN_TO_M)).region_check
                assert r.change is None, (seed, kind, r.statistic, r.critical)
                clean_z.append(r.statistic)
    assert np.isfinite(clean_z).all() and max(clean_z) < ndtri(1 - 1e-3 / 5)
    for seed in range(8):
        case, _, rho = _bat(2000 + seed)
        n = case.retest.profile.length_m / IN_TO_M
        flat = LocalChange((n - 8) * IN_TO_M, (n - 2) * IN_TO_M, flat_depth_m=0.02 * IN_TO_M,
                           flat_angle_deg=case.baseline.theta_deg + 4.0)
        survey, _ = retest_survey(np.random.default_rng(seed), _with(case, [flat]), 4,
                                  mark_deg=case.baseline.theta_deg)
        result = compare_profiles(case.profile, survey, rho,
                                  region_m=((n - 8.5) * IN_TO_M, (n - 1.5) * IN_TO_M))
        missed_by_scan += not result.changes
        r = result.region_check
        if r.change is not None:
            found += 1
            assert abs(r.change.region_m[0] / IN_TO_M - (n - 8)) <= 1.5
    assert found == 8 and missed_by_scan >= 1, (found, missed_by_scan)
