"""Calibration and acceptance of the three-way verdict on the nuisance-rich virtual fleet.

Each bat (``updating.simulate.field_fleet.draw_case``: every nuisance at random, realistic
magnitudes) is written as the lab's files and inspected through the real stateless path
(``batlab.pipeline.inspect_files``: modal fits, diagnose, inspection), with its retest.json.
One JSON line per bat on stdout (status, reasons, reading errors, time); a summary on stderr.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_inspect_field.py \
        --clean 40 --altered 42 --integrity 1 --seed 100 > field.jsonl

``--no-retest-meta`` inspects without retest.json; ``--summary FILE`` re-summarises a run.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from batlab.fleet.cache import field_row as one  # noqa: E402
from batlab.fleet.cache import score_verdict  # noqa: E402, F401
from updating.inspect import decision, kind_table  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.alterations import KINDS  # noqa: E402
from updating.simulate.integrity import INTEGRITY  # noqa: E402


def d_low_in(row: dict) -> float | None:
    """The H1 candidate core's diameter less two standard uncertainties, in (the "practical
    core" test of the decision), or None when no candidate was fitted."""
    c = row.get("candidate") or {}
    sd = (c.get("uncertainty") or {}).get("core_diameter_m")
    if c.get("diameter_m") is None or sd is None:
        return None
    return (c["diameter_m"] - 2 * sd) / IN_TO_M


def clean_margin(clean: list[dict]) -> str:
    """How close the clean bats came to "altered": the largest F among those whose candidate
    core was practical, and the largest lower diameter bound among those whose F passed the
    floor (each gate alone would have let that bat through)."""
    F_FLOOR, MIN_CORE_DIAMETER_IN = decision.F_FLOOR, kind_table.MIN_CORE_DIAMETER_IN
    prac = [r["F"] for r in clean if (d_low_in(r) or 0.0) >= MIN_CORE_DIAMETER_IN
            and r.get("F") is not None]
    over = [d_low_in(r) or 0.0 for r in clean if (r.get("F") or 0.0) >= F_FLOOR]
    f_txt = f"{max(prac):.1f}" if prac else "none"
    d_txt = f"{max(over):.2f} in" if over else "none"
    return (f"  margin: largest F with a practical candidate core {f_txt} (floor {F_FLOOR:g}); "
            f"largest diameter - 2 sd with F over the floor {d_txt} "
            f"(floor {MIN_CORE_DIAMETER_IN} in)")


def summarise(rows: list[dict]) -> str:
    lines = []
    skipped = [r for r in rows if r["status"] == "sim_error"]
    rows = [r for r in rows if r["status"] != "sim_error"]
    clean = [r for r in rows if r["kind"] == "none" and not r["integrity"]]
    alt = [r for r in rows if r["kind"] != "none" and not r["integrity"]]
    integ = [r for r in rows if r["integrity"]]
    if skipped:
        lines.append(f"({len(skipped)} draws the simulator could not make, not counted)")
    if clean:
        n = len(clean)
        fa = sum(r["status"] == "altered" for r in clean)
        inc = sum(r["status"] in ("inconclusive", "refused") for r in clean)
        lines.append(f"clean {n}: false alarms {fa}, inconclusive {inc} ({100 * inc / n:.0f} %)")
        lines.append(clean_margin(clean))
    if alt:
        n = len(alt)
        det = [r for r in alt if r["status"] == "altered"]
        lines.append(f"altered {n}: detected {len(det)} ({100 * len(det) / n:.0f} %), "
                     f"inconclusive {sum(r['status'] == 'inconclusive' for r in alt)}")
        for k in KINDS:
            ks = [r for r in alt if r["kind"] == k]
            if ks:
                lines.append(f"  {k}: {sum(r['status'] == 'altered' for r in ks)}/{len(ks)}")
        if det:
            s = sum(abs(r["start_err_in"]) <= 1.5 for r in det)
            dd = sum(abs(r["d_err_rel"]) <= 0.15 for r in det)
            ff = sum(r["fill_ok"] for r in det)
            lines.append(f"  of all altered: start within 1.5 in {s}/{n} ({100 * s / n:.0f} %),"
                         f" diameter within 15 % {dd}/{n} ({100 * dd / n:.0f} %), fill within "
                         f"25 % (empty: 0.1) {ff}/{n} ({100 * ff / n:.0f} %)")
    for r in integ:
        lines.append(f"integrity {r['integrity']}: {r['status']}")
    t = [r["time_s"] for r in rows if "time_s" in r]
    if t:
        lines.append(f"time per bat (files to verdict): median {np.median(t):.1f} s, "
                     f"max {max(t):.1f} s")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--altered", type=int, default=7, help="altered bats (kinds in turn)")
    ap.add_argument("--integrity", type=int, default=0, help="rounds of the integrity cases")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--no-retest-meta", action="store_true")
    ap.add_argument("--registration", action="store_true",
                    help="meta.json records the baseline's temperature and accelerometer "
                         "mass (as a lab does at registration)")
    ap.add_argument("--summary", default=None, help="summarise a JSON-lines file and stop")
    args = ap.parse_args()
    if args.summary:
        rows = [json.loads(s) for s in Path(args.summary).read_text().splitlines() if s]
        print(summarise(rows))
        return 0
    jobs = [("none", None)] * args.clean
    jobs += [(KINDS[i % len(KINDS)], None) for i in range(args.altered)]
    jobs += [("none", g) for _ in range(args.integrity) for g in INTEGRITY]
    rows = []
    for i, (kind, integ) in enumerate(jobs):
        row = one(args.seed + i, kind, integ, not args.no_retest_meta, args.registration)
        rows.append(row)
        print(json.dumps(row, default=float), flush=True)
        print(f"{i + 1}/{len(jobs)} {kind} {integ or ''}: {row['status']} "
              f"({row.get('time_s', 0):.1f} s)", file=sys.stderr, flush=True)
    print(summarise(rows), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
