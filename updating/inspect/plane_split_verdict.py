"""The flat the bending planes' splits read, joined with the verdict (issue 38).

``with_plane_split`` is the one call (``run.inspect`` makes it after the calipers'): it reads
the change of the resolved pairs' splits (``plane_split.read_plane_split``) and joins it
conservatively, since the splits' null (how far the planes' E/G may move apart on an
unaltered bat, ``plane_split.RATIO_DRIFT``) is stated, not measured on real bats:

- **a flat read** adds its reading to the reasons of any verdict (beside a flat the calipers
  measured, whether it agrees with it); alone it makes a not-altered verdict at most
  **inconclusive** (a flat suspected: measure the re-test's profile), never altered;
- **no flat read**: the reasons of a verdict that is not altered say what the splits cannot
  tell (too few pairs resolved, a flat too shallow, a normal near 45 deg to the grain
  planes) and what would measure it; never evidence of a clean barrel. An altered verdict
  keeps its reasons (the reading is still in ``Verdict.plane_split``).
"""

from __future__ import annotations

from dataclasses import replace

from updating.correlate.measured import MeasuredModes
from updating.inspect.kind_table import kind
from updating.inspect.plane_split import LEVEL, RATIO_DRIFT, PlaneSplit, read_plane_split
from updating.inspect.verdict import Verdict
from updating.model.profile import Profile
from updating.model.reference import BatReference
from updating.model.units import IN_TO_M


def describe_split(s: PlaneSplit) -> str:
    """Say what a significant split reading reads, in the lab's units (1 sigma after +-)."""
    a, b = (x / IN_TO_M for x in s.region_m)
    where = (f"{a:.1f}-{b:.1f} in from the knob end (centre {s.centre_m / IN_TO_M:.1f} +- "
             f"{s.region_centre_sd_m / IN_TO_M:.1f} in)" if s.localised else
             f"somewhere about {a:.1f}-{b:.1f} in from the knob end (the modes do not "
             "localise it)")
    plane = "upper" if s.nearer_plane == "upper" else "lower"
    return (f"a flat at {where}, its normal within 45 deg of the {plane} member's grain "
            f"plane, at least {s.depth_m / IN_TO_M:.3f} +- {s.depth_sd_m / IN_TO_M:.3f} in "
            f"deep (that depth with its normal in the plane), from {len(s.pairs)} pairs' "
            f"splits (Delta chi^2 {s.statistic:.1f} against {s.critical:.1f}: the splits of an "
            f"unaltered bat whose planes' E/G move up to {100 * RATIO_DRIFT:.0f} % apart read "
            f"so at most {LEVEL:g} of the time)")


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return min(a[1], b[1]) > max(a[0], b[0])


def join_plane_split(verdict: Verdict, split: PlaneSplit) -> Verdict:
    """Join the splits' reading with the verdict (module docstring).

    Parameters
    ----------
    verdict : Verdict
        The verdict of the vibration test and the calipers.
    split : PlaneSplit
        The splits' reading.

    Returns
    -------
    Verdict
        The joined verdict, ``plane_split`` set to ``split``.
    """
    if not split.significant:
        notes = () if verdict.altered else split.notes
        return replace(verdict, reasons=(*verdict.reasons, *notes), plane_split=split)
    line = f"the bending planes' splits read {describe_split(split)}"
    f = verdict.finding
    if f is not None and f.kind == kind("flat-surfaced").finding and f.family == "calipers":
        agree = "agrees with" if _overlap(f.region_m, split.region_m) else "lies apart from"
        return replace(verdict, reasons=(*verdict.reasons, f"{line}; it {agree} the calipers' "
                                         "reading, which stands"), plane_split=split)
    if verdict.altered is False:
        return replace(verdict, altered=None, plane_split=split, reasons=(
            f"a flat suspected: {line}; the splits alone do not make a bat altered: measure "
            "the re-test's caliper profile (more orientations, a finer station spacing)",
            *(f"vibration test: {r}" for r in verdict.reasons)))
    return replace(verdict, reasons=(*verdict.reasons, line), plane_split=split)


def with_plane_split(verdict: Verdict, profile: Profile, reference: BatReference,
                     baseline: MeasuredModes, retest: MeasuredModes) -> Verdict:
    """Read the splits' change (``read_plane_split``) and join it with the verdict.

    Parameters
    ----------
    verdict : Verdict
        The verdict of the vibration test and the calipers.
    profile : Profile
        The bat's outer profile.
    reference : BatReference
        Its reference calibrated to the baseline.
    baseline, retest : MeasuredModes
        The two tests' fitted modes with their merged pairs' members.

    Returns
    -------
    Verdict
        ``join_plane_split`` of the verdict and the reading.
    """
    return join_plane_split(verdict, read_plane_split(profile, reference, baseline, retest))
