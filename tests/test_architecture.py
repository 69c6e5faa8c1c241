"""The package's structure: no import cycle, modules of a readable size, Mitsuba's variant never switched by the library.

Checked over every module of ``cdbrdf`` (the layer contract in pyproject.toml,
checked by ``lint-imports``, sees only imports between layers).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import cdbrdf

SRC = Path(cdbrdf.__file__).parent

#: Longest module, lines.
MAX_MODULE_LINES = 700


def _import_graph() -> dict[str, set[str]]:
    grimp = pytest.importorskip("grimp")
    g = grimp.build_graph("cdbrdf")  # every import statement, also inside functions
    return {m: set(g.find_modules_directly_imported_by(m)) for m in g.modules}


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        found.append(sorted(comp))
    return found


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_among_the_modules():
    """Not even through a package's __init__ or an import inside a function."""
    assert _cycles(_import_graph()) == []


def test_no_module_is_longer_than_the_limit():
    long = {str(p.relative_to(SRC)): n for p in SRC.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert long == {}


def _calls(path: Path, name: str) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if called == name:
                lines.append(node.lineno)
    return lines


def test_only_the_command_line_and_the_plugin_set_mitsubas_variant():
    """Library code uses cdbrdf.render.variant (a with block that gives the caller's variant back)."""
    allowed = {"render/plugin.py", "commands/render.py"}
    found = {str(p.relative_to(SRC)): _calls(p, "set_variant") for p in SRC.rglob("*.py")}
    assert {k: v for k, v in found.items() if v and k not in allowed} == {}
