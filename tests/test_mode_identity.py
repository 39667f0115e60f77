"""Which bending plane each paired mode is (``updating.inspect.identity``).

A lone member of the weaker plane, tapped at theta from the other, carries sin(theta) of
the full pair's mass-normalised amplitude; it is left out of the verdict. The band's top can
cut a pair: a mode seen once near it whose amplitude does not say it is the dominant plane's
is left out too. Hidden: the tap angle, which mode is the lone member, the noise.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from updating.inspect.identity import (
    DOMINANT_MIN,
    MINOR_MAX,
    PLANE_SPLIT_MAX_REL,
    band_cut,
    mode_identity,
    relative_amplitude,
)

X = np.linspace(0.0, 1.0, 14)


def _shapes(m: int) -> np.ndarray:
    """Free-free-like shapes: cosines of rising order (points x modes)."""
    return np.column_stack([np.cos((k + 2) * np.pi * X) for k in range(m)]) * 3.0


@settings(max_examples=40, deadline=None)
@given(theta_deg=st.floats(0.0, 30.0), m=st.integers(4, 7), data=st.data(),
       scale=st.floats(0.5, 2.0), noise=st.floats(0.0, 0.03))
def test_the_weaker_planes_lone_member_is_left_out(theta_deg, m, data, scale, noise):
    """Every mode merged or one peak (amplitude 1) but one, seen as the weaker plane's member
    alone (sin theta): that one, and only that one, is left out, whatever the calibration's
    common scale and 3 % noise."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**31)))
    lone = data.draw(st.integers(0, m - 1))
    phi = _shapes(m)
    amp = np.ones(m)
    amp[lone] = np.sin(np.radians(theta_deg))  # below 0.5: the weaker plane's
    noisy = phi * amp * scale + noise * rng.standard_normal(phi.shape)
    f = 150.0 * np.arange(1, m + 1) ** 1.8
    ident = mode_identity(f, np.arange(m), phi * scale, noisy, phi)
    assert not ident.usable[lone]
    assert ident.usable[np.arange(m) != lone].all()
    assert len(ident.notes) == 1 and f"mode {lone + 1}" in ident.notes[0]
    assert ident.amplitude_retest[lone] < MINOR_MAX


def test_relative_amplitude_is_one_for_a_common_scale():
    phi = _shapes(5)
    assert np.allclose(relative_amplitude(7.0 * phi, phi), 1.0)


@given(order=st.integers(0, 7), margin=st.floats(0.002, 0.5))
def test_band_cut_is_the_largest_plane_split_below_the_top(order, margin):
    """A mode seen once is cut when its partner, up to the largest split above it, may lie
    beyond the band's top; a merged pair never is; an unknown band cuts nothing."""
    split = PLANE_SPLIT_MAX_REL[min(order, len(PLANE_SPLIT_MAX_REL) - 1)]
    top = 3200.0
    inside = top / (1 + split) * (1 + margin)   # partner may be above
    below = top / (1 + split) / (1 + margin)    # partner surely in band
    f = np.array([inside, below])
    o = np.array([order, order])
    assert band_cut(f, o, np.array([1, 1]), top).tolist() == [True, False]
    assert not band_cut(f, o, np.array([2, 2]), top).any()
    assert not band_cut(f, o, None, None).any()


def test_a_band_cut_mode_is_kept_only_when_it_is_the_dominant_planes():
    """The top mode seen once near the band's top: kept at amplitude 0.95 (the dominant
    plane's member, or both), left out at 0.75 (cannot tell), left out at 0.3 (the weaker
    plane's), the note saying the band may cut its pair."""
    phi = _shapes(6)
    f = np.array([160.0, 580.0, 1100.0, 1680.0, 2360.0, 3100.0])
    for amp, kept in ((0.95, True), (0.75, False), (0.3, False)):
        a = np.ones(6)
        a[-1] = amp
        ident = mode_identity(f, np.arange(6), phi, phi * a, phi, members_b=np.ones(6, int),
                              members_r=np.ones(6, int), band_top_b_hz=3200.0,
                              band_top_r_hz=3200.0)
        assert ident.band_cut[-1] and not ident.band_cut[:-1].any()
        assert bool(ident.usable[-1]) is kept, amp
        assert ident.usable[:-1].all()
        assert kept or "above the band's top" in ident.notes[0]
    assert 0.75 < DOMINANT_MIN
