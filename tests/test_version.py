"""The code that judged is named: ``batlab --version`` differs between two commits of a
throwaway git repository holding batlab's command line and version module (run from the
checkout, as an editable install runs), and a setuptools-scm version names its commit."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from batlab.version import UNKNOWN, code_version, names_commit, same_code

ROOT = Path(__file__).resolve().parents[1]
GIT_ENV = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org",
           "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@example.org",
           "GIT_CONFIG_GLOBAL": os.devnull, "GIT_CONFIG_NOSYSTEM": "1"}


def git(repo: Path, *args: str) -> str:
    res = subprocess.run(["git", *args], cwd=repo, env={**os.environ, **GIT_ENV},
                         capture_output=True, text=True, check=True)
    return res.stdout.strip()


def version_of(repo: Path) -> str:
    """``python -m batlab --version`` run from the checkout ``repo``."""
    env = {**os.environ, **GIT_ENV, "PYTHONPATH": str(repo)}
    res = subprocess.run([sys.executable, "-m", "batlab", "--version"], cwd=repo, env=env,
                         capture_output=True, text=True, check=True)
    return res.stdout.strip().removeprefix("batlab ")


@pytest.mark.skipif(shutil.which("git") is None, reason="no git on this machine")
def test_the_version_differs_between_two_commits(tmp_path):
    repo = tmp_path / "repo"
    (repo / "batlab").mkdir(parents=True)
    shutil.copyfile(ROOT / "pyproject.toml", repo / "pyproject.toml")
    for name in ("__init__.py", "__main__.py", "cli.py", "version.py"):
        shutil.copyfile(ROOT / "batlab" / name, repo / "batlab" / name)
    git(repo, "init", "-q")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "one")
    first, head1 = version_of(repo), git(repo, "rev-parse", "HEAD")
    (repo / "NOTES").write_text("a second commit\n")
    git(repo, "add", "NOTES")
    git(repo, "commit", "-q", "-m", "two")
    second, head2 = version_of(repo), git(repo, "rev-parse", "HEAD")
    assert first != second
    assert names_commit(first, head1, False) and names_commit(second, head2, False)
    assert not names_commit(first, head2, False)
    (repo / "NOTES").write_text("changed, not committed\n")
    assert version_of(repo) != second  # uncommitted changes are marked


def test_names_commit_reads_the_local_part():
    head = "1a2b3c4d5e6f" + "0" * 28
    assert names_commit("0.2.0.dev5+g1a2b3c4d5", head, dirty=False)
    assert not names_commit("0.2.0.dev5+g1a2b3c4d5", head, dirty=True)
    assert not names_commit("0.2.0.dev5+g1a2b3c4d5.d20260101", head, dirty=False)
    assert not names_commit("0.2.0.dev5+g9a2b3c4d5", head, dirty=False)
    assert not names_commit("0.2.0", head, dirty=False)  # a release names its tag, not HEAD


def test_the_running_code_has_a_version():
    v = code_version()
    assert re.fullmatch(r"\d+(\.\d+)*(\.dev\d+)?(\+[0-9a-z.]+)?", v), v
    assert same_code(v, v) and not same_code(v, v + "x") and not same_code(UNKNOWN, UNKNOWN)
