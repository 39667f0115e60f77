"""The chance as measured: a calibration stored by the function ``fleet calibrate --store``
uses, read by ``inspect`` (stand-in numerics), printed as (1 + b) / (n + 1) exactly; without
one, said unmeasured in the terminal lines, the JSON reasons and the report; a tampered
calibration fails ``registry check``; a stored verdict names the code that judged it; the
schema-6 migration on PostgreSQL; copies keep calibrations."""

from __future__ import annotations

import json
import math
import sqlite3

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import batlab.pipeline as pipeline
from batlab import registry as reg
from batlab.fleet.calibrate import BatSpec, check_resumed, store_calibration, summary, upper95
from batlab.version import code_version
from tests.inspect_standins import SAMPLE, run_cli, stand_in_lab
from updating.inspect.nested import STATISTIC_VERSION
from updating.tails import measured_chance, pareto_tail

SPEC = BatSpec(str(SAMPLE / "profile.csv"), str(SAMPLE / "meta.json"), 1)


@pytest.fixture
def lab(tmp_path, monkeypatch):
    return stand_in_lab(tmp_path, monkeypatch)


def sample_model() -> str:
    profile = pipeline.bat_profile(SAMPLE / "profile.csv")
    meta = pipeline.read_meta_dict(SAMPLE / "meta.json")
    return pipeline.model_name(profile, meta["species"], meta)


def rows_of(F: list[float | None], statuses: list[str] | None = None) -> list[dict]:
    """Calibration rows as ``inspect_clean`` writes them (None: no statistic)."""
    statuses = statuses or ["not_altered"] * len(F)
    return [{"index": i + 1, "grip": None, "status": s, "reasons": [], "F": f,
             "p": None if f is None else 0.5, "dof": [6, 40], "code": code_version(),
             "cpu_s": 3.0} for i, (f, s) in enumerate(zip(F, statuses, strict=True))]


def store(db, F, statuses=None, model=None, false_alarm=0.01):
    """Store a synthetic calibration of the sample bat's model (``store_calibration``)."""
    rows = rows_of(F, statuses)
    spec = BatSpec(SPEC.profile_path, SPEC.meta_path, 1, false_alarm)
    with reg.open_registry(db) as conn:
        return store_calibration(conn, model or sample_model(), rows,
                                 summary(rows, spec, "HX-2001"))


def stateless(lab, *extra):
    return ["inspect", "--profile", lab / "profile.csv", "--meta", lab / "meta.json",
            "--baseline", lab / "baseline.uff", "--retest", lab / "retest_corked.uff", *extra]


def stand_in_F(lab, capsys) -> float:
    """The stand-in inspector's statistic for the corked re-test (read from its evidence)."""
    code, _, err = run_cli(["register", "--profile", lab / "profile.csv", "--meta",
                            lab / "meta.json", "--baseline", lab / "baseline.uff"], capsys)
    assert code == 0, err
    code, out, err = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                              "--json"], capsys)
    assert code == 0, err
    with reg.open_registry(lab / "reg.sqlite", create=False) as conn:
        return float(reg.history(conn, "HX-2001")[-1].verdict["statistic"])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.none(), st.floats(0, 50, allow_nan=False)), min_size=1,
                max_size=300), st.floats(0, 60, allow_nan=False))
def test_measured_chance_is_one_plus_b_over_n_plus_one(null, F):
    values = [math.nan if v is None else v for v in null]
    b = sum(1 for v in null if v is not None and v >= F)
    got = measured_chance(F, values)
    assert (got.value, got.exceeding, got.n) == ((1 + b) / (len(null) + 1), b, len(null))


def test_the_tail_fit_extrapolates_only_beyond_a_large_enough_tail():
    rng = np.random.default_rng(3)
    null = rng.exponential(2.0, size=3000)  # P(F >= s) = exp(-s/2) exactly
    far = 2.0 * math.log(3000) + 4.0  # beyond the largest stored value, most likely
    tail = pareto_tail(far, null)
    assert tail is not None and 0.2 * math.exp(-far / 2) < tail < 5 * math.exp(-far / 2)
    assert pareto_tail(far, null[:100]) is None  # 10 values above the threshold: no fit
    assert pareto_tail(1.0, null) is None  # not in the tail


_REGISTERED: dict[str, float] = {}


@settings(max_examples=8, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_the_printed_chance_is_one_plus_b_over_n_plus_one(lab, capsys, data):
    """Hide a calibration of random n and statistics around the inspected F; the JSON that
    ``inspect`` prints (both forms) states (1 + b) / (n + 1) exactly, with that run's n,
    count and bound, and the stateless form's terminal lines say where it was measured."""
    if str(lab) not in _REGISTERED:  # once per lab: hypothesis keeps the fixture's folder
        _REGISTERED[str(lab)] = stand_in_F(lab, capsys)
    F = _REGISTERED[str(lab)]
    n = data.draw(st.integers(1, 400), label="n")
    null = data.draw(st.lists(st.one_of(st.none(), st.floats(0.0, 2 * F), st.just(F)),
                              min_size=n, max_size=n), label="null")
    statuses = data.draw(st.lists(st.sampled_from(["not_altered", "inconclusive", "altered"]),
                                  min_size=n, max_size=n), label="statuses")
    db = lab / "reg.sqlite"
    stored = store(db, null, statuses)
    b = sum(1 for v in null if v is not None and v >= F)
    k = statuses.count("altered")
    for argv in (stateless(lab, "--db", db, "--json"),
                 ["inspect", "--serial", "HX-2001", lab / "retest_corked.uff", "--again",
                  "--json"]):
        code, out, err = run_cli(argv, capsys)
        assert code == 0, err
        ch = json.loads(out)["chance"]
        assert ch["source"] == "calibration" and ch["value"] == (1 + b) / (n + 1)
        assert ch["calibration"] == {
            "model": sample_model(), "n": n, "exceeding": b, "false_alarms": k,
            "false_alarm_upper95": upper95(k, n), "record_seq": stored.record_seq,
            "statistic": "F", "statistic_version": STATISTIC_VERSION, "code": code_version(),
            "signer": None, "shipped": False}
        fa = json.loads(out)["false_alarm_rate"]
        assert fa["source"] == "calibration" and fa["measured"] == k / n
    code, out, _ = run_cli(stateless(lab, "--db", db), capsys)
    said = f"as measured on {n:,} clean re-tests of bat model {sample_model()}"
    assert code == 0 and said in out and "unmeasured" not in out


def test_without_a_calibration_the_chance_is_said_unmeasured(lab, capsys, monkeypatch):
    """No stored calibration of the bat's model (another model's is there): the JSON says
    nominal, its reasons, the terminal lines and the report say unmeasured."""
    db = lab / "reg.sqlite"
    store(db, [1.0, 2.0, 3.0], model="another-model")
    code, out, err = run_cli(stateless(lab, "--db", db, "--json"), capsys)
    assert code == 0, err
    v = json.loads(out)
    assert v["chance"]["source"] == "nominal" and v["chance"]["calibration"] is None
    assert v["chance"]["value"] == v["chance"]["nominal"] == pytest.approx(0.001)
    assert v["false_alarm_rate"]["source"] == "unmeasured"
    assert any("unmeasured, no calibration of bat model" in r for r in v["reasons"])
    assert not any("differs this much: 0.1 %" in r for r in v["reasons"])  # no bare nominal
    code, out, _ = run_cli(stateless(lab, "--db", db, "-o", lab / "rep"), capsys)
    assert code == 0
    lines = [ln for ln in out.splitlines() if "differs this much" in ln]
    assert len(lines) == 1  # said once: in the reason that holds it (issue 50)
    assert "unmeasured" in lines[0] and "is not a measured rate" in lines[0]
    assert "false-alarm rate unmeasured" in out
    page = (lab / "rep" / "index.html").read_text()
    assert "this much: unmeasured" in page and "not a measured rate" in page
    monkeypatch.setenv("BATLAB_DB", str(lab / "none-yet.sqlite"))
    code, out, err = run_cli(stateless(lab, "--json"), capsys)  # no registry at $BATLAB_DB
    assert code == 0 and "no registry at $BATLAB_DB" in json.loads(out)["chance"]["unmeasured"]
    code, _, err = run_cli(stateless(lab, "--db", lab / "nothere.sqlite"), capsys)
    assert code == 2 and "no registry there" in err  # a --db named must exist


def test_a_stored_verdict_names_the_code_that_wrote_it(lab, capsys):
    stand_in_F(lab, capsys)
    with reg.open_registry(lab / "reg.sqlite", create=False) as conn:
        (done,) = reg.history(conn, "HX-2001")
        record = json.loads(reg.custody_rows(conn)[done.record_seq - 1].payload)
        bat = reg.get_bat(conn, "HX-2001")
    assert done.verdict["code"] == done.inputs["batlab_version"] == code_version()
    assert record["verdict"]["code"] == code_version() and bat.code == code_version()
    code, out, _ = run_cli(["inspect", "--serial", "HX-2001", lab / "retest_corked.uff",
                            "--json"], capsys)  # already inspected: the stored verdict
    assert code == 0 and json.loads(out)["code"] == code_version()


def test_a_tampered_calibration_fails_the_check(lab, capsys):
    db = lab / "reg.sqlite"
    stored = store(db, [0.5, 1.5, 7.0, None])
    code, out, _ = run_cli(["registry", "check", "--json"], capsys)
    assert code == 0, out
    code, out, _ = run_cli(["registry", "calibrations", "--json"], capsys)
    (listed,) = json.loads(out)
    assert listed["n"] == 4 and listed["with_statistic"] == 3 and listed["model"] == \
        sample_model() and listed["record_seq"] == stored.record_seq
    raw = sqlite3.connect(db)
    raw.execute("UPDATE calibrations SET null_json = replace(null_json, '7.0', '70.0')")
    raw.commit()
    raw.close()
    code, out, _ = run_cli(["registry", "check", "--json"], capsys)
    assert code == 1 and json.loads(out)["problems"] == [
        f"calibration #{stored.id}: stored calibration differs from custody record "
        f"#{stored.record_seq}"]
    code, _, err = run_cli(stateless(lab, "--db", db), capsys)  # not used as it is
    assert code == 2 and "differs from its custody record" in err
    raw = sqlite3.connect(db)
    raw.execute("DELETE FROM calibrations")
    raw.commit()
    raw.close()
    code, out, _ = run_cli(["registry", "check", "--json"], capsys)
    assert code == 1 and json.loads(out)["problems"] == [
        f"custody record #{stored.record_seq}: calibration #{stored.id} is no longer in the "
        "registry (rows deleted)"]


def test_a_resumed_calibration_under_other_code_says_so():
    row = rows_of([2.5])[0]
    assert check_resumed("rows.jsonl", row, dict(row)) is None
    old = dict(row, code="0.1.0+gdeadbeef1")
    said = check_resumed("rows.jsonl", old, row)
    assert "other code" in said and "0.1.0+gdeadbeef1" in said and code_version() in said
    with pytest.raises(ValueError, match="stored by batlab 0.1.0\\+gdeadbeef1, judged again"):
        check_resumed("rows.jsonl", old, dict(row, F=3.5))


def test_the_model_name_is_the_profile_unless_meta_names_it():
    profile = pipeline.bat_profile(SAMPLE / "profile.csv")
    name = pipeline.model_name(profile, "white ash")
    assert name == pipeline.model_name(profile, " White Ash")
    assert name.startswith("white-ash-34.0in-")
    noisy = type(profile)(profile.x_m, profile.diameter_m + 1e-5)  # a caliper's thousandth
    assert pipeline.model_name(noisy, "white ash") != name
    assert pipeline.model_name(profile, "sugar maple") != name
    assert pipeline.model_name(profile, "white ash", {"model": " Pro 271 "}) == "Pro 271"


def test_copies_keep_calibrations(lab, capsys, tmp_path):
    stand_in_F(lab, capsys)
    store(lab / "reg.sqlite", [1.0, None, 3.0])
    for dst in (tmp_path / "empty.sqlite", tmp_path / "league.sqlite"):
        if dst.name == "league.sqlite":  # holds a chain already: appended
            store(dst, [9.0], model="league-model")
        code, out, err = run_cli(["registry", "copy", "--from", lab / "reg.sqlite", "--to", dst,
                                  "--json"], capsys)
        assert code == 0, err
        with reg.open_registry(dst, create=False) as conn:
            assert reg.check(conn).ok
            copied = reg.latest_calibration(conn, sample_model())
        assert copied.null["F"] == [1.0, None, 3.0] and copied.n == 3


def test_schema6_migration_on_postgresql(pg_url):
    """A server registry at schema 5 (custody's kind check without 'calibration', no
    calibrations table, no bats.code) is upgraded in place and takes calibrations."""
    import sqlalchemy as sa

    with reg.open_registry(pg_url) as conn:  # created at 7, then taken back to 5's layout
        conn.exec_driver_sql("DROP TABLE calibrations")
        conn.exec_driver_sql("ALTER TABLE bats DROP COLUMN code")
        conn.exec_driver_sql("ALTER TABLE custody DROP CONSTRAINT custody_kind")
        conn.exec_driver_sql("ALTER TABLE custody ADD CONSTRAINT custody_kind CHECK (kind IN "
                             "('file', 'reference', 'verdict', 'seal'))")
        conn.exec_driver_sql("UPDATE alembic_version SET version_num = '0005'")
        conn.commit()
    with reg.open_registry(pg_url) as conn:
        assert reg.schema_version(conn) == 7
        assert "code" in {c["name"] for c in sa.inspect(conn).get_columns("bats")}
    stored = store(pg_url, [1.0, 2.0])
    with reg.open_registry(pg_url, create=False) as conn:
        assert reg.check(conn).ok and reg.latest_calibration(conn, sample_model()).id == \
            stored.id


def test_a_report_drawn_by_other_code_says_so(lab, capsys, monkeypatch):
    """``batlab report`` of a verdict another version of batlab judged shows both versions."""
    import batlab.report

    stand_in_F(lab, capsys)
    monkeypatch.setattr(batlab.report, "code_version", lambda: "9.9.9+gfeedface1")
    code, _, err = run_cli(["report", "HX-2001", "-o", lab / "again"], capsys)
    assert code == 0, err
    page = (lab / "again" / "index.html").read_text()
    assert (f"judged by batlab {code_version()}, this report drawn by batlab 9.9.9+gfeedface1"
            in page)
    assert f"<td>Code that judged (batlab version)</td><td>{code_version()}</td>" in page
