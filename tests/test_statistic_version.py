"""The statistic's version follows its definition: changing the code that defines F without
bumping ``STATISTIC_VERSION`` (and recording the code's new hash beside it) fails here."""

from __future__ import annotations

import ast
import hashlib
import importlib
import inspect
import textwrap

from updating.inspect import nested


def _without_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(body, list) and body and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return tree


def definition_text(name: str) -> str:
    """The code named ``module.attr``: its syntax tree without docstrings (comments and
    layout never reach it), or a constant's value."""
    module, _, attr = name.rpartition(".")
    obj = getattr(importlib.import_module(module), attr)
    if inspect.isfunction(obj) or inspect.isclass(obj):
        tree = ast.parse(textwrap.dedent(inspect.getsource(obj)))
        return ast.dump(_without_docstrings(tree), include_attributes=False)
    return repr(obj)


def definition_sha256(names=nested.STATISTIC_DEFINITION) -> str:
    text = "\n".join(f"{name}\n{definition_text(name)}" for name in names)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


RECORDED = {
    2: "9c90460e3ecf52108754f59c75ff85010f8ad19b1a795b79e655e22a1618799e",
    3: "6f795621ddb74cdf0c7ccf3159e34d28a3bc8e26eeae89826a328f4d5d127d0b",
    4: "c331ba32dc069518a0ad7948cc689519a2df80453bc0df5e6d83ce402954aa1f",
    5: "6fe22cfcf4ccfc66874e49385fc45d011931355fc0fdbd972c8f8859c64ed01d",
    6: "6b3ca321f03b259092fbec9cf59f9457e1fcda96118ff8ad0c4e4af95c4fdcd6",
}
"""The hash of F's defining code at each version: add a line for a new version, never edit
one (so a hash changed in place, the version left as it was, still fails here)."""


def test_the_statistics_version_was_bumped_when_its_code_changed():
    now = definition_sha256()
    version = nested.STATISTIC_VERSION
    bump = (f"the code defining F changed (sha256 {now}); if F's definition changed, bump "
            f"updating.inspect.nested.STATISTIC_VERSION (now {version}), set "
            f"STATISTIC_SOURCE_SHA256 = \"{now}\" beside it and add {version + 1}: \"{now}\" "
            "to RECORDED here")
    assert now == RECORDED.get(version, now), bump
    assert version in RECORDED, f"add {version}: \"{now}\" to RECORDED"
    assert now == nested.STATISTIC_SOURCE_SHA256, bump
    assert version == max(RECORDED) and len(set(RECORDED.values())) == len(RECORDED)


def test_a_change_to_the_definition_changes_the_hash(monkeypatch):
    """The check can fail: F computed another way hashes differently, a docstring does not."""
    before = definition_sha256()
    source = inspect.getsource(nested.nested_f)
    changed = source + "    F = 2.0 * F\n"  # one more statement in the function's body
    reworded = source.replace('"""', '"""Reworded. ', 1)  # its docstring alone
    assert reworded != source
    for text, same in ((changed, False), (reworded, True)):
        monkeypatch.setattr(inspect, "getsource",
                            lambda obj, text=text, real=inspect.getsource:
                            text if obj is nested.nested_f else real(obj))
        assert (definition_sha256() == before) is same
