"""Verdicts in words for a terminal.

Verdicts in words for a terminal: shared by `inspect`, `demo` and `history`, so commands do
not import each other. The stored record's evidence is read through its type
(``updating.inspect.details.InspectionDetails.from_json_dict``).
"""

from __future__ import annotations

import math

from updating.inspect.details import InspectionDetails


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


def chance_words(p: float) -> str:
    """How often, in words a non-specialist reads correctly ("in about 97 of 100 re-tests")."""
    if p < 0.001:
        return "in fewer than 1 of 1,000 re-tests"
    if p < 0.01:
        return f"in about {round(p * 1000)} of 1,000 re-tests"
    return f"in about {round(p * 100)} of 100 re-tests"


def p_value_words(verdict: dict) -> str | None:
    """Say a p-value in words.

    "p = 0.925: an unaltered bat differs this much in about 92 of 100 re-tests" (a
    confidence of 0.075 is not "7.5 % sure").
    """
    p = p_value(verdict)
    if p is None:
        return None
    return f"p = {p:.3g}: an unaltered bat differs this much {chance_words(p)}"


def readable(out: dict) -> str:
    """Write the contract dict as a short verdict for a person."""
    status = status_of(out)
    lines = [f"{out['serial']}: {STATUS_WORDS.get(status, status)}"]
    for reason in out.get("reasons") or []:
        lines.append(f"  reason: {reason}")
    chance = p_value_words(out)
    if chance:
        fa = out.get("false_alarm_rate")
        lines.append(f"  {chance}" + (f" (called altered below p = {fa:g})" if fa else ""))
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
