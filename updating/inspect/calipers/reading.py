"""What a run of short caliper readings is: shaving, a flat or grooves, and how much.

A run found by the scan (``calipers.scan``) is read from its drops, orientation by
orientation: D_k, the mean over the run's stations of ``g (1 + s) - r`` at orientation k,
with covariance

    Sigma = diag(sigma_re^2 / n_k) + tau_c^2 1 1^T + (a^2 / 2) (c c^T + s s^T)

(n_k stations read at theta_k; tau_c^2 the registration's noise, the caliper's placement,
the ovality's and the shrinkage's common offsets; c, s = cos 2 theta_k, sin 2 theta_k: the
bat's own ovality of amplitude a, unknown, taken as random for the reading).

- **Shaving** (the barrel turned down): ``D_k = h`` for every k; h by generalised least
  squares.
- **A flat** of depth h, its normal at phi: ``D_k = mean_i w(R_i, h, theta_k - phi)``
  (``updating.model.calipers.width_loss_m``, R_i = g_i / 2). Read on a grid (phi every
  1 deg, h in 120 geometric steps from 0.001 in to ``FLAT_MAX_IN``) as the posterior mean
  and standard deviation, phi uniform (modulo 180 deg: a caliper cannot tell which side the
  flat is on), h log-uniform (Jeffreys' prior for a scale): a flat seen at one orientation
  only may lie up to its half-angle off it, so its depth is at least the loss read there
  and its uncertainty says how much more (the loss read and the orientations that read none
  bound it; nothing else does).
  A run is a flat when the flat fits its D_k better than shaving by more than
  ``FLAT_MIN_DCHI2`` (a flat facing one orientation shortens it alone, one between two
  orientations both and the others not), else shaving -- or grooves. For this the ovality's
  amplitude is taken as at least ``OVALITY_DEFAULT_IN`` (a few thousandths, the most a
  round bat has): the ovality read on the whole bat may be less than the barrel's.
- **Grooves**: a uniform run shorter than ``GROOVE_MAX_IN`` (the modal reading's length
  between grooved and flat-surfaced), or one whose stations do not all read its loss
  (a station between two rings reads none: a station's own drop below the run's by more
  than ``Phi^-1(1 - GROOVE_GAP_TAIL / n)`` sd, n the run's stations, so that a shaving's
  n stations show such a station by chance at most ``GROOVE_GAP_TAIL`` of the time,
  whatever its length), is grooves: every station whose own drop is
  beyond ``GROOVE_MIN_Z`` standard uncertainties is in a ring; its depth is half the
  diameter it lost.

Where: a run's ends lie between its first (last) station and the neighbour that read no
loss; the region is taken half way, with the uniform distribution's sd (gap / sqrt 12).
How much wood: the wood's density times the volume, ``pi/4 (D^2 - (D - h)^2)`` a unit length
for shaving and a ring, the circular segment ``R^2 (a - sin a cos a)`` for a flat; a ring's
width is not read (a point caliper sees only whether it is in the ring), so its volume takes
the rulebook's widths, 0.1-0.25 in (``GROOVE_WIDTH_IN``, their mean and sd).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri

from updating.inspect.calipers.null import OVALITY_DEFAULT_IN, CaliperNull, Stations, mean_variance
from updating.inspect.calipers.scan import UNIFORM, Run, Terms, window_stats
from updating.inspect.kind_table import GROOVE_MAX_IN
from updating.model.calipers import flat_area_m2, width_loss_m
from updating.model.units import IN_TO_M

FLAT_MAX_IN = 0.25
"""The deepest flat the reading considers, in."""
FLAT_MIN_DCHI2 = 9.0
"""How much better (chi^2) a flat must fit a uniform run's orientations than shaving."""
GROOVE_MIN_Z = 3.0
"""A station of a found run is in a ring when its own drop is this many sd beyond zero."""
GROOVE_GAP_TAIL = 0.00135
"""Chance that some station of a shaved run reads clearly less than the run by noise alone
(one station: 3 sd)."""
GROOVE_WIDTH_IN = (0.1, 0.25)
"""The widths grooves are cut (the rulebook's), for a ring's volume."""


@dataclass(frozen=True)
class CaliperChange:
    """One change the calipers read, SI.

    Attributes
    ----------
    kind : str
        ``shaved``, ``flat`` or ``grooves``.
    region_m : tuple of float
        Where, from the knob end, m.
    region_start_sd_m : float
        The region start's standard uncertainty, m.
    diameter_lost_m, diameter_lost_sd_m : float
        The diameter lost (a flat's depth; a ring's diameter loss, twice its depth), m, and
        its standard uncertainty.
    removed_mass_kg, removed_mass_sd_kg : float
        The wood removed, kg, and its standard uncertainty.
    statistic : float
        The scan's z of the run.
    flat_angle_deg, flat_angle_sd_deg : float or None
        A flat's normal from the marked grain plane (modulo 180 deg), and its sd.
    groove_x_m : tuple of float
        The stations read in a ring, m.
    """

    kind: str
    region_m: tuple[float, float]
    region_start_sd_m: float
    diameter_lost_m: float
    diameter_lost_sd_m: float
    removed_mass_kg: float
    removed_mass_sd_kg: float
    statistic: float
    flat_angle_deg: float | None = None
    flat_angle_sd_deg: float | None = None
    groove_x_m: tuple[float, ...] = ()


@dataclass(frozen=True)
class RunDrops:
    """A run's drops by orientation and their covariance (module docstring), SI."""

    angles_deg: np.ndarray
    drops_m: np.ndarray
    cov: np.ndarray
    radius_m: np.ndarray
    index: np.ndarray


def run_drops(st: Stations, null: CaliperNull, i0: int, i1: int, tau_ov2: float) -> RunDrops:
    """Collect a run's mean drop at each orientation and its covariance (module docstring)."""
    idx = np.arange(i0, i1)
    angles = np.unique(np.round(np.concatenate([st.angles_deg[i] for i in idx]), 3))
    sums, counts = np.zeros(angles.size), np.zeros(angles.size)
    for i in idx:
        k = np.searchsorted(angles, np.round(st.angles_deg[i], 3))
        sums[k] += st.g_m[i] * (1 + null.scale) - st.readings_m[i]
        counts[k] += 1
    common = (mean_variance(st, 0.0, null.sigma_registration_m)[idx] * null.inflation**2).mean()
    tau_c2 = common / idx.size + tau_ov2 + null.scale_sd**2 * float(st.g_m[idx].mean())**2
    t = np.radians(2 * angles)
    a = max(null.ovality_m, OVALITY_DEFAULT_IN * IN_TO_M)
    cov = (np.diag(null.sigma_retest_m**2 / counts) + tau_c2
           + 0.5 * a**2 * (np.outer(np.cos(t), np.cos(t)) + np.outer(np.sin(t), np.sin(t))))
    return RunDrops(angles, sums / counts, cov, st.g_m[idx] / 2, idx)


def _chi2(res: np.ndarray, inv: np.ndarray) -> np.ndarray:
    """r^T Sigma^-1 r over the last axis."""
    return np.einsum("...k,kl,...l->...", res, inv, res)


def read_shave(rd: RunDrops) -> tuple[float, float, float]:
    """(h, sd, chi^2) of shaving: D_k = h by generalised least squares, h >= 0."""
    inv = np.linalg.inv(rd.cov)
    one = np.ones(rd.drops_m.size)
    info = one @ inv @ one
    h = max(float(one @ inv @ rd.drops_m / info), 0.0)
    return h, float(1 / np.sqrt(info)), float(_chi2(rd.drops_m - h, inv))


def read_flat(rd: RunDrops) -> tuple[float, float, float, float, float]:
    """Read a flat on the (phi, h) grid (module docstring).

    Returns
    -------
    h_m, h_sd_m, phi_deg, phi_sd_deg, chi2_min : float
        Posterior means and sds of depth and normal, and the grid's smallest chi^2.
    """
    inv = np.linalg.inv(rd.cov)
    phi = np.arange(0.0, 180.0, 1.0)
    h = np.geomspace(0.001, FLAT_MAX_IN, 120) * IN_TO_M  # log-uniform: even on this grid
    psi = (rd.angles_deg[None, :] - phi[:, None])[:, None, :]  # (phi, 1, k)
    w = np.zeros((phi.size, h.size, rd.angles_deg.size))
    radii, counts = np.unique(np.round(rd.radius_m / IN_TO_M, 3), return_counts=True)
    for R, n in zip(radii * IN_TO_M, counts, strict=True):  # to 0.001 in: a few radii
        w += n * width_loss_m(R, h[None, :, None], psi)
    w /= counts.sum()
    chi2 = _chi2(rd.drops_m - w, inv)
    post = np.exp(-0.5 * (chi2 - chi2.min()))
    post /= post.sum()
    ph = post.sum(axis=0)
    h_mean = float(ph @ h)
    h_sd = float(np.sqrt(max(ph @ h**2 - h_mean**2, 0.0)))
    m = post.sum(axis=1) @ np.exp(2j * np.radians(phi))
    phi_mean = float(np.degrees(np.angle(m)) / 2 % 180.0)
    phi_sd = float(np.degrees(np.sqrt(max(-2 * np.log(max(abs(m), 1e-12)), 0.0))) / 2)
    return h_mean, h_sd, phi_mean, phi_sd, float(chi2.min())


def _ends(st: Stations, i0: int, i1: int, length_m: float) -> tuple[float, float, float]:
    """(start, end, start sd) of a run: half way to the neighbours that read no loss."""
    x = st.x_m
    before = x[i0] - x[i0 - 1] if i0 > 0 else x[i0] - max(x[i0] - 0.5 * IN_TO_M, 0.0)
    after = x[i1] - x[i1 - 1] if i1 < x.size else min(0.5 * IN_TO_M, length_m - x[i1 - 1])
    return (float(x[i0] - before / 2), float(min(x[i1 - 1] + after / 2, length_m)),
            float(before / np.sqrt(12)))


def _removed(st: Stations, x0: float, x1: float, area) -> float:
    """Integrate a removed area over [x0, x1] along the registered diameter, m^3."""
    x = np.linspace(x0, x1, 201)
    D = np.interp(x, st.x_m, st.g_m)
    return float(np.trapezoid(area(D), x))


def _shave_area(h: float):
    return lambda D: np.pi / 4 * (D**2 - np.clip(D - h, 0.0, None) ** 2)


def _flat_area(h: float):
    return lambda D: flat_area_m2(D / 2, min(h, 0.999 * float(np.min(D)) / 2))


def _mass(st, x0, x1, area_of, h, h_sd, start_sd, rho) -> tuple[float, float]:
    """Return the removed mass and its sd (from the depth's and the region's uncertainty), kg."""
    m = rho * _removed(st, x0, x1, area_of(h))
    dm = rho * _removed(st, x0, x1, area_of(h + h_sd)) - m
    rel_len = np.sqrt(2) * start_sd / max(x1 - x0, 1e-9)
    return m, float(np.hypot(dm, m * rel_len))


def groove_stations(st: Stations, t: Terms, run: Run) -> np.ndarray:
    """Return the run's stations read in a ring: own uniform drop beyond ``GROOVE_MIN_Z`` sd."""
    z = np.array([window_stats(t, UNIFORM, i, i + 1)[0] for i in range(run.i0, run.i1)])
    return np.arange(run.i0, run.i1)[z > GROOVE_MIN_Z]


def _reads_less(t: Terms, i: int, h: float, n: int) -> bool:
    """Tell whether station ``i`` reads none of an n-station run's loss ``h``.

    Its own uniform drop lies below h by more than ``Phi^-1(1 - GROOVE_GAP_TAIL / n)`` of its
    sd.
    """
    _, own, sd = window_stats(t, UNIFORM, i, i + 1)
    return bool(own < h - ndtri(1.0 - GROOVE_GAP_TAIL / n) * sd)


def trim_ends(t: Terms, run: Run) -> Run:
    """Drop a uniform reading's end stations that read none of its loss.

    A run found in an ``orientation`` pattern has its ends placed on that orientation's
    readings, half the information of every orientation's: its last station may lie past a
    shaving's end. Read as shaving or grooves, an end station whose own drop is below the
    run's (``_reads_less``) is outside it.
    """
    i0, i1 = run.i0, run.i1
    while i1 - i0 > 1:
        h = window_stats(t, UNIFORM, i0, i1)[1]
        if _reads_less(t, i1 - 1, h, i1 - i0):
            i1 -= 1
        elif _reads_less(t, i0, h, i1 - i0):
            i0 += 1
        else:
            break
    if (i0, i1) == (run.i0, run.i1):
        return run
    _, h, sd = window_stats(t, run.pattern, i0, i1)
    return Run(run.pattern, i0, i1, run.z, h, sd)


def is_grooves(st: Stations, t: Terms, run: Run) -> bool:
    """Tell whether a uniform run is grooves: short, or a station reading clearly less."""
    if st.x_m[run.i1 - 1] - st.x_m[run.i0] < GROOVE_MAX_IN * IN_TO_M:
        return True
    h = window_stats(t, UNIFORM, run.i0, run.i1)[1]
    return any(_reads_less(t, i, h, run.i1 - run.i0) for i in range(run.i0, run.i1))


def read_grooves(st: Stations, t: Terms, run: Run, rho: float,
                 idx: np.ndarray | None = None) -> CaliperChange:
    """Read a run of rings: how many stations in rings, where, how deep, what wood.

    ``idx``: the stations in rings when already known (sets joined), else those of the run
    whose own drop is significant (``groove_stations``).
    """
    idx = groove_stations(st, t, run) if idx is None else np.asarray(idx)
    if idx.size == 0:
        idx = np.arange(run.i0, run.i1)
    own = np.array([window_stats(t, UNIFORM, i, i + 1)[1:] for i in idx])
    h, h_sd = float(own[:, 0].mean()), float(np.sqrt(np.sum(own[:, 1] ** 2)) / idx.size)
    w_mean = np.mean(GROOVE_WIDTH_IN) * IN_TO_M
    w_sd = np.diff(GROOVE_WIDTH_IN)[0] / np.sqrt(12) * IN_TO_M
    ring = _shave_area(h)(st.g_m[idx])
    dring = _shave_area(h + h_sd)(st.g_m[idx]) - ring
    mass = rho * float(ring.sum()) * w_mean
    sd = rho * float(np.hypot(dring.sum() * w_mean, ring.sum() * w_sd))
    half = 0.5 * w_mean
    spacing = float(np.median(np.diff(st.x_m))) if st.n > 1 else w_mean
    return CaliperChange("grooves", (float(st.x_m[idx[0]] - half), float(st.x_m[idx[-1]] + half)),
                         spacing / np.sqrt(12), h, h_sd, mass, sd, run.z,
                         groove_x_m=tuple(float(x) for x in st.x_m[idx]))


def read_run(st: Stations, null: CaliperNull, t: Terms, run: Run, rho: float,
             length_m: float) -> CaliperChange:
    """Read a found run as shaving, a flat or grooves (module docstring).

    Parameters
    ----------
    st : Stations
        The compared stations.
    null : CaliperNull
        The null's estimates.
    t : Terms
        The scan's station terms.
    run : Run
        The run found.
    rho : float
        The wood's density, kg/m^3.
    length_m : float
        The bat's length, m.

    Returns
    -------
    CaliperChange
        What, where, how much, with standard uncertainties.
    """
    rd = run_drops(st, null, run.i0, run.i1, t.tau_ov2)
    h_f, h_f_sd, phi, phi_sd, chi2_f = read_flat(rd)
    h_s, h_s_sd, chi2_s = read_shave(rd)
    flat = chi2_s - chi2_f > FLAT_MIN_DCHI2
    if not flat:
        trimmed = trim_ends(t, run)
        if trimmed != run:
            run = trimmed
            rd = run_drops(st, null, run.i0, run.i1, t.tau_ov2)
            h_s, h_s_sd, chi2_s = read_shave(rd)
    if not flat and is_grooves(st, t, run):
        return read_grooves(st, t, run, rho)
    x0, x1, start_sd = _ends(st, run.i0, run.i1, length_m)
    if not flat:
        mass, mass_sd = _mass(st, x0, x1, _shave_area, h_s, h_s_sd, start_sd, rho)
        return CaliperChange("shaved", (x0, x1), start_sd, h_s, h_s_sd, mass, mass_sd, run.z)
    mass, mass_sd = _mass(st, x0, x1, _flat_area, h_f, h_f_sd, start_sd, rho)
    return CaliperChange("flat", (x0, x1), start_sd, h_f, h_f_sd, mass, mass_sd, run.z, phi,
                         phi_sd)
