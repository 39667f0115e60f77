"""Verdicts in words for a terminal.

Verdicts in words for a terminal: shared by `inspect`, `demo` and `history`, so commands do
not import each other. The stored record's evidence is read through its type
(``updating.inspect.details.InspectionDetails.from_json_dict``).
"""

from __future__ import annotations

import math

from updating.inspect.details import InspectionDetails
from updating.inspect.words import chance, percent


def status_of(verdict: dict) -> str:
    """Return a stored verdict's status.

    "altered", "not_altered" or "inconclusive": the verdict's own ``status``, else derived
    from ``altered`` (true/false/null).
    """
    if verdict.get("status"):
        return str(verdict["status"])
    altered = verdict.get("altered")
    return "inconclusive" if altered is None else ("altered" if altered else "not_altered")


STATUS_WORDS = {"altered": "ALTERED", "not_altered": "not altered",
                "inconclusive": "INCONCLUSIVE (no verdict)"}


def p_value(verdict: dict) -> float | None:
    """Return the p-value of a stored verdict.

    The chance that an unaltered bat differs at least this much from its baseline: the
    verdict's ``details.p_value``, else 1 - ``confidence`` (None when it has neither).
    """
    p = InspectionDetails.from_json_dict(verdict.get("details")).p_value
    if p is not None and math.isnan(p):  # stored as null: not computed
        p = None
    if p is None and verdict.get("confidence") is not None:
        p = 1.0 - float(verdict["confidence"])
    return None if p is None else min(max(float(p), 0.0), 1.0)


def p_value_words(verdict: dict) -> str | None:
    """Say a stored verdict's p-value in the one wording (``updating.inspect.words.chance``).

    "chance an unaltered bat differs this much: 92 %" (a confidence of 0.075 is not
    "7.5 % sure"); None when the verdict has none.
    """
    p = p_value(verdict)
    return None if p is None else chance(p)


def readable(out: dict) -> str:
    """Write the contract dict as a short verdict for a person."""
    status = status_of(out)
    lines = [f"{out['serial']}: {STATUS_WORDS.get(status, status)}"]
    for reason in out.get("reasons") or []:
        lines.append(f"  reason: {reason}")
    said = p_value_words(out)
    if said:
        fa = out.get("false_alarm_rate")
        lines.append(f"  {said}" + (f" (called altered below {percent(fa)})" if fa else ""))
    words = finding_words(out.get("finding"))
    if words:
        lines.append(f"  finding: {words}")
    if status == "altered":
        if out.get("region_in"):
            a, b = out["region_in"]
            lines.append(f"  altered region {a:.1f} to {b:.1f} in from the knob end")
        if out.get("core_diameter_in") is not None:
            lines.append(f"  bore diameter {out['core_diameter_in']:.2f} in")
        if out.get("fill_density_ratio") is not None:
            lines.append(f"  fill density / wood density {out['fill_density_ratio']:.2f}")
    els = out.get("elements") or []
    if any(e["alpha"] or e["beta"] for e in els):
        big = max(els, key=lambda e: abs(e["alpha"]) + abs(e["beta"]))
        lines.append(f"  {len(els)} elements; largest change at {big['x0_in']:.1f}-"
                     f"{big['x1_in']:.1f} in: alpha {big['alpha']:+.4f}, beta {big['beta']:+.4f}")
    return "\n".join(lines)


def finding_words(finding: dict | None, length_in: float | None = None) -> str | None:
    """Say a finding in the rule's words: "nailed: about 18 g of metal in 29.2-32.5 in ...".

    Parameters
    ----------
    finding : dict or None
        The contract's ``finding`` (inches, grams).
    length_in : float or None
        The bat's length, to say "the last N in of the barrel" when the finding reaches the
        barrel end.

    Returns
    -------
    str or None
        One clause, None when nothing was found.
    """
    if not finding:
        return None
    a, b = finding["region_in"]
    r = finding.get("reading") or {}
    where = f"{a:.1f}-{b:.1f} in from the knob end"
    if length_in is not None and length_in - b < 1.5 and finding["kind"] != "handle_substance":
        where = f"the last {length_in - a:.0f} in of the barrel ({a:.1f}-{b:.1f} in)"
    kind, rule = finding["kind"], finding["rule"]
    if kind == "core":
        fill = r.get("fill_density_ratio")
        what = (f"a bore about {r.get('core_diameter_in', float('nan')):.2f} in across and "
                f"{b - a:.1f} in long")
        if fill is not None:
            what += (", left hollow" if fill < 0.05 else
                     f", filled with material about {fill:.2f} times as dense as the wood")
        return f"{rule}: {what}, in {where}"
    if kind == "inserted_mass":
        return f"{rule}: about {r.get('added_mass_g', 0):.0f} g of metal in {where}"
    if kind == "surface_coating":
        return f"{rule}: about {r.get('added_mass_g', 0):.0f} g of a substance over {where}"
    if kind == "material_removed":
        return (f"{rule}: about {r.get('diameter_lost_in', 0):.3f} in of the diameter removed "
                f"along {b - a:.1f} in, {where}")
    if kind == "handle_substance":
        text = f"about {r.get('added_mass_g', 0):.0f} g added on the handle, {a:.0f}-{b:.0f} in"
        if finding.get("legal"):
            return text + ": grip substance, legal under Rule 3.02(c)"
        return text + ": a grip substance past 18 in; the bat must be cleaned before play"
    return f"a local change no alteration explains, over {where}"
