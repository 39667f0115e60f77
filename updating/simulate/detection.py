"""The detection study's re-tests and its report: batlab against the lab's methods.

Paired design: one nuisance-rich bat re-tested clean, with a cork core of every size on a
grid (diameter x filled length) and with one alteration of each further kind
(``retests``). ``detection_report`` gives the false alarms, the detection rate per grid cell
and per kind of each method (batlab, ``lab_methods``' scale and scale + balance point), the
smallest core each finds on at least 90 % of the bats and the volume from which 90 % are
found (``volume_found``: a logistic fit in log volume), batlab's readings against the targets
and the ROC areas; ``lab_only_report`` the lab's methods alone on further bats.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from updating.model.units import IN_TO_M
from updating.simulate.alterations import draw_alteration, end_bored
from updating.simulate.field_fleet import FieldCase, alter_case, draw_case
from updating.simulate.lab_methods import lab_statistics, lab_verdicts
from updating.simulate.limits import core_volume_in3
from updating.simulate.nuisances import NUISANCES
from updating.simulate.scoring import roc_auc

METHODS = ("batlab", "batlab screen", "scale", "scale+balance")
"""The methods compared: batlab's verdict (``altered``), batlab's screen (``altered`` or
``inconclusive``: the bat goes to the X-ray), a scale, a scale and a balance point."""
LAB_METHODS = METHODS[2:]


def retests(case: FieldCase, grid: list[tuple[float, float]], ratio: float, kinds: list[str],
            rng: np.random.Generator) -> list[FieldCase]:
    """Make a bat's re-tests: clean, each grid core (cork), each kind (random size).

    Parameters
    ----------
    case : FieldCase
        The clean bat.
    grid : list of (float, float)
        (diameter in, filled length in) of the cork cores, behind a plug of at least 1 in.
    ratio : float
        The cork's fill density ratio.
    kinds : list of str
        Further alteration kinds (``alterations.KINDS``), one of each at a random size.
    rng : numpy.random.Generator
        The draws of the kinds' sizes and of the scale readings.

    Returns
    -------
    list of FieldCase
        ``case`` first, then the grid's cores in order, then the kinds.
    """
    L_in = case.profile.length_m / IN_TO_M
    plug = max(1.0, case.min_plug_in)
    out = [case]
    for d, length in grid:
        out.append(alter_case(case, end_bored("cork", L_in, d, length, ratio, plug), rng))
    for kind in kinds:
        out.append(alter_case(case, draw_alteration(rng, kind, L_in, case.min_plug_in), rng))
    return out


def reading_errors(row: dict) -> tuple[float, float, float] | None:
    """Compare a detected alteration's reading with the truth.

    The fill error is relative to the fill ratio (an empty hole: absolute, in percentage
    points of the wood's density).

    Parameters
    ----------
    row : dict
        A result row (``scoring.verdict_row``).

    Returns
    -------
    tuple of float or None
        (start error in, diameter error %, fill ratio error %); None when batlab gave no
        reading.
    """
    t = row["truth"]
    if row["status"] != "altered" or not row.get("region_in") or \
            row.get("core_diameter_in") is None or row.get("fill_density_ratio") is None:
        return None
    r_true = t["fill_density_ratio"]
    fill = row["fill_density_ratio"] - r_true
    return (row["region_in"][0] - t["region_in"][0],
            100 * (row["core_diameter_in"] / t["core_diameter_in"] - 1),
            100 * (fill / r_true if r_true > 0 else fill))


def reading_table(altered: list[dict]) -> str:
    """Tabulate the detected alterations' readings against the targets, per kind.

    Targets: start within 1.5 in, diameter within 15 %, fill ratio within 25 %.

    Parameters
    ----------
    altered : list of dict
        Result rows of altered re-tests.

    Returns
    -------
    str
        A markdown table.
    """
    out = ["| kind | detected with a reading | start within 1.5 in | diameter within 15 % |"
           " fill within 25 % |", "|---|---|---|---|---|"]
    for kind in sorted({r["kind"] for r in altered}):
        rs = [r for r in altered if r["kind"] == kind]
        e = [x for x in (reading_errors(r) for r in rs) if x is not None]
        a = np.abs(np.array(e)) if e else np.zeros((0, 3))
        out.append(f"| {kind} | {len(e)}/{len(rs)} | {np.sum(a[:, 0] <= 1.5)} | "
                   f"{np.sum(a[:, 1] <= 15)} | {np.sum(a[:, 2] <= 25)} |")
    return "\n".join(out)


def cell_order(name: str) -> tuple:
    """Return a sort key of grid cells: by diameter then length, other names after them.

    "0.50 x 3 in" comes before "0.50 x 10 in"; names not of that form sort alphabetically
    after every cell.
    """
    try:
        d, rest = name.split(" x ")
        return (0, float(d), float(rest.split()[0]), "")
    except ValueError:
        return (1, 0.0, 0.0, name)


def cell_name(truth: dict) -> str:
    """Name a core's grid cell: "D x L in" (diameter, filled length) from its truth."""
    a, b = truth["region_in"]
    return f"{truth['core_diameter_in']:.2f} x {b - a:.0f} in"


def _rate_table(title: str, keyfn, subset: list[dict]) -> tuple[list[str], dict]:
    """Tabulate each method's detection rate by ``keyfn``'s key (markdown lines, rates)."""
    keys = sorted({keyfn(r) for r in subset}, key=cell_order)
    out = [f"| {title} | bats | " + " | ".join(METHODS) + " | batlab inconclusive |",
           "|---|---|" + "---|" * (len(METHODS) + 1)]
    found = {}
    for k in keys:
        rs = [r for r in subset if keyfn(r) == k]
        rates = {m: np.mean([r["said"][m] for r in rs]) for m in METHODS}
        found[k] = rates
        inc = sum(r["status"] == "inconclusive" for r in rs)
        out.append(f"| {k} | {len(rs)} | " + " | ".join(
            f"{100 * rates[m]:.0f} %" for m in METHODS) + f" | {inc} |")
    return out, found


def _false_alarm_lines(clean: list[dict], balance_limit_in: float) -> list[str]:
    """Tabulate each method's false alarms on the clean re-tests (markdown lines)."""
    return [f"clean re-tests: {len(clean)}; balance-point limit {balance_limit_in:.3f} in",
            "", "| false alarms on clean re-tests | " + " | ".join(METHODS) + " |",
            "|---|" + "---|" * len(METHODS),
            "| called altered | " + " | ".join(
                f"{sum(r['said'][m] for r in clean)}/{len(clean)}" for m in METHODS) + " |",
            "| batlab inconclusive | " + f"{sum(r['status'] == 'inconclusive' for r in clean)}"
            f"/{len(clean)} | | |", ""]


def volume_found(volume_in3: np.ndarray, found: np.ndarray, rate: float = 0.9,
                 ridge: float = 1e-3) -> float | None:
    """Return the core volume found at ``rate``, from a logistic fit in log volume.

    P(found | V) = 1 / (1 + exp(-(a + b ln V))), (a, b) by maximum likelihood with a small
    ridge on b (``ridge``, so a perfectly separated fleet gives a finite, steep fit rather
    than none); V_rate = exp((ln(rate / (1 - rate)) - a) / b).

    Parameters
    ----------
    volume_in3 : ndarray
        Each core's volume, in^3.
    found : ndarray of bool
        Whether the method found it.
    rate : float
        The detection rate asked for (0.9: the volume from which 90 % are found).
    ridge : float
        Penalty ridge * b^2 on the log-likelihood.

    Returns
    -------
    float or None
        The volume, in^3; None when nothing, or everything, was found, or the fitted rate
        does not rise with volume.

    Examples
    --------
    >>> v = np.array([0.3, 0.6, 1.2, 2.4, 4.8] * 4)
    >>> round(volume_found(v, v > 1.0), 1) <= 1.2
    True
    """
    y = np.asarray(found, dtype=float)
    if y.size == 0 or y.min() == y.max():
        return None
    x = np.log(np.asarray(volume_in3, dtype=float))
    x0 = float(np.mean(x))

    def nll(theta):
        z = theta[0] + theta[1] * (x - x0)
        return float(np.sum(np.logaddexp(0.0, z) - y * z) + ridge * theta[1] ** 2)

    a, b = minimize(nll, np.array([0.0, 1.0]), method="Nelder-Mead",
                    options={"xatol": 1e-8, "fatol": 1e-10, "maxiter": 4000}).x
    if b <= 0:
        return None
    return float(np.exp(x0 + (np.log(rate / (1 - rate)) - a) / b))


def _smallest_found_lines(found: dict, grid: list[dict]) -> list[str]:
    """Give each method's 90 % volume (``volume_found``) and smallest 90 % grid cell."""
    vol = {k: np.pi / 4 * float(k.split(" x ")[0]) ** 2 * float(k.split(" x ")[1].split()[0])
           for k in found}
    v = np.array([core_volume_in3(r["truth"]) for r in grid])
    drawn = f"drawn {v.min():.2f}-{v.max():.2f} in^3" if v.size else "none drawn"
    lines = []
    for m in METHODS:
        ok = [k for k in found if found[k][m] >= 0.9]
        best = min(ok, key=vol.get) if ok else "none on the grid"
        v90 = volume_found(v, np.array([r["said"][m] for r in grid]))
        where = ("not fitted (all or none found)" if v90 is None else
                 f"{v90:.2f} in^3" + (" (below every core drawn: an extrapolation)"
                                      if v90 < v.min() else
                                      " (above every core drawn: an extrapolation)"
                                      if v90 > v.max() else ""))
        lines.append(f"- cork cores, {m}: 90 % found from {where} (logistic in log volume; "
                     f"{drawn}); smallest cell found on >= 90 % of the bats: {best}")
    return lines


def _roc_lines(clean: list[dict], altered: list[dict]) -> list[str]:
    """Give batlab's and the lab statistics' ROC areas and batlab at zero false alarms."""
    conf = [r["confidence"] for r in clean if r["confidence"] is not None]
    conf_alt = [r["confidence"] if r["confidence"] is not None else 0.0 for r in altered]
    lines = [f"- batlab ROC area over its confidence (clean vs altered re-tests): "
             f"{roc_auc(conf, conf_alt):.3f}"]
    if conf:
        top = max(conf)
        det = np.mean([c > top for c in conf_alt]) if conf_alt else float("nan")
        lines.append(f"- at zero false alarms on these clean re-tests (confidence above the "
                     f"highest clean one, 1 - {1 - top:.1e}): {100 * det:.0f} % of altered "
                     "re-tests")
    for name, idx in (("scale", 0), ("balance point", 1)):
        c = [lab_statistics(r["truth"])[idx] for r in clean]
        a = [lab_statistics(r["truth"])[idx] for r in altered]
        lines.append(f"- {name} ROC area: {roc_auc(c, a):.3f}")
    return lines


def detection_report(rows: list[dict], balance_limit_in: float) -> str:
    """Report the detection study in markdown.

    Adds to every row ``said``: each method's call (batlab: ``status`` == "altered"; its
    screen: "altered" or "inconclusive").

    Parameters
    ----------
    rows : list of dict
        Result rows (``scoring.verdict_row``) of every re-test; grid re-tests carry
        ``truth["grid"]`` true.
    balance_limit_in : float
        The scale + balance method's limit, in (``lab_methods.clean_balance_limit_in``).

    Returns
    -------
    str
        False alarms, detection rates per grid cell and per kind, the smallest core found,
        the readings table, ROC areas and inspect times.
    """
    for r in rows:
        r["said"] = {"batlab": r["status"] == "altered",
                     "batlab screen": r["status"] in ("altered", "inconclusive"),
                     **lab_verdicts(r["truth"], balance_limit_in)}
    clean = [r for r in rows if r["kind"] == "none"]
    grid = [r for r in rows if r["truth"].get("grid")]
    lines = _false_alarm_lines(clean, balance_limit_in)
    t, found = _rate_table("cork core (d x filled length)", lambda r: cell_name(r["truth"]),
                           grid)
    lines += t + [""] + _smallest_found_lines(found, grid)
    others = [r for r in rows if r["kind"] != "none" and not r["truth"].get("grid")]
    if others:
        t, _ = _rate_table("alteration kind", lambda r: r["kind"], others)
        lines += [""] + t
    altered = [r for r in rows if r["kind"] != "none"]
    lines += ["", reading_table(altered), ""] + _roc_lines(clean, altered)
    t = sorted(r["seconds"] for r in rows)
    lines.append(f"- inspect --serial time: median {t[len(t) // 2]:.1f} s, max {t[-1]:.1f} s")
    return "\n".join(lines)


def lab_only_report(n: int, seed: int, grid: list[tuple[float, float]], ratio: float,
                    kinds: list[str], balance_limit_in: float) -> str:
    """Report the lab's two methods on ``n`` further bats (readings only, no FRFs).

    The same grid and kinds as ``retests``, re-tested under every nuisance; bat k is drawn
    with seed ``seed * 104729 + k``.

    Parameters
    ----------
    n : int
        Bats.
    seed : int
        The study's seed.
    grid, ratio, kinds
        As ``retests`` takes them.
    balance_limit_in : float
        The scale + balance method's limit, in.

    Returns
    -------
    str
        A markdown table of detection rates by re-test.
    """
    said: dict[str, list[dict]] = {}
    cells = {(d, float(length)) for d, length in grid}
    for k in range(n):
        rng = np.random.default_rng(seed * 104729 + k)
        case = draw_case(rng, "none", NUISANCES)
        for rt in retests(case, grid, ratio, kinds, rng):
            t = rt.truth
            key = "clean (false alarms)" if t["kind"] == "none" else (
                cell_name(t) if t["kind"] == "cork" and (
                    t["core_diameter_in"], round(t["region_in"][1] - t["region_in"][0], 6))
                in cells else t["kind"])
            said.setdefault(key, []).append(lab_verdicts(t, balance_limit_in))
    lines = [f"| re-test ({n} bats, readings only) | scale | scale+balance |", "|---|---|---|"]
    for key, vs in said.items():
        lines.append(f"| {key} | " + " | ".join(
            f"{100 * np.mean([v[m] for v in vs]):.0f} %" for m in LAB_METHODS) + " |")
    return "\n".join(lines)
