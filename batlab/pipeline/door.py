"""The door: a command's input files and options checked before any work.

A command calls ``admit`` first; nothing is fitted, created or opened for writing before
it has passed, in this order:

1. **options** (``NUMBERS``, the serial, the registry): a number finite and within its
   range, a serial that can name a bat (``lab_input.serial_problem``), ``--db`` or
   ``$BATLAB_DB`` a file's path or a postgresql:// URL (``cli_support.db_path``);
2. **each input file** an option names (``INPUTS``, one entry per option): a file, not a
   directory, read by its reader, whose errors are one line naming the file, the key (or row
   and column) and what was expected. Keys and columns a file has that batlab does not use
   are ignored, as the contract says, and said once (``note``);
3. **the files together** (``together``): profile.csv and meta.json against what a wooden
   bat can be (``files.check_bat``), meta.json's points_in against the baseline's impact
   points, a baseline an inspection can use (``updating.diagnose.pairing_check.MIN_POINTS``
   points at least, the barrel covered: ``updating.inspect.checks.coverage_reason``), the
   re-test's points against the baseline's, a re-test that is the baseline over again
   (``files.same_test_reason``), ``--serial`` against meta.json's serial, the moisture
   readings of meta.json and retest.json on the bat profile.csv describes
   (``updating.inspect.retest_meta.stations_problem``; against a registered bat's profile,
   ``batlab.pipeline.registered.inspect_registered``);
4. **what the command writes** (``outputs``, ``registry``): a file's directory exists, a
   directory or the registry's file is what it must be (or can be made), and each is
   writable; nothing is created here.

Every refusal is a ``ValueError`` of one line; ``batlab.cli`` prints it and exits 2.
Adding an input file to a command is one entry in ``INPUTS`` (and, if it must agree with
another file, a check in ``together``).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from batlab.pipeline.files import (
    check_bat,
    read_conditions,
    read_frf,
    read_meta_file,
    read_profile,
    same_test_reason,
)
from updating.model.bar import read_bar_json
from updating.model.json_input import read_json_object, shown, unused_keys
from updating.model.lab_input import CONDITION_KEYS, META_KEYS, serial_problem
from updating.model.profile import unused_columns

__all__ = ["admit", "check_output", "check_registry"]


@dataclass(frozen=True)
class LabFile:
    """An input file an option names.

    Attributes
    ----------
    option : str
        The option, as messages name it (``--meta``).
    what : str
        What the file is, as messages say it ("meta.json").
    read : callable
        ``read(path)``: the file's content; ValueError of one line naming the file when
        unusable.
    unused : callable or None
        ``unused(path)``: the file's keys or columns batlab does not use (ignored).
    """

    option: str
    what: str
    read: Callable[[Path], object]
    unused: Callable[[Path], list[str]] | None = None


def _unused_json(keys: dict, path: Path) -> list[str]:
    return unused_keys(read_json_object(path), keys)


INPUTS: dict[str, LabFile] = {  # argparse dest: the file it names
    "profile": LabFile("--profile", "profile.csv", read_profile,
                       unused_columns),
    "meta": LabFile("--meta", "meta.json", read_meta_file, partial(_unused_json, META_KEYS)),
    "baseline": LabFile("--baseline", "the baseline test", read_frf),
    "frf": LabFile("--frf", "an FRF test", read_frf),
    "retest": LabFile("--retest", "the re-test", read_frf),
    "retest_file": LabFile("R.uff", "the re-test", read_frf),
    "test": LabFile("TEST", "an FRF test", partial(read_frf, require_driving=False)),
    "retest_meta": LabFile("--retest-meta", "retest.json", read_conditions,
                           partial(_unused_json, CONDITION_KEYS)),
    "bar": LabFile("--bar", "the reference bar's JSON", read_bar_json),
}
"""Every input file an option names, by the option's argparse ``dest``."""

NUMBERS: dict[str, tuple[str, float, float]] = {  # dest: (option, lowest, highest)
    "band": ("--band", 0.0, 1e6),
    "mass_kg": ("--mass-kg", 1e-3, 1e4),
    "min_snr": ("--min-snr", 0.0, 1e6),
    "max_order": ("--max-order", 2, 1000),
    "min_gain": ("--min-gain", 0.0, 100.0),
    "freq_tol": ("--freq-tol", 0.0, 100.0),
    "max_damping": ("--max-damping", 0.0, 100.0),
    "scale_tol": ("--scale-tol", 0.0, 100.0),
    "records": ("--records", 0, 100),
}
"""Numeric options: finite and within [lowest, highest] (``--band``: each end, increasing)."""


def _number(value, option: str, lo: float, hi: float) -> None:
    if not lo <= value <= hi:  # NaN fails too
        raise ValueError(f"{option} {value:g}: expected a number from {lo:g} to {hi:g}")


def check_options(args: argparse.Namespace, serial_label: str = "--serial") -> None:
    """Check a command's numeric options (``NUMBERS``) and its serial.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    serial_label : str
        How the serial is given, for the message (``--serial``, or ``SERIAL`` positional).

    Raises
    ------
    ValueError
        One line naming the option and what was expected.
    """
    for dest, (option, lo, hi) in NUMBERS.items():
        value = getattr(args, dest, None)
        if value is None:
            continue
        for v in value if isinstance(value, list) else [value]:
            _number(v, option, lo, hi)
        if isinstance(value, list) and not value[0] < value[1]:
            raise ValueError(f"{option} {value[0]:g} {value[1]:g}: expected LO_HZ below HI_HZ")
    serial = getattr(args, "serial", None)
    if serial is not None:
        problem = serial_problem(serial)
        if problem:
            raise ValueError(f"{serial_label}: a serial {problem}, not {shown(serial)}")


def read_inputs(args: argparse.Namespace, note: Callable[[str], None]) -> dict[str, object]:
    """Read every input file the command line names (``INPUTS``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    note : callable
        Receives one line per file with keys or columns batlab does not use.

    Returns
    -------
    dict
        Each given option's ``dest``: the file's content as its reader returns it.
    """
    out = {}
    for dest, lab_file in INPUTS.items():
        given = getattr(args, dest, None)
        if given is None:
            continue
        path = Path(given)
        if path.is_dir():
            raise ValueError(f"{path}: is a directory, not a file ({lab_file.option}: "
                             f"{lab_file.what})")
        if not path.is_file():
            raise ValueError(f"{path}: no such file ({lab_file.option}: {lab_file.what})")
        out[dest] = lab_file.read(path)
        unused = lab_file.unused(path) if lab_file.unused else []
        if unused:
            note(f"{path}: {', '.join(map(repr, unused))} not used (ignored)")
    return out


def together(args: argparse.Namespace, read: dict[str, object]) -> None:
    """Check the files a command line names against each other.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (the files' paths, for messages).
    read : dict
        ``read_inputs``' result.

    Raises
    ------
    ValueError
        One line naming the file and the key that disagree.
    """
    from updating.correlate.points import (
        listed_points_reason,
        match_points,
        point_positions_m,
    )
    from updating.diagnose.pairing_check import MIN_POINTS
    from updating.inspect.checks import coverage_reason
    from updating.inspect.retest_meta import conditions_from_dict, stations_problem

    profile, meta = read.get("profile"), read.get("meta")
    if profile is not None and meta is not None:
        check_bat(profile, meta, args.profile, args.meta)
        serial = getattr(args, "serial", None)
        if serial is not None and serial != meta.serial:
            raise ValueError(f"{args.meta}: key 'serial' {meta.serial!r} differs from "
                             f"--serial {serial!r}")
    if profile is not None:  # meta.json's readings alone: its other keys are judged above
        readings = None if meta is None else conditions_from_dict(
            {k: meta.extra[k] for k in ("moisture",) if k in meta.extra}, args.meta)
        for dest, cond in (("meta", readings), ("retest_meta", read.get("retest_meta"))):
            why = stations_problem(cond, profile.length_m)
            if why:
                raise ValueError(f"{getattr(args, dest)}: {why}")
    base_dest = next((d for d in ("baseline", "frf") if d in read), None)
    if meta is not None and base_dest:
        base_path = getattr(args, base_dest)
        points = point_positions_m(read[base_dest])
        why = listed_points_reason(meta.points_m, points, str(base_path))
        if why:
            raise ValueError(f"{args.meta}: key 'points_in' {why}")
        if points.size < MIN_POINTS:
            raise ValueError(f"{base_path}: {points.size} impact point(s), a baseline needs "
                             f"at least {MIN_POINTS} (mode shapes are paired over them)")
        why = coverage_reason(points, profile.length_m) if profile is not None and \
            base_dest == "baseline" else None
        if why:
            raise ValueError(f"{base_path}: {why}")
    re_dest = next((d for d in ("retest", "retest_file") if d in read), None)
    if base_dest and re_dest:
        base_path, re_path = Path(getattr(args, base_dest)), Path(getattr(args, re_dest))
        why = same_test_reason(str(base_path), read[base_dest], base_path.read_bytes(),
                               str(re_path), read[re_dest], re_path.read_bytes())
        if why:
            raise ValueError(why)
        match_points(point_positions_m(read[base_dest]), point_positions_m(read[re_dest]),
                     str(re_path))


def _nearest_existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _writable_dir(path: Path, shown_as: str, what: str) -> None:
    """Refuse unless ``path`` (a directory, or where one can be made) is writable."""
    base = _nearest_existing(path)
    if not base.is_dir():
        raise ValueError(f"{shown_as}: {what} not writable ({base} is a file, not a "
                         "directory)")
    if not os.access(base, os.W_OK | os.X_OK):
        raise ValueError(f"{shown_as}: {what} not writable ({base}: permission denied)")


def check_output(path, option: str, kind: str) -> None:
    """Check, creating nothing, that a command can write its output there.

    Parameters
    ----------
    path : str or os.PathLike
        The output.
    option : str
        Its option, for the message.
    kind : str
        ``"file"`` (its directory must exist) or ``"dir"`` (made if needed, later).

    Raises
    ------
    ValueError
        One line naming the path and the option.
    """
    p = Path(path)
    if kind == "file":
        if p.is_dir():
            raise ValueError(f"{p}: {option} destination is a directory, not a file")
        if not p.parent.is_dir():
            raise ValueError(f"{p}: {option} destination's directory {p.parent} does not "
                             "exist")
        _writable_dir(p.parent, str(p), f"{option} destination")
    else:
        if p.exists() and not p.is_dir():
            raise ValueError(f"{p}: {option} destination is not a directory")
        _writable_dir(p, str(p), f"{option} destination")


def _read_only_mount(path: Path) -> bool:
    """Return whether ``path`` lies on a file system mounted read-only."""
    try:
        return bool(os.statvfs(path).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):  # (no statvfs on Windows)
        return False


def check_registry(db: Path | str, create: bool) -> None:
    """Check, creating nothing, that the registry can be opened for writing.

    A PostgreSQL URL is left to the server. A file must not be a directory; it and its
    directory must be writable (SQLite's write-ahead log needs both); a registry to be made
    (``create``) must have a writable directory, or one that can be made.

    Parameters
    ----------
    db : Path or str
        ``cli_support.db_path``'s registry.
    create : bool
        The command makes the registry when there is none (``register``).

    Raises
    ------
    ValueError
        One line naming the registry.
    """
    if isinstance(db, str):
        return
    if db.is_dir():
        raise ValueError(f"{db}: registry path is a directory (--db)")
    if db.exists():
        if _read_only_mount(db):
            raise ValueError(f"{db}: registry is read-only (on a read-only file system): "
                             "nothing can be stored in it; reading it works")
        if not os.access(db, os.W_OK) or not os.access(db.parent, os.W_OK | os.X_OK):
            raise ValueError(f"{db}: registry not writable (permission denied)")
    elif create:
        _writable_dir(db.parent, str(db), "the registry")


def admit(args: argparse.Namespace, note: Callable[[str], None],
          outputs: dict[str, str] | None = None, registry: Path | str | None = None,
          create: bool = False, serial_label: str = "--serial") -> dict[str, object]:
    """Check a command's options, input files and outputs before any work.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    note : callable
        Receives a line for each file with keys or columns batlab ignores.
    outputs : dict or None
        The command's outputs: ``dest`` -> ``"file"`` or ``"dir"``.
    registry : Path or str or None
        The registry the command writes (``cli_support.db_path``), None when it writes none.
    create : bool
        The command makes the registry when there is none.
    serial_label : str
        How the command takes a serial (``--serial``, or ``SERIAL`` positional).

    Returns
    -------
    dict
        Each input file's ``dest``: its content (``read_inputs``).

    Raises
    ------
    ValueError
        One line naming the file, option or key and what was expected.
    """
    check_options(args, serial_label)
    read = read_inputs(args, note)
    together(args, read)
    for dest, kind in (outputs or {}).items():
        if getattr(args, dest, None):
            check_output(getattr(args, dest), f"--{dest.replace('_', '-')}" if dest != "out"
                         else "-o/--out", kind)
    if registry is not None:
        check_registry(registry, create)
    return read
