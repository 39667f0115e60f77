"""Cache the inspection's inputs of nuisance-rich fleet bats, then re-score the inspection alone.

Files to verdict costs ~3 s a bat, most of it the two modal fits and diagnose, which a change
of the inspection's H0/H1 or of its decision gates does not touch. ``build`` runs the real
stateless path (``bench_inspect_field``'s bats: ``draw_case``, ``write_case``, then
``batlab.pipeline.stateless_case``: reading, modal fits and calibration) once per bat and
pickles what ``updating.inspect.run.inspect`` takes (profile, calibrated reference,
both tests' modes, the re-test's and the registration's conditions) with the truth;
``score`` runs only the inspection on the cached bats (~1 s each) and prints
``bench_inspect_field``'s summary.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/inspect_cache.py build \
        --clean 40 --altered 42 --seed 600
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/inspect_cache.py score \
        --clean 40 --altered 42 --seed 600 [--out rows.jsonl]

Bats live in ``--dir`` (default /tmp/batlab-inspect-cache) as <seed>_<kind>.pkl. The final
numbers come from ``bench_inspect_field.py`` (files to verdict), not from this cache.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import pickle
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from bench_inspect_field import score_verdict, summarise  # noqa: E402

from batlab import pipeline  # noqa: E402
from updating.inspect.retest_meta import RetestConditions, conditions_from_dict  # noqa: E402
from updating.inspect.run import inspect  # noqa: E402
from updating.simulate.alterations import KINDS  # noqa: E402
from updating.simulate.field_fleet import draw_case, write_case  # noqa: E402
from updating.simulate.integrity import INTEGRITY  # noqa: E402
from updating.simulate.nuisances import NUISANCES  # noqa: E402

DEFAULT_DIR = Path("/tmp/batlab-inspect-cache")


def jobs(clean: int, altered: int, integrity: int, seed: int) -> list[tuple[int, str, str | None]]:
    """(seed, kind, integrity) of each bat, laid out as ``bench_inspect_field`` lays them."""
    js = [("none", None)] * clean + [(KINDS[i % len(KINDS)], None) for i in range(altered)]
    js += [("none", g) for _ in range(integrity) for g in INTEGRITY]
    return [(seed + i, k, g) for i, (k, g) in enumerate(js)]


def path_of(folder: Path, seed: int, kind: str, integ: str | None) -> Path:
    return folder / f"{seed}_{kind}{'_' + integ if integ else ''}.pkl"


def build_one(seed: int, kind: str, integ: str | None, with_meta: bool = True,
              nuisances=NUISANCES, registration: bool = False) -> dict:
    """Everything ``inspect`` needs for this bat, and its truth (or an error)."""
    rng = np.random.default_rng(seed)
    out: dict = {"seed": seed, "kind": kind, "integrity": integ}
    with tempfile.TemporaryDirectory(prefix="batlab-cache-") as tmp:
        try:
            case = draw_case(rng, kind, nuisances, integrity=integ, serial=f"F-{seed}")
            paths = write_case(case, tmp, seed, retest_meta_keys=None if with_meta else [],
                               registration=registration)
        except ValueError as exc:
            out["error"] = ("sim_error", str(exc))
            return out
        out["truth"], out["expected"] = case.truth, case.expected
        try:
            cond = pipeline.read_conditions(paths["retest_meta"])
            bat = pipeline.stateless_case(paths["profile"], paths["meta"], paths["baseline"],
                                          paths["retest"])
        except ValueError as exc:
            out["error"] = ("refused", str(exc))
            return out
    out.update(nuisances=list(nuisances), registration=registration, serial=bat.serial,
               profile=bat.profile, reference=bat.reference,
               baseline=bat.baseline.modes, retest=bat.retest.modes, conditions=cond,
               registered=bat.registered)
    return out


def registered_conditions(bat: dict) -> RetestConditions:
    """The bat's registration as if meta.json had recorded the baseline's temperature and
    accelerometer mass (``FieldCase.registration_conditions``; the case re-drawn from its
    seed, which makes the same bat)."""
    case = draw_case(np.random.default_rng(bat["seed"]), bat["kind"],
                     bat.get("nuisances", NUISANCES), integrity=bat["integrity"],
                     serial=f"F-{bat['seed']}")
    extra = conditions_from_dict(case.registration_conditions, "meta.json")
    return replace(bat["registered"], sensor_mass_kg=extra.sensor_mass_kg,
                   temperature_c=extra.temperature_c)


def score_one(bat: dict, false_alarm: float = 0.01, registration: bool = False) -> dict:
    """The inspection alone on a cached bat: ``bench_inspect_field``'s row (with
    ``registration``: meta.json's baseline temperature and accelerometer mass given)."""
    row = {"seed": bat["seed"], "kind": bat["kind"], "integrity": bat["integrity"]}
    if "error" in bat:
        row.update(status=bat["error"][0], reasons=[bat["error"][1]])
        return row
    row["expected"] = bat["expected"]
    if registration and not bat.get("registration"):
        bat = dict(bat, registered=registered_conditions(bat))
    t0 = time.perf_counter()
    try:
        v = inspect(bat["profile"], bat["reference"], bat["baseline"], bat["retest"],
                    false_alarm, bat["conditions"], bat["registered"])
    except ValueError as exc:
        row.update(status="refused", reasons=[str(exc)], time_s=time.perf_counter() - t0)
        return row
    row["time_s"] = time.perf_counter() - t0
    return score_verdict(row, bat["serial"], v, bat["kind"], bat["truth"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("build", "score"))
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--altered", type=int, default=7)
    ap.add_argument("--integrity", type=int, default=0)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--dir", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--nuisances", default=",".join(NUISANCES),
                    help="build: the nuisances drawn (comma-separated; '' for none)")
    ap.add_argument("--registration", action="store_true",
                    help="meta.json records the baseline's temperature and accelerometer "
                         "mass (build: written; score: added to cached bats)")
    ap.add_argument("--out", type=Path, default=None, help="score: JSON lines of the rows")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE",
                    help="score: override a module constant, e.g. updating.inspect."
                         "decision.F_FLOOR=10 (for studies; the summary's gates read the module)")
    args = ap.parse_args()
    for item in args.set:
        name, value = item.split("=", 1)
        mod, attr = name.rsplit(".", 1)
        module = importlib.import_module(mod)
        getattr(module, attr)  # must exist
        setattr(module, attr, float(value))
    args.dir.mkdir(parents=True, exist_ok=True)
    todo = jobs(args.clean, args.altered, args.integrity, args.seed)
    rows = []
    for i, (seed, kind, integ) in enumerate(todo):
        p = path_of(args.dir, seed, kind, integ)
        if args.action == "build":
            if p.exists():
                continue
            t0 = time.perf_counter()
            bat = build_one(seed, kind, integ,
                            nuisances=[n for n in args.nuisances.split(",") if n],
                            registration=args.registration)
            tmp = p.with_suffix(".tmp")
            tmp.write_bytes(pickle.dumps(bat))
            tmp.replace(p)
            print(f"{i + 1}/{len(todo)} {p.name} ({time.perf_counter() - t0:.1f} s)",
                  file=sys.stderr, flush=True)
            continue
        row = score_one(pickle.loads(p.read_bytes()), registration=args.registration)
        rows.append(row)
        print(f"{i + 1}/{len(todo)} {kind} {integ or ''}: {row['status']} "
              f"F={row.get('F') or float('nan'):.1f}", file=sys.stderr, flush=True)
    if args.action == "score":
        if args.out:
            args.out.write_text("".join(json.dumps(r, default=float) + "\n" for r in rows))
        print(summarise(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
