"""The wide-nuisance drawer (updating/simulate/wide.py): bounds, each nuisance alone changing
only what it owns, its physics against closed forms, and the band-edge constructor against
the truth model's two planes."""

from dataclasses import fields, is_dataclass, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.model.modes import model_modes
from updating.model.units import IN_TO_M, LB_TO_KG
from updating.simulate import wide
from updating.simulate.field_fleet import draw_case
from updating.simulate.rulebook import HANDLE_LIMIT_IN

SEED = 100_003

OWNS = {  # nuisance -> the VirtualBat fields it may change (b: baseline, r: re-test)
    "moisture_shape": {"r.wood"}, "moisture_shear": {"r.wood"},
    "temperature": {"b.wood", "r.wood"}, "angle": {"b.theta_deg", "r.theta_deg"},
    "band_edge": set(), "points": {"b.points_m", "r.points_m"},
    "accelerometer": {"b.sensor_mass_kg", "r.sensor_mass_kg", "r.sensor_offset_m"},
    "bungees": {"r.bungee_k_n_per_m"}, "grip": {"r.local_changes"},
    "tar_past_18": {"r.local_changes"}, "noise": {"b.rel_noise", "r.rel_noise"},
}


def same(x, y) -> bool:
    """Deep equality of dataclasses, arrays, tuples and numbers."""
    if is_dataclass(x) and is_dataclass(y):
        return type(x) is type(y) and all(same(getattr(x, f.name), getattr(y, f.name))
                                          for f in fields(x))
    if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
        return np.array_equal(x, y)
    if isinstance(x, tuple) and isinstance(y, tuple):
        return len(x) == len(y) and all(same(a, b) for a, b in zip(x, y, strict=True))
    return x == y


def differing(a, b, tag) -> set:
    return {f"{tag}.{f.name}" for f in fields(a)
            if not same(getattr(a, f.name), getattr(b, f.name))}


def one(nuisance: str, seed: int = SEED, draw: int = 0) -> dict:
    rng = np.random.default_rng([seed, 1, draw])
    return wide.settings_of(wide.random_unit(rng, (nuisance,)), (nuisance,))


@settings(max_examples=30, deadline=None)
@given(u=st.lists(st.floats(0.0, 1.0), min_size=len(wide.COORDINATES),
                  max_size=len(wide.COORDINATES)))
def test_settings_stay_within_bounds_and_round_trip(u):
    s = wide.settings_of(np.array(u), wide.WIDE_NUISANCES)
    for c, ui in zip(wide.COORDINATES, u, strict=True):
        for owner in c.owners:
            v = s[owner][c.name]
            assert c.lo <= v <= c.hi
            assert c.unit(v) == pytest.approx(ui, abs=1e-12)


def test_a_nuisance_draws_the_same_values_alone_and_with_others():
    u_all = wide.random_unit(np.random.default_rng(5), wide.WIDE_NUISANCES)
    s_all = wide.settings_of(u_all, wide.WIDE_NUISANCES)
    for n in wide.WIDE_NUISANCES:
        s_one = wide.settings_of(wide.random_unit(np.random.default_rng(5), (n,)), (n,))
        assert s_one[n] == s_all[n]


def test_random_starts_favour_angles_near_a_grain_plane():
    rng = np.random.default_rng(0)
    th = np.array([wide.settings_of(wide.random_unit(rng, ("angle",)), ("angle",))
                   ["angle"]["baseline_deg"] for _ in range(400)])
    near = np.mean((th <= 20.0) | (th >= 70.0))
    assert 0.65 < near < 0.85  # 1/2 favoured + 1/2 x 40/90 uniform = 0.72


def test_bad_settings_are_refused_with_their_name():
    with pytest.raises(ValueError, match="bungees.factor = 2"):
        wide.wide_case(SEED, {"bungees": {"factor": 2.0}})
    with pytest.raises(ValueError, match="unknown wide nuisance"):
        wide.wide_case(SEED, {"humidity": {}})
    with pytest.raises(ValueError, match="needs"):
        wide.wide_case(SEED, {"angle": {"baseline_deg": 10.0}})


def test_no_nuisance_is_the_projects_clean_bat_tapped_on_a_plane():
    case = wide.wide_case(SEED, {})
    ref = draw_case(np.random.default_rng(SEED), "none", ("planes",))
    assert differing(case.baseline, replace(ref.baseline, theta_deg=0.0), "b") == set()
    assert differing(case.retest, case.baseline, "r") == set()
    assert case.freq_hz[-1] == 3200.0 and case.expected == "not_altered"
    assert case.meta["points_in"] == ref.meta["points_in"]


@pytest.mark.parametrize("nuisance", wide.WIDE_NUISANCES)
def test_each_nuisance_alone_changes_only_what_it_owns(nuisance):
    clean = wide.wide_case(SEED, {})
    case = wide.wide_case(SEED, one(nuisance))
    changed = (differing(case.baseline, clean.baseline, "b")
               | differing(case.retest, clean.retest, "r"))
    assert changed <= OWNS[nuisance]
    assert changed or nuisance == "band_edge"
    assert (case.freq_hz.size != clean.freq_hz.size) == (nuisance == "band_edge")
    assert case.expected == "not_altered"


@settings(max_examples=8, deadline=None)
@given(draw=st.integers(0, 10_000))
def test_moisture_shapes_and_couplings_reach_the_truth_model(draw):
    """The re-test's sections follow the drawn profile: density +1 %/point, EI the E
    coupling, kGA the G coupling, sample by sample (against ``moisture_pct``'s closed form)."""
    s = wide.settings_of(wide.random_unit(np.random.default_rng([draw, 7]), wide.MOISTURE),
                         wide.MOISTURE)
    case = wide.wide_case(SEED, s)
    p0, p1 = case.baseline.truth_model().samples, case.retest.truth_model().samples
    L = case.baseline.profile.length_m
    d = wide.moisture_pct(p1.x_m, L, s["moisture_shape"])
    sh = s["moisture_shear"]
    tol = dict(rtol=2e-4, atol=2e-5)  # the field's 1/8 in grid, interpolated linearly
    np.testing.assert_allclose(p1.props.rhoa / p0.props.rhoa, 1 + 0.01 * d, **tol)
    np.testing.assert_allclose(p1.props.ei / p0.props.ei, 1 + sh["e_per_point"] * d, **tol)
    np.testing.assert_allclose(p1.props.kga / p0.props.kga, 1 + sh["g_per_point"] * d, **tol)


def test_moisture_profile_closed_form():
    L = 0.85
    base = {"middle_pct": 1.0, "knob_ratio": 1.0, "knob_decay_in": 2.0, "barrel_ratio": 3.0,
            "barrel_decay_in": 0.5, "gradient_pct": 0.0, "patch_pct": 0.0, "patch_at": 0.5,
            "patch_half_in": 2.0}
    x = np.array([0.0, L / 2, L])
    np.testing.assert_allclose(wide.moisture_pct(x, L, base), [1.0, 1.0, 3.0], atol=1e-6)
    grad = dict(base, barrel_ratio=1.0, gradient_pct=0.8)
    np.testing.assert_allclose(wide.moisture_pct(x, L, grad), [0.6, 1.0, 1.4], atol=1e-9)
    patch = dict(base, barrel_ratio=1.0, patch_pct=-0.5, patch_at=0.5)
    np.testing.assert_allclose(wide.moisture_pct(x, L, patch), [1.0, 0.5, 1.0], atol=1e-9)


def test_temperature_moves_e_and_g_by_their_own_rates():
    s = {"temperature": {"baseline_c": 24.0, "change_c": -8.0, "e_per_c": 0.001,
                         "g_per_c": 0.005}}
    case = wide.wide_case(SEED, s)
    p0, p1 = case.baseline.truth_model().samples, case.retest.truth_model().samples
    np.testing.assert_allclose(p1.props.ei / p0.props.ei, (1 + 0.004) / (1 - 0.004),
                               rtol=1e-12)
    np.testing.assert_allclose(p1.props.kga / p0.props.kga, (1 + 0.020) / (1 - 0.020),
                               rtol=1e-12)
    assert case.retest_meta["temperature_c"] == 16.0


@settings(max_examples=10, deadline=None)
@given(draw=st.integers(0, 10_000), handle=st.sampled_from(["grip", "tar_past_18"]))
def test_a_handle_substance_weighs_its_grams_and_keeps_its_rule(draw, handle):
    s = one(handle, draw=draw)
    case = wide.wide_case(SEED, s)
    t = case.truth
    grams = t["finding"]["reading"]["added_mass_g"]
    w = t["true_weight_lb"]
    assert (w["retest"] - w["baseline"]) * LB_TO_KG * 1e3 == pytest.approx(grams, rel=2e-3)
    x0, x1 = t["finding"]["region_in"]
    masses = [c.added_mass_kg for c in case.retest.local_changes]
    assert 1e3 * sum(masses) == pytest.approx(grams, abs=1e-4)  # the truth: 4 decimals
    assert all(a >= b for a, b in zip(masses, masses[1:], strict=False))  # thicker near knob
    assert t["expected"] == "not_altered"
    if handle == "grip":
        kind = wide.grip_kind(s["grip"]["kind_pick"])
        assert t["kind"] == kind and t["finding"]["legal"]
        assert wide.GRIP_KINDS[kind][0] <= grams <= wide.GRIP_KINDS[kind][1]
        assert 0.0 <= x0 <= 3.0 and 4.0 <= x1 <= HANDLE_LIMIT_IN
    else:
        assert t["needs_cleaning"] and not t["finding"]["legal"]
        assert 19.0 <= x1 <= 26.0 and 1.0 <= grams <= 10.0


@settings(max_examples=20, deadline=None)
@given(count=st.integers(8, 20), warp=st.floats(-0.5, 0.5), jitter=st.floats(0.0, 0.3),
       length_in=st.floats(32.0, 34.0), seed=st.integers(0, 1000))
def test_layouts_keep_their_ends_order_and_count(count, warp, jitter, length_in, seed):
    pattern = np.random.default_rng(seed).uniform(-1.0, 1.0, 21)
    x = wide.layout_in(length_in, count, warp, jitter, pattern)
    assert x.size == count and x[0] == 1.0 and x[-1] == pytest.approx(length_in - 1.0, abs=6e-3)
    assert np.all(np.diff(x) > 0.3)
    if warp > 0.1 and jitter == 0.0:  # crowded towards the barrel
        assert np.diff(x)[-1] < np.diff(x)[0]


def planes_hz(bat):
    out = []
    for plane in ("radial", "tangential"):
        f = model_modes(bat.truth_model(plane), n_modes=14).freq_hz
        out.append(f[f >= 20.0][:10])
    return np.array(out)


@pytest.mark.parametrize("seed", [100_000, 100_001, 100_002, 100_006, 900_000])
def test_band_edge_case_ends_its_band_inside_a_pair(seed):
    """Both tests: every member of the modes below the cut pair in the band, the cut pair's
    tangential member in it and its radial member above it; tapped 10-25 deg off the radial
    plane; pine tar 3-6 g over 1-14 in, legal."""
    case = wide.band_edge_case(seed)
    fmax = case.freq_hz[-1]
    assert np.allclose(np.diff(case.freq_hz), 0.5)
    for bat in (case.baseline, case.retest):
        f = planes_hz(bat)
        radial, tangential = f
        k = int(np.flatnonzero(tangential < fmax)[-1])
        assert tangential[k] < fmax < radial[k]
        assert np.all(f[:, :k] < fmax)
        assert wide.BAND_EDGE_LOWER_HZ[0] <= tangential[k]
        assert 10.0 <= bat.theta_deg <= 25.0
    t = case.truth
    assert t["kind"] == "pine_tar" and t["finding"]["legal"] and t["expected"] == "not_altered"
    assert t["finding"]["region_in"] == [1.0, 14.0]
    assert 3.0 <= t["finding"]["reading"]["added_mass_g"] <= 6.0
    assert case.retest_meta["accelerometer_mass_g"] >= 2.0


def test_fleet_seeds_keep_to_their_ranges():
    assert wide.fleet_seeds(3, "validation") == [900_000, 900_001, 900_002]
    assert wide.fleet_seeds(2, "development", 5) == [100_005, 100_006]
    with pytest.raises(ValueError, match="do not fit"):
        wide.fleet_seeds(10, "development", 99_995)
    handles = [set(wide.fleet_nuisances(i)) & {"grip", "tar_past_18"} for i in range(6)]
    assert handles == [set(), {"grip"}, set(), {"grip"}, set(), {"tar_past_18"}]


def test_band_edge_top_is_on_the_grid_and_between_the_members():
    case = wide.wide_case(SEED, {"angle": {"baseline_deg": 15.0, "change_deg": 3.0},
                                 "band_edge": {"mode_pick": 0.0, "position": 0.5}})
    edge = case.truth["drawn"]["band_edge"]
    lo, hi = edge["baseline_pair_hz"]
    assert lo < case.freq_hz[-1] < hi and edge["cuts_baseline"] and edge["cuts_retest"]
    assert (2 * case.freq_hz[-1]) % 1 == 0
    assert case.truth["drawn"]["points_in"][-1] == pytest.approx(
        case.baseline.profile.length_m / IN_TO_M - 1.0, abs=6e-3)


def test_a_tapered_coat_shares_its_mass_by_the_mean_thickness():
    """Thickness 1 - t s over four even layers: at t = 1 the shares are 7, 5, 3, 1 sixteenths;
    t = 0 is the single even layer it always was."""
    from updating.simulate.rulebook import coating

    tapered = coating("pine_tar", 8.0, 1.0, 13.0, taper=1.0)
    grams = [1e3 * c.added_mass_kg for c in tapered.changes]
    np.testing.assert_allclose(grams, [3.5, 2.5, 1.5, 0.5], rtol=1e-12)
    np.testing.assert_allclose([c.x0_m / IN_TO_M for c in tapered.changes], [1, 4, 7, 10])
    assert tapered.region_in == (1.0, 13.0) and tapered.reading["taper"] == 1.0
    even = coating("pine_tar", 8.0, 1.0, 13.0)
    assert len(even.changes) == 1 and even.reading == {"added_mass_g": 8.0}


def test_describe_says_every_nuisance_that_is_on():
    s = wide.settings_of(wide.random_unit(np.random.default_rng(1), wide.WIDE_NUISANCES),
                         wide.WIDE_NUISANCES)
    text = wide.describe(s)
    for word in ("moisture", "%/pt", " C (E", "angle", "band top", "points", "sensor",
                 "bungees", "over", "pine tar", "noise"):
        assert word in text
    assert wide.describe({}) == "none"
    assert wide.describe({"bungees": {"factor": 1.25}}) == "bungees x1.25"
