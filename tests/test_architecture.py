"""The layering docs/architecture.md states, read from the source with ``ast`` (every import,
also those inside functions):

- data flow one way, rigs -> ema -> updating -> batlab: a stage imports no later one;
- inside ``updating`` the sub-packages import only those above them;
- ``batlab/commands/*`` import only ``batlab`` modules (the stages through
  ``batlab.pipeline``, the seam), never each other, and of the application modules only those
  that present or store results.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "ema", "updating", "batlab")

MAY_IMPORT = {
    "rigs": set(),
    "ema": {"rigs"},
    "updating": {"rigs", "ema"},
    "batlab": {"rigs", "ema", "updating"},
}

UPDATING_LAYERS = {  # sub-package (or top module) -> the updating sub-packages it may import
    "model": set(),
    "correlate": {"model"},
    "lsq": set(),
    "tails": set(),
    "solid": {"model", "correlate"},
    "msso": {"model", "correlate", "lsq"},
    "diagnose": {"model", "correlate", "lsq", "tails", "solid"},
    "inspect": {"model", "correlate", "lsq", "tails", "msso"},
    "simulate": {"model", "correlate", "lsq", "msso", "inspect", "solid"},
}

APPLICATION_MAY_NOT_IMPORT = (  # the stages' runners: only the pipeline calls them
    "rigs", "ema.modal_fit", "ema.poles", "updating.diagnose", "updating.inspect.run",
    "updating.msso", "updating.simulate", "updating.solid",
)

FLEET_MAY_IMPORT = (  # batlab/fleet runs virtual bats through the real command line (and
    # re-scores the inspection alone on cached fits: updating.inspect)
    "batlab.cli", "batlab.fleet", "batlab.pipeline", "updating.simulate", "updating.inspect",
    "batlab.registry",  # fleet inspect's workers read the registry, its client stores verdicts
)

COMMAND_MAY_IMPORT = {  # what a command may import from batlab besides batlab.pipeline
    "batlab", "batlab.cli_support", "batlab.formatting", "batlab.registry", "batlab.report",
    "batlab.diagnose_report", "batlab.report_check", "batlab.lab",
}


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in a file, at any depth; ``from a import
    b`` gives ``a.b`` as well as ``a`` (b may be a module)."""
    tree = ast.parse(path.read_text(), str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the file's package
                parts = path.relative_to(ROOT).with_suffix("").parts[: -node.level]
                base = ".".join(parts + ((node.module,) if node.module else ()))
            else:
                base = node.module or ""
            out.append((node.lineno, base))
            out += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
    return out


def files_of(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def top(name: str) -> str:
    return name.split(".")[0]


def test_the_parser_sees_function_level_and_relative_imports(tmp_path, monkeypatch):
    """The checks below can fail: an import inside a function, and a relative one, are
    found."""
    pkg = ROOT / "batlab" / "commands"
    src = "def run(args):\n    from updating.model import units\n    from . import fit\n"
    fake = pkg / "_probe_for_test.py"
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: src)
    found = {name for _, name in imported_modules(fake)}
    assert "updating.model.units" in found
    assert "batlab.commands.fit" in found


@pytest.mark.parametrize("package", PACKAGES)
def test_data_flow_one_way(package):
    bad = [f"{p.relative_to(ROOT)}:{line} imports {name}"
           for p in files_of(package) for line, name in imported_modules(p)
           if top(name) in PACKAGES and top(name) != package
           and top(name) not in MAY_IMPORT[package]]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("name", sorted(COMMAND_MAY_IMPORT - {"batlab"}))
def test_application_modules_run_no_stage(name):
    path = ROOT / (name.replace(".", "/") + ".py")
    paths = [path] if path.exists() else files_of(name.replace(".", "/"))  # a package
    bad = [f"{name}:{line} imports {mod}" for p in paths for line, mod in imported_modules(p)
           if any(mod == s or mod.startswith(s + ".") for s in APPLICATION_MAY_NOT_IMPORT)
           or mod.startswith("batlab.commands")]
    assert not bad, "\n".join(bad)


def test_updating_sub_packages_layered():
    bad = []
    for p in files_of("updating"):
        rel = p.relative_to(ROOT / "updating").with_suffix("").parts
        if rel == ("__init__",):
            continue
        own = rel[0]
        allowed = UPDATING_LAYERS[own] | {own}
        for line, name in imported_modules(p):
            parts = name.split(".")
            if parts[0] == "updating" and len(parts) > 1 and parts[1] not in allowed:
                bad.append(f"{p.relative_to(ROOT)}:{line} ({own}) imports {name}")
    assert not bad, "\n".join(bad)


def test_commands_reach_the_stages_only_through_the_pipeline():
    commands = files_of("batlab/commands")
    assert len(commands) > 10
    bad = []
    for p in commands:
        for line, name in imported_modules(p):
            where = f"{p.relative_to(ROOT)}:{line} imports {name}"
            if top(name) in ("rigs", "ema", "updating"):
                bad.append(where)
            elif top(name) == "batlab":
                parts = name.split(".")
                if len(parts) > 1 and parts[1] == "commands":
                    bad.append(where + " (commands do not import each other)")
                elif len(parts) > 1 and parts[1] == "pipeline":
                    continue
                elif p.name == "fleet.py" and parts[:2] == ["batlab", "fleet"]:
                    continue  # `batlab fleet` runs the cluster's work of batlab/fleet
                elif name not in COMMAND_MAY_IMPORT and ".".join(parts[:-1]) \
                        not in COMMAND_MAY_IMPORT:
                    bad.append(where + " (not the pipeline nor a presenting module)")
    assert not bad, "\n".join(bad)


def test_fleet_runs_bats_through_the_command_line():
    """batlab/fleet (the fleet benchmarks' runner) reaches batlab through the CLI's ``main``
    or the pipeline and the stages only through the virtual bats; no other batlab module
    imports it."""
    fleet = files_of("batlab/fleet")
    assert fleet
    bad = [f"{p.relative_to(ROOT)}:{line} imports {name}"
           for p in fleet for line, name in imported_modules(p)
           if top(name) in PACKAGES
           and not any(name == m or name.startswith(m + ".") for m in FLEET_MAY_IMPORT)]
    bad += [f"{p.relative_to(ROOT)}:{line} imports {name}"
            for p in files_of("batlab") if p not in fleet
            and p != ROOT / "batlab" / "commands" / "fleet.py"
            for line, name in imported_modules(p) if name.startswith("batlab.fleet")]
    assert not bad, "\n".join(bad)


def test_no_function_of_100_lines_or_more():
    """Every function and method in the four packages is under 100 lines (split by step)."""
    long = []
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    n = node.end_lineno - node.lineno + 1
                    if n >= 100:
                        long.append(f"{path.relative_to(ROOT)}:{node.name} ({n} lines)")
    assert not long, long


def test_pipeline_serves_the_names_its_modules_declare():
    """``batlab.pipeline``'s public names are declared once, in each module's ``__all__``:
    the declarations the package reads from the source are the imported modules' own, no
    name is declared twice, each is served as the module's object, and every module of the
    package is one it serves from."""
    import importlib

    import batlab.pipeline as pipeline

    folder = ROOT / "batlab" / "pipeline"
    modules = sorted(p.stem for p in folder.glob("*.py") if p.stem != "__init__")
    assert sorted(pipeline._SUBMODULES) == modules
    seen: dict[str, str] = {}
    for name in modules:
        module = importlib.import_module(f"batlab.pipeline.{name}")
        assert pipeline.declared(name) == tuple(module.__all__), name
        for public in module.__all__:
            assert public not in seen, f"{public} declared by {seen.get(public)} and {name}"
            seen[public] = name
            assert getattr(pipeline, public) is getattr(module, public)
    assert sorted(pipeline.__all__) == sorted(seen)
