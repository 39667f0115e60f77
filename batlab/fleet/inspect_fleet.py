"""`batlab fleet inspect`'s work: a folder of re-tests inspected on the cluster, stored here.

Every ``SERIAL.uff`` of a folder is a re-test of registered bat SERIAL (``SERIAL.json``, when
present, its retest.json; ``SERIAL.profile.csv``, when present, its retest_profile.csv). A
worker opens the registry, reads the bat and judges the re-test as ``batlab inspect
--serial`` does (``pipeline.inspect_registered``) and sends back the verdict with the
re-test's bytes as judged; the client stores each one as it comes back
(``pipeline.store_inspection``), so the registry has one writer, the custody chain is
extended by one process, and workers need read access only. A re-test file already
inspected (no retest.json, no re-test profile) is not inspected again: its stored verdict
is given, as ``inspect --serial`` gives it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

import batlab.pipeline as pipeline
from batlab.fleet.cluster import ordered_map
from batlab.registry import open_registry


@dataclass(frozen=True)
class RetestJob:
    """One re-test of a fleet folder.

    Attributes
    ----------
    serial : str
        The registered bat (the file's stem).
    retest_path : str
        SERIAL.uff.
    retest_meta_path : str or None
        SERIAL.json when present.
    retest_profile_path : str or None
        SERIAL.profile.csv when present (the re-test's caliper profile).
    """

    serial: str
    retest_path: str
    retest_meta_path: str | None
    retest_profile_path: str | None = None


def retest_jobs(folder) -> list[RetestJob]:
    """List a folder's re-tests, by file name.

    Parameters
    ----------
    folder : str or os.PathLike
        The folder of ``SERIAL.uff`` files (and ``SERIAL.json``).

    Returns
    -------
    list of RetestJob
        One per ``.uff`` file, sorted by name, with its SERIAL.json and SERIAL.profile.csv.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: no such folder")
    files = sorted(folder.glob("*.uff"))
    if not files:
        raise ValueError(f"{folder}: no SERIAL.uff re-test in it")
    def beside(p: Path, suffix: str) -> str | None:
        q = p.with_suffix(suffix)
        return str(q) if q.is_file() else None

    return [RetestJob(p.stem, str(p), beside(p, ".json"), beside(p, ".profile.csv"))
            for p in files]


def inspect_job(db: str, false_alarm: float, job: RetestJob):
    """Judge one re-test against the registry (a worker's task; nothing stored).

    Returns
    -------
    InspectionResult or str
        The result, slimmed to what storing and printing take (serial, verdict,
        registration, re-test bytes), or the one-line reason the re-test was refused.
    """
    try:
        with open_registry(db, create=False) as conn:
            result = pipeline.inspect_registered(conn, job.serial, job.retest_path, false_alarm,
                                                 retest_meta_path=job.retest_meta_path,
                                                 with_map=False,
                                                 retest_profile_path=job.retest_profile_path)
    except (ValueError, OSError) as exc:
        return f"{job.retest_path}: {exc}"
    return replace(result, baseline=None, retest=None, profile=None, reference=None)


def _stored_before(conn, job: RetestJob, false_alarm: float) -> dict | None:
    """Return the stored verdict of a re-test file already inspected (None: not yet)."""
    if job.retest_meta_path is not None or job.retest_profile_path is not None:
        return None
    try:
        done = pipeline.already_inspected(conn, job.serial, job.retest_path, false_alarm)
    except (ValueError, OSError):  # not registered: the worker words the refusal
        return None
    return None if done is None else pipeline.stored_contract_dict(done.verdict, done.inputs)


def inspect_fleet(client, db, jobs: list[RetestJob], false_alarm: float,
                  progress) -> list[dict]:
    """Inspect every re-test on the cluster and store each verdict as it comes back.

    Parameters
    ----------
    client : distributed.Client
        The cluster's client.
    db : str or os.PathLike
        The registry (workers open it too).
    jobs : list of RetestJob
        The re-tests.
    false_alarm : float
        The decision's false-alarm rate.
    progress : callable
        Receives one-line messages.

    Returns
    -------
    list of dict
        Per re-test, in ``jobs``' order: the object ``batlab inspect --json`` prints, or
        ``{"serial", "retest", "error"}`` for a re-test refused.
    """
    with open_registry(db, create=False) as conn:
        out = [_stored_before(conn, job, false_alarm) for job in jobs]
        todo = [i for i, o in enumerate(out) if o is None]
        if len(todo) < len(jobs):
            progress(f"{len(jobs) - len(todo)} re-test file(s) already inspected: their stored "
                     "verdicts, not stored again")

        def store(k: int, result) -> dict:
            job = jobs[todo[k]]
            if isinstance(result, str):
                progress(f"refused: {result}")
                return {"serial": job.serial, "retest": job.retest_path, "error": result}
            stored = pipeline.store_inspection(conn, result, job.retest_path, false_alarm,
                                               retest_meta=job.retest_meta_path is not None)
            out = pipeline.result_dict(result)
            progress(f"{job.serial}: {out['status']} (stored as inspection #{stored.id})")
            return out

        done = ordered_map(client, partial(inspect_job, str(db), false_alarm),
                           [jobs[i] for i in todo], "re-test", progress, store)
    for i, o in zip(todo, done, strict=True):
        out[i] = o
    return out
