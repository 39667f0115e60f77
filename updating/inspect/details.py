"""The evidence behind an inspection's verdict, typed (``Verdict.details``, ``Verdict.modes``).

Built once by ``updating.inspect.run.inspect_retest``; readers use attributes. For storage and
``--json`` each type has one ``to_json_dict()`` (the keys and values the registry has always
stored, so records written before these types existed read the same), and its inverse
``from_json_dict()`` for readers of stored records (the report, the history): a key an older
record lacks takes its field's "not computed" value (None, empty, NaN), never an error, and a
key no longer written is ignored (older records hold an empty ``position_scan``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # only a type here: fit.py imports this module without the MSSO stack
    from updating.inspect.msso_map import MssoMap


@dataclass(frozen=True)
class ModePair:
    """One mode paired re-test to baseline (to reference model).

    Optional fields are None when not computed (and then left out of the JSON).

    Attributes
    ----------
    baseline_hz, retest_hz
        The two tests' natural frequencies.
    mac
        MAC baseline-retest.
    reference_hz, mac_reference
        The paired reference mode.
    change_pct
        100 (f_retest / f_baseline - 1).
    moisture_fit_change_pct, core_fit_change_pct
        The same change predicted by the drift-only (H0) and drift+core (H1) fits, relative to
        the reference.
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
        """Write the pair as a JSON dict (None fields left out)."""
        return {k: float(v) for k, v in vars(self).items() if v is not None}

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any]) -> ModePair:
        """Read a pair from its JSON dict.

        Inverse of ``to_json_dict``: a stored null (NaN) is NaN, a missing key None
        (missing frequencies NaN); unknown keys are ignored.
        """
        kw = {f.name: _num(d[f.name]) for f in fields(cls) if f.name in d}
        kw.setdefault("baseline_hz", math.nan)
        kw.setdefault("retest_hz", math.nan)
        return cls(**kw)


@dataclass(frozen=True)
class ElementMap:
    """The MSSO element map (``msso_map``) or why it could not be computed.

    Attributes
    ----------
    result
        The map, or None when ``error`` says why there is none.
    agrees_with_fit
        Both localisations agree (no change, or overlapping regions).
    error
        The reason there is no map, or None.
    """

    result: MssoMap | None = None
    agrees_with_fit: bool | None = None
    error: str | None = None

    @property
    def region_m(self) -> tuple[float, float] | None:
        """Return the map's region (start, end), m, or None."""
        return None if self.result is None else self.result.region_m

    def to_json_dict(self) -> dict[str, Any]:
        """Write the map as a JSON dict."""
        if self.result is None:
            return {"error": self.error} if self.error is not None else {}
        out = self.result.to_dict()
        if self.agrees_with_fit is not None:
            out["agrees_with_fit"] = bool(self.agrees_with_fit)
        return out

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any] | None, x0_m=None, x1_m=None) -> ElementMap:
        """Read a map from its JSON dict.

        Inverse of ``to_json_dict``. The stored map does not repeat the element ends (the
        record's ``elements`` hold them): pass them as ``x0_m``, ``x1_m``, else they are NaN.
        No ``alpha``: no map (with the stored ``error`` if any).
        """
        d = d or {}
        if "alpha" not in d:
            return cls(error=d.get("error"))
        import numpy as np

        from updating.inspect.msso_map import MssoMap  # numpy, only for a stored map

        alpha = np.asarray(d["alpha"], dtype=float)
        ends = [np.full(alpha.size, np.nan) if x is None else np.asarray(x, dtype=float)
                for x in (x0_m, x1_m)]
        region = d.get("region_m")
        result = MssoMap(
            ends[0], ends[1], alpha, np.asarray(d.get("beta") or [], dtype=float),
            np.asarray(d.get("alpha_std") or [], dtype=float),
            np.asarray(d.get("beta_std") or [], dtype=float),
            None if region is None else (float(region[0]), float(region[1])),
            _num(d.get("peak_z")), int(d.get("rank") or 0), _num(d.get("chi2")),
            int(d.get("n_data") or 0), _num(d.get("baseline_chi2")),
            tuple(d.get("groups") or ()), _num(d.get("time_s")))
        agrees = d.get("agrees_with_fit")
        return cls(result, None if agrees is None else bool(agrees))


@dataclass(frozen=True)
class CoreCandidate:
    """The drift+core (H1) fit's core, whatever the decision (SI).

    Attributes
    ----------
    region_m
        (start, end) from the knob end.
    diameter_m, fill_density_ratio
        The core.
    uncertainty
        Standard uncertainties of the fitted quantities (SI, by name).
    """

    region_m: tuple[float, float]
    diameter_m: float
    fill_density_ratio: float
    uncertainty: dict[str, float] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        """Write the candidate as a JSON dict."""
        return {"region_m": list(self.region_m), "diameter_m": self.diameter_m,
                "fill_density_ratio": self.fill_density_ratio,
                "uncertainty": dict(self.uncertainty)}

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any] | None) -> CoreCandidate:
        """Inverse of ``to_json_dict`` (missing values NaN)."""
        d = d or {}
        region = d.get("region_m") or (math.nan, math.nan)
        return cls((_num(region[0]), _num(region[1])), _num(d.get("diameter_m")),
                   _num(d.get("fill_density_ratio")), dict(d.get("uncertainty") or {}))


@dataclass(frozen=True)
class FitEvidence:
    """The test and the fits behind a verdict (absent when the tests could not be compared).

    Attributes
    ----------
    statistic
        The test statistic's name.
    dof
        (q, N - p_1) of the F test.
    p_value
        P(F_{q, N-p_1} > F).
    rss_null, rss_core
        The fits' weighted residuals.
    n_data
        Number of data.
    shape_noise_rel, freq_noise_rel
        The noise levels weighted with (relative, per paired mode).
    null_fit
        The H0 parameters by name.
    null_at_bound, core_fit_at_bound
        Nuisances held at their physical bounds in H0 and (confusable ones) in H1.
    weight_change_rel
        W_retest / W_registered - 1, or None without weights.
    element_source
        Which model the element factors come from.
    element_beta_shear
        (e,) shear-stiffness factors of the elements.
    candidate_core
        H1's core.
    core_fit_moisture
        H1's uniform scales.
    sensor_shift_m
        Accelerometer shift fitted beyond the stated re-mount.
    baseline_sensor_offset_m
        The baseline accelerometer's fitted offset.
    msso
        The element map.
    plug_m
        H1's plug (solid wood at the barrel end).
    fill_modulus_ratio
        Assumed.
    empty_m
        The reading's empty stretch of the hole behind the plug (a partial fill), m; 0 when the
        hole reads as filled to the plug.
    local_change
        H1's generic local change (start, length in inches; relative mass and stiffness).
    kind_scores
        Akaike score of each kind's fit, when the change was significant.
    leave_one_out
        The finding refitted with each mode and each point left out (``robustness``:
        ``cases`` and the readings' ``spread``, SI), when it was checked; else empty.
    modes_left_out
        Why paired modes were left out of the verdict (``identity``), one line each.
    F_fit
        The nested test's F with the noise the best local change leaves (the change's size;
        ``statistic`` and ``p_value`` are the test with the noise H0 leaves).
    decided_on
        Where the chance the decision read came from: "calibration" (measured on the bat
        model's clean re-tests) or "nominal" (``p_value``; ``decision.decided_chance``).
    """

    statistic: str
    dof: tuple[int, int]
    p_value: float
    rss_null: float
    rss_core: float
    n_data: int
    shape_noise_rel: tuple[float, ...]
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
    msso: ElementMap
    plug_m: float
    fill_modulus_ratio: float
    empty_m: float = 0.0
    local_change: dict[str, float] = field(default_factory=dict)
    kind_scores: dict[str, float] = field(default_factory=dict)
    leave_one_out: dict[str, Any] = field(default_factory=dict)
    modes_left_out: tuple[str, ...] = ()
    F_fit: float = math.nan
    decided_on: str = "nominal"


@dataclass(frozen=True)
class InspectionDetails:
    """Everything worth reporting beside the verdict: fit residuals, ranks, timings.

    Attributes
    ----------
    n_modes
        Number of paired modes.
    time_s
        Wall time of the inspection.
    fit
        The test and fits, or None when no test was made (inconclusive before it).
    plane_split
        The bending pairs' splits' reading as stored (``PlaneSplit.to_json_dict``), or None
        (not read, or a record written before it).
    """

    n_modes: int
    time_s: float | None = None
    fit: FitEvidence | None = None
    plane_split: dict[str, Any] | None = None

    @property
    def p_value(self) -> float | None:
        """Return the nested test's p-value, or None without a test."""
        return None if self.fit is None else self.fit.p_value

    @property
    def msso(self) -> ElementMap:
        """Return the MSSO element map (empty without a test)."""
        return ElementMap() if self.fit is None else self.fit.msso

    def to_json_dict(self) -> dict[str, Any]:
        """Write the details as a JSON dict.

        The stored form (key order as stored since issue 11).
        """
        f = self.fit
        split = {} if self.plane_split is None else {"plane_split": dict(self.plane_split)}
        if f is None:
            out: dict[str, Any] = {"n_modes": self.n_modes}
            if self.time_s is not None:
                out["time_s"] = self.time_s
            return {**out, **split}
        return {
            "statistic": f.statistic, "dof": list(f.dof), "p_value": f.p_value,
            "rss_null": f.rss_null, "rss_core": f.rss_core,
            "n_modes": self.n_modes, "n_data": f.n_data,
            "shape_noise_rel": list(f.shape_noise_rel),
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
            "msso": f.msso.to_json_dict(),
            "plug_m": f.plug_m, "fill_modulus_ratio": f.fill_modulus_ratio,
            "empty_m": f.empty_m, "local_change": dict(f.local_change),
            "kind_scores": dict(f.kind_scores), "time_s": self.time_s,
            "leave_one_out": dict(f.leave_one_out),
            "modes_left_out": list(f.modes_left_out), "F_fit": f.F_fit,
            "decided_on": f.decided_on, **split,
        }

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any] | None, x0_m=None, x1_m=None
                       ) -> InspectionDetails:
        """Read the details from a stored record.

        Inverse of ``to_json_dict``: a stored record's ``details`` (None or {}: nothing
        known). The fit evidence is read when the record has the test (``statistic`` or
        ``p_value``); ``x0_m``, ``x1_m``: the element ends for the MSSO map (see
        ``ElementMap.from_json_dict``).
        """
        d = d or {}
        n_modes = int(d.get("n_modes") or 0)
        time_s = None if d.get("time_s") is None else float(d["time_s"])
        split = d.get("plane_split")
        if "statistic" not in d and "p_value" not in d:
            return cls(n_modes, time_s, plane_split=split)
        dof = d.get("dof") or (0, 0)
        weight = d.get("weight_change_rel")
        fit = FitEvidence(
            statistic=str(d.get("statistic") or ""), dof=(int(dof[0]), int(dof[1])),
            p_value=_num(d.get("p_value")), rss_null=_num(d.get("rss_null")),
            rss_core=_num(d.get("rss_core")), n_data=int(d.get("n_data") or 0),
            shape_noise_rel=_levels(d.get("shape_noise_rel")),
            freq_noise_rel=tuple(float(v) for v in d.get("freq_noise_rel") or ()),
            null_fit=dict(d.get("null_fit") or {}),
            null_at_bound=tuple(d.get("null_at_bound") or ()),
            core_fit_at_bound=tuple(d.get("core_fit_at_bound") or ()),
            weight_change_rel=None if weight is None else float(weight),
            element_source=str(d.get("element_source") or ""),
            element_beta_shear=tuple(float(v) for v in d.get("element_beta_shear") or ()),
            candidate_core=CoreCandidate.from_json_dict(d.get("candidate_core")),
            core_fit_moisture=dict(d.get("core_fit_moisture") or {}),
            sensor_shift_m=_num(d.get("sensor_shift_m")),
            baseline_sensor_offset_m=_num(d.get("baseline_sensor_offset_m")),
            msso=ElementMap.from_json_dict(d.get("msso"), x0_m, x1_m),
            plug_m=_num(d.get("plug_m")), fill_modulus_ratio=_num(d.get("fill_modulus_ratio")),
            empty_m=_num(d.get("empty_m")),
            local_change=dict(d.get("local_change") or {}),
            kind_scores=dict(d.get("kind_scores") or {}),
            leave_one_out=dict(d.get("leave_one_out") or {}),
            modes_left_out=tuple(d.get("modes_left_out") or ()), F_fit=_num(d.get("F_fit")),
            decided_on=str(d.get("decided_on") or "nominal"))
        return cls(n_modes, time_s, fit, split)


def _levels(v: Any) -> tuple[float, ...]:
    """Read stored noise levels.

    Stored noise levels: a list per mode, or one number (records before per-mode shape
    noise); missing: ().
    """
    if v is None:
        return ()
    return tuple(_num(x) for x in v) if isinstance(v, list | tuple) else (_num(v),)


def _num(v: Any) -> float:
    """Read a stored number (JSON null: NaN was stored as null) as a float; missing: NaN."""
    return math.nan if v is None else float(v)
