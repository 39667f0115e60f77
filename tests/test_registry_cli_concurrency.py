"""Several `batlab register` / `batlab inspect --serial` processes on one registry at once.

The numerics are the test-only stand-ins (this checks the registry under the real command
line, in real processes, not the modal fit)."""

from __future__ import annotations

import multiprocessing as mp

from batlab.registry import check, history, list_bats, open_registry
from tests.inspect_standins import bat_folders, lab_worker


def test_concurrent_register_and_inspect_processes(tmp_path):
    db = str(tmp_path / "lab.sqlite")
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=lab_worker, args=(db, str(folder), 3))
             for folder in bat_folders(tmp_path, "C", 3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
    assert [p.exitcode for p in procs] == [0, 0, 0]
    with open_registry(db) as conn:
        assert [b.serial for b in list_bats(conn)] == ["C-0", "C-1", "C-2"]
        for k in range(3):
            hist = history(conn, f"C-{k}")
            assert len(hist) == 3 and all(h.altered for h in hist)
        assert conn.exec_driver_sql("PRAGMA integrity_check").fetchone()[0] == "ok"
        # one baseline and one re-test file, each stored once, shared by the three bats
        assert conn.exec_driver_sql("SELECT count(*) FROM files").fetchone()[0] == 2
        assert check(conn).ok  # one unbroken custody chain however the writers interleaved
