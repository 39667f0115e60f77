"""The re-test's caliper profile against the registration's: removal measured, not inferred.

``compare_profiles`` is the one entry (../../../docs/kinds.md, "The re-test's caliper
profile"):

1. the survey's stations are paired with the registered profile (``calipers.null``);
2. the null -- caliper noise, the bat's ovality (free at every station), the
   registration's noise, the caliper's placement, moisture's shrinkage -- is estimated from
   the data;
3. runs of stations read short, in every orientation (shaving, a groove's ring) or in one
   (a flat facing it), are found by a scan whose false-alarm level is stated
   (``calipers.scan``: Hunter's bound over every run and pattern, ``CALIPER_FALSE_ALARM``); the
   null is estimated again without the runs found and the scan repeated once;
4. each run is read (``calipers.reading``): shaving, a flat (depth, normal) or grooves
   (rings, depth), where, and the wood removed, with standard uncertainties;
5. what the survey cannot see (``blind_spots``): flats whose normal falls between the
   orientations read, grooves between the stations, stretches not surveyed -- and what
   would measure them.

With ``region_m``, where the vibration test, an independent measurement, already reads a
removal over a stretch, the survey is also asked about that one stretch alone --
z of each pattern over the stations inside it (``calipers.scan.window_stats``) against
Bonferroni's bound over the patterns only, ``Phi^-1(1 - alpha / P)`` (about 3.5 at four
orientations against the scan's 4.8). The stretch is chosen by data the calipers' null is
independent of, so an unaltered bat's survey passes it with probability at most alpha
whatever the vibration test said, and both must read the removal for it to count.

Pure numpy; the result is a small frozen dataclass (``CaliperResult``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri

from updating.inspect.calipers.null import (
    CaliperNull,
    Stations,
    estimate_null,
    station_basis,
    station_table,
)
from updating.inspect.calipers.reading import CaliperChange, read_grooves, read_run
from updating.inspect.calipers.scan import (
    CALIPER_FALSE_ALARM,
    Run,
    Terms,
    critical_z,
    find_runs,
    patterns_for,
    station_terms,
    window_stats,
)
from updating.model.calipers import CaliperSurvey, flat_half_angle
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

GROOVE_NARROWEST_IN = 0.1
"""The narrowest groove cut (the rulebook's 0.1-0.25 in): a station at least this often
catches every groove."""
GROOVE_SET_GAP_IN = 2.0
"""Rings found closer than this are one set of grooves."""
JOIN_GAP_IN = 1.0
"""Flats or shaving found this close together are one change."""
FLAT_SAME_DEG = 30.0
"""Flats found side by side whose normals differ by less than this are one flat."""
BARREL_IN = 16.0
"""The barrel's stretch from the end (where flats, shaving and grooves are cut) over which
the station spacing is judged."""


@dataclass(frozen=True)
class CaliperResult:
    """What the re-test's calipers read against the registration's profile, SI.

    Attributes
    ----------
    changes : tuple of CaliperChange
        Every removal found beyond the null, knob end first (empty: none the survey shows).
    statistic, critical : float
        The scan's largest z and the bound it was held to.
    false_alarm : float
        The scan's false-alarm level (its chance of calling an unaltered bat's survey
        changed, at most).
    null : CaliperNull
        Caliper noise, registration noise, ovality, shrinkage, as estimated.
    orientations_deg : tuple of float
        The orientations read.
    station_spacing_m : float
        The widest gap between compared stations on the barrel, m.
    hidden_flat_depth_m : float
        The deepest flat that can hide: its normal half way between two orientations read,
        shortening no reading by more than three caliper sigmas, m.
    surveyed_m : tuple of float
        The first and last station compared, m.
    unseen : tuple of str
        What the survey cannot see, each with what would measure it.
    region_check : RegionCheck or None
        The survey asked about the stretch the vibration test named (``region_m``; None:
        not asked).
    """

    changes: tuple[CaliperChange, ...]
    statistic: float
    critical: float
    false_alarm: float
    null: CaliperNull
    orientations_deg: tuple[float, ...]
    station_spacing_m: float
    hidden_flat_depth_m: float
    surveyed_m: tuple[float, float]
    unseen: tuple[str, ...]
    region_check: RegionCheck | None = None


def _merged(runs: list[Run], t: Terms) -> list[Run]:
    """Join runs of one pattern that touch (a change the greedy scan took in two pieces)."""
    out: list[Run] = []
    for r in sorted(runs, key=lambda r: r.i0):
        if out and out[-1].pattern == r.pattern and out[-1].i1 == r.i0:
            z, h, sd = window_stats(t, r.pattern, out[-1].i0, r.i1)
            out[-1] = Run(r.pattern, out[-1].i0, r.i1, z, h, sd)
        else:
            out.append(r)
    return out


def _same_change(a: CaliperChange, b: CaliperChange) -> bool:
    """Tell whether two changes found side by side are one (shaving, or one flat).

    Side by side: at most ``JOIN_GAP_IN`` apart (a station that read less than its
    neighbours stops a run's end: the rest is found as another run). Shaving joins shaving,
    and a short piece read as grooves beside it that lost the same diameter (within three
    standard uncertainties of the difference: a shaved taper, where the caliper's placement
    is noisiest, can be taken as a separate run under 2 in long); the joined run is read
    again as a whole, so rings between stations that read no loss stay grooves.
    """
    gap = b.region_m[0] - a.region_m[1]
    if gap > JOIN_GAP_IN * IN_TO_M:
        return False
    if a.kind == b.kind == "flat":
        return abs((a.flat_angle_deg - b.flat_angle_deg + 90.0) % 180.0 - 90.0) < FLAT_SAME_DEG
    kinds = {a.kind, b.kind}
    if "shaved" not in kinds or not kinds <= {"shaved", "grooves"}:
        return False
    sd = np.hypot(a.diameter_lost_sd_m, b.diameter_lost_sd_m)
    return abs(a.diameter_lost_m - b.diameter_lost_m) <= 3 * sd


def _joined(changes: list[CaliperChange], runs: list[Run], read) -> list[CaliperChange]:
    """Read side-by-side pieces of one change as one (the scan's hill climb stops early)."""
    out: list[tuple[CaliperChange, Run]] = []
    for c, r in sorted(zip(changes, runs, strict=True), key=lambda cr: cr[1].i0):
        if out and _same_change(out[-1][0], c):
            prev = out[-1][1]
            run = Run(max((prev, r), key=lambda x: x.z).pattern, prev.i0, r.i1,
                      max(prev.z, r.z), 0.0, 0.0)
            out[-1] = (read(run), run)
        else:
            out.append((c, r))
    return [c for c, _ in out]


def _groove_sets(changes: list[CaliperChange], st: Stations, t: Terms,
                 rho: float) -> list[CaliperChange]:
    """Join rings found apart into one set when closer than ``GROOVE_SET_GAP_IN``."""
    out: list[CaliperChange] = []
    for c in changes:
        prev = out[-1] if out else None
        if (prev is not None and prev.kind == c.kind == "grooves"
                and c.region_m[0] - prev.region_m[1] < GROOVE_SET_GAP_IN * IN_TO_M):
            x = np.array(prev.groove_x_m + c.groove_x_m)
            idx = np.flatnonzero(np.isin(st.x_m, x))
            joined = read_grooves(st, t, Run(0, idx[0], idx[-1] + 1, max(prev.statistic,
                                                                         c.statistic), 0, 0),
                                  rho, idx)
            out[-1] = joined
        else:
            out.append(c)
    return out


def _scan(st: Stations, registered: Profile, false_alarm: float):
    """Estimate the null, scan, and again without the runs found (module docstring)."""
    bases = [station_basis(a) for a in st.angles_deg]
    patterns = patterns_for(st, bases)
    use = np.ones(st.n, dtype=bool)
    for _ in range(2):
        null = estimate_null(st, registered, bases, use)
        terms = station_terms(st, bases, null, patterns)
        z_crit = critical_z(terms, false_alarm)
        runs, z_max = find_runs(terms, z_crit)
        found = np.zeros(st.n, dtype=bool)
        for r in runs:
            found[max(r.i0 - 1, 0):r.i1 + 1] = True
        if not runs or (~found == use).all() or (~found).sum() < 10:
            break
        use = ~found
    return null, terms, _merged(runs, terms), z_max, z_crit


def hidden_flat_depth_m(orientations_deg, radius_m: float, sigma_m: float) -> float:
    """Return the deepest flat that shortens no reading by more than three caliper sigmas, m.

    Its normal half way across the widest gap G between the orientations read (modulo 180
    deg): the flat hides while ``R (1 - cos(a - G/2)) <= 3 sigma``, i.e. up to the half-angle
    ``a = G/2 + arccos(1 - 3 sigma / R)``, depth ``R (1 - cos a)`` (at most R).
    """
    a = np.sort(np.mod(np.asarray(orientations_deg, dtype=float), 180.0))
    gaps = np.diff(np.append(a, a[0] + 180.0))
    half = np.radians(gaps.max() / 2)
    alpha = min(half + float(flat_half_angle(radius_m, 3 * sigma_m)), np.pi / 2)
    return float(radius_m * (1 - np.cos(alpha)))


def blind_spots(st: Stations, survey: CaliperSurvey, registered: Profile,
                null: CaliperNull) -> tuple[tuple[str, ...], float, float]:
    """Say what the survey cannot see and what would measure it.

    Returns
    -------
    unseen : tuple of str
        One line each: flats between the orientations, grooves between the stations,
        stretches not surveyed, stations not compared.
    hidden_depth_m : float
        ``hidden_flat_depth_m`` on the barrel.
    spacing_m : float
        The widest gap between compared stations on the barrel, m.
    """
    length = registered.length_m
    R = float(registered.diameter_m.max()) / 2
    sigma = null.sigma_retest_m
    orient = survey.orientations_deg
    hidden = hidden_flat_depth_m(orient, R, sigma)
    out = []
    if not survey.angles_given or orient.size == 1:
        out.append("a flat shows only where it faces the one orientation read: flats of any "
                   "depth facing elsewhere are not measurable by this survey (read at 0, 45, "
                   "90 and 135 deg)")
    else:
        finer = hidden_flat_depth_m(np.arange(0.0, 180.0, 22.5), R, sigma)
        out.append(f"a flat up to {hidden / IN_TO_M:.3f} in deep whose normal lies between "
                   f"the orientations read ({', '.join(f'{a:g}' for a in orient)} deg) "
                   "shortens no reading beyond noise: not measurable by this survey (every "
                   f"22.5 deg, down to {finer / IN_TO_M:.3f} in)")
        if orient.size < 4:
            out.append("with fewer than four orientations a flat is read only in the mean over "
                       "orientations, where ovality hides the rest (read four or more)")
    barrel = st.x_m[st.x_m >= length - BARREL_IN * IN_TO_M]
    spacing = float(np.diff(barrel).max()) if barrel.size > 1 else float(length)
    if spacing > GROOVE_NARROWEST_IN * IN_TO_M:
        out.append(f"a groove narrower than the station spacing ({spacing / IN_TO_M:.2f} in on "
                   "the barrel) can fall between stations and is not measurable by this survey "
                   f"(a station every {GROOVE_NARROWEST_IN:g} in catches every groove "
                   f"{GROOVE_NARROWEST_IN:g} in wide or wider)")
    if st.n:
        lo, hi = float(st.x_m[0]), float(st.x_m[-1])
        if hi < length - 0.5 * IN_TO_M:
            out.append(f"the last {(length - hi) / IN_TO_M:.1f} in of the barrel were not "
                       "surveyed")
        if lo > 0.5 * IN_TO_M:
            out.append(f"the first {lo / IN_TO_M:.1f} in from the knob were not surveyed")
    if st.excluded_x_m.size:
        out.append("stations at a step of the registered profile were not compared ("
                   + ", ".join(f"{x / IN_TO_M:.2f}" for x in st.excluded_x_m) + " in)")
    return tuple(out), hidden, spacing


@dataclass(frozen=True)
class RegionCheck:
    """The survey asked about one stretch another measurement named, SI.

    ``compare_profiles``' ``region_m``: module docstring.

    Attributes
    ----------
    region_m : tuple of float
        The stretch asked about (start, end) from the knob end.
    statistic, critical : float
        The largest z over the patterns on the stations inside it, and Bonferroni's bound
        over the patterns at ``false_alarm`` (NaN: no station inside).
    false_alarm : float
        The check's level: an unaltered bat's survey passes it at most this often.
    change : CaliperChange or None
        What the calipers read there when ``statistic`` exceeds ``critical``.
    """

    region_m: tuple[float, float]
    statistic: float
    critical: float
    false_alarm: float
    change: CaliperChange | None


def _check_region(st: Stations, null: CaliperNull, terms: Terms, region_m: tuple[float, float],
                  rho_kg_m3: float, length_m: float, false_alarm: float) -> RegionCheck:
    """Test the stations inside ``region_m`` alone, each pattern, at ``Phi^-1(1 - alpha / P)``.

    z of each pattern over the stretch (``calipers.scan.window_stats``), the largest held to
    Bonferroni's bound over the P patterns (module docstring); the stretch read as a run
    (``read_run``) when it passes.
    """
    inside = np.flatnonzero((st.x_m >= region_m[0]) & (st.x_m <= region_m[1]))
    n_patterns = terms.a.shape[0]
    critical = float(ndtri(1.0 - false_alarm / n_patterns))
    if inside.size == 0:
        return RegionCheck(region_m, float("nan"), critical, false_alarm, None)
    i0, i1 = int(inside[0]), int(inside[-1]) + 1
    stats = [window_stats(terms, k, i0, i1) for k in range(n_patterns)]
    k = int(np.argmax([z for z, _, _ in stats]))
    z, h, sd = stats[k]
    change = None
    if z > critical:
        change = read_run(st, null, terms, Run(k, i0, i1, z, h, sd), rho_kg_m3, length_m)
    return RegionCheck(region_m, float(z), critical, false_alarm, change)


def compare_profiles(registered: Profile, survey: CaliperSurvey, rho_kg_m3: float,
                     false_alarm: float = CALIPER_FALSE_ALARM,
                     region_m: tuple[float, float] | None = None) -> CaliperResult:
    """Compare a re-test's caliper survey with the registered profile (module docstring).

    Parameters
    ----------
    registered : Profile
        The registered profile (x from its knob end).
    survey : CaliperSurvey
        The re-test's readings (checked at the door: ``plausible.check_survey``).
    rho_kg_m3 : float
        The wood's density, kg/m^3 (for the wood removed).
    false_alarm : float
        The scan's false-alarm level (and the region check's).
    region_m : tuple of float or None
        A stretch, m from the knob end, named by a measurement independent of the survey
        (the vibration test's finding): the survey is also asked about it alone
        (``CaliperResult.region_check``; module docstring). None: not asked.

    Returns
    -------
    CaliperResult
        What the calipers read, where, how much, with uncertainties, and what they cannot
        see.

    Examples
    --------
    A survey that reads nothing anywhere passes no stretch; one short by 0.02 in over 6 in
    at 4 deg from an orientation read, which the whole scan misses on some bats, passes the
    stretch a vibration test named there (tests/test_calipers.py).
    """
    st = station_table(survey, registered)
    if st.n < 2:
        raise ValueError("the caliper survey has fewer than two stations to compare")
    null, terms, runs, z_max, z_crit = _scan(st, registered, false_alarm)
    def read(run: Run) -> CaliperChange:
        return read_run(st, null, terms, run, rho_kg_m3, registered.length_m)

    runs = sorted(runs, key=lambda r: r.i0)
    changes = _joined([read(r) for r in runs], runs, read)
    changes = _groove_sets(sorted(changes, key=lambda c: c.region_m[0]), st, terms, rho_kg_m3)
    unseen, hidden, spacing = blind_spots(st, survey, registered, null)
    check = None if region_m is None else _check_region(
        st, null, terms, region_m, rho_kg_m3, registered.length_m, false_alarm)
    return CaliperResult(tuple(changes), z_max, z_crit, false_alarm, null,
                         tuple(float(a) for a in survey.orientations_deg), spacing, hidden,
                         (float(st.x_m[0]), float(st.x_m[-1])), unseen, check)
