"""The re-test's caliper profile joined with the vibration test's verdict.

``with_calipers`` is the one call (``run.inspect`` makes it when a re-test profile is given):
it compares the survey with the registered profile (``calipers.compare_profiles``) and joins
what the calipers read with the modal verdict (``join_calipers``):

- **a removal the calipers measured** beyond noise and ovality, off the handle, over less
  than ``MOST_OF_BAT`` of the surveyed length, makes the bat altered: it is a measurement,
  not an inference. Its finding is ``material_removed``, rule "flat-surfaced" (shaving, a
  flat) or "grooved" (rings), with the calipers' reading (diameter lost, wood removed, a
  flat's normal, rings and their depth) and standard uncertainties; the reasons say what the
  calipers read, then the vibration test's own reasons. A vibration verdict of another kind
  (a core, nails, a coat) keeps its finding and gains the calipers' line;
- **a loss within 18 in of the knob** (``HANDLE_ZONE_IN``) is what a grip substance cleaned
  off since registration leaves: said, not an alteration;
- **a loss along most of the bat** is not shaving (4-14 in): another bat's profile or a
  caliper zeroed wrong; said, and the verdict is left to the vibration test;
- **no removal the scan finds, but the vibration test reads one** (its finding
  ``material_removed``, whatever its status): the survey is asked about that stretch alone
  (``compare_profiles``' ``region_m``, a bound over the patterns only, at the same level). Read
  there, it is the calipers' removal above, and the bat is altered: two independent measurements
  read it in the same place, and the survey alone passes the check on an unaltered bat at most
  ``CALIPER_FALSE_ALARM`` of the time;
- **no removal**: the vibration verdict stands, and its reasons gain what the survey cannot
  see (flats between its orientations, grooves between its stations) and what would measure
  it -- never as evidence of a clean barrel.
"""

from __future__ import annotations

from dataclasses import replace

from updating.inspect.calipers.compare import CaliperResult, compare_profiles
from updating.inspect.calipers.reading import CaliperChange
from updating.inspect.finding import Finding, found
from updating.inspect.kind_table import HANDLE_SLACK_IN, RULE_MAX_HANDLE_IN, kind
from updating.inspect.verdict import Verdict
from updating.model.calipers import CaliperSurvey
from updating.model.profile import Profile
from updating.model.units import IN_TO_M

HANDLE_ZONE_IN = RULE_MAX_HANDLE_IN + HANDLE_SLACK_IN
"""A loss ending this close to the knob is on the handle (Rule 3.02(c)'s 18 in)."""
MOST_OF_BAT = 0.5
"""A loss over more than this share of the surveyed length is not shaving (4-14 in)."""


def _in(x_m: float) -> str:
    return f"{x_m / IN_TO_M:.1f}"


def describe_change(c: CaliperChange) -> str:
    """Say what the calipers read, in the lab's units (1 sigma after +-)."""
    where = f"{_in(c.region_m[0])}-{_in(c.region_m[1])} in from the knob end"
    grams = f"about {1e3 * c.removed_mass_kg:.1f} +- {1e3 * c.removed_mass_sd_kg:.1f} g of wood"
    lost = f"{c.diameter_lost_m / IN_TO_M:.3f} +- {c.diameter_lost_sd_m / IN_TO_M:.3f} in"
    if c.kind == "shaved":
        return f"the barrel turned down by {lost} at every orientation read, {where}, {grams}"
    if c.kind == "flat":
        return (f"a flat {lost} deep at {where}, its normal at {c.flat_angle_deg:.0f} +- "
                f"{c.flat_angle_sd_deg:.0f} deg from the marked grain plane, {grams}")
    rings = ", ".join(_in(x) for x in c.groove_x_m)
    n = len(c.groove_x_m)
    return (f"{n} ring{'s' if n > 1 else ''} cut {c.diameter_lost_m / 2 / IN_TO_M:.3f} +- "
            f"{c.diameter_lost_sd_m / 2 / IN_TO_M:.3f} in deep ({lost} of diameter) at the "
            f"stations {rings} in from the knob end, {grams}")


def caliper_finding(c: CaliperChange) -> Finding:
    """Return a caliper change as the contract's finding (``material_removed``).

    Rule "grooved" for rings, "flat-surfaced" for shaving and a flat; reading and
    uncertainty (1 sigma) SI: ``diameter_lost_m``, ``removed_mass_kg``, a flat's
    ``flat_angle_deg``, rings' ``n_grooves`` and ``groove_depth_m``, ``region_start_m``.
    """
    reading = {"diameter_lost_m": c.diameter_lost_m, "removed_mass_kg": c.removed_mass_kg}
    unc = {"diameter_lost_m": c.diameter_lost_sd_m, "removed_mass_kg": c.removed_mass_sd_kg,
           "region_start_m": c.region_start_sd_m}
    if c.kind == "flat":
        reading["flat_angle_deg"] = c.flat_angle_deg
        unc["flat_angle_deg"] = c.flat_angle_sd_deg
    if c.kind == "grooves":
        reading.update(n_grooves=len(c.groove_x_m), groove_depth_m=c.diameter_lost_m / 2)
        unc["groove_depth_m"] = c.diameter_lost_sd_m / 2
    return found(kind("grooved" if c.kind == "grooves" else "flat-surfaced"), c.region_m,
                 reading, unc, "calipers")


def _on_handle(c: CaliperChange) -> bool:
    return c.region_m[1] <= HANDLE_ZONE_IN * IN_TO_M


def _most_of_bat(c: CaliperChange, r: CaliperResult) -> bool:
    surveyed = r.surveyed_m[1] - r.surveyed_m[0]
    return c.region_m[1] - c.region_m[0] > MOST_OF_BAT * surveyed


def _measured(r: CaliperResult) -> str:
    return (f"beyond caliper noise ({r.null.sigma_retest_m / IN_TO_M:.4f} in) and a round "
            f"bat's ovality (z {max(c.statistic for c in r.changes):.1f} against "
            f"{r.critical:.1f}: an unaltered bat's survey reads so at most {r.false_alarm:g} "
            "of the time)")


def _confirmed(r: CaliperResult) -> str:
    c = r.region_check
    return (f"beyond caliper noise ({r.null.sigma_retest_m / IN_TO_M:.4f} in) and a round "
            f"bat's ovality where the vibration test reads a removal ({_in(c.region_m[0])}-"
            f"{_in(c.region_m[1])} in; z {c.statistic:.1f} against {c.critical:.1f} for that "
            f"one stretch, an unaltered bat's survey reads so there at most {c.false_alarm:g} "
            f"of the time; below the whole survey's scan bound, z {r.statistic:.1f} against "
            f"{r.critical:.1f})")


def _blind(r: CaliperResult) -> str:
    return "; ".join(r.unseen)


def _removals(r: CaliperResult) -> list[CaliperChange]:
    """Return the changes found that may be alterations (off the handle, not most of the bat)."""
    return [c for c in r.changes if not _on_handle(c) and not _most_of_bat(c, r)]


def _side_notes(r: CaliperResult) -> list[str]:
    """Lines for the losses that are not alterations (handle, most of the bat)."""
    out = []
    for c in r.changes:
        if _most_of_bat(c, r):
            out.append(f"the caliper profile reads {describe_change(c)}: along most of the "
                       "bat that is no shaving (4-14 in) but another bat's profile or a "
                       "caliper zeroed wrong: check the caliper and that the profile is this "
                       "bat's")
        elif _on_handle(c):
            out.append(f"the caliper profile reads {describe_change(c)}: on the handle, "
                       "within 18 in of the knob, as a grip substance cleaned off since "
                       "registration leaves it; not an alteration")
    return out


def join_calipers(verdict: Verdict, result: CaliperResult | None) -> Verdict:
    """Join the caliper survey's reading with the vibration test's verdict (module docstring).

    Parameters
    ----------
    verdict : Verdict
        The vibration test's verdict.
    result : CaliperResult or None
        The re-test profile's comparison (None: no re-test profile; ``verdict`` returned).

    Returns
    -------
    Verdict
        The joined verdict, ``calipers`` set to ``result``.
    """
    if result is None:
        return verdict
    removals = _removals(result)
    notes = _side_notes(result)
    modal = [f"vibration test: {r}" for r in verdict.reasons]
    check = result.region_check
    confirmed = not removals and check is not None and check.change is not None and \
        not _on_handle(check.change)
    if confirmed:
        removals = [check.change]
    if not removals:
        blind = (f"the re-test's caliper profile reads no removal beyond noise and ovality, "
                 f"which is not evidence of a clean barrel: {_blind(result)}")
        return replace(verdict, reasons=(*verdict.reasons, *notes, blind), calipers=result)
    main = max(removals, key=lambda c: c.removed_mass_kg)
    read = [f"the re-test's caliper profile measures {describe_change(c)}" for c in removals]
    read[0] += (f", {_confirmed(result) if confirmed else _measured(result)}: a measurement, "
                "not an inference")
    kind = verdict.finding.kind if verdict.finding is not None else None
    if verdict.altered and kind not in (None, "material_removed"):
        return replace(verdict, reasons=(*verdict.reasons, *read, *notes), calipers=result)
    finding = caliper_finding(main)
    uncertainty = {**{k: v for k, v in verdict.uncertainty.items()
                      if k in ("stiffness_scale", "density_scale", "sensor_shift_m")},
                   **finding.uncertainty}
    return replace(verdict, altered=True, region_m=finding.region_m, core_diameter_m=None,
                   fill_density_ratio=None, uncertainty=uncertainty, finding=finding,
                   reasons=(*read, *notes, *modal), calipers=result)


def with_calipers(verdict: Verdict, profile: Profile, survey: CaliperSurvey | None,
                  rho_kg_m3: float) -> Verdict:
    """Compare the re-test's survey with the registered profile and join it to the verdict.

    Parameters
    ----------
    verdict : Verdict
        The vibration test's verdict.
    profile : Profile
        The registered profile.
    survey : CaliperSurvey or None
        The re-test's caliper profile (None: ``verdict`` returned unchanged).
    rho_kg_m3 : float
        The wood's density (the calibrated reference's), kg/m^3.

    Returns
    -------
    Verdict
        ``join_calipers`` of the verdict and ``compare_profiles``.
    """
    if survey is None:
        return verdict
    f = verdict.finding
    named = f is not None and f.family != "calipers" and f.kind == kind("flat-surfaced").finding
    region = f.region_m if named else None
    return join_calipers(verdict, compare_profiles(profile, survey, rho_kg_m3, region_m=region))
