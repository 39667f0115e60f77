"""The evidence behind an inspection's verdict, typed (``Verdict.details``, ``Verdict.modes``).

Built once by ``updating.inspect.run.inspect_retest``; readers use attributes. For storage and
``--json`` each type has one ``to_json_dict()`` (the keys and values the registry has always
stored, so records written before these types existed read the same).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # only a type here: fit.py imports this module without the MSSO stack
    from updating.inspect.msso_map import MssoMap


@dataclass(frozen=True)
class ModePair:
    """One mode paired re-test to baseline (to reference model).

    Attributes:
        baseline_hz, retest_hz: the two tests' natural frequencies.
        mac: MAC baseline-retest. reference_hz, mac_reference: the paired reference mode.
        change_pct: 100 (f_retest / f_baseline - 1).
        moisture_fit_change_pct, core_fit_change_pct: the same change predicted by the
            drift-only (H0) and drift+core (H1) fits, relative to the reference.
    Optional fields are None when not computed (and then left out of the JSON).
    """

    baseline_hz: float
    retest_hz: float
    mac: float | None = None
    reference_hz: float | None = None
    mac_reference: float | None = None
    change_pct: float | None = None
    moisture_fit_change_pct: float | None = None
    core_fit_change_pct: float | None = None

    def to_json_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in vars(self).items() if v is not None}


@dataclass(frozen=True)
class PositionScan:
    """The linearised scan that seeds the core fit (``updating.inspect.fit.fit_core``).

    Attributes:
        scan_norm: weighted residual norm of each trial (plug, length).
        starts_plug_length_in: the (plug, length) in inches refined by least squares.
        start_rss: the RSS each start reached.
    """

    scan_norm: tuple[float, ...] = ()
    starts_plug_length_in: tuple[tuple[float, float], ...] = ()
    start_rss: tuple[float, ...] = ()

    def to_json_dict(self) -> dict[str, Any]:
        if not (self.scan_norm or self.starts_plug_length_in or self.start_rss):
            return {}
        return {"scan_norm": list(self.scan_norm),
                "starts_plug_length_in": [list(s) for s in self.starts_plug_length_in],
                "start_rss": list(self.start_rss)}


@dataclass(frozen=True)
class ElementMap:
    """The MSSO element map (``msso_map``) or why it could not be computed.

    Attributes:
        result: the map, or None when ``error`` says why there is none.
        agrees_with_fit: both localisations agree (no change, or overlapping regions).
        error: the reason there is no map, or None.
    """

    result: MssoMap | None = None
    agrees_with_fit: bool | None = None
    error: str | None = None

    @property
    def region_m(self) -> tuple[float, float] | None:
        return None if self.result is None else self.result.region_m

    def to_json_dict(self) -> dict[str, Any]:
        if self.result is None:
            return {"error": self.error} if self.error is not None else {}
        out = self.result.to_dict()
        if self.agrees_with_fit is not None:
            out["agrees_with_fit"] = bool(self.agrees_with_fit)
        return out


@dataclass(frozen=True)
class CoreCandidate:
    """The drift+core (H1) fit's core, whatever the decision (SI).

    Attributes:
        region_m: (start, end) from the knob end. diameter_m, fill_density_ratio: the core.
        uncertainty: standard uncertainties of the fitted quantities (SI, by name).
    """

    region_m: tuple[float, float]
    diameter_m: float
    fill_density_ratio: float
    uncertainty: dict[str, float] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        return {"region_m": list(self.region_m), "diameter_m": self.diameter_m,
                "fill_density_ratio": self.fill_density_ratio,
                "uncertainty": dict(self.uncertainty)}


@dataclass(frozen=True)
class FitEvidence:
    """The test and the fits behind a verdict (absent when the tests could not be compared).

    Attributes:
        statistic: the test statistic's name. dof: (q, N - p_1) of the F test.
        p_value: P(F_{q, N-p_1} > F). rss_null, rss_core: the fits' weighted residuals.
        n_data: number of data. shape_noise_rel, freq_noise_rel: the noise levels weighted
            with (relative; per mode for frequencies).
        null_fit: the H0 parameters by name. null_at_bound, core_fit_at_bound: nuisances
            held at their physical bounds in H0 and (confusable ones) in H1.
        weight_change_rel: W_retest / W_registered - 1, or None without weights.
        element_source: which model the element factors come from.
        element_beta_shear: (e,) shear-stiffness factors of the elements.
        candidate_core: H1's core. core_fit_moisture: H1's uniform scales.
        sensor_shift_m: accelerometer shift fitted beyond the stated re-mount.
        baseline_sensor_offset_m: the baseline accelerometer's fitted offset.
        position_scan: the scan that seeded H1. msso: the element map.
        plug_m: H1's plug (solid wood at the barrel end). fill_modulus_ratio: assumed.
    """

    statistic: str
    dof: tuple[int, int]
    p_value: float
    rss_null: float
    rss_core: float
    n_data: int
    shape_noise_rel: float
    freq_noise_rel: tuple[float, ...]
    null_fit: dict[str, float]
    null_at_bound: tuple[str, ...]
    core_fit_at_bound: tuple[str, ...]
    weight_change_rel: float | None
    element_source: str
    element_beta_shear: tuple[float, ...]
    candidate_core: CoreCandidate
    core_fit_moisture: dict[str, float]
    sensor_shift_m: float
    baseline_sensor_offset_m: float
    position_scan: PositionScan
    msso: ElementMap
    plug_m: float
    fill_modulus_ratio: float


@dataclass(frozen=True)
class InspectionDetails:
    """Everything worth reporting beside the verdict: fit residuals, ranks, timings.

    Attributes:
        n_modes: number of paired modes. time_s: wall time of the inspection.
        fit: the test and fits, or None when no test was made (inconclusive before it).
    """

    n_modes: int
    time_s: float | None = None
    fit: FitEvidence | None = None

    @property
    def p_value(self) -> float | None:
        return None if self.fit is None else self.fit.p_value

    @property
    def msso(self) -> ElementMap:
        return ElementMap() if self.fit is None else self.fit.msso

    def to_json_dict(self) -> dict[str, Any]:
        """The stored form (key order as stored since issue 11)."""
        f = self.fit
        if f is None:
            out: dict[str, Any] = {"n_modes": self.n_modes}
            if self.time_s is not None:
                out["time_s"] = self.time_s
            return out
        return {
            "statistic": f.statistic, "dof": list(f.dof), "p_value": f.p_value,
            "rss_null": f.rss_null, "rss_core": f.rss_core,
            "n_modes": self.n_modes, "n_data": f.n_data,
            "shape_noise_rel": f.shape_noise_rel,
            "freq_noise_rel": list(f.freq_noise_rel),
            "null_fit": dict(f.null_fit),
            "null_at_bound": list(f.null_at_bound),
            "core_fit_at_bound": list(f.core_fit_at_bound),
            "weight_change_rel": f.weight_change_rel,
            "element_source": f.element_source,
            "element_beta_shear": list(f.element_beta_shear),
            "candidate_core": f.candidate_core.to_json_dict(),
            "core_fit_moisture": dict(f.core_fit_moisture),
            "sensor_shift_m": f.sensor_shift_m,
            "baseline_sensor_offset_m": f.baseline_sensor_offset_m,
            "position_scan": f.position_scan.to_json_dict(),
            "msso": f.msso.to_json_dict(),
            "plug_m": f.plug_m, "fill_modulus_ratio": f.fill_modulus_ratio,
            "time_s": self.time_s,
        }
