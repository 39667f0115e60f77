"""H1 as a local change anywhere along the bat, and the families that tell its kind.

Each family adds to the null parameters x[:N_NULL] (``hypotheses``) one stretch of the bat,
``start`` and ``length`` in inches from the knob end, and what happened there
(``segments.Segment``):

- ``local_change`` (start, length, alpha, beta): the wood's mass and bending stiffness
  changed by the relative alpha and beta (shear stiffness as the mass), the generic local
  change and the detection statistic's H1;
- ``added_mass`` (start, length, grams): non-structural mass, no stiffness: nails and metal
  (short), wax or another coating (long), a grip substance (on the handle);
- ``diameter_loss`` (start, length, inches): outer diameter removed: shaved, flattened,
  grooved (mass ~ D^2, bending stiffness ~ D^4);

(the fourth kind, a core bored from the barrel end, is ``hypotheses.fit_core``.)

Every family starts from a linearised scan over trial stretches along the whole bat: the
residual's change for a unit change in each of the family's amplitudes is combined with the
null model's Jacobian, the least-squares amplitudes and the norm left over rank the
stretches, and the best two distinct stretches are refined by bounded least squares
(``hypotheses.fit_bounded``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.inspect.hypotheses import (
    N_NULL,
    ChangeFit,
    Differences,
    NullBounds,
    SigmaRel,
    fit_bounded,
    null_params,
    residual_function,
)
from updating.inspect.kind_table import FAMILIES, MIN_LENGTH_IN, SEGMENT_FAMILIES
from updating.inspect.model import ChangeParams
from updating.inspect.parallel import fork_map
from updating.inspect.segments import Segment, coverage, element_masses_kg
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

N_SEGMENT = len(FAMILIES["local_change"].params)
"""Parameters of the generic local change (start, length, alpha, beta): q of the F test."""
SCAN_STEP_IN = 3.0
SCAN_LENGTHS_IN = (2.0, 5.0, 10.0)
"""Trial stretches of the scan: starts every ``SCAN_STEP_IN`` along the bat, these lengths."""
MAX_NFEV = 20


@dataclass(frozen=True)
class SegmentSpace:
    """How a parameter vector of a segment family becomes a state of the bat.

    Parameters
    ----------
    profile : Profile
        The bat's outer profile (its length bounds the stretch).
    bounds : NullBounds
        The null parameters' bounds and priors.
    family : str
        One of ``kind_table.SEGMENT_FAMILIES`` (its parameters and bounds:
        ``kind_table.FAMILIES``).
    sensor_mount_m : float
        Nominal move of the accelerometer between the tests, m.
    """

    profile: Profile
    bounds: NullBounds
    family: str
    sensor_mount_m: float = 0.0

    @property
    def length_in(self) -> float:
        """The bat's length, in."""
        return self.profile.length_m / IN_TO_M

    def family_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of the family's own parameters (start, length, amplitudes)."""
        if self.family not in SEGMENT_FAMILIES:
            raise ValueError(f"unknown local-change family {self.family!r}")
        return FAMILIES[self.family].bounds(self.length_in)

    def index(self, name: str) -> int:
        """Return where the family's parameter ``name`` sits in x (after the null's)."""
        return N_NULL + FAMILIES[self.family].index(name)

    def lower(self) -> np.ndarray:
        """Lower bounds of the whole vector (null, then the family's)."""
        return np.concatenate([self.bounds.lower, self.family_bounds()[0]])

    def upper(self) -> np.ndarray:
        """Upper bounds of the whole vector."""
        return np.concatenate([self.bounds.upper, self.family_bounds()[1]])

    def interval_m(self, x: np.ndarray) -> tuple[float, float]:
        """Return the stretch (start, end) of x, m from the knob end, within the bat."""
        start_in, length_in = float(x[self.index("start_in")]), float(x[self.index("length_in")])
        end_in = min(start_in + length_in, self.length_in)
        return start_in * IN_TO_M, end_in * IN_TO_M

    def segment(self, x: np.ndarray) -> Segment:
        """Return the family's ``Segment`` for x."""
        x0, x1 = self.interval_m(x)
        if self.family == "local_change":
            alpha = float(x[self.index("mass_rel")])
            return Segment(x0, x1, mass_rel=alpha, bend_rel=float(x[self.index("stiffness_rel")]),
                           shear_rel=alpha)
        if self.family == "added_mass":
            return Segment(x0, x1, added_mass_kg=float(x[self.index("mass_g")]) * 1e-3)
        return Segment(x0, x1, diameter_loss_m=float(x[self.index("loss_in")]) * IN_TO_M)

    def params(self, x: np.ndarray) -> ChangeParams:
        """Return the bat's state for x (null part and, when present, the family's stretch)."""
        x = np.asarray(x, dtype=float)
        segs = () if x.size == N_NULL else (self.segment(x),)
        return null_params(x, self.sensor_mount_m, segments=segs)

    def seed(self, start_in: float, length_in: float, amplitudes) -> np.ndarray:
        """Return the family's part of x for a stretch and its amplitudes, inside the bounds."""
        lo, hi = self.family_bounds()
        return np.clip(np.concatenate([[start_in, length_in], amplitudes]), lo, hi)


@dataclass(frozen=True)
class SegmentScan:
    """The linearised scan of one family: trial stretches, residual norms and seeds.

    Parameters
    ----------
    stretches_in : ndarray
        (k, 2) start and length of each trial stretch, in.
    norm : ndarray
        (k,) weighted residual norm left by the linearised fit there.
    seeds : ndarray
        (k, N_NULL + p) start vectors for the nonlinear fit.
    """

    stretches_in: np.ndarray
    norm: np.ndarray
    seeds: np.ndarray


def trial_stretches(length_in: float) -> np.ndarray:
    """Return the scan's trial stretches: (k, 2) start and length, in.

    Starts ``SCAN_STEP_IN`` apart, each of ``SCAN_LENGTHS_IN`` that fits inside the bat, and
    each length ending at the barrel end.
    """
    out = []
    for ell in SCAN_LENGTHS_IN:
        starts = np.arange(0.0, length_in - ell + 1e-9, SCAN_STEP_IN)
        out += [(s, ell) for s in starts] + [(length_in - ell, ell)]
    return np.unique(np.round(np.array(out), 6), axis=0)


def segment_scan(predict, diff: Differences, space: SegmentSpace, sigma_rel: SigmaRel,
                 null: ChangeFit) -> SegmentScan:
    """Linearised scan of a family along the bat (module docstring).

    Parameters
    ----------
    predict : ChangePredictor
        The bat's change predictor.
    diff : Differences
        The measured changes and their weights.
    space : SegmentSpace
        The family.
    sigma_rel : float or ndarray
        Relative shape noise (per mode).
    null : ChangeFit
        The null fit (its Jacobian linearises the nuisances).

    Returns
    -------
    SegmentScan
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    r0 = null.residual
    units = FAMILIES[space.family].scan_unit
    stretches = trial_stretches(space.length_in)
    norms, seeds = [], []
    for start, ell in stretches:
        cols = []
        for k, u in enumerate(units):
            amp = np.zeros(len(units))
            amp[k] = u
            cols.append(fun(np.concatenate([null.x, [start, ell], amp])) - r0)
        A = np.column_stack([null.jac[:, :N_NULL], *cols])
        coef, *_ = np.linalg.lstsq(A, -r0, rcond=None)
        norms.append(float(np.linalg.norm(r0 + A @ coef)))
        amp = coef[N_NULL:] * np.asarray(units)
        seeds.append(np.concatenate([null.x + coef[:N_NULL], space.seed(start, ell, amp)]))
    return SegmentScan(stretches, np.array(norms), np.array(seeds))


def distinct_best(scan: SegmentScan, n: int, apart_in: float = 2.0) -> list[np.ndarray]:
    """Return the ``n`` best seeds of a scan whose stretches start ``apart_in`` apart."""
    chosen: list[int] = []
    for i in np.argsort(scan.norm):
        if all(abs(scan.stretches_in[i, 0] - scan.stretches_in[j, 0]) >= apart_in
               for j in chosen):
            chosen.append(int(i))
        if len(chosen) == n:
            break
    return [scan.seeds[i] for i in chosen]


def fit_segment(predict, diff: Differences, space: SegmentSpace, sigma_rel: SigmaRel,
                null: ChangeFit, n_starts: int = 2,
                starts: list[np.ndarray] | None = None) -> ChangeFit:
    """Fit the null model plus one stretch of the family, best of several starts.

    Parameters
    ----------
    predict, diff, space, sigma_rel, null
        As ``segment_scan``.
    n_starts : int
        Stretches of the scan refined by least squares.
    starts : list of ndarray, optional
        Start vectors to refine instead of the scan's.

    Returns
    -------
    ChangeFit
        The fit with the lowest weighted residual sum of squares.
    """
    fun = residual_function(predict, diff, space, sigma_rel)
    lo, hi = space.lower(), space.upper()
    if starts is None:
        starts = distinct_best(segment_scan(predict, diff, space, sigma_rel, null), n_starts)
    fits = fork_map(lambda s: fit_bounded(fun, np.clip(s, lo, hi), lo, hi, space, diff,
                                          MAX_NFEV), starts)
    return min(fits, key=lambda f: f.rss)


def start_from(other: ChangeFit, other_space: SegmentSpace, space: SegmentSpace,
               predict) -> np.ndarray:
    """Start ``space``'s family on the stretch another family's fit found.

    The amplitude is converted through the wood there: alpha of the generic change is an
    added mass alpha m_wood (the stretch's wood mass), or a diameter loss -alpha D / 2.
    """
    x = other.x
    x0, x1 = other_space.interval_m(x)
    start_in, ell_in = x0 / IN_TO_M, max(x1 - x0, MIN_LENGTH_IN * IN_TO_M) / IN_TO_M
    generic = other_space.family == "local_change"
    alpha = float(x[other_space.index("mass_rel")]) if generic else 0.0
    model = predict.system().model
    if space.family == "added_mass":
        wood_g = 1e3 * float(coverage(model.node_x_m, x0, x1) @ element_masses_kg(model))
        amp = [max(alpha, 0.01) * wood_g]
    elif space.family == "diameter_loss":
        d_m = float(np.mean(space.profile.diameter_at(np.linspace(x0, x1, 9))))
        amp = [max(-alpha, 0.005) * d_m / 2 / IN_TO_M]
    else:
        amp = [alpha, float(x[other_space.index("stiffness_rel")]) if generic else 0.0]
    return np.concatenate([x[:N_NULL], space.seed(start_in, ell_in, amp)])
