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
        --clean 40 --altered 42 --seed 600 [--records N] [--out rows.jsonl]

Add ``coherence`` to ``--nuisances`` for files that carry their coherence (the noise
measured, docs/noise.md); ``score --residual-noise`` then judges the same bats as if they did
not (docs/results/noise.md):

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/inspect_cache.py build \
        --clean 40 --altered 28 --seed 900000 --nuisances \
        moisture,temperature,billet,planes,cup,noise,points,band,accelerometer,bungees,coherence

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
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_inspect_field import summarise  # noqa: E402

from batlab.fleet.cache import build_one, jobs, path_of, registered_conditions, score_one  # noqa: E402, F401, E501
from updating.simulate.nuisances import NUISANCES  # noqa: E402

DEFAULT_DIR = Path("/tmp/batlab-inspect-cache")


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
    ap.add_argument("--records", type=int, default=None, metavar="N",
                    help="score: both tests' dates, rooms and N moisture meter readings a "
                         "station (updating.simulate.meter; 0: dates and rooms alone)")
    ap.add_argument("--out", type=Path, default=None, help="score: JSON lines of the rows")
    ap.add_argument("--residual-noise", action="store_true",
                    help="score: judge as if the files carried no coherence (the noise from "
                         "H0's residual), for comparison with the measured noise")
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
        bat = pickle.loads(p.read_bytes())
        if args.residual_noise and "error" not in bat:  # as if the files had no coherence
            bat = dict(bat, **{k: replace(bat[k], shape_noise_rel=None)
                               for k in ("baseline", "retest")})
        row = score_one(bat, registration=args.registration, records=args.records)
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
