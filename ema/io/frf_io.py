"""One entry point for FRF test files, by extension: .uff/.unv (UFF), .csv, .npz.

``read_test`` is the reader the pipeline uses: besides reading, it demands FRFs that hold a
signal at a usable scale (``frf_assembly.require_signal``) and a driving point (a reference
node equal to a response node), as the input contract does.
"""

from __future__ import annotations

import os
from pathlib import Path

from ema.io.frf_assembly import require_signal
from ema.io.frf_csv import read_frf_csv, write_frf_csv
from ema.io.frf_data import FrfTest
from ema.io.frf_npz import read_frf_npz, write_frf_npz
from ema.io.uff import read_uff, write_uff

READERS = {".uff": read_uff, ".unv": read_uff, ".csv": read_frf_csv, ".npz": read_frf_npz}
WRITERS = {".uff": write_uff, ".unv": write_uff, ".csv": write_frf_csv, ".npz": write_frf_npz}


def _suffix(path: Path, table: dict) -> str:
    ext = path.suffix.lower()
    if ext not in table:
        raise ValueError(f"{path}: unknown FRF file type {ext!r} (expected .uff, .unv, .csv "
                         "or .npz)")
    return ext


def require_driving_point(test: FrfTest, path: str | os.PathLike) -> FrfTest:
    """Return ``test`` unchanged if it has a driving-point FRF; ValueError naming ``path``."""
    try:
        _ = test.driving_point
    except ValueError:
        raise ValueError(
            f"{path}: no driving-point FRF (no impact node equals the response node(s) "
            f"{test.response_nodes.tolist()})"
        ) from None
    return test


def read_test(path: str | os.PathLike, require_driving: bool = True) -> FrfTest:
    """Read an FRF test file of any supported type (.uff/.unv, .csv, .npz).

    Every FRF must hold a signal at a usable scale (``require_signal``). By default the test
    must have a driving point; ``batlab fit`` reads without that check (it then gives
    unscaled shapes).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension chooses the reader.
    require_driving : bool, optional
        Refuse a test without a driving-point FRF (default True).

    Returns
    -------
    FrfTest
        The test in SI units.

    Raises
    ------
    OSError
        The file cannot be read.
    ValueError
        Its content is not a usable FRF test (one line naming the file and the problem).
    """
    path = Path(path)
    test = READERS[_suffix(path, READERS)](path)
    require_signal(test.frf, test.response_nodes, test.reference_nodes, str(path))
    return require_driving_point(test, path) if require_driving else test


def write_test(path: str | os.PathLike, test: FrfTest) -> None:
    """Write an FRF test file, its type chosen by extension (UFF written binary).

    Parameters
    ----------
    path : str or os.PathLike
        The file (.uff/.unv, .csv or .npz), replaced atomically.
    test : FrfTest
        The test, SI units.
    """
    path = Path(path)
    WRITERS[_suffix(path, WRITERS)](path, test)
