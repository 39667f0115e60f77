"""The bat's outer profile: diameter along the axis, from a caliper CSV.

`profile.csv` has the header ``x_in,diameter_in`` with x from the knob end, non-decreasing;
a step in diameter is two rows at the same x (docs/contract.md). Between stations the
diameter varies linearly. With a third column ``angle_deg`` (the caliper's orientation, as
``retest_profile.csv`` has it) the rows at one x are that station's readings at several
orientations: the profile is their mean (a turned bat's ovality, ``cos 2(theta - theta0)``,
cancels in the mean of orientations spread evenly over 180 deg); an orientation read again
at the same x starts the step's barrel side (``orientation_groups``).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ema.io.atomic_write import atomic_write
from ema.io.finite import finite_number
from updating.model.units import IN_TO_M


@dataclass(frozen=True)
class Profile:
    """Outer diameter along the bat, SI.

    Attributes
    ----------
        x_m: (S,) stations from the knob end, m, non-decreasing (a repeated x is a step).
        diameter_m: (S,) outer diameter at each station, m.
    """

    x_m: np.ndarray
    diameter_m: np.ndarray

    @property
    def length_m(self) -> float:
        """Return the bat's length, m."""
        return float(self.x_m[-1] - self.x_m[0])

    def segments(self) -> np.ndarray:
        """(k, 4) rows (x0, x1, d0, d1) of the linear pieces of positive length."""
        x, d = self.x_m, self.diameter_m
        keep = np.diff(x) > 0
        return np.column_stack([x[:-1][keep], x[1:][keep], d[:-1][keep], d[1:][keep]])

    def diameter_at(self, x_m: np.ndarray) -> np.ndarray:
        """Outer diameter (m) at positions x_m; at a step, the value on the barrel side."""
        seg = self.segments()
        x = np.asarray(x_m, dtype=float)
        i = np.clip(np.searchsorted(seg[:, 0], x, side="right") - 1, 0, len(seg) - 1)
        t = np.clip((x - seg[i, 0]) / (seg[i, 1] - seg[i, 0]), 0.0, 1.0)
        return seg[i, 2] + t * (seg[i, 3] - seg[i, 2])


def check_readings(source: str, x: np.ndarray, d: np.ndarray, *others: np.ndarray,
                   noun: str = "stations") -> None:
    """Check a caliper file's columns, raising ValueError naming ``source`` and the row.

    One length, two rows or more, every value finite, x not decreasing, the diameters ``d``
    positive.
    """
    if x.ndim != 1 or any(v.shape != x.shape for v in (d, *others)):
        raise ValueError(f"{source}: the columns differ in length")
    if x.size < 2:
        raise ValueError(f"{source}: at least two {noun} are needed, found {x.size}")
    if not all(np.all(np.isfinite(v)) for v in (x, d, *others)):
        raise ValueError(f"{source}: non-numeric or missing values")
    bad = np.flatnonzero(np.diff(x) < 0)
    if bad.size:
        raise ValueError(f"{source}: x decreases at row {bad[0] + 3} (x must be non-decreasing)")
    if np.any(d <= 0):
        raise ValueError(f"{source}: diameter must be positive (row {np.argmax(d <= 0) + 2})")


def make_profile(x_m, diameter_m, source: str = "profile") -> Profile:
    """Validate stations and diameters; raise ValueError naming ``source`` on bad input."""
    x = np.asarray(x_m, dtype=float)
    d = np.asarray(diameter_m, dtype=float)
    check_readings(source, x, d)
    if x[-1] <= x[0]:
        raise ValueError(f"{source}: profile has zero length")
    if np.any((np.diff(x[:-1]) == 0) & (np.diff(x[1:]) == 0)):
        raise ValueError(f"{source}: more than two rows at the same x")
    return Profile(x - x[0], d)


PROFILE_COLUMNS = ("x_in", "diameter_in")
"""The columns a caliper CSV must have."""

OPTIONAL_COLUMNS = ("angle_deg",)
"""The columns read when present (a station's orientations); others are ignored
(``unused_columns``)."""


def _read_table(path: Path) -> tuple[list[str], list[list[str]]]:
    """Read a CSV file's header (cells stripped) and its non-blank rows."""
    if path.is_dir():
        raise ValueError(f"{path}: is a directory, not a file")
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            try:
                header = [h.strip() for h in next(reader)]
            except StopIteration:
                raise ValueError(f"{path}: empty file") from None
            return header, [r for r in reader if any(c.strip() for c in r)]
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (UTF-8 CSV expected)") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: not a CSV file ({exc})") from None
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror})") from None


def unused_columns(path: str | Path) -> list[str]:
    """Return the columns of profile.csv that batlab does not read (ignored), in file order."""
    header, _ = _read_table(Path(path))
    return [h for h in header if h not in PROFILE_COLUMNS + OPTIONAL_COLUMNS]


def _swapped(path: Path, x: list[float], d: list[float]) -> str | None:
    """Say whether the two columns hold each other's values (a swapped header)."""
    xs, ds = np.array(x), np.array(d)
    if xs.size > 2 and np.all(np.diff(ds) >= 0) and ds.max() > 2 * xs.max() and ds.max() > 5:
        return (f"{path}: columns x_in and diameter_in look swapped (diameter_in rises to "
                f"{ds.max():.4g} as x does, x_in stays within {xs.min():.3g}-{xs.max():.3g} "
                "as a diameter does): the header must name the columns as they are")
    return None


def read_caliper_rows(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a caliper CSV's rows: x and diameter (in), and the orientation (deg) if given.

    The header names the columns ``x_in``, ``diameter_in`` and optionally ``angle_deg``, in
    any order; other columns are ignored. A spreadsheet's byte-order mark, Windows line ends
    and blank lines are accepted. Every value must be a finite number (ranges are the
    callers' to check: a unit slip is named by ``plausible``).

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    x_in, diameter_in : ndarray
        The rows' stations and readings, in the file's order, in.
    angle_deg : ndarray or None
        The rows' orientations, deg, None without an ``angle_deg`` column.

    Raises
    ------
    ValueError
        One line naming the file: empty, not text, a missing column, a row that is not
        numbers.
    """
    path = Path(path)
    header, rows = _read_table(path)
    for col in PROFILE_COLUMNS:
        if col not in header:
            raise ValueError(f"{path}: missing column {col!r} (header must be x_in,diameter_in"
                             "[,angle_deg])")
    names = [c for c in PROFILE_COLUMNS + OPTIONAL_COLUMNS if c in header]
    cols = [header.index(c) for c in names]
    values = []
    for n, r in enumerate(rows, 2):
        try:
            values.append([float(r[i]) for i in cols])
        except (ValueError, IndexError):
            raise ValueError(f"{path}: row {n} is not {('two', 'three')[len(cols) - 2]} numbers "
                             f"{','.join(names)} "
                             f"({','.join(r)[:40]!r})") from None
    values = np.array(values, dtype=float).reshape(-1, len(cols))
    swapped = _swapped(path, list(values[:, 0]), list(values[:, 1]))
    if swapped:
        raise ValueError(swapped)
    for n, row in enumerate(values, 2):
        for name, v in zip(names, row, strict=True):
            finite_number(v, f"{path}: row {n} {name}")
    angle = values[:, 2] if len(cols) == 3 else None
    return values[:, 0], values[:, 1], angle


def orientation_groups(x_in: np.ndarray, angle_deg: np.ndarray) -> list[np.ndarray]:
    """Group caliper rows into stations: consecutive rows at one x, each orientation once.

    Orientations are taken modulo 180 deg (the jaws across at theta and theta + 180 read the
    same width). An orientation read again at the same x starts a new station there: the
    barrel side of a step, as two rows at one x are in a profile without orientations.

    Parameters
    ----------
    x_in, angle_deg : ndarray
        The rows' stations (in, to 1e-4 in) and orientations (deg), in the file's order.

    Returns
    -------
    list of ndarray
        The row indices of each station, in order.
    """
    key_x = np.round(np.asarray(x_in, dtype=float), 4)
    key_a = np.round(np.mod(np.asarray(angle_deg, dtype=float), 180.0), 3) % 180.0
    groups: list[list[int]] = []
    for i in range(key_x.size):
        g = groups[-1] if groups else None
        if g is not None and key_x[g[0]] == key_x[i] and key_a[i] not in key_a[g]:
            g.append(i)
        else:
            groups.append([i])
    return [np.array(g) for g in groups]


def read_profile_csv(path: str | Path) -> Profile:
    """Read a caliper profile CSV (``x_in,diameter_in``, inches) into SI.

    With an ``angle_deg`` column each station's diameter is the mean of its orientations
    (module docstring). A spreadsheet's byte-order mark, Windows line ends and blank lines
    are accepted.
    """
    x, d, angle = read_caliper_rows(path)
    for n, (xi, di) in enumerate(zip(x, d, strict=True), 2):
        finite_number(xi, f"{path}: row {n} x_in", -100.0, 200.0)
        finite_number(di, f"{path}: row {n} diameter_in", -np.inf, 20.0)
    if angle is not None and x.size:
        groups = orientation_groups(x, angle)
        x = np.array([x[g[0]] for g in groups])
        d = np.array([d[g].mean() for g in groups])
    return make_profile(x * IN_TO_M, d * IN_TO_M, str(path))


def write_profile_csv(path: str | Path, profile: Profile) -> None:
    """Write a profile as ``x_in,diameter_in`` (temporary file, then rename)."""
    rows = np.column_stack([profile.x_m, profile.diameter_m]) / IN_TO_M
    lines = ["x_in,diameter_in"] + [f"{x:.4f},{d:.4f}" for x, d in rows]
    atomic_write(path, lambda tmp: tmp.write_text("\n".join(lines) + "\n"))


def paper_profile() -> Profile:
    """Return the paper's stepped bat.

    Lengths x diameters, in: nub 1x1.25, handle 10x0.75, taper 10x1.725, barrel 12x2.7.
    """
    x_in = [0, 1, 1, 11, 11, 21, 21, 33]
    d_in = [1.25, 1.25, 0.75, 0.75, 1.725, 1.725, 2.7, 2.7]
    return make_profile(np.array(x_in) * IN_TO_M, np.array(d_in) * IN_TO_M, "paper bat")
