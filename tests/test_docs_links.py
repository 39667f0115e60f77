"""The docs point at what exists: links, paths, dotted names, modules and benchmark scripts.

Relative links in README.md, CHANGELOG.md and docs/*.md must reach a file; README.md and
docs/architecture.md describe the current tree, so every repository path and dotted name they
quote in backticks must exist, docs/architecture.md must name every module of the four
packages, and README's benchmark list must be the benchmarks/ folder.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "ema", "updating", "batlab")
CURRENT = ("README.md", "docs/architecture.md")  # describe the tree as it is (no history)

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
CODE = re.compile(r"`([^`\s]+)`")
REPO_PATH = re.compile(r"(?:rigs|ema|updating|batlab|benchmarks|tests|docs|data_samples)/"
                       r"[\w./-]*")
DOTTED = re.compile(r"(?:rigs|ema|updating|batlab)(?:\.\w+)+")


def doc_files() -> list[Path]:
    """Return README.md, CHANGELOG.md and docs/**/*.md (the results pages too)."""
    return [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]


def dead_links(path: Path) -> list[str]:
    """Return the relative link targets of a Markdown file that reach no file."""
    dead = []
    for target in LINK.findall(path.read_text()):
        if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # a URL or an anchor on the same page
        if not (path.parent / target.split("#")[0]).exists():
            dead.append(target)
    return dead


def top_level_names(module: Path) -> set[str]:
    """Return the names a module defines or imports at its top level."""
    names = set()
    for node in ast.parse(module.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    return names


def dotted_name_exists(name: str) -> bool:
    """Whether ``a.b.c[.attr[.member]]`` is a module, or a name defined at its top level."""
    parts = name.split(".")
    for n in range(len(parts), 0, -1):
        base = ROOT.joinpath(*parts[:n])
        module = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
        if module.exists():
            rest = parts[n:]
            return not rest or rest[0] in top_level_names(module) | {
                p.stem for p in base.glob("*") if base.is_dir()}
    return False


@pytest.mark.parametrize("path", doc_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_reach_a_file(path):
    assert not dead_links(path), f"{path.relative_to(ROOT)}: dead links {dead_links(path)}"


def test_dead_link_is_found(tmp_path):
    page = tmp_path / "page.md"
    (tmp_path / "here.md").write_text("")
    page.write_text("[ok](here.md) [web](https://x.org/a.md) [gone](there.md#top) [a](#b)")
    assert dead_links(page) == ["there.md#top"]


@pytest.mark.parametrize("doc", CURRENT)
def test_paths_and_dotted_names_exist(doc):
    quoted = CODE.findall((ROOT / doc).read_text())
    paths = [q.rstrip(".,:;") for q in quoted if REPO_PATH.fullmatch(q.rstrip(".,:;"))]
    missing = [p for p in paths if not (ROOT / p).exists()]
    missing += [q for q in quoted if DOTTED.fullmatch(q) and not dotted_name_exists(q)]
    assert not missing, f"{doc} names what does not exist: {missing}"


def test_dotted_name_check_can_fail():
    assert dotted_name_exists("updating.inspect.run.inspect")
    assert dotted_name_exists("ema.io")
    assert not dotted_name_exists("updating.inspect.run.no_such_function")
    assert not dotted_name_exists("ema.fit")


def test_architecture_names_every_module():
    text = (ROOT / "docs/architecture.md").read_text()
    named = {part for c in CODE.findall(text) for part in re.split(r"[/.]", c)}
    missing = [str(p.relative_to(ROOT)) for pkg in PACKAGES
               for p in sorted((ROOT / pkg).rglob("*.py"))
               if p.stem != "__init__" and p.stem not in named]
    assert not missing, f"docs/architecture.md does not describe {missing}"


def test_readme_lists_the_benchmark_scripts():
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Benchmarks"):]
    listed = {c for c in CODE.findall(section) if re.fullmatch(r"\w+\.py", c)}
    present = {p.name for p in (ROOT / "benchmarks").glob("*.py")}
    assert listed == present, (f"README lists {sorted(listed - present)} that do not exist, "
                               f"misses {sorted(present - listed)}")
