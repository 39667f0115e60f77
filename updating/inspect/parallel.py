"""The independent starts of a multi-start fit, on a second core when there is one.

``fork_map(fn, items)`` is ``[fn(i) for i in items]``: the first half of the items (the
first one of two or three) in this process, the others in one forked child that inherits
every cache (no pickling of the model), its results
sent back through a pipe. The same computations run either way, so the results are the same
as sequential ones. It runs sequentially when forking is not safe or not useful: one item,
one core, a daemonic process (a Dask or multiprocessing worker may not have children),
other threads running (a fork copies their locks), no ``fork`` start method, or
``BATLAB_FIT_WORKERS=1`` in the environment. A thread named with ``QUIET_THREAD_PREFIX``
does not count: it promises to hold no lock the child's numerics take (the command line's
progress heartbeat, which sleeps and prints; the child never prints). Before this rule the
heartbeat alone kept every ``batlab inspect`` sequential.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from collections.abc import Callable, Iterable
from typing import TypeVar

QUIET_THREAD_PREFIX = "batlab-quiet-"
"""Name prefix of a thread that holds no lock a forked child's numerics need."""

T = TypeVar("T")
R = TypeVar("R")


def _can_fork() -> bool:
    """Say whether a child process may run part of the work (module docstring)."""
    if os.environ.get("BATLAB_FIT_WORKERS", "") == "1":
        return False
    if "fork" not in multiprocessing.get_all_start_methods():
        return False
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    others = [t for t in threading.enumerate() if t is not threading.main_thread()
              and not t.name.startswith(QUIET_THREAD_PREFIX)]
    return (cores or 1) >= 2 and not multiprocessing.current_process().daemon and \
        threading.current_thread() is threading.main_thread() and not others


def _child(fn: Callable, items: list, conn) -> None:
    """Run ``fn`` on ``items`` in the child and send ("ok", results) or ("error", exc)."""
    try:
        conn.send(("ok", [fn(i) for i in items]))
    except BaseException as exc:  # noqa: BLE001 - re-raised in the parent
        conn.send(("error", exc))
    finally:
        conn.close()


def fork_map(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """Return ``[fn(i) for i in items]``, the second half of the items in a forked child.

    Parameters
    ----------
    fn : callable
        The work on one item (a closure is fine: the child inherits it).
    items : iterable
        The items; their results must pickle.

    Returns
    -------
    list
        The results in the items' order.
    """
    items = list(items)
    if len(items) < 2 or not _can_fork():
        return [fn(i) for i in items]
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    half = len(items) // 2
    child = ctx.Process(target=_child, args=(fn, items[half:], send), daemon=True)
    child.start()
    send.close()
    try:
        first = [fn(i) for i in items[:half]]
        status, rest = recv.recv()
    finally:
        recv.close()
        child.join(timeout=60)
        if child.is_alive():
            child.terminate()
            child.join()
    if status == "error":
        raise rest
    return [*first, *rest]
