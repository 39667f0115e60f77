"""The command line starts at once: ``import batlab.cli`` and ``batlab --help`` load no heavy
library and no command module; ``batlab CMD --help`` loads CMD's module alone.

Structural checks in a fresh interpreter (the test session has imported everything
already); the times are benchmarks/bench_startup.py's job."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from batlab.cli import COMMANDS, chosen_command

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy.signal", "pandas", "matplotlib", "serial", "scipy", "sqlalchemy", "alembic",
         "psycopg")

PROBE = """
import contextlib, io, json, sys
from batlab.cli import main
argv = json.loads(sys.argv[1])
if argv is not None:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        main(argv)
print(json.dumps(sorted(sys.modules)))
"""


def loaded_after(argv: list[str] | None) -> set[str]:
    """Modules loaded by a fresh interpreter importing batlab.cli (then running ``argv``)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv)], env=env,
                         capture_output=True, text=True, check=True)
    return set(json.loads(res.stdout))


@pytest.mark.parametrize("argv", [None, ["--help"], ["--version"]])
def test_starting_loads_no_heavy_library_and_no_command(argv):
    mods = loaded_after(argv)
    assert not [m for m in HEAVY if m in mods]
    assert not [m for m in mods if m.startswith("batlab.commands.")]


def test_a_command_loads_its_own_module_alone():
    mods = loaded_after(["export", "--help"])
    assert [m for m in mods if m.startswith("batlab.commands.")] == ["batlab.commands.export"]


def test_the_chosen_command_is_the_first_word_not_an_option():
    assert chosen_command(["inspect", "--serial", "S", "r.uff"]) == "inspect"
    assert chosen_command(["--version"]) is None
    assert chosen_command(["check-rig", "--json"]) == "check-rig"
    assert chosen_command(["--help", "fit"]) == "fit"
    assert chosen_command(["bogus", "fit"]) is None
    assert all(c.module == "batlab.commands." + name.replace("-", "_")
               for name, c in COMMANDS.items())
