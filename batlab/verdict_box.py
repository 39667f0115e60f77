"""The report's first screen: the verdict box, at most 40 words.

Composed from the structured verdict (its ``status``, ``finding``, ``chance`` source and
value, and what kind of reason an inconclusive verdict gives), never by rewriting the
verdict's ``reasons`` (which the evidence table below shows as stored). Four short lines:
the verdict; what, where and how much; how sure, in one plain sentence; what to do next.
No statistics words ("F", "nominal", "p-value"), no model hash, no option or file name:
those live in the evidence below it. Layout: docs/report.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from batlab.formatting import share, stated_chance, status_of
from updating.inspect.kind_table import UNEXPLAINED, kind, kind_of

MAX_WORDS = 40
"""The first screen's budget (issue 50): a league reads it in one glance."""


@dataclass(frozen=True)
class VerdictBox:
    """The four lines of the first screen, in plain words.

    Attributes
    ----------
    verdict : str
        "Altered: filled.", "Not altered.", "No verdict."
    what : str
        What, where and how much ("" when nothing was found).
    sure : str
        How sure, in one sentence.
    next : str
        What to do next.
    """

    verdict: str
    what: str
    sure: str
    next: str

    def lines(self) -> list[tuple[str, str]]:
        """Return the (label, text) lines that are not empty."""
        return [(label, text) for label, text in (("", self.verdict), ("Found", self.what),
                                                  ("How sure", self.sure),
                                                  ("Next", self.next)) if text]

    def text(self) -> str:
        """Return the box as one plain paragraph (a terminal, a test's word count)."""
        return " ".join(f"{label}: {t}" if label else t for label, t in self.lines())


def word_count(text: str) -> int:
    """Count the words a reader sees (runs of characters between spaces)."""
    return len(text.split())


def _amount(f: dict) -> str:
    """Say how much a finding is, in the lab's units, from its reading."""
    r = f.get("reading") or {}
    a, b = f["region_in"]
    if r.get("core_diameter_in") is not None:
        fill = r.get("fill_density_ratio")
        hollow = "" if fill is None or fill >= 0.1 else ", hollow"
        return f"a {r['core_diameter_in']:.2f} in bore, {b - a:.0f} in long{hollow}"
    if r.get("added_mass_g") is not None:
        return f"about {r['added_mass_g']:.0f} g added"
    if r.get("diameter_lost_in") is not None:
        return f"{r['diameter_lost_in']:.3f} in of diameter removed"
    if r.get("removed_mass_g") is not None:
        return f"about {r['removed_mass_g']:.0f} g removed"
    return "a local change"


def _what(f: dict | None) -> str:
    """Say what, where and how much: "a 1.00 in bore, 9 in long, 24-33 in from the knob."."""
    if not f or not f.get("region_in"):
        return ""
    a, b = f["region_in"]
    return f"{_amount(f)}, {a:.0f}–{b:.0f} in from the knob."


NEXT_ALTERED = {"core": "keep it out of play; X-ray the barrel.",
                "inserted_mass": "keep it out of play; X-ray it.",
                "material_removed": "keep it out of play; caliper it.",
                "surface_coating": "keep it out of play; inspect its surface.",
                "local_change": "keep it out of play; X-ray it."}
"""What to do with an altered bat, by the finding's kind."""


REASON_KINDS = (
    ("another_bat", ("two bats of this profile",),
     "The re-test does not look like this bat.", "check the serial and the baseline."),
    ("one_point", ("rests on",),
     "The change rests on a single measurement.", "re-test with the same set-up."),
    ("drift", ("also fits", "not beyond drift", "not surely beyond", "too little to be sure"),
     "A change, but not surely beyond moisture or temperature.",
     "weigh it, X-ray the barrel, re-test in a week."),
    ("unexplained", ("not as any alteration",),
     "The tests differ, but not as any alteration does.",
     "look the bat over and re-test."),
    ("weight", ("weight changed",),
     "Its weight changed, but no alteration surely explains it.",
     "re-weigh it and re-test."),
    ("setup", ("physical bounds",),
     "The set-up changed more than the wood can.",
     "re-test with the baseline's set-up."),
    ("modes", ("too few modes", "pair"),
     "Too few vibration modes matched between the two tests.", "re-test with more hits."),
    ("amplitude", ("amplitude",),
     "The two tests' signal levels disagree, as a sensor slip makes them.",
     "check the sensors' settings; re-test."),
    ("barrel", ("cannot see the barrel",),
     "The test points do not cover the barrel.", "re-test with points along the barrel."),
)
"""What kind of reason an inconclusive verdict gives: (kind, phrases that mark it in a
reason, how sure in plain words, what to do next). The first kind any reason matches is
said; a reason of no listed kind is said generically (``INCONCLUSIVE``)."""
INCONCLUSIVE = ("The two tests cannot be compared.", "re-test the bat.")


def reason_kind(reasons: list[str]) -> tuple[str, str, str]:
    """Return (kind, how sure, next) of an inconclusive verdict's reasons (``REASON_KINDS``)."""
    text = " ".join(reasons).lower()
    for name, marks, sure, todo in REASON_KINDS:
        if any(m in text for m in marks):
            return name, sure, todo
    return "other", *INCONCLUSIVE


def _sure(v: dict, status: str) -> str:
    """How sure, in one sentence, from the verdict's chance (its source and value)."""
    ch = stated_chance(v) or {}
    cal = ch.get("calibration") if ch.get("source") == "calibration" else None
    if cal and ch.get("value") is not None:
        n, b = int(cal["n"]), int(cal.get("exceeding") or 0)
        if status == "altered":
            return (f"none of {n:,} clean re-tests of this bat model differed this much."
                    if b == 0 else
                    f"only {b:,} of {n:,} clean re-tests of this bat model differed this much.")
        return (f"{share(float(ch['value']))} of {n:,} clean re-tests of this bat model "
                "differed more.")
    if status == "altered":
        return "far beyond what moisture, temperature or the sensor's mounting do."
    return "no more change than moisture, temperature or the sensor's mounting make."


def verdict_box(v: dict, weighed: bool = False) -> VerdictBox:
    """Compose the first screen from a stored verdict (module docstring).

    Parameters
    ----------
    v : dict
        The verdict as stored (contract JSON).
    weighed : bool
        Whether the re-test's weight was given (retest.json): then the bat is not asked to
        be weighed.

    Returns
    -------
    VerdictBox
        Its four lines; ``text()`` has at most ``MAX_WORDS`` words for every kind and
        status (``tests/test_verdict_box.py``).
    """
    status = status_of(v)
    f = v.get("finding")
    if not f and status == "altered" and v.get("region_in"):  # stored before the rulebook
        f = {"kind": "core", "rule": "altered", "region_in": v["region_in"],
             "reading": {"core_diameter_in": v.get("core_diameter_in"),
                         "fill_density_ratio": v.get("fill_density_ratio")}}
    if status == "inconclusive":
        _, sure, todo = reason_kind([str(r) for r in v.get("reasons") or []])
        if weighed:
            todo = todo.replace("weigh it, ", "").replace("re-weigh it and ", "")
        what = _what(f)
        if what:
            k = kind_of(f["kind"], f.get("rule")) or kind(UNEXPLAINED)
            what = f"possibly {k.short.format(rule=f.get('rule') or '')}: {what}"
        return VerdictBox("No verdict: not called altered.", what, sure,
                          todo[0].upper() + todo[1:])
    if status == "altered":
        rule = (f or {}).get("rule") or "altered"
        todo = NEXT_ALTERED.get((f or {}).get("kind", "core"), NEXT_ALTERED["core"])
        sure = _sure(v, status)
        said = "Altered." if rule == "altered" else f"Altered: {rule}."
        return VerdictBox(said, _what(f), sure[0].upper() + sure[1:],
                          todo[0].upper() + todo[1:])
    sure = _sure(v, status)
    what, todo = "", "none; the bat may be used."
    if f and f.get("region_in"):
        k = kind_of(f["kind"], f.get("rule")) or kind(UNEXPLAINED)
        what = f"{_what(f)[:-1]}: {k.short.format(rule=f.get('rule') or '')}."
        if not f.get("legal"):
            todo = "clean it off past 18 in before play."
    return VerdictBox("Not altered.", what,
                      sure[0].upper() + sure[1:], todo[0].upper() + todo[1:])
