"""Acceptance regression of the inspection on the full path: FRF files to verdict.

    python benchmarks/bench_pipeline.py [--n 24] [--seed 1] [--registry 3] [--keep DIR]

For each of N seeded random bats (``updating.simulate.fleet.lab_case``: smooth profile with
caliper noise, a random species with E +-15 % and density +-8 % of the handbook values that
meta.json gives, Timoshenko with E/G 10-18, a 2-6 g accelerometer, bungees, 0.5 % FRF noise;
at the re-test moisture up to +-1 point and the accelerometer moved up to 0.1 in; half altered
with cork 0.2-0.4, heavy fill 1.5-2.2 or density-neutral soft fill, cores 0.75-1.25 in wide,
6-11 in deep) it writes profile.csv, meta.json, baseline.uff and retest.uff as `batlab
simulate` does, runs the real command

    batlab inspect --profile --meta --baseline --retest --json

(``batlab.cli.main`` in this process) and reads the contract JSON. Prints the confusion table,
the error table of the altered bats, pass/fail against the targets of issue "Inspect" (verdicts
right >= 90 %, no false alarm, start within 1.5 in, diameter within 15 %, fill ratio within
25 %) and the wall-clock time per inspection (two UFF files to verdict; target < 5 s). The
first ``--registry`` bats are also registered (`batlab register`) and inspected through the
registry (`batlab inspect --serial S R.uff`); their verdicts must equal the stateless ones.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small matrices: threads only contend
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab.cli import main as batlab_main  # noqa: E402
from updating.model.units import IN_TO_M  # noqa: E402
from updating.simulate.fleet import FILLS, lab_case, write_lab_files  # noqa: E402

KINDS = ["none", "cork", "none", "heavy", "none", "neutral"]  # half altered, fills in turn
TARGETS = {"right": 0.90, "start_in": 1.5, "d_pct": 15.0, "ratio_pct": 25.0}


def batlab(args: list, quiet: bool = True) -> dict:
    """Run a batlab command in this process; exit 0 and one JSON object on stdout."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err if quiet else
                                                                     sys.stderr):
        code = batlab_main([str(a) for a in args])
    if code != 0:
        raise RuntimeError(f"batlab {args[0]} exited {code}: {err.getvalue().strip()}")
    return json.loads(out.getvalue())


def inspect_stateless(paths: dict) -> tuple[dict, float]:
    t0 = time.perf_counter()
    out = batlab(["inspect", "--profile", paths["profile"], "--meta", paths["meta"],
                  "--baseline", paths["baseline"], "--retest", paths["retest"], "--json"])
    return out, time.perf_counter() - t0


def inspect_registered(paths: dict, serial: str, db: Path) -> dict:
    batlab(["register", "--profile", paths["profile"], "--meta", paths["meta"], "--baseline",
            paths["baseline"], "--db", db, "--json"])
    return batlab(["inspect", "--serial", serial, paths["retest"], "--db", db, "--json"])


def truth_row(case) -> dict:
    row = {"kind": case.kind, "moisture_pct": case.retest.moisture_pct}
    if case.core is not None:
        L = case.profile.length_m
        row.update(start_in=(L - case.core.depth_m) / IN_TO_M,
                   d_in=case.core.diameter_m / IN_TO_M, ratio=case.core.fill_density_ratio)
    return row


def run_bat(i: int, seed: int, folder: Path) -> tuple[dict, dict]:
    """Make bat ``i``'s files in ``folder`` and inspect them; (truth row, contract JSON)."""
    kind = KINDS[i % len(KINDS)]
    rng = np.random.default_rng(seed)
    case = lab_case(rng, kind, serial=f"SIM-{i + 1:04d}")
    paths = write_lab_files(case, folder, seed=int(rng.integers(2**31)))
    out, dt = inspect_stateless(paths)
    row = truth_row(case)
    row.update(serial=case.meta["serial"], time_s=dt, paths=paths)
    return row, out


def errors(row: dict, out: dict) -> tuple[float, float, float]:
    return (out["region_in"][0] - row["start_in"],
            100 * (out["core_diameter_in"] / row["d_in"] - 1),
            100 * (out["fill_density_ratio"] / row["ratio"] - 1))


def report(rows: list[dict], outs: list[dict]) -> bool:
    """Print the tables; True when every target is met."""
    truth = np.array([r["kind"] != "none" for r in rows])
    said = np.array([o["altered"] for o in outs])
    n = len(rows)
    print(f"\n## Confusion table ({n} bats, full path, false_alarm = 0.01)\n")
    print("| truth \\ verdict | altered | not altered |")
    print("|---|---|---|")
    print(f"| altered | {np.sum(truth & said)} | {np.sum(truth & ~said)} |")
    print(f"| not altered | {np.sum(~truth & said)} | {np.sum(~truth & ~said)} |")
    for kind in FILLS:
        k = [o["altered"] for r, o in zip(rows, outs, strict=True) if r["kind"] == kind]
        print(f"  {kind}: {sum(k)}/{len(k)} detected")
    right = float(np.mean(truth == said))
    false_alarms = int(np.sum(~truth & said))

    print("\n## Errors on the altered bats\n")
    print("| serial | fill | moisture pt | start in (true / est) | d in (true / est) |"
          " ratio (true / est) | start err in | d err % | ratio err % |")
    print("|---|---|---|---|---|---|---|---|---|")
    errs = []
    for r, o in zip(rows, outs, strict=True):
        if r["kind"] == "none":
            continue
        if not o["altered"]:
            print(f"| {r['serial']} | {r['kind']} | {r['moisture_pct']:+.2f} | "
                  f"{r['start_in']:.2f} / - | {r['d_in']:.3f} / - | {r['ratio']:.2f} / - |"
                  " missed | | |")
            continue
        e = errors(r, o)
        errs.append(e)
        print(f"| {r['serial']} | {r['kind']} | {r['moisture_pct']:+.2f} | "
              f"{r['start_in']:.2f} / {o['region_in'][0]:.2f} | "
              f"{r['d_in']:.3f} / {o['core_diameter_in']:.3f} | "
              f"{r['ratio']:.2f} / {o['fill_density_ratio']:.2f} | "
              f"{e[0]:+.2f} | {e[1]:+.1f} | {e[2]:+.1f} |")
    a = np.abs(np.array(errs)) if errs else np.zeros((0, 3))
    within = (a[:, 0] <= TARGETS["start_in"]) & (a[:, 1] <= TARGETS["d_pct"]) & \
        (a[:, 2] <= TARGETS["ratio_pct"])
    t = np.array([r["time_s"] for r in rows])

    checks = [
        (f"verdicts right {100 * right:.1f} % (>= 90 %)", right >= TARGETS["right"]),
        (f"false alarms {false_alarms} (0)", false_alarms == 0),
    ]
    if errs:
        checks += [
            (f"max |start err| {a[:, 0].max():.2f} in (<= 1.5)",
             a[:, 0].max() <= TARGETS["start_in"]),
            (f"max |diameter err| {a[:, 1].max():.1f} % (<= 15)",
             a[:, 1].max() <= TARGETS["d_pct"]),
            (f"max |fill ratio err| {a[:, 2].max():.1f} % (<= 25)",
             a[:, 2].max() <= TARGETS["ratio_pct"]),
        ]
    checks.append((f"time per inspection median {np.median(t):.2f} s, max {t.max():.2f} s "
                   "(< 5 s)", t.max() < 5.0))
    print("\n## Targets\n")
    if errs:
        print(f"detected altered bats within all three reading targets: {int(within.sum())}/"
              f"{len(errs)}")
    for text, ok in checks:
        print(f"  {'PASS' if ok else 'FAIL'}  {text}")
    return all(ok for _, ok in checks)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=24, help="number of bats (default 24)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--registry", type=int, default=3,
                    help="bats also run through register + inspect --serial (default 3)")
    ap.add_argument("--keep", default=None, help="keep the bats' files under DIR")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix="batlab-bench-") as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        rows, outs = [], []
        for i in range(args.n):
            folder = root / f"bat{i + 1:02d}"
            folder.mkdir(parents=True, exist_ok=True)
            row, out = run_bat(i, args.seed * 100000 + i, folder)
            rows.append(row)
            outs.append(out)
            print(f"  bat {i + 1:2d}/{args.n} {row['kind']:8s} altered={out['altered']!s:5s} "
                  f"confidence={out['confidence']:.4f} {row['time_s']:.2f} s", file=sys.stderr)
        ok = report(rows, outs)

        if args.registry:
            db = root / "registry.sqlite"
            same = 0
            print(f"\n## Registry form on {args.registry} bats (register, inspect --serial)\n")
            for r, o in list(zip(rows, outs, strict=True))[:args.registry]:
                reg = inspect_registered(r["paths"], r["serial"], db)
                agree = reg == o
                same += agree
                print(f"  {r['serial']} ({r['kind']}): stateless altered={o['altered']}, "
                      f"registry altered={reg['altered']}, identical JSON: {agree}")
            ok = ok and same == args.registry
            print(f"  {'PASS' if same == args.registry else 'FAIL'}  registry verdicts equal "
                  f"the stateless ones: {same}/{args.registry}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
