"""Nuisances from families wider than the inspection's null hypothesis, for checking it.

The inspection's H0 (docs/inspection.md, "Step 2") assumes a uniform moisture change with E
coupled at -2 %/point, extra moisture at either end decaying as exp(-s / 2 in), a temperature
change moving E and G together, a sensor shift and mass change, a two-plane mix and a grip on
the handle. The project's own fleets (``updating.simulate.nuisances``) draw from exactly
those families, so a check with them shares H0's assumptions. This module draws every
nuisance from a wider family, each within physical bounds (docs/virtual_rig.md, "Wider
nuisances"), each switchable on its own (units in the coordinates' names, ``COORDINATES``):

- moisture_shape: middle -2..+2 points; end ratios 0-3x the middle at the knob and at the
  barrel end, each with its own decay 0.5-8 in; a linear gradient -1..+1 point (barrel end
  minus knob end); a wet or dry patch -1..+1 point, centred 10-90 % along the bat,
  half-width 1-4 in (a cosine bump) (``moisture_pct``);
- moisture_shear: the moisture change (the middle's, uniform unless moisture_shape is on)
  moves E by -1.5..-2.5 %/point and G by -2..-4 %/point (density +1 %/point);
- temperature: baseline 18-26 C, re-test -10..+10 C from it; E -0.1..-0.5 %/C and G
  -0.1..-0.5 %/C, each its own;
- angle: tapped 0-90 deg from the radial plane at the baseline (random starts favour 0-20
  and 70-90 deg), re-test -20..+20 deg from it (kept in 0-90);
- band_edge: both tests' band ends between the two planes' members of one mode, the lower
  (tangential) member in the band, the radial one above it: which mode (among those whose
  lower member lies at 1.8-3.2 kHz) and where between them (20-80 % of the split); 0.5 Hz
  lines (``band_edge_top``);
- points: 8-20 impact points (count 8-21, rounded down, 20 at most) from 1 in to 1 in short
  of the end; warp -0.5..+0.5 (positive: denser towards the barrel), jitter 0-0.3 of the
  smallest spacing (a fixed pattern per bat) (``layout_in``);
- accelerometer: baseline 2-6 g, re-test mass -2..+2 g from it (kept in 2-6 g), re-mounted
  -0.15..+0.15 in;
- bungees: re-hung, stiffness x 0.6-1.6;
- grip: a legal grip since the baseline: pine tar 1-10 g, tape 5-30 g or spray 1-3 g, from
  0-3 in to 4-18 in, taper 0-1 (thicker near the knob; ``rulebook.coating``);
- tar_past_18: pine tar 1-10 g from 0-3 in to 19-26 in, taper 0-1 (must be cleaned; not an
  alteration);
- noise: FRF noise 0.5-3 % in each test.

A nuisance that is off leaves what ``field_fleet.draw_case`` gives a bat with none: impact
points every 2 in, 0-3.2 kHz, 0.5 % noise, the same 2-6 g accelerometer and bungees in both
tests, both tests tapped on the radial plane (theta 0), no moisture, temperature or grip.
The bat itself (profile, species, wood, E/G of both bending planes: radial 9-12,
tangential 12-16) comes from ``draw_case(rng, "none", ("planes",))`` for its seed.

A nuisance vector is a point of the unit cube over the coordinates of the nuisances that are
on (``space``); ``settings_of`` maps it to physical settings ``{nuisance: {name: value}}``
and ``wide_case`` makes the bat's lab files and truth from a seed and settings, through the
project's machinery (``VirtualBat``, ``WoodField``, ``rulebook.coating``,
``field_fleet.restage``). The expected answer is always ``not_altered``.

Seeds (``fleet_seeds``): development 100000-199999 (a method may be tuned and looked at on
these); VALIDATION 900000-999999, never used to tune anything, only to measure a method once
it is fixed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.model.modes import model_modes
from updating.model.units import IN_TO_M
from updating.simulate import nuisances as nz
from updating.simulate.field_fleet import FieldCase, draw_case, restage
from updating.simulate.rulebook import RulebookChange, coating
from updating.simulate.virtual_bat import VirtualBat
from updating.simulate.wood import grid_m, moisture_factors, temperature_field

WIDE_NUISANCES = ("moisture_shape", "moisture_shear", "temperature", "angle", "band_edge",
                  "points", "accelerometer", "bungees", "grip", "tar_past_18", "noise")
"""Every wide nuisance, in the order their coordinates are drawn."""
DEVELOPMENT_SEEDS = range(100_000, 200_000)
"""Seeds a method may be tuned and looked at on."""
VALIDATION_SEEDS = range(900_000, 1_000_000)
"""Seeds never used to tune anything: only to measure a method once it is fixed."""
GRIP_KINDS = {"pine_tar": (1.0, 10.0), "grip_tape": (5.0, 30.0), "spray": (1.0, 3.0)}
"""A legal grip's kind and its mass range, g."""
BAND_EDGE_LOWER_HZ = (1800.0, 3200.0)
"""The band-edge mode's lower member lies in this range, Hz."""
SENSOR_G = (2.0, 6.0)
"""An accelerometer's mass, g."""
NEAR_PLANES_DEG = ((0.0, 20.0), (70.0, 90.0))
LAB_BAND_HZ = 3200.0
LAB_NOISE = 0.005


@dataclass(frozen=True)
class Coordinate:
    """One coordinate of a nuisance vector.

    Attributes
    ----------
    owners : tuple of str
        The nuisances that use it (on when any of them is).
    name : str
        Its name in the settings (the unit in the name).
    lo, hi : float
        Its physical bounds.
    favoured : tuple of (float, float)
        Sub-ranges a random start falls in half of the time (uniform over them), else uniform
        over [lo, hi].
    """

    owners: tuple[str, ...]
    name: str
    lo: float
    hi: float
    favoured: tuple[tuple[float, float], ...] = ()

    def value(self, u: float) -> float:
        """Return the physical value at ``u`` in [0, 1]: lo + u (hi - lo)."""
        return float(self.lo + float(np.clip(u, 0.0, 1.0)) * (self.hi - self.lo))

    def unit(self, value: float) -> float:
        """Return the unit-cube coordinate of a physical ``value`` (``value``'s inverse)."""
        return float((value - self.lo) / (self.hi - self.lo))

    def draw(self, rng: np.random.Generator) -> float:
        """Draw a random start's unit coordinate (favoured ranges half of the time)."""
        if self.favoured and rng.uniform() < 0.5:
            lo, hi = self.favoured[int(rng.integers(len(self.favoured)))]
            return self.unit(rng.uniform(lo, hi))
        return float(rng.uniform())


def _c(owner, name, lo, hi, favoured=()) -> Coordinate:
    owners = owner if isinstance(owner, tuple) else (owner,)
    return Coordinate(owners, name, lo, hi, favoured)


MOISTURE = ("moisture_shape", "moisture_shear")
COORDINATES: tuple[Coordinate, ...] = (
    _c(MOISTURE, "middle_pct", -2.0, 2.0),
    _c("moisture_shape", "knob_ratio", 0.0, 3.0),
    _c("moisture_shape", "knob_decay_in", 0.5, 8.0),
    _c("moisture_shape", "barrel_ratio", 0.0, 3.0),
    _c("moisture_shape", "barrel_decay_in", 0.5, 8.0),
    _c("moisture_shape", "gradient_pct", -1.0, 1.0),
    _c("moisture_shape", "patch_pct", -1.0, 1.0),
    _c("moisture_shape", "patch_at", 0.1, 0.9),
    _c("moisture_shape", "patch_half_in", 1.0, 4.0),
    _c("moisture_shear", "e_per_point", -0.025, -0.015),
    _c("moisture_shear", "g_per_point", -0.04, -0.02),
    _c("temperature", "baseline_c", 18.0, 26.0),
    _c("temperature", "change_c", -10.0, 10.0),
    _c("temperature", "e_per_c", 0.001, 0.005),
    _c("temperature", "g_per_c", 0.001, 0.005),
    _c("angle", "baseline_deg", 0.0, 90.0, NEAR_PLANES_DEG),
    _c("angle", "change_deg", -20.0, 20.0),
    _c("band_edge", "mode_pick", 0.0, 1.0),
    _c("band_edge", "position", 0.2, 0.8),
    _c("points", "count", 8.0, 21.0),
    _c("points", "warp", -0.5, 0.5),
    _c("points", "jitter", 0.0, 0.3),
    _c("accelerometer", "baseline_g", *SENSOR_G),
    _c("accelerometer", "change_g", -2.0, 2.0),
    _c("accelerometer", "shift_in", -0.15, 0.15),
    _c("bungees", "factor", 0.6, 1.6),
    _c("grip", "kind_pick", 0.0, 1.0),
    _c("grip", "mass_share", 0.0, 1.0),
    _c("grip", "start_in", 0.0, 3.0),
    _c("grip", "end_in", 4.0, 18.0),
    _c("grip", "taper", 0.0, 1.0),
    _c("tar_past_18", "mass_g", 1.0, 10.0),
    _c("tar_past_18", "start_in", 0.0, 3.0),
    _c("tar_past_18", "end_in", 19.0, 26.0),
    _c("tar_past_18", "taper", 0.0, 1.0),
    _c("noise", "baseline", 0.005, 0.03),
    _c("noise", "retest", 0.005, 0.03),
)
"""Every coordinate, in drawing order (the module's list)."""


def _check_names(nuisances) -> tuple[str, ...]:
    """Return the nuisances as a tuple; ValueError naming an unknown one."""
    nuis = tuple(nuisances)
    unknown = sorted(set(nuis) - set(WIDE_NUISANCES))
    if unknown:
        raise ValueError(f"unknown wide nuisance(s) {unknown} (one of {', '.join(WIDE_NUISANCES)})")
    return nuis


def space(nuisances) -> tuple[Coordinate, ...]:
    """Return the coordinates of the nuisances that are on, in drawing order."""
    on = set(_check_names(nuisances))
    return tuple(c for c in COORDINATES if on & set(c.owners))


def random_unit(rng: np.random.Generator, nuisances) -> np.ndarray:
    """Draw a random start: a unit-cube point over ``space(nuisances)``.

    Every coordinate is drawn, in the fixed order of ``COORDINATES``, and those of the
    nuisances that are off are dropped: one generator gives a nuisance the same values
    whether it is on alone or with others.
    """
    on = set(_check_names(nuisances))
    drawn = [(c, c.draw(rng)) for c in COORDINATES]
    return np.array([u for c, u in drawn if on & set(c.owners)])


def settings_of(unit: np.ndarray, nuisances) -> dict[str, dict[str, float]]:
    """Map a unit-cube point over ``space(nuisances)`` to physical settings.

    Returns
    -------
    dict
        ``{nuisance: {coordinate name: value}}`` for every nuisance that is on (a shared
        coordinate under each of its owners that is on).
    """
    nuis = _check_names(nuisances)
    coords = space(nuis)
    u = np.asarray(unit, dtype=float)
    if u.shape != (len(coords),):
        raise ValueError(f"a nuisance vector of {len(coords)} coordinates was expected for "
                         f"{', '.join(nuis) or 'no nuisance'}, not {u.shape}")
    out: dict[str, dict[str, float]] = {n: {} for n in WIDE_NUISANCES if n in nuis}
    for c, ui in zip(coords, u, strict=True):
        for owner in c.owners:
            if owner in out:
                out[owner][c.name] = c.value(ui)
    return out


def _check_settings(settings: dict) -> None:
    """Raise ValueError for an unknown nuisance or coordinate or a value out of its bounds."""
    _check_names(settings)
    for nuisance, values in settings.items():
        known = {c.name: c for c in COORDINATES if nuisance in c.owners}
        for name, v in values.items():
            c = known.get(name)
            if c is None:
                raise ValueError(f"{nuisance} has no coordinate {name!r}")
            if not c.lo - 1e-9 <= v <= c.hi + 1e-9:
                raise ValueError(f"{nuisance}.{name} = {v:g} is outside {c.lo:g}..{c.hi:g}")
        missing = sorted(set(known) - set(values))
        if missing:
            raise ValueError(f"{nuisance} needs {', '.join(missing)}")


def layout_in(length_in: float, count: int, warp: float, jitter: float,
              pattern: np.ndarray) -> np.ndarray:
    """Return an impact-point layout, in from the knob.

        t_i = i / (n - 1),  t'_i = t_i + w t_i (1 - t_i),  x_i = 1 + (L - 2) t'_i

    (monotone for |w| <= 1; w > 0 crowds the points towards the barrel end), then the inner
    points moved by ``jitter`` x the smallest spacing x ``pattern`` (values in [-1, 1]); the
    first point 1 in from the knob, the last (the accelerometer's) 1 in from the end.
    """
    t = np.linspace(0.0, 1.0, count)
    x = 1.0 + (length_in - 2.0) * (t + warp * t * (1 - t))
    x[1:-1] += jitter * np.min(np.diff(x)) * np.asarray(pattern, dtype=float)[1:count - 1]
    return np.round(x, 2)


def moisture_pct(x_m: np.ndarray, length_m: float, s: dict) -> np.ndarray:
    """Return the moisture change along the bat, points, for ``moisture_shape``'s settings.

        dMC(x) = m [1 + (r_k - 1) e^(-x / l_k) + (r_b - 1) e^(-(L - x) / l_b)]
                 + g (x / L - 1/2) + p (1 + cos(pi (x - c) / h)) / 2  for |x - c| < h

    m the middle's change, r the end ratios, l the decays, g the gradient (barrel end minus
    knob end), p the patch's peak, c its centre, h its half-width.
    """
    x = np.asarray(x_m, dtype=float)
    lk, lb = s["knob_decay_in"] * IN_TO_M, s["barrel_decay_in"] * IN_TO_M
    d = s["middle_pct"] * (1 + (s["knob_ratio"] - 1) * np.exp(-x / lk)
                           + (s["barrel_ratio"] - 1) * np.exp(-(length_m - x) / lb))
    d = d + s["gradient_pct"] * (x / length_m - 0.5)
    c, h = s["patch_at"] * length_m, s["patch_half_in"] * IN_TO_M
    bump = np.where(np.abs(x - c) < h, 0.5 * (1 + np.cos(np.pi * (x - c) / h)), 0.0)
    return d + s["patch_pct"] * bump


def _moisture(length_m: float, settings: dict):
    """Return the re-test's moisture field (or None) and its record."""
    shape, shear = settings.get("moisture_shape"), settings.get("moisture_shear")
    if shape is None and shear is None:
        return None, None
    x = grid_m(length_m, 0.125)
    if shape is not None:
        d = moisture_pct(x, length_m, shape)
    else:
        d = np.full(x.size, shear["middle_pct"])
    e_pp, g_pp = (shear["e_per_point"], shear["g_per_point"]) if shear else (-0.02, None)
    rec = {"ends_pct": [float(d[0]), float(d[-1])], "range_pct": [float(d.min()),
                                                                  float(d.max())]}
    return moisture_factors(x, d, e_pp, g_pp), rec


def grip_mass_g(kind: str, share: float) -> float:
    """Return a grip's mass, g: ``share`` (0-1) of the way through its kind's range."""
    lo, hi = GRIP_KINDS[kind]
    return lo + share * (hi - lo)


def grip_kind(pick: float) -> str:
    """Return the grip kind a pick in [0, 1] names (thirds: pine tar, tape, spray)."""
    kinds = list(GRIP_KINDS)
    return kinds[min(len(kinds) - 1, int(pick * len(kinds)))]


def _handle_changes(settings: dict) -> list[RulebookChange]:
    """Return the grip and pine tar past 18 in the settings ask for."""
    out = []
    if "grip" in settings:
        g = settings["grip"]
        kind = grip_kind(g["kind_pick"])
        out.append(coating(kind, grip_mass_g(kind, g["mass_share"]), g["start_in"], g["end_in"],
                           g["taper"]))
    if "tar_past_18" in settings:
        t = settings["tar_past_18"]
        out.append(coating("tar_past_18", t["mass_g"], t["start_in"], t["end_in"], t["taper"]))
    return out


def pair_frequencies(bat: VirtualBat, n_modes: int = 10) -> np.ndarray:
    """Return the elastic bending modes of both planes, Hz: (2, n) rows radial, tangential.

    Each plane's truth model with the test's attachments and wood (``VirtualBat.truth_model``);
    modes below 20 Hz (the suspension) dropped.
    """
    rows = []
    for plane in ("radial", "tangential"):
        f = model_modes(bat.truth_model(plane), n_modes=n_modes + 4).freq_hz
        rows.append(f[f >= 20.0][:n_modes])
    return np.array(rows)


def band_edge_top(base: VirtualBat, retest: VirtualBat, s: dict) -> tuple[float, dict]:
    """Place the band's top between the two planes' members of one mode.

    The modes whose lower (tangential) member lies in ``BAND_EDGE_LOWER_HZ`` in the baseline
    are eligible; ``mode_pick`` chooses among them (1: the highest). The top goes
    ``position`` of the way from the lower to the upper member, over the stretch where both
    tests' pairs overlap (the baseline's alone when they do not), on the 0.5 Hz grid.

    Returns
    -------
    fmax_hz : float
        The band's top, Hz.
    record : dict
        The mode (1-based), both tests' pair frequencies and whether each test's band cuts
        its pair.
    """
    fb, fr = pair_frequencies(base), pair_frequencies(retest)
    lo_b, hi_b = fb.min(axis=0), fb.max(axis=0)
    lo_r, hi_r = fr.min(axis=0), fr.max(axis=0)
    ok = np.flatnonzero((lo_b >= BAND_EDGE_LOWER_HZ[0]) & (lo_b <= BAND_EDGE_LOWER_HZ[1]))
    if ok.size == 0:
        raise ValueError("no bending pair has its lower member at 1.8-3.2 kHz")
    k = int(ok[min(ok.size - 1, int(s["mode_pick"] * ok.size))])
    a, b = max(lo_b[k], lo_r[k]), min(hi_b[k], hi_r[k])
    if b <= a:
        a, b = lo_b[k], hi_b[k]
    fmax = float(np.round(2 * (a + s["position"] * (b - a))) / 2)
    rec = {"mode": k + 1, "baseline_pair_hz": [float(lo_b[k]), float(hi_b[k])],
           "retest_pair_hz": [float(lo_r[k]), float(hi_r[k])],
           "cuts_baseline": bool(lo_b[k] < fmax < hi_b[k]),
           "cuts_retest": bool(lo_r[k] < fmax < hi_r[k])}
    return fmax, rec


def wide_case(seed: int, settings: dict, serial: str | None = None,
              coherence: bool = False) -> FieldCase:
    """Make a clean (or legally gripped) bat's lab files and truth under wide nuisances.

    Parameters
    ----------
    seed : int
        The bat (``draw_case(default_rng(seed), "none", ("planes",))``), the points'
        jitter pattern and the scale's readings; the FRF noise seeds are ``write_case``'s.
    settings : dict
        ``{nuisance: {coordinate: value}}`` in physical units (``settings_of``); a
        nuisance absent is off.
    serial : str or None
        The serial in meta.json (default W-<seed>).
    coherence : bool
        The tests' files carry their coherence (``nuisances.OPTIONAL_NUISANCES``; the same
        bat either way).

    Returns
    -------
    FieldCase
        The case; ``truth["drawn"]`` holds the settings (``wide``), the planes' E/G and
        what the settings made (moisture's range, the band edge's pairs, the layout).
    """
    _check_settings(settings)
    case = draw_case(np.random.default_rng(seed), "none",
                     ("planes", "coherence") if coherence else ("planes",),
                     serial=serial or f"W-{seed}")
    base = replace(case.baseline, theta_deg=0.0)
    length_m = base.profile.length_m
    length_in = length_m / IN_TO_M
    drawn: dict = {"wide": settings, "planes": {
        "e_over_g_radial": base.material.e_over_g, "e_over_g_tangential": base.e_over_g_t}}
    if "points" in settings:
        p = settings["points"]
        pattern = np.random.default_rng([seed, 2]).uniform(-1.0, 1.0, 21)
        points_in = layout_in(length_in, min(20, int(p["count"])), p["warp"], p["jitter"],
                              pattern)
    else:
        points_in = nz.lab_points_in(length_in)
    drawn["points_in"] = [float(x) for x in points_in]
    base = replace(base, points_m=points_in * IN_TO_M)
    re: dict = {}
    if "noise" in settings:
        base = replace(base, rel_noise=settings["noise"]["baseline"])
        re["rel_noise"] = settings["noise"]["retest"]
    if "accelerometer" in settings:
        a = settings["accelerometer"]
        base = replace(base, sensor_mass_kg=1e-3 * a["baseline_g"])
        re["sensor_mass_kg"] = 1e-3 * float(np.clip(a["baseline_g"] + a["change_g"], *SENSOR_G))
        re["sensor_offset_m"] = base.sensor_offset_m + a["shift_in"] * IN_TO_M
    if "bungees" in settings:
        re["bungee_k_n_per_m"] = base.bungee_k_n_per_m * settings["bungees"]["factor"]
    if "angle" in settings:
        th = settings["angle"]
        base = replace(base, theta_deg=th["baseline_deg"])
        re["theta_deg"] = float(np.clip(th["baseline_deg"] + th["change_deg"], 0.0, 90.0))
    re_wood = []
    if "temperature" in settings:
        t = settings["temperature"]
        t_re = t["baseline_c"] + t["change_c"]
        base = replace(base, wood=temperature_field(length_m, t["baseline_c"] - 20.0,
                                                    t["e_per_c"], t["g_per_c"]))
        re_wood.append(temperature_field(length_m, t_re - 20.0, t["e_per_c"], t["g_per_c"]))
        drawn["temperature"] = {"baseline_c": t["baseline_c"], "retest_c": t_re}
    moist, drawn["moisture"] = _moisture(length_m, settings)
    re_wood.append(moist)
    changes = _handle_changes(settings)
    retest = replace(base, wood=nz.combine(*re_wood), **re,
                     local_changes=tuple(c for ch in changes for c in ch.changes))
    fmax = LAB_BAND_HZ
    if "band_edge" in settings:
        fmax, drawn["band_edge"] = band_edge_top(base, retest, settings["band_edge"])
    freq = np.arange(0.0, fmax + 0.25, 0.5)
    return restage(case, base, retest, freq, np.random.default_rng([seed, 4]), drawn,
                   list(settings), changes)


def band_edge_case(seed: int, drift: bool = True, serial: str | None = None) -> FieldCase:
    """Make a legally gripped bat whose band ends inside its highest in-band bending pair.

    The case issue 36 met: tapped 10-25 deg off the radial plane (plane 1) in both tests,
    the band's top 30-70 % of the way between the tangential and the radial member of the
    highest mode whose lower member lies at 1.8-3.2 kHz (both tests' pairs; a lower such
    mode when the drift moves the highest pair apart between the tests), so the last mode in
    the band is the barely excited plane's; pine tar 3-6 g over 1-14 in since the
    baseline. With ``drift``: the wood 0.5-1 point wetter (ends 1.5-2x the middle, decay
    2 in, H0's couplings), 0-1 C warmer, the accelerometer replaced (2-6 g, within 2 g).

    Parameters
    ----------
    seed : int
        The bat and the draws of the settings (development or validation seeds alike).
    drift : bool
        Add the moisture, temperature and accelerometer changes above.
    serial : str or None
        The serial in meta.json (default W-<seed>).

    Returns
    -------
    FieldCase
        The case (expected ``not_altered``; ``truth["drawn"]["band_edge"]`` has both tests'
        pair frequencies).
    """
    settings = _band_edge_settings(seed, drift)
    for pick in np.linspace(1.0, 0.0, 5):  # the highest eligible pair both tests cut
        settings["band_edge"]["mode_pick"] = float(pick)
        case = wide_case(seed, settings, serial)
        edge = case.truth["drawn"]["band_edge"]
        if edge["cuts_baseline"] and edge["cuts_retest"]:
            return case
    raise ValueError(f"seed {seed}: the drift moves every eligible pair out of the band's "
                     "reach in one of the tests; take another seed")


def _band_edge_settings(seed: int, drift: bool) -> dict:
    """Draw ``band_edge_case``'s settings (generator [seed, 5])."""
    rng = np.random.default_rng([seed, 5])
    th_b, th_r = rng.uniform(10.0, 25.0, 2)
    mass = rng.uniform(3.0, 6.0)
    settings: dict = {
        "angle": {"baseline_deg": th_b, "change_deg": th_r - th_b},
        "band_edge": {"mode_pick": 1.0, "position": rng.uniform(0.3, 0.7)},
        "grip": {"kind_pick": 0.0, "mass_share": (mass - 1.0) / 9.0, "start_in": 1.0,
                 "end_in": 14.0, "taper": 0.0},
    }
    if drift:
        m = rng.uniform(0.5, 1.0)
        settings["moisture_shape"] = {
            "middle_pct": m, "knob_ratio": rng.uniform(1.5, 2.0), "knob_decay_in": 2.0,
            "barrel_ratio": rng.uniform(1.5, 2.0), "barrel_decay_in": 2.0,
            "gradient_pct": 0.0, "patch_pct": 0.0, "patch_at": 0.5, "patch_half_in": 1.0}
        settings["temperature"] = {"baseline_c": rng.uniform(18.0, 26.0),
                                   "change_c": rng.uniform(0.0, 1.0), "e_per_c": 0.002,
                                   "g_per_c": 0.002}
        g_b = rng.uniform(*SENSOR_G)
        g_r = rng.uniform(max(SENSOR_G[0], g_b - 2.0), min(SENSOR_G[1], g_b + 2.0))
        settings["accelerometer"] = {"baseline_g": g_b, "change_g": g_r - g_b,
                                     "shift_in": rng.uniform(-0.05, 0.05)}
    return settings


def fleet_seeds(n: int, purpose: str = "development", offset: int = 0) -> list[int]:
    """Return ``n`` consecutive seeds of a purpose's range, from ``offset`` into it.

    Parameters
    ----------
    n : int
        How many.
    purpose : {"development", "validation"}
        "development": 100000-199999, seeds a method may be tuned and looked at on;
        "validation": 900000-999999, NEVER used to tune anything (only to measure a fixed
        method).
    offset : int
        Where in the range to start.

    Returns
    -------
    list of int
        The seeds.
    """
    ranges = {"development": DEVELOPMENT_SEEDS, "validation": VALIDATION_SEEDS}
    if purpose not in ranges:
        raise ValueError(f"unknown purpose {purpose!r} (development or validation)")
    r = ranges[purpose]
    if offset < 0 or offset + n > len(r):
        raise ValueError(f"{n} seeds from {offset} do not fit in the {purpose} range "
                         f"{r.start}-{r.stop - 1}")
    return list(r[offset:offset + n])


HANDLES = ("clean", "grip", "clean", "grip", "clean", "tar_past_18")
"""A fleet's handles in turn: bare half of the time, a legal grip a third, tar past 18 in a
sixth."""


def fleet_nuisances(index: int, nuisances=WIDE_NUISANCES) -> tuple[str, ...]:
    """Return the nuisances of a fleet's ``index``-th bat.

    ``nuisances`` without ``grip`` and ``tar_past_18``, plus the one ``HANDLES`` names for
    this bat (if it is among ``nuisances``).
    """
    nuis = _check_names(nuisances)
    handle = HANDLES[index % len(HANDLES)]
    return tuple(n for n in nuis if n not in ("grip", "tar_past_18") or n == handle)


def fleet_start(seed: int, nuisances) -> np.ndarray:
    """Return a fleet bat's random nuisance vector (``random_unit`` of generator [seed, 1])."""
    return random_unit(np.random.default_rng([seed, 1]), nuisances)


def describe(settings: dict, made: dict | None = None) -> str:
    """Say a nuisance vector's settings in one line, in the lab's units.

    Parameters
    ----------
    settings : dict
        ``{nuisance: {coordinate: value}}`` (``settings_of``).
    made : dict or None
        What the settings made (``truth["drawn"]`` without ``wide``): the band edge's mode
        and pair, the moisture's range.

    Returns
    -------
    str
        E.g. "moisture +0.8 pt (ends x1.9 / x1.6, decay 2.0 / 2.0 in); angle 17 -> 20 deg;
        ...", nuisances in ``WIDE_NUISANCES`` order, "; "-separated ("none" without any).
    """
    made = made or {}
    parts = []
    m, sh = settings.get("moisture_shape"), settings.get("moisture_shear")
    if m:
        txt = (f"moisture {m['middle_pct']:+.2f} pt (ends x{m['knob_ratio']:.1f} / "
               f"x{m['barrel_ratio']:.1f}, decay {m['knob_decay_in']:.1f} / "
               f"{m['barrel_decay_in']:.1f} in; gradient {m['gradient_pct']:+.2f} pt; patch "
               f"{m['patch_pct']:+.2f} pt at {100 * m['patch_at']:.0f} %, "
               f"+-{m['patch_half_in']:.1f} in)")
        rng_pct = (made.get("moisture") or {}).get("range_pct")
        if rng_pct:
            txt += f" [{rng_pct[0]:+.1f}..{rng_pct[1]:+.1f} pt]"
        parts.append(txt)
    if sh:
        mid = "" if m else f"moisture {sh['middle_pct']:+.2f} pt uniform, "
        parts.append(f"{mid}E {100 * sh['e_per_point']:.1f} %/pt, G "
                     f"{100 * sh['g_per_point']:.1f} %/pt")
    if "temperature" in settings:
        t = settings["temperature"]
        parts.append(f"{t['baseline_c']:.1f} -> {t['baseline_c'] + t['change_c']:.1f} C "
                     f"(E {100 * t['e_per_c']:.2f}, G {100 * t['g_per_c']:.2f} %/C)")
    if "angle" in settings:
        a = settings["angle"]
        th_r = float(np.clip(a["baseline_deg"] + a["change_deg"], 0.0, 90.0))
        parts.append(f"angle {a['baseline_deg']:.0f} -> {th_r:.0f} deg")
    if "band_edge" in settings:
        e = made.get("band_edge")
        parts.append("band top inside a pair" if e is None else
                     f"band top inside mode {e['mode']}'s pair "
                     f"({e['baseline_pair_hz'][0]:.0f} / {e['baseline_pair_hz'][1]:.0f} Hz)")
    if "points" in settings:
        p = settings["points"]
        parts.append(f"{min(20, int(p['count']))} points (warp {p['warp']:+.2f}, jitter "
                     f"{p['jitter']:.2f})")
    if "accelerometer" in settings:
        a = settings["accelerometer"]
        g_r = float(np.clip(a["baseline_g"] + a["change_g"], *SENSOR_G))
        parts.append(f"sensor {a['baseline_g']:.1f} -> {g_r:.1f} g, moved "
                     f"{a['shift_in']:+.2f} in")
    if "bungees" in settings:
        parts.append(f"bungees x{settings['bungees']['factor']:.2f}")
    if "grip" in settings:
        g = settings["grip"]
        kind = grip_kind(g["kind_pick"])
        parts.append(f"{kind} {grip_mass_g(kind, g['mass_share']):.1f} g over "
                     f"{g['start_in']:.1f}-{g['end_in']:.1f} in (taper {g['taper']:.2f})")
    if "tar_past_18" in settings:
        t = settings["tar_past_18"]
        parts.append(f"pine tar {t['mass_g']:.1f} g over {t['start_in']:.1f}-"
                     f"{t['end_in']:.1f} in (taper {t['taper']:.2f})")
    if "noise" in settings:
        n = settings["noise"]
        parts.append(f"noise {100 * n['baseline']:.1f} / {100 * n['retest']:.1f} %")
    return "; ".join(parts) or "none"
