"""Scoring a virtual fleet's verdicts: statuses, result rows, count tables, ROC area.

The pure half of the fleet benchmarks (``batlab.fleet`` runs the bats): a verdict's status
read from the inspection's JSON, one result row per inspected bat, the per-group count
table, the false-alarm study's plan and summary, and the area under the ROC.
"""

from __future__ import annotations

import numpy as np

from updating.simulate.integrity import INTEGRITY
from updating.simulate.nuisances import NUISANCES, OPTIONAL_NUISANCES

STATUSES = ("not_altered", "inconclusive", "altered", "refused", "error")
"""Verdicts, a refusal (non-zero exit), and "error": the benchmark itself failed on that bat
(the simulation, not batlab), reported, never counted as a verdict."""


def verdict_status(out: dict | None) -> str:
    """Read the three-way verdict of an inspection's JSON output.

    Parameters
    ----------
    out : dict or None
        The JSON object `batlab inspect --json` printed; None when it refused (non-zero exit).

    Returns
    -------
    str
        ``status`` when the output has it, else "altered" / "not_altered" from ``altered``
        ("inconclusive" when that is null: older outputs); "refused" without output.
    """
    if out is None:
        return "refused"
    if "status" in out:
        return str(out["status"])
    if out.get("altered") is None:
        return "inconclusive"
    return "altered" if out["altered"] else "not_altered"


def verdict_row(out: dict | None, err: str, seconds: float, truth: dict) -> dict:
    """Make one result row: what was hidden, what came back, how long it took.

    Parameters
    ----------
    out : dict or None
        The inspection's JSON output, None on a refusal.
    err : str
        The last stderr line (the refusal's reason).
    seconds : float
        Wall time of the inspection, s.
    truth : dict
        The case's hidden truth (``FieldCase.truth``).

    Returns
    -------
    dict
        serial, kind, integrity, expected, status, confidence, seconds, error, truth, and the
        reading (region_in, core_diameter_in, fill_density_ratio, reasons) when there is output.
    """
    row = {"serial": truth.get("serial"), "kind": truth["kind"],
           "integrity": truth.get("integrity"), "expected": truth["expected"],
           "status": verdict_status(out), "confidence": None if out is None else
           out.get("confidence"), "seconds": round(seconds, 2), "error": err if out is None
           else None, "truth": truth}
    if out is not None:
        row.update(region_in=out.get("region_in"), core_diameter_in=out.get("core_diameter_in"),
                   fill_density_ratio=out.get("fill_density_ratio"),
                   reasons=out.get("reasons"))
    return row


def count_table(groups: dict[str, list[dict]]) -> str:
    """Tabulate, per group, how many bats got each status, and the median inspect time.

    Parameters
    ----------
    groups : dict of str to list of dict
        Result rows (``verdict_row``) by group name.

    Returns
    -------
    str
        A markdown table.
    """
    lines = ["| group | bats | not_altered | inconclusive | altered | refused | error | median s |",
             "|---|---|---|---|---|---|---|---|"]
    for name, rows in groups.items():
        c = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
        t = sorted(r["seconds"] for r in rows)
        med = t[len(t) // 2] if t else float("nan")
        lines.append(f"| {name} | {len(rows)} | {c['not_altered']} | {c['inconclusive']} | "
                     f"{c['altered']} | {c['refused']} | {c['error']} | {med:.1f} |")
    return "\n".join(lines)


def false_alarm_plan(n_all: int, n_alone: int, n_integrity: int, seed: int) -> list[dict]:
    """Plan the false-alarm study's unaltered bats.

    Parameters
    ----------
    n_all : int
        Bats with every nuisance at once (group "all nuisances").
    n_alone : int
        Bats per nuisance alone (groups "alone: X"), optional nuisances included.
    n_integrity : int
        Bats per data-integrity slip among all nuisances (groups "integrity: X").
    seed : int
        The study's seed; bat k's seed is ``seed * 100003 + k``.

    Returns
    -------
    list of dict
        One job per bat: group, serial, seed, nuisances, integrity.
    """
    jobs: list[dict] = []

    def add(group, nuisances, integrity, count):
        for _ in range(count):
            k = len(jobs)
            jobs.append({"group": group, "serial": f"FA-{k + 1:04d}", "seed": seed * 100003 + k,
                         "nuisances": tuple(nuisances), "integrity": integrity})

    add("all nuisances", NUISANCES, None, n_all)
    for name in NUISANCES + OPTIONAL_NUISANCES:
        add(f"alone: {name}", (name,), None, n_alone)
    for integ in INTEGRITY:
        add(f"integrity: {integ}", NUISANCES, integ, n_integrity)
    return jobs


def false_alarm_summary(rows: list[dict]) -> tuple[str, list[tuple[str, bool]]]:
    """Summarise the false-alarm study: the count table and its checks.

    The checks: no clean bat called altered, at most 5 % inconclusive among the all-nuisance
    bats, no integrity case called altered, no bat the benchmark itself failed on; and the
    inspect time (always passes).

    Parameters
    ----------
    rows : list of dict
        Result rows with their ``group``.

    Returns
    -------
    table : str
        The markdown count table by group.
    checks : list of (str, bool)
        Each check's text and whether it passed.
    """
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(r)
    clean = [r for r in rows if r["integrity"] is None]
    slips = [r for r in rows if r["integrity"] is not None]
    every = groups.get("all nuisances", [])
    fa = sum(r["status"] == "altered" for r in clean)
    inc = sum(r["status"] == "inconclusive" for r in every)
    checks = [(f"clean bats called altered: {fa}/{len(clean)} (0)", fa == 0)]
    errors = sum(r["status"] == "error" for r in rows)
    if errors:
        checks.append((f"bats the benchmark itself failed on: {errors}", False))
    if every:
        checks.append((f"inconclusive among all-nuisance bats: {inc}/{len(every)} "
                       f"({100 * inc / len(every):.0f} %, <= 5 %)", inc <= 0.05 * len(every)))
    if slips:
        bad = sum(r["status"] == "altered" for r in slips)
        checks.append((f"integrity cases called altered: {bad}/{len(slips)} (0)", bad == 0))
    t = sorted(r["seconds"] for r in rows)
    if t:
        checks.append((f"inspect time (stateless, calibration included): median "
                       f"{t[len(t) // 2]:.1f} s, max {t[-1]:.1f} s", True))
    return count_table(groups), checks


def roc_auc(clean: list[float], altered: list[float]) -> float:
    """Compute the area under the ROC of a statistic, clean against altered.

    AUC = P(altered statistic > clean statistic), ties counted half (the Mann-Whitney U
    statistic over the product of the group sizes).

    Parameters
    ----------
    clean, altered : list of float
        The statistic on the clean and on the altered re-tests.

    Returns
    -------
    float
        The area, NaN when either group is empty.
    """
    if not clean or not altered:
        return float("nan")
    c, a = np.asarray(clean, float)[:, None], np.asarray(altered, float)[None, :]
    return float(np.mean((a > c) + 0.5 * (a == c)))
