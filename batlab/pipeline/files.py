"""The lab's files in and out: FRF tests, profile.csv, meta.json, retest.json, CSV.

Every reader turns a bad file into a one-line ``ValueError`` naming it. ``Progress``
callables receive one-line messages (the commands print them on stderr).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from batlab.registry import sha256_bytes
from ema.io.atomic_write import atomic_write
from ema.io.frf_data import FrfTest
from updating.correlate.points import POINT_TOL_M
from updating.inspect.retest_meta import RetestConditions, read_retest_meta
from updating.model.lab_input import BatMeta, read_meta
from updating.model.profile import Profile, read_profile_csv
from updating.model.units import IN_TO_M

Progress = Callable[[str], None]
"""A callable taking one-line progress messages."""


def quiet(_: str) -> None:
    """Drop a progress message (the default ``Progress``)."""
    return None


def read_frf(path: str | os.PathLike) -> FrfTest:
    """Read an FRF test file (UFF, CSV, NPZ) with a driving point.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    FrfTest
        Its FRFs.

    Raises
    ------
    ValueError
        A one-line error naming the file when it is missing or unreadable.
    """
    from ema.io.frf_io import read_test

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        return read_test(path)
    except (ValueError, OSError):
        raise
    except Exception as exc:  # a reader's internal error on a damaged file
        raise ValueError(f"{path}: unreadable FRF file ({type(exc).__name__}: {exc})") from None


def frf_from_bytes(content: bytes, name: str, label: str | None = None) -> FrfTest:
    """Read an FRF file's bytes, its format from ``name``'s extension.

    Parameters
    ----------
    content : bytes
        The file's bytes.
    name : str
        The file's name (its extension gives the format).
    label : str or None
        What errors name (default ``name``), not the temporary copy.

    Returns
    -------
    FrfTest
        Its FRFs.
    """
    with tempfile.TemporaryDirectory(prefix="batlab-") as tmp:
        path = Path(tmp) / Path(name).name
        path.write_bytes(content)
        try:
            return read_frf(path)
        except ValueError as exc:
            raise ValueError(str(exc).replace(str(path), label or name)) from None


def read_bat_files(profile_path, meta_path) -> tuple[Profile, BatMeta]:
    """Read a bat's profile.csv and meta.json.

    Parameters
    ----------
    profile_path, meta_path : str or os.PathLike
        The two files.

    Returns
    -------
    profile : Profile
        The outer profile.
    meta : BatMeta
        The bat's meta.json.

    Raises
    ------
    ValueError
        A missing file, or test points past the end of the bat, naming the file.
    """
    for p in (profile_path, meta_path):
        if not Path(p).is_file():
            raise ValueError(f"{p}: no such file")
    profile = read_profile_csv(profile_path)
    meta = read_meta(meta_path)
    if meta.points_m.size and meta.points_m.max() > profile.length_m + POINT_TOL_M:
        raise ValueError(f"{meta_path}: points_in run past the end of the bat "
                         f"({profile.length_m / IN_TO_M:.2f} in long in {profile_path})")
    return profile, meta


def read_conditions(path) -> RetestConditions | None:
    """Read the optional retest.json: the re-test's weight, accelerometer mass, temperature.

    Parameters
    ----------
    path : str or os.PathLike or None
        The file, or None when not given.

    Returns
    -------
    RetestConditions or None
        The conditions, None without a file.
    """
    return None if path is None else read_retest_meta(path)


def read_meta_dict(path) -> dict:
    """Read meta.json as a dict (for the report's provenance).

    Parameters
    ----------
    path : str or os.PathLike
        meta.json.

    Returns
    -------
    dict
        Its keys as read.
    """
    return dict(read_meta(path).extra)


def file_sha256(path) -> str:
    """Return a file's SHA-256, hex.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    str
        The hex digest of its bytes.
    """
    return sha256_bytes(Path(path).read_bytes())


def write_csv(path, table) -> None:
    """Write a pandas DataFrame as CSV, atomically (temporary name, then rename).

    Parameters
    ----------
    path : str or os.PathLike
        The file written.
    table : pandas.DataFrame
        The table.
    """
    atomic_write(path, lambda tmp: table.to_csv(tmp, index=False))
