"""Several `batlab register` / `batlab inspect --serial` processes on one registry at once.

The numerics are the test-only stand-ins (this checks the registry under the real command
line, in real processes, not the modal fit)."""

from __future__ import annotations

import json
import multiprocessing as mp
import shutil
from pathlib import Path

from batlab.registry import check, history, list_bats, open_registry

SAMPLE = Path("data_samples/smooth_bat").resolve()


def _lab_worker(db: str, folder: str, serial: str, n_inspections: int) -> None:
    import batlab.pipeline.inspection as pipeline
    from batlab.cli import main
    from tests.inspect_standins import fake_calibrate, fake_fit, fake_inspect
    from updating.correlate import fitted

    fitted.fit_test, pipeline.calibrate = fake_fit, fake_calibrate
    pipeline.inspect = fake_inspect
    d = Path(folder)
    code = main(["register", "--profile", str(d / "profile.csv"), "--meta",
                 str(d / "meta.json"), "--baseline", str(SAMPLE / "baseline.uff"),
                 "--db", db, "--json"])
    assert code == 0
    for _ in range(n_inspections):
        assert main(["inspect", "--serial", serial, str(SAMPLE / "retest_corked.uff"),
                     "--db", db, "--json", "--again"]) == 0  # the same file: stored anew


def test_concurrent_register_and_inspect_processes(tmp_path):
    db = str(tmp_path / "lab.sqlite")
    ctx = mp.get_context("spawn")
    procs = []
    for k in range(3):
        folder = tmp_path / f"bat{k}"
        folder.mkdir()
        shutil.copyfile(SAMPLE / "profile.csv", folder / "profile.csv")
        meta = json.loads((SAMPLE / "meta.json").read_text())
        meta["serial"] = f"C-{k}"
        (folder / "meta.json").write_text(json.dumps(meta))
        procs.append(ctx.Process(target=_lab_worker, args=(db, str(folder), f"C-{k}", 3)))
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
