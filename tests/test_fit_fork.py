"""The fits' second core (``updating.inspect.parallel``): when it forks, and that the forked
results are the sequential ones."""

import os
import threading

import numpy as np
import pytest

from batlab.cli_support import progress_printer, stop_all
from updating.inspect import parallel


def _square_sum(seed: int) -> float:
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((60, 60))
    return float(np.linalg.eigvalsh(a @ a.T).sum())


def _two_cores() -> bool:
    return len(os.sched_getaffinity(0)) >= 2 if hasattr(os, "sched_getaffinity") else False


@pytest.mark.skipif(not _two_cores(), reason="one core: the fits never fork")
def test_the_progress_heartbeat_does_not_stop_the_fork(monkeypatch):
    """A command's heartbeat thread is quiet; any other thread keeps the fits sequential."""
    monkeypatch.delenv("BATLAB_FIT_WORKERS", raising=False)
    if not parallel._can_fork():
        pytest.skip("an earlier test left a thread running in this process")
    progress = progress_printer("test")
    try:
        progress("a long step")
        assert any(t.name.startswith(parallel.QUIET_THREAD_PREFIX)
                   for t in threading.enumerate())
        assert parallel._can_fork()
        stop = threading.Event()
        other = threading.Thread(target=stop.wait, name="someone-else", daemon=True)
        other.start()
        try:
            assert not parallel._can_fork()
        finally:
            stop.set()
            other.join()
    finally:
        stop_all()
    monkeypatch.setenv("BATLAB_FIT_WORKERS", "1")
    assert not parallel._can_fork()


def test_forked_results_are_the_sequential_ones(monkeypatch):
    seeds = [3, 1, 4, 1, 5]
    monkeypatch.setenv("BATLAB_FIT_WORKERS", "1")
    alone = parallel.fork_map(_square_sum, seeds)
    monkeypatch.delenv("BATLAB_FIT_WORKERS")
    assert parallel.fork_map(_square_sum, seeds) == alone == [_square_sum(s) for s in seeds]


def test_an_error_in_the_child_is_raised_in_the_parent():
    def fails(i: int) -> int:
        if i == 2:
            raise ValueError("item 2 is bad")
        return i

    with pytest.raises(ValueError, match="item 2 is bad"):
        parallel.fork_map(fails, [1, 2])
