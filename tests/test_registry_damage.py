"""Nothing is written into a damaged registry: garbage written into random b-tree pages of a
registry holding verdicts, then every command that writes must refuse in one line naming the
file and `batlab registry check`, exit 2, the file's bytes unchanged; reads answer with one
warning line. Whether a file is damaged is decided here by SQLite's own ``quick_check`` on a
read-only copy, independently of batlab (garbage that lands in a page's unused space, or that
reads as other valid values, is not damage SQLite can see: those files are counted, not
judged, and the test requires a third of the drawn files at least to be damaged)."""

from __future__ import annotations

import hashlib
import json
import random
import shutil
import sqlite3
import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.inspect_standins import SAMPLE, bat_folders, run_cli, stand_in_lab


def page_size(data: bytes) -> int:
    """The file's page size from its header (bytes 16-17, big-endian; 1 means 65536)."""
    size = struct.unpack(">H", data[16:18])[0]
    return 65536 if size == 1 else size


def btree_pages(data: bytes, roots: list[int]) -> list[int]:
    """Every page of the b-trees rooted at ``roots``: interior pages (types 2, 5) name their
    children (a 4-byte page number at each cell and the right-most pointer at header byte 8),
    leaves (10, 13) end the walk. Overflow and free pages are not b-tree pages."""
    size, seen, todo = page_size(data), set(), list(roots)
    while todo:
        page = todo.pop()
        if page in seen:
            continue
        seen.add(page)
        base = (page - 1) * size
        head = base + (100 if page == 1 else 0)
        if data[head] in (2, 5):
            n_cells = struct.unpack(">H", data[head + 3:head + 5])[0]
            todo.append(struct.unpack(">I", data[head + 8:head + 12])[0])
            for i in range(n_cells):
                cell = struct.unpack(">H", data[head + 12 + 2 * i:head + 14 + 2 * i])[0]
                todo.append(struct.unpack(">I", data[base + cell:base + cell + 4])[0])
    return sorted(seen)


def sqlite_finds_damage(path: Path) -> bool:
    """SQLite's own quick check, on a read-only opening of ``path`` (not batlab's code)."""
    try:
        with sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True) as c:
            rows = c.execute("SELECT CAST(quick_check AS BLOB) FROM pragma_quick_check"
                             ).fetchall()
    except (sqlite3.DatabaseError, UnicodeDecodeError):  # a garbled schema: not even read
        return True
    return rows != [(b"ok",)]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def lab(tmp_path, monkeypatch, capsys):
    """A registry with two bats and three verdicts (stand-in numerics), and the files the
    writing commands take: a second bat's meta.json, a good registry to copy from, a fleet
    folder of one re-test."""
    lab = stand_in_lab(tmp_path, monkeypatch)
    db = lab / "reg.sqlite"
    other = bat_folders(tmp_path, "HX-9", 2)
    for meta in (lab / "meta.json", other[0] / "meta.json"):
        code, _, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta", meta,
                                "--baseline", lab / "baseline.uff", "--db", db], capsys)
        assert code == 0, err
    for _ in range(3):
        code, _, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                                "--db", db, "--again"], capsys)
        assert code == 0, err
    shutil.copyfile(db, lab / "source.sqlite")
    (lab / "fleet").mkdir()
    shutil.copyfile(SAMPLE / "retest_corked.uff", lab / "fleet" / "HX-2001.uff")
    (lab / "new_meta.json").write_text((other[1] / "meta.json").read_text())
    assert not Path(f"{db}-wal").exists()  # every writer closed: the file holds it all
    return lab


def writers(lab: Path, db) -> dict[str, list]:
    """Every command that writes into the registry ``db``."""
    registration = ["--profile", lab / "profile.csv", "--baseline", lab / "baseline.uff"]
    retest = lab / "retest_corked.uff"
    return {
        "register (a new bat)": ["register", *registration, "--meta", lab / "new_meta.json"],
        "register --replace": ["register", *registration, "--meta", lab / "meta.json",
                               "--replace"],
        "inspect --serial --again": ["inspect", "--serial", "HX-2001", retest, "--again"],
        "inspect --serial (stored before)": ["inspect", "--serial", "HX-2001", retest],
        "registry copy --to": ["registry", "copy", "--from", lab / "source.sqlite", "--to", db],
        "fleet inspect": ["fleet", "inspect", lab / "fleet"],
        "demo --db": ["demo", "--out", lab / "demo"],
    }


def _run(args: list, db, capsys) -> tuple[int, str, str]:
    extra = [] if "copy" in args else ["--db", db]
    return run_cli([*args, *extra], capsys)


def test_the_undamaged_registry_takes_every_write(lab, capsys):
    """The control: on the same registry undamaged, the writers do write (so a refusal
    below is the damage's doing)."""
    db = lab / "reg.sqlite"
    before = sha256(db)
    for name, args in writers(lab, db).items():
        if name in ("fleet inspect", "demo --db", "registry copy --to"):
            continue  # a cluster, a simulation; a copy refuses serials already there
        code, _, err = _run(args, db, capsys)
        assert code == 0, (name, err)
    code, out, _ = run_cli(["history", "HX-2001", "--db", db, "--json"], capsys)
    assert code == 0 and len(json.loads(out)["inspections"]) == 4
    assert sha256(db) != before


def test_damaged_registry_refuses_every_write(lab, capsys):
    """Garbage over 1-3 random b-tree pages (from the page's start, or anywhere in it):
    whenever SQLite's quick check finds the file damaged, every writer exits 2 with one line
    naming the file and `batlab registry check`, and the file's bytes (and its write-ahead
    log) are unchanged; `history` and `bats` warn in one line; `registry check` says
    DAMAGED. A third of the drawn files at least must be damaged (the test cannot pass by
    judging none): garbage over a page's header always is, garbage elsewhere in it one time
    in four (it may land in unused space or read as other valid values)."""
    good = (lab / "reg.sqlite").read_bytes()
    with sqlite3.connect(lab / "source.sqlite") as c:
        roots = [1] + [r for (r,) in c.execute("SELECT rootpage FROM sqlite_schema "
                                               "WHERE rootpage > 0")]
    pages = btree_pages(good, roots)
    assert len(pages) > len(roots)  # interior pages too: the walk went down
    size = page_size(good)
    judged: list[bool] = []

    @settings(max_examples=25, deadline=None, database=None)
    @given(chosen=st.lists(st.sampled_from(pages), min_size=1, max_size=3, unique=True),
           from_start=st.booleans(), seed=st.integers(0, 2**32 - 1))
    def one(chosen, from_start, seed):
        rng = random.Random(seed)
        damaged = bytearray(good)
        for page in chosen:
            base = (page - 1) * size + (100 if page == 1 else 0)
            room = page * size - base
            start = 0 if from_start else rng.randrange(room - 16)
            n = rng.randint(16, room - start)
            damaged[base + start:base + start + n] = rng.randbytes(n)
        db = lab / "damaged.sqlite"
        db.write_bytes(bytes(damaged))
        judged.append(sqlite_finds_damage(db))
        if judged[-1]:
            refused_everywhere(lab, db, capsys, chosen)
        for leftover in lab.glob("damaged.sqlite*"):
            leftover.unlink()

    one()
    assert sum(judged) >= max(5, len(judged) // 3), judged


def refused_everywhere(lab: Path, db: Path, capsys, chosen) -> None:
    """Every writer refused in one line, the bytes unchanged; reads warn; check says so."""
    digest = sha256(db)
    for name, args in writers(lab, db).items():
        code, out, err = _run(args, db, capsys)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (name, chosen, err)
        assert "registry damaged" in lines[0] and db.name in lines[0], (name, lines)
        assert "`batlab registry check --db" in lines[0], (name, lines)
        assert sha256(db) == digest, (name, chosen)
        wal = Path(f"{db}-wal")
        assert not wal.exists() or wal.stat().st_size == 0, name
    for args in (["history", "HX-2001"], ["bats"]):
        code, out, err = _run(args, db, capsys)
        lines = err.strip().splitlines()
        assert "Traceback" not in err and sha256(db) == digest
        if lines and "not a usable batlab registry" in lines[0]:  # its schema unreadable
            assert code == 2 and len(lines) == 1 and db.name in lines[0]
            continue
        assert lines and "warning:" in lines[0] and "`batlab registry check --db" in lines[0]
        assert len(lines) <= 2 and code in (0, 2)  # the warning, then an error if any
    code, out, err = run_cli(["registry", "check", "--db", db], capsys)
    assert (code == 1 and "DAMAGED" in out) or "not a usable batlab registry" in err


@pytest.mark.parametrize("table", ["bats", "stations", "inspections", "custody"])
def test_damaged_server_registry_refuses_writes(lab, pg_url, capsys, table):
    """PostgreSQL: the header of a random page of a table holding rows garbled on disk (the
    server stopped); after its restart every writer is refused in one line naming the
    registry and `batlab registry check`, nothing stored (as many custody records as
    before), and a read warns in one line."""
    import sqlalchemy as sa

    from tests.pg_server import server_stopped

    for args in (["register", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
                  "--baseline", lab / "baseline.uff"],
                 ["inspect", "--serial", "HX-2001", lab / "retest_corked.uff"]):
        code, _, err = run_cli([*args, "--db", pg_url], capsys)
        assert code == 0, err
    engine = sa.create_engine(pg_url.replace("postgresql://", "postgresql+psycopg://"))
    count = "SELECT count(*) FROM alembic_version"  # a table left whole
    with engine.connect() as c:
        where = c.exec_driver_sql(f"SELECT pg_relation_filepath('{table}')").scalar()
        n_pages = c.exec_driver_sql(f"SELECT pg_relation_size('{table}') / 8192").scalar()
        n_records = c.exec_driver_sql("SELECT max(seq) FROM custody").scalar()
    engine.dispose()
    rng = random.Random(table)
    page = rng.randrange(n_pages)
    with server_stopped(pg_url) as data:
        heap = bytearray((data / where).read_bytes())
        heap[page * 8192:page * 8192 + 24] = rng.randbytes(8) + b"\xff" * 16  # its header
        (data / where).write_bytes(bytes(heap))
    for name, args in writers(lab, pg_url).items():
        code, out, err = _run(args, pg_url, capsys)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (name, table, err)
        assert "registry damaged" in lines[0] and "`batlab registry check --db" in lines[0]
    code, out, err = run_cli(["history", "HX-2001", "--db", pg_url], capsys)
    assert "warning:" in err.splitlines()[0] and "registry damaged" in err
    engine = sa.create_engine(pg_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.connect() as c:
        assert c.exec_driver_sql(count).scalar() == 1
        if table != "custody":
            assert c.exec_driver_sql("SELECT max(seq) FROM custody").scalar() == n_records
    engine.dispose()
