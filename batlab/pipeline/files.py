"""The lab's files in and out: FRF tests, profile.csv, meta.json, retest.json, modes, CSV.

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
from ema.modal_fit import MIN_SNR
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


def read_test_file(path, require_driving: bool = True) -> FrfTest:
    """Read an FRF test file as ``ema.io.frf_io.read_test`` reads it.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    require_driving : bool
        False allows a test without a driving point (`batlab fit`).

    Returns
    -------
    FrfTest
        Its FRFs.
    """
    from ema.io.frf_io import read_test

    return read_test(path, require_driving=require_driving)


def fit_test_file(test: FrfTest, band_hz=None, method: str = "lscf", max_order=None,
                  known_mass_kg: float | None = None, refine: bool = False,
                  min_snr: float = MIN_SNR):
    """Run `batlab fit`'s automatic modal analysis of a test (``ema.modal_fit.fit_test``).

    Parameters
    ----------
    test : FrfTest
        The FRFs.
    band_hz : tuple of float or None
        The band fitted, Hz (None: automatic).
    method : str
        The pole estimator.
    max_order : int or None
        The highest model order.
    known_mass_kg : float or None
        The bat's weighed mass, kg.
    refine : bool
        Refine the poles by a nonlinear fit.
    min_snr : float
        The least signal-to-noise ratio of a kept mode.

    Returns
    -------
    ModalFit
        The fit.
    """
    from ema.modal_fit import fit_test

    return fit_test(test, band_hz=band_hz, method=method, max_order=max_order,
                    known_mass_kg=known_mass_kg, refine=refine, min_snr=min_snr)


def write_modes_file(path, fit) -> None:
    """Write a fit's real mass-normalised modes as UFF 55 (``ema.io.uff_modes``).

    Parameters
    ----------
    path : str or os.PathLike
        The file written.
    fit : ModalFit
        The fit.
    """
    from ema.io.uff_modes import write_modes_uff

    write_modes_uff(path, fit.freq_hz, fit.damping_ratio, fit.real_shapes, fit.nodes, fit.x_m)


def plot_fit_files(fit, test: FrfTest, out_dir) -> list:
    """Draw a fit's stabilisation.png, synthesis.png and automac.png (``ema.plots.plot_fit``).

    Parameters
    ----------
    fit : ModalFit
        The fit.
    test : FrfTest
        Its FRFs (the fitted band is drawn).
    out_dir : str or os.PathLike
        The folder written to.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    from ema.plots import plot_fit

    sel = (test.freq_hz >= fit.band_hz[0]) & (test.freq_hz <= fit.band_hz[1])
    sel &= test.freq_hz > 0
    return list(plot_fit(fit, test.frf[sel], out_dir))


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
