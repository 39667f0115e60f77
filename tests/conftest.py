"""Test session set-up: one BLAS thread (batlab's matrices are small; on 2 cores extra BLAS
threads only contend with each other), matplotlib without a display, and under pytest-xdist
no forked second fit (``updating.inspect.parallel``): the workers already fill the cores,
and a fork per multi-start fit only copies the caches and contends (the inspection tests
205 s against 217 s on 2 cores, measured together)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.setdefault("BATLAB_FIT_WORKERS", "1")


import pytest  # noqa: E402


@pytest.fixture(autouse=True, scope="session")
def _private_signing_key(tmp_path_factory):
    """Every test (and every CLI subprocess it starts, which inherits os.environ) signs with a
    throw-away lab key under a per-session XDG_CONFIG_HOME, never the real ~/.config."""
    old = {k: os.environ.get(k) for k in ("XDG_CONFIG_HOME", "BATLAB_KEY")}
    os.environ["XDG_CONFIG_HOME"] = str(tmp_path_factory.mktemp("xdg-config"))
    os.environ.pop("BATLAB_KEY", None)
    yield
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


@pytest.fixture(scope="session")
def pg_server_url():
    """A PostgreSQL 15 server of this test session (one per xdist worker), on a Unix socket.

    Yields the URL of its ``batlab`` database; skipped, with the reason, only when the server
    binaries are absent (tests/pg_server.py).
    """
    import shutil
    import tempfile
    from pathlib import Path

    from tests.pg_server import missing_reason, pg_server

    reason = missing_reason()
    if reason:
        pytest.skip(reason)
    folder = Path(tempfile.mkdtemp(prefix="batlab-pg-"))  # short: a socket path has a limit
    try:
        with pg_server(folder) as url:
            yield url
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def pg_url(pg_server_url, request):
    """A fresh, empty database on the session's PostgreSQL server, as a ``postgresql://`` URL."""
    import re

    from tests.pg_server import create_database

    pg_url.count = getattr(pg_url, "count", 0) + 1
    name = re.sub(r"\W", "_", request.node.name.lower())[:40] + f"_{pg_url.count}"
    return create_database(pg_server_url, name)
