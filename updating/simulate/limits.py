"""Detection limits per kind: the smallest change found on 90 % of the bats that size or larger.

Each altered bat's change is measured in its kind's own currency (``change_size``): cores by
the volume bored, pi/4 d^2 (end - start) in in^3; nails by the net grams of steel (the
steel less the wood of its pilot holes); wax by its grams; shaved, flattened and grooved
barrels by the grams of wood removed (with the diameter lost beside it). ``found_from``
reads, from the bats' sizes and whether a method found them, the smallest size from which
a method finds at least 90 % of the bats; ``limits_rows`` and ``limits_table`` put batlab
(with and without retest.json, and with the re-test's caliper profile and retest.json) beside
a scale and a scale with the balance point
(``updating.simulate.lab_methods``) judged on the same bats. Clean and legal kinds give
their false alarms instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from updating.simulate.lab_methods import lab_verdicts
from updating.simulate.rulebook import SIZE

PROFILE = "with re-test profile"
"""The method that inspects with retest.json and the re-test's caliper profile."""
METHODS = ("with retest.json", "without retest.json", PROFILE, "scale", "scale+balance")
"""The methods, in the table's order."""
RATE = 0.9
MIN_BATS = 3
@dataclass(frozen=True)
class MethodCount:
    """How often one method called one kind's bats altered.

    Attributes
    ----------
    found : int
        Bats called altered.
    bats : int
        Bats the method judged.
    from_size : float or None
        ``found_from`` of the method (None for a clean kind, or when no size qualifies).
    """

    found: int
    bats: int
    from_size: float | None


@dataclass(frozen=True)
class KindLimits:
    """One kind's line of the limits table.

    Attributes
    ----------
    kind : str
        The kind.
    altered : bool
        Whether its bats are altered (False: the counts are false alarms).
    bats : int
        Distinct bats (kind, seed).
    unit : str
        The size's unit ("" for a clean kind).
    size_range : tuple of float or None
        Smallest and largest size, in ``unit``.
    detail : str
        The ranges of the kind's other numbers (core diameter and length, diameter lost, ...).
    counts : dict of str to MethodCount
        Per method of ``METHODS``.
    """

    kind: str
    altered: bool
    bats: int
    unit: str
    size_range: tuple[float, float] | None
    detail: str
    counts: dict[str, MethodCount]


def change_size(truth: dict) -> tuple[float, str] | None:
    """Measure an altered bat's change in its kind's currency.

    Cores: V = pi/4 d^2 (x1 - x0), in^3, with d the core diameter and [x0, x1] the region;
    nails: net grams of steel; wax: grams; shaved, flattened, grooved: grams of wood removed.

    Parameters
    ----------
    truth : dict
        A case's truth (``updating.simulate.field_fleet.draw_case``).

    Returns
    -------
    tuple of (float, str) or None
        The size and its unit; None for a clean bat or a legal (or merely unclean) grip.
    """
    if not truth.get("altered"):
        return None
    finding = truth.get("finding")
    if finding is not None:
        key, unit = SIZE[truth["kind"]]
        return float(finding["reading"][key]), unit
    return core_volume_in3(truth), "in^3"


def core_volume_in3(truth: dict) -> float:
    """Return a core's volume, in^3: pi / 4 d^2 times its length (``core_dimensions_in``)."""
    d_in, length_in = core_dimensions_in(truth)
    return float(np.pi / 4 * d_in**2 * length_in)


def core_dimensions_in(truth: dict) -> tuple[float, float]:
    """Return a core's diameter and length, in, from its truth's core_diameter_in and region_in."""
    start_in, end_in = truth["region_in"]
    return float(truth["core_diameter_in"]), float(end_in - start_in)


def change_details(truth: dict) -> dict[str, float]:
    """Return an altered bat's other numbers beside its size.

    Parameters
    ----------
    truth : dict
        A case's truth with an alteration.

    Returns
    -------
    dict of str to float
        Cores: d_in, length_in; shaved and flattened: diameter_lost_in, length_in; grooved:
        diameter_lost_in; nails: steel_g (the steel's whole mass); wax: none.
    """
    finding = truth.get("finding")
    if finding is None:
        return dict(zip(("d_in", "length_in"), core_dimensions_in(truth), strict=True))
    reading = finding["reading"]
    out = {k: float(reading[k]) for k in ("diameter_lost_in", "length_in") if k in reading}
    if truth["kind"] == "nails":
        out["steel_g"] = float(reading["added_mass_g"])
    return out


def found_from(sizes, found, rate: float = RATE, min_bats: int = MIN_BATS) -> float | None:
    """Find the smallest size from which a method finds at least ``rate`` of the bats.

    The smallest s among ``sizes`` such that, of the bats of size >= s, at least ``min_bats``
    are there and a fraction of at least ``rate`` were found.

    Parameters
    ----------
    sizes : array_like of float
        Each bat's change size.
    found : array_like of bool
        Whether the method found each bat.
    rate : float
        The fraction to reach.
    min_bats : int
        Fewest bats of that size or larger to trust the fraction.

    Returns
    -------
    float or None
        The size, None when no size qualifies.
    """
    s, f = np.asarray(sizes, float), np.asarray(found, bool)
    order = np.argsort(s, kind="stable")
    s, f = s[order], f[order]
    start = np.searchsorted(s, s, side="left")
    n_tail = s.size - start
    k_tail = np.cumsum(f[::-1])[::-1][start] if s.size else np.zeros(0)
    ok = (n_tail >= min_bats) & (k_tail >= rate * n_tail - 1e-9)
    return float(s[ok][0]) if ok.any() else None


def pair_bats(rows: list[dict]) -> dict[tuple, dict]:
    """Gather result rows by bat, (kind, seed): its truth and its status per way inspected.

    Rows without a truth (the benchmark failed on that bat) are left out. A row with
    ``with_profile`` true was inspected with the re-test's caliper profile (and retest.json).

    Parameters
    ----------
    rows : list of dict
        The benchmark's rows (``updating.simulate.scoring.verdict_row`` plus seed, with_meta).

    Returns
    -------
    dict
        (kind, seed) to {"kind", "truth", True: status with retest.json, False: without,
        ``PROFILE``: with the re-test profile}.
    """
    bats: dict[tuple, dict] = {}
    for r in rows:
        if r.get("truth") is None:
            continue
        key = (r["kind"], r.get("seed", r.get("serial")))
        bat = bats.setdefault(key, {"kind": r["kind"], "truth": r["truth"]})
        way = PROFILE if r.get("with_profile") else bool(r.get("with_meta", True))
        bat[way] = r["status"]
    return bats


def _calls(bats: list[dict], balance_limit_in: float) -> dict[str, tuple[list[int], list[bool]]]:
    """Return, per method, the indices of the bats it judged and whether it called them altered."""
    lab = [lab_verdicts(b["truth"], balance_limit_in) for b in bats]
    calls = {}
    for name, way in (("with retest.json", True), ("without retest.json", False),
                      (PROFILE, PROFILE)):
        idx = [i for i, b in enumerate(bats) if way in b]
        calls[name] = (idx, [bats[i][way] == "altered" for i in idx])
    for name in ("scale", "scale+balance"):
        calls[name] = (list(range(len(bats))), [v[name] for v in lab])
    return calls


def _detail(details: list[dict[str, float]]) -> str:
    """Return the ranges of the bats' other numbers, "d 0.5-1 in, length 3-9 in"."""
    names = {"d_in": ("d", "in"), "length_in": ("length", "in"),
             "diameter_lost_in": ("diameter lost", "in"), "steel_g": ("steel", "g")}
    parts = []
    for key, (name, unit) in names.items():
        vals = [d[key] for d in details if key in d]
        if vals:
            parts.append(f"{name} {min(vals):.3g}-{max(vals):.3g} {unit}")
    return ", ".join(parts)


def kind_limits(kind: str, bats: list[dict], balance_limit_in: float) -> KindLimits:
    """Count one kind's bats per method, with each method's ``found_from`` when altered.

    Parameters
    ----------
    kind : str
        The kind.
    bats : list of dict
        Its bats (``pair_bats`` values).
    balance_limit_in : float
        The balance-point limit of the scale + balance point, in.

    Returns
    -------
    KindLimits
        The kind's line.
    """
    sized = [change_size(b["truth"]) for b in bats]
    altered = all(s is not None for s in sized)
    sizes = np.array([s[0] for s in sized]) if altered else np.zeros(len(bats))
    counts = {}
    for name, (idx, hit) in _calls(bats, balance_limit_in).items():
        limit = found_from(sizes[idx], hit) if altered else None
        counts[name] = MethodCount(int(sum(hit)), len(idx), limit)
    if not altered:
        return KindLimits(kind, False, len(bats), "", None, "", counts)
    details = _detail([change_details(b["truth"]) for b in bats])
    return KindLimits(kind, True, len(bats), sized[0][1],
                      (float(sizes.min()), float(sizes.max())), details, counts)


def limits_rows(rows: list[dict], balance_limit_in: float) -> list[KindLimits]:
    """Summarise a benchmark's rows per kind, in the order the kinds first appear.

    Parameters
    ----------
    rows : list of dict
        The benchmark's rows; a bat's rows with and without retest.json share (kind, seed).
    balance_limit_in : float
        The balance-point limit of the scale + balance point, in
        (``updating.simulate.lab_methods.clean_balance_limit_in``).

    Returns
    -------
    list of KindLimits
        One per kind.
    """
    by_kind: dict[str, list[dict]] = {}
    for bat in pair_bats(rows).values():
        by_kind.setdefault(bat["kind"], []).append(bat)
    return [kind_limits(kind, bats, balance_limit_in) for kind, bats in by_kind.items()]


def _line(k: KindLimits) -> str:
    """Return one kind's markdown line."""
    counts = [f"{c.found}/{c.bats}" if c.bats else "-" for c in k.counts.values()]
    if not k.altered:
        what, limits = "false alarms (called altered)", ["-"] * len(METHODS)
    else:
        lo, hi = k.size_range
        what = f"{lo:.3g}-{hi:.3g} {k.unit}" + (f" ({k.detail})" if k.detail else "")
        limits = ["-" if c.from_size is None else f"{c.from_size:.3g} {k.unit}"
                  for c in k.counts.values()]
    return f"| {k.kind} | {k.bats} | {what} | " + " | ".join(counts + limits) + " |"


def limits_table(rows: list[dict], balance_limit_in: float) -> str:
    """Tabulate the detection limits per kind (markdown).

    Per kind: bats, the size range with its unit, found k/n with retest.json, without it,
    with the re-test's caliper profile, by the scale, by the scale and balance point, and for
    each the size from which
    90 % of the bats were found (``found_from``, at least 3 bats); a clean or legal kind's
    counts are its false alarms.

    Parameters
    ----------
    rows : list of dict
        The benchmark's rows (``limits_rows``).
    balance_limit_in : float
        The balance-point limit, in.

    Returns
    -------
    str
        The table, with a line saying the balance limit.
    """
    head = " | ".join(f"found {m}" for m in METHODS)
    head_from = " | ".join(f"{100 * RATE:.0f} % found from: {m}" for m in METHODS)
    lines = [f"| kind | bats | size | {head} | {head_from} |",
             "|---" * (3 + 2 * len(METHODS)) + "|"]
    lines += [_line(k) for k in limits_rows(rows, balance_limit_in)]
    lines.append(f"\nscale + balance point: balance limit {balance_limit_in:.3f} in; "
                 f"found from: the smallest size s with >= {100 * RATE:.0f} % of the bats of "
                 f"size >= s found (at least {MIN_BATS} of them).")
    return "\n".join(lines)
