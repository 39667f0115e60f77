"""`batlab registry check`: integrity, stored files and the chain of custody."""

from __future__ import annotations

import json
from dataclasses import asdict

from batlab.cli_support import add_db_argument, db_path

HELP = "check the registry: SQLite integrity, every stored file's hash, the custody chain"
EXAMPLE = "batlab registry check --db lab.sqlite"


def add_arguments(p) -> None:
    p.add_argument("action", choices=["check"], help="check: verify everything stored")
    add_db_argument(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON on stdout")


def run(args) -> int:
    from batlab.registry import check, open_registry

    path = db_path(args)
    with open_registry(path, create=False) as conn:
        res = check(conn)
    if args.json:
        print(json.dumps({**asdict(res), "ok": res.ok}))
    else:
        state = "intact" if res.ok else "DAMAGED OR CHANGED"
        print(f"{path}: {state}: {res.n_records} custody records, {res.n_files} files")
        if res.head_sha256:
            print(f"  chain head sha256 {res.head_sha256}")
        for line in res.problems:
            print(f"  problem: {line}")
        for line in res.notes:
            print(f"  note: {line}")
        if res.first_changed is not None:
            print(f"  first changed record: #{res.first_changed}")
    return 0 if res.ok else 1
