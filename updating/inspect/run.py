"""Phase 3: the verdict on a re-tested bat (../docs/inspection.md).

1. Pair the re-test's modes with the baseline's (MAC and frequency) and with the calibrated
   reference model's.
2. Fit, to the changes retest - baseline of frequencies and shapes, the model's changes
   model(theta) - model(reference) under two hypotheses:
   H0 (what every bat does between tests): uniform stiffness and density scales (moisture)
   and a shift of the re-mounted accelerometer, 3 parameters;
   H1: H0 plus an axial core from the barrel end (depth, diameter, fill density ratio; fill
   modulus and plug length fixed), 6 parameters.
3. Nested-model F test, residuals weighted by their estimated noise:

       F = ((RSS_0 - RSS_1) / q) / (RSS_1 / (N - p_1)),  q = 3, p_1 = 6,

   p = P(F_{q, N-p_1} > F); altered when p < false_alarm; confidence = 1 - p.
4. Reading: the H1 core (region, diameter, fill ratio) with standard uncertainties from the
   Jacobian, and the element factors it implies.
5. The MSSO element map (``msso_map``), independent of the core fit: the re-test against the
   baseline-updated reference with H0's moisture and sensor shift removed (``details["msso"]``).
"""

from __future__ import annotations

import time

import numpy as np
from scipy.stats import f as f_dist

from updating.correlate.measured import MeasuredModes
from updating.correlate.pairing import align_signs, pair_modes
from updating.inspect.fit import (
    MAX_NFEV_CORE,
    Differences,
    ParamSpace,
    fit_bounded,
    fit_core,
    fit_null,
    residual_function,
    shape_noise,
)
from updating.inspect.model import (
    ChangeParams,
    baseline_sensor_offset,
    make_predictor,
    wood_system,
)
from updating.inspect.msso_map import msso_map
from updating.inspect.verdict import Verdict
from updating.lsq import covariance
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M
from updating.msso.core_elements import core_element_factors

ELASTIC_MIN_HZ = 20.0
FALLBACK_FREQ_STD_PER_ZETA = 0.05
"""Without the fitter's frequency uncertainty: sigma_f / f = 0.05 zeta (1/20 of the
half-power half-bandwidth)."""
INITIAL_SHAPE_NOISE = 0.01
MAP_MASS_NORMALISED = True
SCAN_DEPTHS_IN = tuple(float(d) for d in np.arange(4.0, 14.5, 1.0))
"""Core depths (in, from the barrel end) scanned to seed the core fit."""


def _rel_freq_std(m: MeasuredModes) -> np.ndarray:
    if m.freq_std_hz is not None and np.all(np.asarray(m.freq_std_hz) > 0):
        return np.asarray(m.freq_std_hz) / m.freq_hz
    return FALLBACK_FREQ_STD_PER_ZETA * np.maximum(np.asarray(m.damping_ratio), 1e-3)


def _check(profile: Profile, baseline: MeasuredModes, retest: MeasuredModes) -> None:
    if baseline.x_m.shape != retest.x_m.shape or not np.allclose(baseline.x_m, retest.x_m,
                                                                atol=1e-4):
        raise ValueError("baseline and re-test were measured at different points")
    if np.any(baseline.x_m < 0) or np.any(baseline.x_m > profile.length_m + 1e-6):
        raise ValueError("test points lie outside the bat's profile")


def differences(
    predict, baseline: MeasuredModes, retest: MeasuredModes, min_mac: float,
) -> tuple[Differences, list[dict]]:
    """Pair modes (retest-baseline, baseline-reference) and form the measured changes."""
    ib, ir, mac_br = pair_modes(baseline.shapes, retest.shapes, freq_a_hz=baseline.freq_hz,
                                freq_b_hz=retest.freq_hz, min_mac=min_mac, max_rel_df=0.15)
    f_mod, phi_mod = predict(ChangeParams())
    elastic = np.flatnonzero(f_mod >= ELASTIC_MIN_HZ)
    jb, jm, mac_bm = pair_modes(baseline.shapes, phi_mod[:, elastic],
                                freq_a_hz=baseline.freq_hz, freq_b_hz=f_mod[elastic],
                                min_mac=min_mac, max_rel_df=0.3)
    to_model = dict(zip(jb.tolist(), elastic[jm].tolist(), strict=True))
    mac_model = dict(zip(jb.tolist(), mac_bm.tolist(), strict=True))
    keep = [k for k, b in enumerate(ib) if b in to_model]
    if len(keep) < 3:
        raise ValueError(f"only {len(keep)} modes pair between baseline, re-test and "
                         "reference (need 3)")
    ib, ir, mac_br = ib[keep], ir[keep], mac_br[keep]
    jmod = np.array([to_model[b] for b in ib])
    psi_b = baseline.shapes[:, ib]
    psi_r = align_signs(psi_b, retest.shapes[:, ir])
    phi0 = align_signs(psi_b, phi_mod[:, jmod])
    fb, fr = baseline.freq_hz[ib], retest.freq_hz[ir]
    sig = np.hypot(_rel_freq_std(baseline)[ib], _rel_freq_std(retest)[ir])
    rms = np.hypot(np.sqrt(np.mean(psi_b**2, axis=0)), np.sqrt(np.mean(psi_r**2, axis=0)))
    diff = Differences(jmod, np.log(fr / fb), sig, psi_r - psi_b, rms, f_mod[jmod], phi0)
    modes = [{"baseline_hz": float(a), "retest_hz": float(b), "mac": float(m),
              "reference_hz": float(c), "mac_reference": float(mac_model[int(i)])}
             for a, b, m, c, i in zip(fb, fr, mac_br, f_mod[jmod], ib, strict=True)]
    return diff, modes


def _element_map(profile, reference, baseline, retest, modes, drift, offset, sigma,
                 sigma_lnf) -> dict:
    """The MSSO map of the paired modes as a dict for ``details["msso"]`` ({"error": ...}
    when the modes cannot be updated element by element)."""
    ib = [int(np.argmin(np.abs(baseline.freq_hz - m["baseline_hz"]))) for m in modes]
    ir = [int(np.argmin(np.abs(retest.freq_hz - m["retest_hz"]))) for m in modes]
    try:
        mp = msso_map(profile, reference, baseline.select(ib), retest.select(ir),
                      stiffness_scale=drift.stiffness_scale, density_scale=drift.density_scale,
                      sensor_shift_m=drift.sensor_shift_m, baseline_sensor_offset_m=offset,
                      shape_sigma=sigma,
                      freq_sigma=float(np.median(sigma_lnf)) / np.sqrt(2),
                      mass_normalised=MAP_MASS_NORMALISED)
    except ValueError as exc:
        return {"error": str(exc)}
    return mp.to_dict()


def _agree(map_region, fit_region) -> bool:
    """Both say "no local change", or both regions overlap."""
    if map_region is None or fit_region is None:
        return map_region is None and fit_region is None
    return bool(map_region[0] < fit_region[1] and fit_region[0] < map_region[1])


def inspect_retest(
    profile: Profile, reference: BatReference, baseline: MeasuredModes,
    retest: MeasuredModes, false_alarm: float = 0.01, *, plug_m: float = IN_TO_M,
    fill_modulus_ratio: float = 0.0, depths_in=SCAN_DEPTHS_IN,
    n_starts: int = 2, min_mac: float = 0.8,
) -> Verdict:
    """The lab's verdict on a re-test of a bat against its baseline test and reference.

    Args:
        profile: the bat's outer profile.
        reference: its calibrated reference (from the baseline test).
        baseline, retest: identified elastic modes of the two tests, at the same points.
        false_alarm: significance level of the test "no local alteration".
        plug_m, fill_modulus_ratio: assumed plug length and fill stiffness of a core.
        depths_in: core depths (from the barrel end) scanned to start the core fit.
        n_starts: number of depth starts refined by least squares.
        min_mac: minimum MAC to pair two modes.
    Raises:
        ValueError: when the tests cannot be compared (points differ, too few paired modes).
    """
    t0 = time.perf_counter()
    _check(profile, baseline, retest)
    points = np.asarray(baseline.x_m, dtype=float)
    n_solve = max(baseline.freq_hz.size, retest.freq_hz.size) + 6
    predict = make_predictor(profile, reference, points, reference.sensor_x_m, n_solve)
    offset = baseline_sensor_offset(predict, baseline.freq_hz, baseline.shapes)
    predict = make_predictor(profile, reference, points, reference.sensor_x_m + offset, n_solve)
    diff, modes = differences(predict, baseline, retest, min_mac)
    space = ParamSpace(profile, plug_m, fill_modulus_ratio,
                       float(retest.sensor_x_m - baseline.sensor_x_m))
    depths = np.asarray(depths_in, dtype=float)

    # noise: shape level from the null fit, then from the core fit (both refitted with it)
    null = fit_null(predict, diff, space, INITIAL_SHAPE_NOISE)
    sigma = shape_noise(null, diff, INITIAL_SHAPE_NOISE, 3)
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    full, scan = fit_core(predict, diff, space, sigma, null, depths, n_starts)
    sigma = shape_noise(full, diff, sigma, 6)
    null = fit_null(predict, diff, space, sigma, x0=null.x)
    full, _ = fit_core(predict, diff, space, sigma, null, depths, x0=full.x)
    if null.rss < full.rss:  # H1 contains H0 (p = q = 0): restart H1 from there
        x0 = np.concatenate([null.x, [full.x[3], 0.0, 0.0]])
        full = fit_bounded(residual_function(predict, diff, space, sigma), x0, space.lower(),
                           space.upper(), space, diff.n_freq, MAX_NFEV_CORE)

    n, p1, q = diff.n_data, 6, 3
    dof = n - p1
    rss0, rss1 = null.rss, min(full.rss, null.rss)
    # residual variance per datum, not below 1: the weights hold the noise floors
    # (SHAPE_NOISE_FLOOR), and data cleaner than them must not make model error significant
    F = max(rss0 - rss1, 0.0) / q / max(rss1 / dof, 1.0)
    p_value = float(f_dist.sf(F, q, dof))
    altered = p_value < false_alarm

    cov1 = covariance(full.jac, full.residual, dof)
    cov0 = covariance(null.jac, null.residual, n - 3)
    accepted, cov = (full, cov1) if altered else (null, cov0)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    ps = accepted.params
    uncertainty = {"stiffness_scale": sd[0] / 100, "density_scale": sd[1] / 100,
                   "sensor_shift_m": sd[2] * IN_TO_M}
    region = core_d = ratio = None
    candidate = space.reading(full.x, cov1)
    if altered:
        core = ps.core
        region = core.interval_m(profile.length_m)
        core_d, ratio = core.diameter_m, core.fill_density_ratio
        uncertainty.update(candidate["sd"])
    model = wood_system(profile, reference, points, None).model
    factors = core_element_factors(model, ps.core if altered else None)

    f_fit, _ = predict(full.params)
    f_null, _ = predict(null.params)
    for k, m in enumerate(modes):
        j = diff.model_index[k]
        m["change_pct"] = 100 * (m["retest_hz"] / m["baseline_hz"] - 1)
        m["moisture_fit_change_pct"] = 100 * (f_null[j] / diff.f0[k] - 1)
        m["core_fit_change_pct"] = 100 * (f_fit[j] / diff.f0[k] - 1)

    # the accepted model's drift: when there is a core, the moisture-only fit's uniform scales
    # absorb part of it and the map would show that as a change of the whole bat
    msso = _element_map(profile, reference, baseline, retest, modes, ps, offset, sigma,
                        diff.sigma_lnf)
    if "error" not in msso:
        msso["agrees_with_fit"] = _agree(msso["region_m"], region)

    c = full.params.core
    details = {
        "statistic": "F (moisture+core vs moisture-only, nested least squares)",
        "dof": [q, dof], "p_value": p_value, "rss_null": rss0, "rss_core": rss1,
        "n_modes": len(modes), "n_data": n,
        "shape_noise_rel": sigma,
        "freq_noise_rel": diff.sigma_lnf.tolist(),
        "element_source": ("physical core fit (element-averaged section ratios)" if altered
                           else "moisture-only model (no local change)"),
        "element_beta_shear": factors.beta_shear.tolist(),
        "candidate_core": {"region_m": [float(v) for v in c.interval_m(profile.length_m)],
                           "diameter_m": c.diameter_m,
                           "fill_density_ratio": c.fill_density_ratio,
                           "uncertainty": candidate["sd"]},
        "core_fit_moisture": {"stiffness_scale": float(full.params.stiffness_scale),
                              "density_scale": float(full.params.density_scale)},
        "sensor_shift_m": float(ps.sensor_shift_m - space.sensor_mount_m),
        "baseline_sensor_offset_m": offset,
        "depth_scan": scan,
        "msso": msso,
        "plug_m": plug_m, "fill_modulus_ratio": fill_modulus_ratio,
        "time_s": time.perf_counter() - t0,
    }
    return Verdict(
        altered=bool(altered), confidence=1.0 - p_value, false_alarm_rate=false_alarm,
        statistic=float(F), region_m=None if region is None else (float(region[0]),
                                                                  float(region[1])),
        core_diameter_m=None if core_d is None else float(core_d),
        fill_density_ratio=None if ratio is None else float(ratio),
        uncertainty={k: float(v) for k, v in uncertainty.items()},
        element_x0_m=factors.x0_m, element_x1_m=factors.x1_m,
        alpha=factors.alpha, beta=factors.beta,
        moisture={"stiffness_scale": float(ps.stiffness_scale),
                  "density_scale": float(ps.density_scale)},
        modes=modes, details=details,
    )
