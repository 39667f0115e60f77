"""The one seam between batlab's commands and the stages (``rigs``, ``ema``, ``updating``).

A command (``batlab/commands/<name>.py``) parses its arguments, calls the functions here
with explicit arguments, and prints what they return (``batlab.formatting`` words it); it
imports no stage module itself (tests/test_architecture.py checks it). One module per job:

- ``door``: a command's options, input files and outputs checked before any work
  (``admit``).
- ``files``: the lab's files in and out (FRF tests, profile.csv, meta.json, retest.json,
  CSV).
- ``modal``: `batlab fit` -- a test's modal analysis, its modes file and figures.
- ``records``: the fitted tests, a report's inputs and the contract's JSON (light: the
  report imports it without the stages).
- ``chance``: a bat's model, and its verdict's chance and false-alarm rate as measured on
  the model's stored calibration (or said unmeasured).
- ``inspection``: files to verdict -- a bat's inputs read once (``InspectionCase``), then
  the method's one call (``judge``); the stateless form.
- ``registered``: register a bat, inspect a re-test against it.
- ``stored``: an inspection stored, and read back -- provenance, report inputs, export.
- ``diagnosis``: a baseline against the nominal model, a rig's reference bar.
- ``bench``: the test bench -- a bat's wood, FE model and pre-test summary, tests on the
  virtual rig (one test, a nuisance-rich field case, the demo's pair, the rig's modal model).
- ``paper``: the paper's corked-bat case (SEREP + MSSO, the refinement, Figures 2 and 3).
- ``acquisition``: the acquisition box's driver and session, the session's files, the FRF
  file written at the end.
- ``edge``: the unit constants the commands convert lab units with at the edge, and the
  JSON object reader (re-exported from the stages).

Each module declares its public names in its ``__all__``; this package serves them all,
each loaded on first use (PEP 562): importing one light module of the package loads no
stage. The declarations are read from the modules' source (a literal ``__all__ = [...]``),
not by importing them; tests/test_architecture.py checks them against the imported
modules' ``__all__``.
"""

from __future__ import annotations

import ast
import functools
import importlib
import re
from pathlib import Path

_SUBMODULES = ("acquisition", "bench", "chance", "diagnosis", "door", "edge", "files",
               "inspection", "modal", "paper", "records", "registered", "stored")
_ALL = re.compile(r"^__all__ = (\[[^\]]*\])", re.MULTILINE)


def declared(module: str) -> tuple[str, ...]:
    """Return the public names sub-module ``module`` declares (its literal ``__all__``).

    Read from its source, without importing it.
    """
    found = _ALL.search(Path(__file__).with_name(f"{module}.py").read_text())
    if found is None:
        raise ImportError(f"batlab.pipeline.{module} declares no __all__ = [...]")
    return tuple(ast.literal_eval(found.group(1)))


@functools.cache
def _where() -> dict[str, str]:
    """Map every public name to the sub-module that declares it (read once)."""
    return {name: f"{__name__}.{m}" for m in _SUBMODULES for name in declared(m)}


def __getattr__(name: str):
    """Load a public name (or a sub-module, or ``__all__``) on first use."""
    if name == "__all__":
        value = sorted(_where())
    elif name in _SUBMODULES:
        value = importlib.import_module(f"{__name__}.{name}")
    elif name in _where():
        value = getattr(importlib.import_module(_where()[name]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """List the public names and sub-modules."""
    return sorted(set(globals()) | set(_where()) | set(_SUBMODULES))
