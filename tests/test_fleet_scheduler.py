"""`batlab fleet` against a real Dask scheduler and workers (``dask scheduler``, ``dask
worker``) started here on 127.0.0.1 at a free port: ``fleet inspect`` gives, bat by bat, the
verdict ``inspect --serial`` gives (one bat, drawn at random, corked), and ``fleet
calibrate --n 8`` its counts and bound."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import batlab.pipeline as pipeline
from batlab.cli import main
from batlab.fleet.calibrate import upper95
from batlab.registry import history, open_registry

ROOT = Path(__file__).resolve().parents[1]
BUILTIN = pipeline.bench.builtin_dir()
DASK = str(Path(sys.executable).parent / "dask")
CORK = "cork:depth=10,d=1.0,ratio=0.3,plug=1"


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """A scheduler and two one-thread worker processes; yields the scheduler's address."""
    from distributed import Client

    tmp = tmp_path_factory.mktemp("dask")
    file = tmp / "scheduler.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get(
        "PYTHONPATH", "")]), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    common = dict(cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(file)], **common)]
    try:
        deadline = time.monotonic() + 60
        while not file.is_file() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(file.read_text())["address"]
        procs.append(subprocess.Popen([DASK, "worker", address, "--nworkers", "2",
                                       "--nthreads", "1", "--no-dashboard", "--host",
                                       "127.0.0.1", "--local-directory", str(tmp)], **common))
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def _register(db: Path, files, serial: str) -> None:
    args = ["register", "--profile", files.profile, "--meta", files.meta, "--baseline",
            files.baseline, "--db", db]
    assert main([str(a) for a in args]) == 0


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """Two registered bats (the same registry twice) and a folder of their re-tests."""
    tmp = tmp_path_factory.mktemp("lab")
    corked = int(np.random.default_rng().integers(2))
    folder = tmp / "retests"
    folder.mkdir()
    serials = ["FLT-1", "FLT-2"]
    for k, serial in enumerate(serials):
        work = tmp / serial
        work.mkdir()
        files = pipeline.simulate_demo_pair(work, 300 + k,
                                            alteration=CORK if k == corked else None)
        meta = json.loads(files.meta.read_text())
        files.meta.write_text(json.dumps(dict(meta, serial=serial)))
        for db in (tmp / "fleet.sqlite", tmp / "one.sqlite"):
            _register(db, files, serial)
        (folder / f"{serial}.uff").write_bytes(files.retest.read_bytes())
    return {"tmp": tmp, "folder": folder, "serials": serials, "corked": serials[corked]}


def test_fleet_inspect_gives_what_inspect_serial_gives(scheduler, lab, capsys):
    tmp = lab["tmp"]
    assert main(["fleet", "inspect", str(lab["folder"]), "--db", str(tmp / "fleet.sqlite"),
                 "--scheduler", scheduler, "--json"]) == 0
    fleet = json.loads(capsys.readouterr().out)
    one = []
    for serial in lab["serials"]:
        assert main(["inspect", "--serial", serial, str(lab["folder"] / f"{serial}.uff"),
                     "--db", str(tmp / "one.sqlite"), "--json"]) == 0
        one.append(json.loads(capsys.readouterr().out))
    assert [o["status"] for o in fleet] == [o["status"] for o in one]
    assert fleet == one
    assert [o["status"] == "altered" for o in fleet] == \
        [s == lab["corked"] for s in lab["serials"]]
    with open_registry(tmp / "fleet.sqlite", create=False) as conn:  # stored, once each
        assert [len(history(conn, s)) for s in lab["serials"]] == [1, 1]


def test_fleet_calibrate_on_the_scheduler(scheduler, tmp_path, capsys):
    rows = tmp_path / "rows.jsonl"
    assert main(["fleet", "calibrate", "--profile", str(BUILTIN / "profile.csv"), "--meta",
                 str(BUILTIN / "meta.json"), "--n", "8", "--seed", "3", "--scheduler",
                 scheduler, "--json", "-o", str(rows)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n"] == 8
    assert out["false_alarms"] + out["inconclusive"] + out["not_altered"] + out["refused"] == 8
    assert out["false_alarm_upper95"] == pytest.approx(upper95(out["false_alarms"], 8))
    if out["false_alarms"] == 0:
        assert out["false_alarm_upper95"] == pytest.approx(1 - 0.05 ** (1 / 8))
    assert sorted(json.loads(s)["index"] for s in rows.read_text().splitlines()) == \
        list(range(1, 9))


def test_fleet_inspect_refuses_an_unregistered_bat_and_goes_on(scheduler, lab, tmp_path,
                                                               capsys):
    folder = tmp_path / "mixed"
    folder.mkdir()
    (folder / "NOPE-9.uff").write_bytes((lab["folder"] / "FLT-1.uff").read_bytes())
    (folder / "FLT-2.uff").write_bytes((lab["folder"] / "FLT-2.uff").read_bytes())
    code = main(["fleet", "inspect", str(folder), "--db", str(lab["tmp"] / "one.sqlite"),
                 "--scheduler", scheduler, "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1
    assert out[0]["serial"] == "FLT-2" and out[0]["status"] in ("altered", "not_altered",
                                                                "inconclusive")
    assert out[1]["serial"] == "NOPE-9" and "NOPE-9.uff" in out[1]["error"]
