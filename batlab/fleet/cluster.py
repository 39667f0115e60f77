"""Spread a fleet's bats over a Dask cluster and gather them back in order.

``connect`` opens a client on a running scheduler (``tcp://HOST:PORT``) or, without one, on a
``distributed.LocalCluster`` sized to the machine: one worker process per core, one thread
each (batlab's matrices are small; BLAS threads only contend), without the workers'
statistical profiler (it samples every task's stack every 10 ms). Dask's nanny starts its
workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also freezes glibc's mmap threshold at
128 kB, so every FE matrix and eigenvector block of the fits is mapped and unmapped afresh:
an inspection took 6.5-7 s in a worker against 3.5-4 s in a plain process. ``plain_heap``,
called by each task, gives the worker the thresholds glibc's own adaptation reaches (the
same numbers, at plain-process speed). ``ordered_map``, through ``on_plain_heap`` submits one
task per item and returns the results in item order whatever order they finish in; each
finished item can be handed to ``on_result`` (the client storing verdicts as they come), and
progress (count, rate, elapsed time) goes to ``progress`` about every ``every_s`` seconds.
"""

from __future__ import annotations

import ctypes
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import cache, partial

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD_BYTES = 32 * 2**20
"""glibc's largest dynamic mmap threshold on 64-bit (``DEFAULT_MMAP_THRESHOLD_MAX``), B."""


@cache
def plain_heap() -> bool:
    """Give this process glibc's adapted heap thresholds, once (module docstring).

    ``mallopt(M_MMAP_THRESHOLD, 32 MiB)`` and ``mallopt(M_TRIM_THRESHOLD, 64 MiB)``: blocks
    below 32 MiB come from the heap, and the heap is trimmed past 64 MiB free, as glibc
    settles by itself in a process that frees its large blocks, unless an environment
    variable (a Dask nanny's ``MALLOC_TRIM_THRESHOLD_``) fixed the thresholds. Numbers are
    unchanged; only where memory comes from.

    Returns
    -------
    bool
        True when set; False off glibc (nothing to do).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:  # musl and others: their allocators differ
        return False
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and \
        bool(libc.mallopt(M_TRIM_THRESHOLD, 2 * MMAP_THRESHOLD_BYTES))


def local_workers() -> int:
    """Return the worker processes a local cluster gets: the cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


@contextmanager
def connect(scheduler: str | None = None, workers: int | None = None) -> Iterator:
    """Open a Dask client: on ``scheduler`` if given, else on a local cluster.

    Parameters
    ----------
    scheduler : str or None
        A running scheduler's address (``tcp://127.0.0.1:8786``); None starts a
        ``LocalCluster`` of processes, one thread each, closed on exit.
    workers : int or None
        The local cluster's worker processes (default ``local_workers()``).

    Yields
    ------
    distributed.Client
        The client.
    """
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler, timeout="20s") as client:
            yield client
        return
    local = {"n_workers": workers or local_workers(), "threads_per_worker": 1, "processes": True,
             "host": "127.0.0.1", "dashboard_address": "127.0.0.1:0"}  # any free port
    with dask.config.set({"distributed.worker.profile.enabled": False}), \
            LocalCluster(**local) as cluster, Client(cluster) as client:
        yield client


def on_plain_heap(fn: Callable, item):
    """Return ``fn(item)`` with ``plain_heap()`` set first (a worker's task)."""
    plain_heap()
    return fn(item)


def _rate_line(label: str, done: int, total: int, elapsed_s: float) -> str:
    """Word a progress line: count, rate (items a minute) and elapsed time."""
    rate = 60.0 * done / elapsed_s if elapsed_s > 0 else 0.0
    left = (total - done) * elapsed_s / done if done else float("nan")
    return (f"{label}: {done}/{total} done, {rate:.1f} a minute, {elapsed_s:.0f} s elapsed, "
            f"~{left:.0f} s left")


def ordered_map(
    client, fn: Callable, items: Sequence, label: str, progress: Callable[[str], None],
    on_result: Callable[[int, object], None] | None = None, every_s: float = 10.0,
) -> list:
    """Run ``fn(item)`` for every item on the cluster; the results in item order.

    Parameters
    ----------
    client : distributed.Client
        The cluster's client.
    fn : callable
        A module-level function (sent to the workers by reference).
    items : sequence
        Its arguments, one task each.
    label : str
        What an item is, for the progress lines.
    progress : callable
        Receives one progress line at most every ``every_s`` seconds, and the last one.
    on_result : callable or None
        Called in the client as ``on_result(index, result)`` as each item finishes; what it
        returns is kept in the item's place (the result itself is then let go).
    every_s : float
        Seconds between progress lines.

    Returns
    -------
    list
        ``fn(item)`` (or what ``on_result`` made of it) for every item, in item order. A
        task's exception is raised here.
    """
    from distributed import as_completed

    keys = [f"{label}-{os.getpid()}-{time.time_ns()}-{i}" for i in range(len(items))]
    futures = client.map(partial(on_plain_heap, fn), items, key=keys)
    index = {f.key: i for i, f in enumerate(futures)}
    results: list = [None] * len(items)
    t0 = last = time.perf_counter()
    for done, future in enumerate(as_completed(futures), start=1):
        i = index[future.key]
        result = future.result()
        future.release()
        results[i] = result if on_result is None else on_result(i, result)
        now = time.perf_counter()
        if now - last >= every_s or done == len(items):
            progress(_rate_line(label, done, len(items), now - t0))
            last = now
    return results
