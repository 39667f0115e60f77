"""``registry copy``: every bat, file, inspection, calibration and custody record into another.

The source's chain is verified first, from one snapshot; everything is written in one write
transaction on the destination, whose chain is verified before that transaction commits, so
a refused or failed copy leaves the destination as it was.

Two ways to land, chosen by the destination:

- **verbatim** (its chain is empty: a lab moving its registry to a server, or back): every
  row and every custody record as it is, same numbers, same signatures, same head;
- **appended** (it already holds a chain: a league registry holding other labs' bats): the
  source's files, bats and inspections are re-recorded as new records at the end of the
  destination's chain, signed by the key running the copy, inspections renumbered and each
  pointing at its bat's re-recorded registration.

Either way a signed ``seal`` record (subject ``copy``) closes the copy, its payload naming the
source's head (``SEQ:SHA256``), the keys that signed the source and how many records it held:
the league's chain anchors the lab's, and ``registry check --head`` on the lab's own registry
proves that head is still there. A serial already in the destination is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import sqlalchemy as sa

from batlab.registry.chain import (
    append_record,
    bat_payload,
    calibration_payload,
    canonical,
    custody_rows,
    head,
    inspection_payload,
    lab_key_id,
)
from batlab.registry.lock import snapshot, transaction
from batlab.registry.records import store_file
from batlab.registry.schema import (
    TABLES,
    bats,
    calibrations,
    custody,
    files,
    inspections,
    stations,
)
from batlab.registry.verify import check
from batlab.version import code_version


@dataclass(frozen=True)
class CopyResult:
    """What ``registry copy`` moved: counts, how it landed, the two heads."""

    mode: str
    n_bats: int
    n_files: int
    n_inspections: int
    n_records: int
    source_head: str
    head: str


def _count(conn: sa.Connection, table: sa.Table) -> int:
    return int(conn.execute(sa.select(sa.func.count()).select_from(table)).scalar())


def _refuse_unverified(res, where: str, when: str) -> None:
    if not res.ok:
        raise ValueError(f"{where}: custody chain does not verify {when} ({res.problems[0]}; "
                         "`batlab registry check` lists all); nothing copied")


def copy_registry(src: sa.Connection, dst: sa.Connection, trusted: set[str] | None,
                  source: str = "source", destination: str = "destination") -> CopyResult:
    """Copy registry ``src`` into ``dst`` (verbatim into an empty one, else appended).

    Parameters
    ----------
    src, dst : sqlalchemy.Connection
        Open registries (either dialect); ``src`` is only read.
    trusted : set of str or None
        Key ids accepted as signers on both sides (the copying lab's own is added for
        the destination: it signs the closing seal); None: the signatures' consistency
        only (``registry check`` without ``--trust``).
    source, destination : str
        How messages name the two registries.

    Returns
    -------
    CopyResult
        The counts copied, ``verbatim`` or ``appended``, the source's head and the
        destination's head after the copy.

    Raises
    ------
    ValueError
        One line, nothing written: the source does not verify or is empty, a serial is in
        both, or the destination would not verify after the copy.
    """
    with snapshot(src):
        before = check(src, trusted)
        _refuse_unverified(before, source, "before the copy")
        if not before.n_records:
            raise ValueError(f"{source}: holds no custody record: nothing to copy")
        with transaction(dst):
            mode = _copy_rows(src, dst, source, destination)
            signers = sorted({r.signer for r in custody_rows(src) if r.signer})
            append_record(dst, "seal", "copy", None, canonical({
                "copied_from": before.head, "source_signers": signers,
                "source_records": before.n_records, "mode": mode, "code": code_version()}))
            after = None if trusted is None else trusted | {lab_key_id()}
            _refuse_unverified(check(dst, after), destination, "after the copy")
            counts = (_count(src, bats), _count(src, files), _count(src, inspections))
            return CopyResult(mode, *counts, before.n_records, before.head, head(dst))


def _copy_rows(src: sa.Connection, dst: sa.Connection, source: str, destination: str) -> str:
    """Write the source's rows into the destination; return how (verbatim or appended)."""
    serials = set(src.execute(sa.select(bats.c.serial)).scalars())
    both = sorted(serials & set(dst.execute(sa.select(bats.c.serial)).scalars()))
    if both:
        raise ValueError(f"{destination}: already holds bat(s) {', '.join(both[:5])} of "
                         f"{source} (conflicting serials); nothing copied")
    if _count(dst, custody) == 0 and _count(dst, files) == 0:
        _copy_verbatim(src, dst)
        return "verbatim"
    _copy_appended(src, dst)
    return "appended"


def _copy_verbatim(src: sa.Connection, dst: sa.Connection) -> None:
    """Copy every row of every table as it is (parents first)."""
    for table in TABLES:
        rows = [dict(r) for r in src.execute(sa.select(table)).mappings()]
        if rows:
            dst.execute(sa.insert(table), rows)
    if dst.dialect.name == "postgresql":  # ids were given: move the id sequences past them
        for table in ("inspections", "calibrations"):
            dst.exec_driver_sql(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                                f"coalesce(max(id), 0) + 1, false) FROM {table}")


def _copy_appended(src: sa.Connection, dst: sa.Connection) -> None:
    """Re-record the source's files, bats and inspections at the end of the destination."""
    chain = custody_rows(src)
    for r in chain:
        if r.kind == "file":
            name, content = src.execute(sa.select(files.c.name, files.c.content)
                                        .where(files.c.sha256 == r.subject)).one()
            store_file(dst, name, bytes(content))
    for table in (bats, stations):
        rows = [dict(r) for r in src.execute(sa.select(table)).mappings()]
        if rows:
            dst.execute(sa.insert(table), rows)
    latest = {r.subject: r.seq for r in chain if r.kind == "reference"}
    new_seq: dict[int, int] = {}
    for r in chain:
        if r.kind == "reference":  # the latest as the rows now read (a file kept once under
            payload = (canonical(bat_payload(dst, r.subject))  # another lab's name keeps that)
                       if latest[r.subject] == r.seq else r.payload)
            new_seq[r.seq] = append_record(dst, "reference", r.subject, None, payload)
        elif r.kind == "verdict":
            _copy_inspection(src, dst, int(r.subject), new_seq)
        elif r.kind == "calibration":
            _copy_calibration(src, dst, int(r.subject))


def _copy_inspection(src: sa.Connection, dst: sa.Connection, inspection_id: int,
                     new_seq: dict[int, int]) -> None:
    """Store one source inspection anew, renumbered, with its verdict record."""
    row = dict(src.execute(sa.select(inspections).where(inspections.c.id == inspection_id))
               .mappings().one())
    del row["id"]
    ref = row["reference_seq"]
    row.update(reference_seq=None if ref is None else new_seq[ref], record_seq=None)
    new_id = int(dst.execute(sa.insert(inspections).values(**row)).inserted_primary_key[0])
    seq = append_record(dst, "verdict", str(new_id), None,
                        canonical(inspection_payload(dst, new_id)))
    dst.execute(sa.update(inspections).where(inspections.c.id == new_id).values(record_seq=seq))


def _copy_calibration(src: sa.Connection, dst: sa.Connection, calibration_id: int) -> None:
    """Store one source calibration anew, renumbered, with its calibration record."""
    row = dict(src.execute(sa.select(calibrations).where(calibrations.c.id == calibration_id))
               .mappings().one())
    del row["id"]
    row["record_seq"] = None
    new_id = int(dst.execute(sa.insert(calibrations).values(**row)).inserted_primary_key[0])
    seq = append_record(dst, "calibration", str(new_id), None,
                        canonical(calibration_payload(dst, new_id)))
    dst.execute(sa.update(calibrations).where(calibrations.c.id == new_id)
                .values(record_seq=seq))
