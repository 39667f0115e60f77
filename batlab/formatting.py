"""Verdicts in words for a terminal.

Verdicts in words for a terminal: shared by `inspect`, `demo` and `history`, so commands do
not import each other. The stored record's evidence is read through its type
(``updating.inspect.details.InspectionDetails.from_json_dict``).
"""

from __future__ import annotations

import math

from updating.inspect.details import InspectionDetails
from updating.inspect.kind_table import UNEXPLAINED, kind, kind_of, say_parts
from updating.inspect.words import CHANCE, chance, percent


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
    """Say a stored verdict's chance in the one wording (``chance_words`` of ``stated_chance``).

    "chance an unaltered bat differs this much: ..." as measured on the bat model's
    calibration, or said unmeasured (a confidence of 0.075 is a 92 % chance, not "7.5 %
    sure"); None when the verdict has none.
    """
    return chance_words(stated_chance(verdict))


def stated_chance(verdict: dict) -> dict | None:
    """Return a verdict's ``chance`` (a record stored before it existed: nominal, from its p)."""
    if isinstance(verdict.get("chance"), dict):
        return verdict["chance"]
    p = p_value(verdict)
    return None if p is None else {"value": p, "source": "nominal", "calibration": None,
                                   "nominal": p, "model": None,
                                   "unmeasured": "judged before batlab measured chances"}


def share(p: float) -> str:
    """Write a measured probability: "2.3 %", "0.033 %" (two digits), "over 99 %"."""
    return "over 99 %" if p > 0.99 else f"{100 * p:.2g} %"


def chance_words(ch: dict | None) -> str | None:
    """Say the chance an unaltered bat differs this much, with where it was measured.

    Measured: "...: 0.23 % as measured on 3,000 clean re-tests of bat model M, 6 of which
    differed at least as much"; beyond them: "below 1 in 3,001 ..., none of which differed
    as much" (and a tail fit's extrapolation, named as one); without a calibration:
    "...: unmeasured, WHY; the F distribution's nominal 4.2 % is not a measured rate".

    Parameters
    ----------
    ch : dict or None
        The verdict's ``chance`` (``batlab.pipeline.chance.statement``).

    Returns
    -------
    str or None
        One clause; None when the verdict has no chance (no test was made).
    """
    if not ch or ch.get("value") is None:
        return None
    cal = ch.get("calibration")
    if ch.get("source") == "calibration" and cal:
        n, b = int(cal["n"]), cal.get("exceeding")
        where = f"as measured on {n:,} clean re-tests of bat model {cal['model']}"
        if not b:
            text = (f"{CHANCE}: below 1 in {n + 1:,} {where}, none of which differed as "
                    "much")
            if ch.get("extrapolated") is not None:
                text += (f"; beyond that range a generalized-Pareto tail fit extrapolates "
                         f"{ch['extrapolated']:.1g} (an extrapolation, not a measurement)")
        else:
            text = (f"{CHANCE}: {share(float(ch['value']))} {where}, {b:,} of which differed "
                    "at least as much")
        if ch.get("decided_on") == "nominal" and ch.get("nominal") is not None:
            text += (f"; decided on the F distribution's nominal {percent(float(ch['nominal']))}"
                     f": {n:,} re-tests are too few to measure a chance as small as the "
                     "decision's level")
        return text
    text = f"{CHANCE}: unmeasured, {ch.get('unmeasured') or 'no calibration'}"
    if ch.get("nominal") is not None:
        text += (f"; the F distribution's nominal {percent(float(ch['nominal']))} is not a "
                 "measured rate")
    return text


def false_alarm_words(fa) -> str | None:
    """Say a verdict's false-alarm rate: measured (k of n, its 95 % bound) or unmeasured.

    Parameters
    ----------
    fa : dict or float or None
        The verdict's ``false_alarm_rate`` (a record stored before it was measured holds the
        decision's level, a number).

    Returns
    -------
    str or None
        One clause.
    """
    if fa is None:
        return None
    if not isinstance(fa, dict):
        return (f"called altered below a nominal {percent(float(fa))} (false-alarm rate "
                "unmeasured)")
    if fa.get("level") is None:
        level = ""
    elif fa.get("decided_on") == "calibration":
        level = (f"; called altered below a chance of {percent(float(fa['level']))} as "
                 "measured on the calibration")
    else:
        level = f"; called altered below the F test's nominal {percent(float(fa['level']))}"
    if fa.get("source") == "calibration":
        k, n = int(fa["false_alarms"]), int(fa["n"])
        seen = "none" if k == 0 else f"{k:,} ({share(k / n)})"
        return (f"false-alarm rate measured on bat model {fa.get('model')}: {seen} of {n:,} "
                f"clean re-tests called altered, below {share(float(fa['upper95']))} (95 % "
                f"Clopper-Pearson bound){level}")
    return f"false-alarm rate unmeasured ({fa.get('unmeasured') or 'no calibration'}){level}"


def decision_level(verdict: dict) -> float | None:
    """Return the decision's level (its nominal false-alarm rate) from any stored verdict."""
    fa = verdict.get("false_alarm_rate")
    if isinstance(fa, dict):
        fa = fa.get("level")
    return None if fa is None else float(fa)


def reasons_with_chance(reasons: list[str], nominal: float | None,
                        ch: dict | None) -> list[str]:
    """State the chance in the reasons as ``chance`` does.

    The decision words its reasons with the F distribution's p-value
    (``updating.inspect.words.chance``); each such clause becomes ``chance_words(ch)``, and
    when no reason held one, that clause is a reason of its own. Reasons without a chance
    (no test was made) are kept as they are.

    Parameters
    ----------
    reasons : list of str
        The decision's reasons.
    nominal : float or None
        The p-value they were worded with.
    ch : dict or None
        The verdict's ``chance``.

    Returns
    -------
    list of str
        The reasons.
    """
    said = chance_words(ch)
    if said is None:
        return list(reasons)
    old = None if nominal is None else chance(nominal)
    out = [r.replace(old, said) if old else r for r in reasons]
    return out if out != list(reasons) else [*out, said]


def readable(out: dict) -> str:
    """Write the contract dict as a short verdict for a person."""
    status = status_of(out)
    lines = [f"{out['serial']}: {STATUS_WORDS.get(status, status)}"]
    for reason in out.get("reasons") or []:
        lines.append(f"  reason: {reason}")
    said = p_value_words(out)
    if said:
        if not any(said in str(r) for r in out.get("reasons") or []):  # said once
            lines.append(f"  {said}")
        rate = false_alarm_words(out.get("false_alarm_rate"))
        if rate:
            lines.append(f"  {rate}")
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
    if out.get("code"):
        lines.append(f"  judged by batlab {out['code']}")
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
        One clause, None when nothing was found: its kind's words
        (``updating.inspect.kind_table.Kind.words``).
    """
    if not finding:
        return None
    a, b = finding["region_in"]
    k = kind_of(finding["kind"], finding.get("rule")) or kind(UNEXPLAINED)
    where = f"{a:.1f}-{b:.1f} in from the knob end"
    if length_in is not None and length_in - b < 1.5 and k.alteration:
        where = f"the last {length_in - a:.0f} in of the barrel ({a:.1f}-{b:.1f} in)"
    return say_parts(k.words, {**(finding.get("reading") or {}), "rule": finding["rule"],
                               "where": where, "a": a, "b": b, "length_in": b - a})


def gum(value: float, u: float | None, unit_decimals: int = 3) -> str:
    """Write a value with its standard uncertainty as the GUM asks: "1.003 ± 0.012".

    The uncertainty to two significant digits and the value to the same decimal place
    (JCGM 100:2008, 7.2.6); without an uncertainty (or a zero one), the value to
    ``unit_decimals`` decimals.
    """
    if u is None or not math.isfinite(u) or u <= 0:
        return f"{value:.{unit_decimals}f}"
    decimals = 1 - math.floor(math.log10(u))
    if round(u, decimals) >= 10 ** (2 - decimals):  # 0.0996 rounds to 0.100: two digits
        decimals -= 1
    shown = max(decimals, 0)
    return f"{round(value, decimals):,.{shown}f} ± {round(u, decimals):,.{shown}f}"


def significant(value: float, digits: int = 3) -> str:
    """Write a value to ``digits`` significant digits, with thousands separators."""
    if value == 0 or not math.isfinite(value):
        return f"{value:g}"
    decimals = digits - 1 - math.floor(math.log10(abs(value)))
    return f"{round(value, decimals):,.{max(decimals, 0)}f}"
