"""The lab's files in and out: FRF tests, profile.csv, meta.json, retest.json, CSV.

Every reader turns a bad file into a one-line ``ValueError`` naming it. ``Progress``
callables receive one-line messages (the commands print them on stderr). The re-test's
caliper profile (retest_profile.csv) is checked against the registered profile here.
"""

from __future__ import annotations

import os
import tempfile
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from batlab.registry import sha256_bytes
from ema.io.atomic_write import atomic_write
from ema.io.frf_data import FrfTest
from updating.correlate.points import POINT_TOL_M
from updating.inspect.retest_meta import RetestConditions, read_retest_meta
from updating.model import plausible
from updating.model.calipers import CaliperSurvey, read_survey_csv
from updating.model.json_input import read_json_object
from updating.model.lab_input import BatMeta, read_meta
from updating.model.profile import Profile, read_profile_csv
from updating.model.units import IN_TO_M

__all__ = [
    "file_sha256", "read_bat_files", "read_conditions", "read_frf", "read_meta_dict",
    "write_csv",
]


Progress = Callable[[str], None]
"""A callable taking one-line progress messages."""


def quiet(_: str) -> None:
    """Drop a progress message (the default ``Progress``)."""
    return None


def read_frf(path: str | os.PathLike, require_driving: bool = True) -> FrfTest:
    """Read an FRF test file (UFF, CSV, NPZ), with a driving point unless told otherwise.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    require_driving : bool
        Refuse a test without a driving-point FRF (``batlab fit`` reads without).

    Returns
    -------
    FrfTest
        Its FRFs (each holding a signal at a usable scale: ``ema.io.frf_io.read_test``).

    Raises
    ------
    ValueError
        A one-line error naming the file when it is missing, unreadable or unusable.
    """
    from ema.io.frf_io import read_test

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: is a directory, not a file" if path.is_dir() else
                         f"{path}: no such file")
    try:
        return read_test(path, require_driving=require_driving)
    except ValueError:
        raise
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except Exception as exc:  # a reader's internal error on a damaged file
        raise ValueError(f"{path}: unreadable FRF file ({type(exc).__name__}: {exc})") from None


@contextmanager
def numeric_failure(name: str) -> Iterator[None]:
    """Make a failure inside the block one line naming the file.

    A fit's linear algebra failing on a file's numbers (``LinAlgError`` "Singular matrix",
    an overflow) is a ValueError naming ``name`` and the usual cause (the file's units or
    scale); another ValueError (scipy's "Residuals are not finite", a band too narrow) gets
    the file's name in front.

    Parameters
    ----------
    name : str
        The file the block works on.
    """
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"{name}: the fit failed on its numbers ({text}): check the FRFs' "
                         "units and scale") from None
    except ValueError as exc:
        if str(exc).startswith(name):
            raise
        raise ValueError(f"{name}: {exc}") from None


SAME_TEST_REL = 1e-5
"""FRFs closer than this, relative to the baseline's largest |H|, are one test, not two.

Two impact tests of a bat differ by their noise and by the hammer's and the support's
repeatability, 1e-3 of the peak and more; a copy differs by nothing, a copy written in
another format by its text's rounding (a UFF's six significant digits: 5e-7)."""


def same_test_reason(baseline_label: str, baseline: FrfTest, baseline_bytes: bytes,
                     retest_label: str, retest: FrfTest, retest_bytes: bytes) -> str | None:
    """Say why a re-test is its baseline over again (None when they are two tests).

    The same bytes, or the same frequency lines, points and quantity with FRFs equal within
    ``SAME_TEST_REL`` of the baseline's largest magnitude. A re-test identical to its
    baseline would clear any bat, so it is refused, naming both files.

    Parameters
    ----------
    baseline_label, retest_label : str
        The files, as messages name them.
    baseline, retest : FrfTest
        Their FRFs.
    baseline_bytes, retest_bytes : bytes
        Their content.

    Returns
    -------
    str or None
        One line naming the re-test and the baseline, or None.
    """
    end = ("two tests of a bat are never identical, so this one would clear any bat: "
           "refused (give a new test of the bat)")
    if baseline_bytes == retest_bytes:
        return (f"{retest_label}: the re-test is the baseline {baseline_label} itself (the "
                f"same bytes, sha256 {sha256_bytes(retest_bytes)[:16]}...); {end}")
    same_shape = (baseline.frf.shape == retest.frf.shape
                  and baseline.quantity == retest.quantity
                  and np.array_equal(baseline.freq_hz, retest.freq_hz)
                  and np.array_equal(baseline.response_nodes, retest.response_nodes)
                  and np.array_equal(baseline.reference_nodes, retest.reference_nodes))
    if not same_shape:
        return None
    scale = float(np.max(np.abs(baseline.frf))) or 1.0
    diff = float(np.max(np.abs(retest.frf - baseline.frf))) / scale
    if diff > SAME_TEST_REL:
        return None
    return (f"{retest_label}: its FRFs equal the baseline {baseline_label}'s (largest "
            f"difference {diff:.1e} of the peak; two tests differ by 1e-3 or more): the "
            f"baseline under another name or format; {end}")


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
        A missing file, test points off the bat, or a value no wooden bat has
        (``updating.model.plausible``), naming the file.
    """
    profile, meta = read_profile(profile_path), read_meta_file(meta_path)
    check_bat(profile, meta, profile_path, meta_path)
    return profile, meta


def check_bat(profile: Profile, meta: BatMeta, profile_path, meta_path) -> None:
    """Check a bat's profile and meta.json together against what a wooden bat can be.

    ``updating.model.plausible``: the profile's length and diameters, meta.json's weight and
    species values, and its test points on the bat.

    Parameters
    ----------
    profile : Profile
        The outer profile.
    meta : BatMeta
        The bat's meta.json.
    profile_path, meta_path : str or os.PathLike
        The two files, for the message.

    Raises
    ------
    ValueError
        One line naming the file and the key.
    """
    message = (plausible.check_profile(profile.x_m, profile.diameter_m, str(profile_path))
               or plausible.check_meta(meta.extra, str(meta_path))
               or plausible.check_points(meta.points_m, profile.x_m, POINT_TOL_M, str(meta_path)))
    if message:
        raise ValueError(message)
    if meta.points_m.size and meta.points_m.max() > profile.length_m + POINT_TOL_M:
        raise ValueError(f"{meta_path}: points_in run past the end of the bat "
                         f"({profile.length_m / IN_TO_M:.2f} in long in {profile_path})")


def read_profile(path) -> Profile:
    """Read profile.csv (``read_profile_csv``).

    One refused for its size that is in mm (or cm, m) is named so.
    """
    try:
        return read_profile_csv(path)
    except ValueError:
        try:
            with warnings.catch_warnings():  # an empty file: the reader's message stands
                warnings.simplefilter("ignore")
                rows = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=(0, 1),
                                     ndmin=2)
            x_m, d_m = rows[:, 0] * IN_TO_M, rows[:, 1] * IN_TO_M
            slip = plausible.check_profile(x_m, d_m, str(path)) if np.isfinite(rows).all() else None
        except (ValueError, OSError, IndexError):
            slip = None
        if slip and slip.endswith("metres?"):
            raise ValueError(slip) from None
        raise


def read_meta_file(path) -> BatMeta:
    """Read meta.json (``read_meta``).

    A value outside its range that is a unit slip is named as one (``plausible.check_meta``).
    """
    try:
        return read_meta(path)
    except ValueError:
        try:
            slip = plausible.check_meta(read_json_object(path), str(path))
        except ValueError:
            slip = None
        if slip and " looks like " in slip:
            raise ValueError(slip) from None
        raise


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


def read_retest_profile(path, registered: Profile) -> CaliperSurvey | None:
    """Read the optional retest_profile.csv and check it against the registered profile.

    Parameters
    ----------
    path : str or os.PathLike or None
        The re-test's caliper profile (``x_in,diameter_in,angle_deg``), or None.
    registered : Profile
        The bat's registered profile.

    Returns
    -------
    CaliperSurvey or None
        The readings, None without a file.

    Raises
    ------
    ValueError
        One line naming the file: unreadable, a unit slip, another bat's profile, knob and
        barrel swapped (``updating.model.plausible.check_survey``).
    """
    if path is None:
        return None
    if not Path(path).is_file():
        raise ValueError(f"{path}: no such file")
    survey = read_survey_csv(path)
    means = survey.mean_profile(str(path))
    message = plausible.check_survey(means.x_m, means.diameter_m, registered.x_m,
                                     registered.diameter_m, str(path))
    if message:
        raise ValueError(message)
    return survey


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

    A text cell that a spreadsheet would run as a formula is neutralised first
    (``batlab.safe_text.for_csv_cell``, OWASP's rule).

    Parameters
    ----------
    path : str or os.PathLike
        The file written.
    table : pandas.DataFrame
        The table.
    """
    from batlab.safe_text import for_csv_cell

    text = table.astype(object).map(for_csv_cell) if len(table) else table
    atomic_write(path, lambda tmp: text.to_csv(tmp, index=False))
