"""Test session set-up: one BLAS thread (batlab's matrices are small; on 2 cores extra BLAS
threads only contend with each other), and matplotlib without a display."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")


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
