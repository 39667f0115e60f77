"""The code that judged: batlab's version, a string that differs for every commit.

setuptools-scm writes it into the installed metadata at install time (pyproject.toml,
``[tool.setuptools_scm]``): ``X.Y.Z`` at a release tag, ``X.Y.Z.devN+gHASH`` N commits after
one (``0.2.0.devN+gHASH`` before the first tag), ``.dYYYYMMDD`` added when the tree had
uncommitted changes, and ``0.2.0.dev0`` (no ``+gHASH``: commit unknown) for a copy without git
metadata. Every stored record and every verdict's JSON (``code``) carries it.

An installed copy (``pip install .``) runs the code its metadata names. A git checkout that
runs its own files (``pip install -e .``, or ``PYTHONPATH``) may have moved on since it was
installed: there the checkout's HEAD (``git rev-parse``) and its uncommitted changes (``git
status``) are compared with the metadata, and when they differ the version is computed again
from the checkout (``python -m setuptools_scm``, as the build does; a quarter of a second).
Looked up once per process, on first use, never at import: ``batlab --help`` and the
commands' start-up do not pay for it.
"""

from __future__ import annotations

import subprocess
import sys
from functools import cache
from pathlib import Path

DIST = "batlab"
UNKNOWN = "0+unknown"
"""The version of a copy that is neither installed nor a git checkout."""


def installed_version() -> str | None:
    """Return the version in batlab's installed metadata (None when it is not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(DIST)
    except PackageNotFoundError:
        return None


def checkout_root() -> Path | None:
    """Return the git checkout this module runs from (None for an installed copy)."""
    root = Path(__file__).resolve().parents[1]
    return root if (root / ".git").exists() and (root / "pyproject.toml").is_file() else None


def _run(argv: list[str], cwd: Path) -> str | None:
    """Return a command's stdout, stripped (None when it cannot run or fails)."""
    try:
        res = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=30,
                             check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return res.stdout.strip() if res.returncode == 0 else None


def names_commit(version: str, head: str, dirty: bool) -> bool:
    """Say whether a setuptools-scm version names commit ``head`` in that state.

    Its local part holds ``gHASH`` (a prefix of ``head``) and, for uncommitted changes,
    ``dYYYYMMDD``; a clean tree must have none.

    Parameters
    ----------
    version : str
        ``X.Y.Z.devN+gHASH[.dYYYYMMDD]``.
    head : str
        The commit's full hash.
    dirty : bool
        Whether the tree has uncommitted changes (then no version names its code exactly).

    Returns
    -------
    bool
    """
    local = version.partition("+")[2].split(".")
    node = next((p[1:] for p in local if p.startswith("g") and len(p) > 4), None)
    marked_dirty = any(p.startswith("d") and p[1:].isdigit() for p in local)
    return node is not None and head.startswith(node) and not dirty and not marked_dirty


def checkout_version(root: Path) -> str | None:
    """Compute a checkout's version as its build would: ``python -m setuptools_scm``.

    The command line is setuptools-scm's stable interface (its Python API moves between
    releases); it reads ``[tool.setuptools_scm]`` from the checkout's pyproject.toml. None
    when setuptools-scm is not installed here.
    """
    out = _run([sys.executable, "-m", "setuptools_scm", "-c", str(root / "pyproject.toml")],
               root)
    return out.splitlines()[-1].strip() if out else None


@cache
def code_version() -> str:
    """Return the version of the code running now (looked up once per process).

    Returns
    -------
    str
        The installed metadata's version; for a git checkout whose HEAD or working tree no
        longer matches it, the checkout's own version (``checkout_version``), else the
        installed release with ``+gHASH`` of HEAD (``.dirty`` for uncommitted changes).
    """
    installed = installed_version()
    root = checkout_root()
    head = None if root is None else _run(["git", "rev-parse", "HEAD"], root)
    if not head:
        return installed or UNKNOWN
    dirty = bool(_run(["git", "status", "--porcelain", "--untracked-files=no"], root))
    if installed and names_commit(installed, head, dirty):
        return installed
    again = checkout_version(root)
    if again:
        return again
    public = (installed or "0").partition("+")[0]
    return f"{public}+g{head[:9]}" + (".dirty" if dirty else "")


def same_code(a: str | None, b: str | None) -> bool:
    """Say whether two stored versions name the same code (an unknown one never does)."""
    return a is not None and a == b and a != UNKNOWN
