"""Make the calibration batlab ships for its built-in bat model (`batlab demo`'s bat).

    python benchmarks/make_shipped_calibration.py --key release.pem [--n 3000] [--seed 2026]
        [--scheduler tcp://HOST:PORT] [--work DIR] [--into batlab/builtin/calibrations]

Runs, as anyone can, `batlab fleet calibrate` on the built-in bat (``batlab/builtin``:
profile.csv, meta.json) with ``--n`` clean re-tests and ``--seed``, stores the measured null
in a registry of its own (``--work``/registry.sqlite, signed by ``--key``), its rows in
``--work``/rows.jsonl (so a run cut short resumes: run it again with the same arguments),
then exports the calibration as a file signed by ``--key`` into
``--into``/MODEL.json and adds that key to ``--into``/signers.keys (the keys batlab accepts
a shipped calibration from). The calibration measures the statistic of the code running
it (``updating.inspect.nested.STATISTIC_VERSION``): remake it whenever that version changes,
or `inspect` says the shipped one measured another version. Cost: the clean re-tests at
about 2-4 core-s each (docs/scale.md), so 3,000 take one to three hours on two cores.

Prints the export's line and the model, n, false alarms and the statistic's version.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUILTIN = ROOT / "batlab" / "builtin"


def batlab(*args, key: Path) -> str:
    """Run ``python -m batlab ARGS`` from the repository, signing with ``key``; its stdout."""
    env = {**os.environ, "BATLAB_KEY": str(key)}
    done = subprocess.run([sys.executable, "-m", "batlab", *map(str, args)], cwd=ROOT,
                          env=env, stdout=subprocess.PIPE, text=True, check=False)
    if done.returncode:
        raise SystemExit(f"batlab {' '.join(map(str, args[:2]))} failed ({done.returncode})")
    return done.stdout


def main(argv: list[str] | None = None) -> int:
    """Calibrate the built-in bat model, export it signed, list the signer; exit 0."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--key", required=True, type=Path,
                   help="the signing key (PKCS#8 PEM; created if absent)")
    p.add_argument("--n", type=int, default=3000, help="clean re-tests (default 3000)")
    p.add_argument("--seed", type=int, default=2026, help="the study's seed")
    p.add_argument("--scheduler", default=None, help="a Dask scheduler to run on")
    p.add_argument("--work", type=Path, default=ROOT / "benchmarks" / "shipped-calibration",
                   help="where the rows and the registry are kept (resumable)")
    p.add_argument("--into", type=Path, default=BUILTIN / "calibrations",
                   help="where the signed file goes, beside signers.keys")
    args = p.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    db, rows = args.work / "registry.sqlite", args.work / "rows.jsonl"
    if db.exists():  # a finished run stored already: start the registry afresh
        db.unlink()
    run = ["fleet", "calibrate", "--profile", BUILTIN / "profile.csv", "--meta",
           BUILTIN / "meta.json", "--n", args.n, "--seed", args.seed, "-o", rows, "--store",
           "--db", db, "--json"]
    if rows.exists():
        run.append("--resume")
    if args.scheduler:
        run += ["--scheduler", args.scheduler]
    result = json.loads(batlab(*run, key=args.key))
    listed = json.loads(batlab("registry", "calibrations", "--db", db, "--json",
                               key=args.key))[-1]
    args.into.mkdir(parents=True, exist_ok=True)
    target = args.into / f"{listed['model']}.json"
    print(batlab("registry", "calibrations", "--db", db, "--export", target,
                 key=args.key).strip())
    signer = batlab("registry", "key", key=args.key).strip()
    keys = args.into / "signers.keys"
    known = keys.read_text(encoding="utf-8") if keys.exists() else ""
    if signer not in known.split():
        keys.write_text(known + signer + "\n", encoding="utf-8")
    print(f"bat model {listed['model']}: n {result['n']}, false alarms "
          f"{result['false_alarms']} (below {result['false_alarm_upper95']:.2g}), F version "
          f"{listed['statistic_version']}; signed by {signer}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
