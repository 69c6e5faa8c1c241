"""The package's structure: no import cycle, short functions, narrow signatures, Mitsuba's variant kept.

Checked over every module of ``cdbrdf`` (the layer contract in pyproject.toml,
checked by ``lint-imports``, sees only imports between layers).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import cdbrdf

SRC = Path(cdbrdf.__file__).parent

#: Longest function, lines of code (its docstring not counted).
MAX_FUNCTION_LINES = 120

#: Most parameters of a public callable (``self`` and ``*args``/``**kwargs`` not counted).
MAX_PARAMETERS = 16


def _import_graph() -> dict[str, set[str]]:
    """Every import of a module (also inside functions), and the package faces it goes through."""
    grimp = pytest.importorskip("grimp")
    g = grimp.build_graph("cdbrdf")  # every import statement, also inside functions
    edges = {m: set(g.find_modules_directly_imported_by(m)) for m in g.modules}
    for m, faces in _package_faces().items():
        edges.setdefault(m, set()).update(faces)
    return edges


def _module_name(path: Path) -> str:
    parts = ("cdbrdf", *path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _package_faces() -> dict[str, set[str]]:
    """``from PACKAGE import name`` reads ``name`` off PACKAGE's face (its ``__init__``), even for a submodule.

    grimp records the submodule alone, so ``cdbrdf`` -> ``cdbrdf.btf`` -> ``cdbrdf.btf.file`` -> ``cdbrdf``
    (``from .. import limits``) would go unseen. A module's own package (``from . import _kernel``) is not
    counted: the idiom of a package's private modules.
    """
    faces: dict[str, set[str]] = {}
    for path in SRC.rglob("*.py"):
        name = _module_name(path)
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                target = f"{base}.{node.module}" if node.module else base
            elif isinstance(node, ast.ImportFrom) and node.module:
                target = node.module
            else:
                continue
            if target not in (name, package) and (SRC.parent / target.replace(".", "/") / "__init__.py").is_file():
                faces.setdefault(name, set()).add(target)
    return faces


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
    """Not even through a package's __init__ (its face) or an import inside a function."""
    assert _cycles(_import_graph()) == []


def test_the_cycle_finder_sees_a_cycle_through_a_package_face():
    """``from .. import limits`` in cdbrdf.btf.file ran cdbrdf's face, which imports cdbrdf.btf: a cycle."""
    faces = _package_faces()
    assert "cdbrdf" in faces["cdbrdf.plot._common"]  # from .. import colour: through cdbrdf's face
    edges = {"cdbrdf": {"cdbrdf.btf"}, "cdbrdf.btf": {"cdbrdf.btf.file"}, "cdbrdf.btf.file": {"cdbrdf.limits"},
             "cdbrdf.limits": set()}
    assert _cycles(edges) == []
    edges["cdbrdf.btf.file"].add("cdbrdf")  # the face the former import went through
    assert _cycles(edges) == [["cdbrdf", "cdbrdf.btf", "cdbrdf.btf.file"]]


def _functions() -> list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef, bool]]:
    """Every function of the package: ``(module:name, node, public)``; public: no ``_`` in its or its module's path."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = str(path.relative_to(SRC))
        private_module = any(part.startswith("_") and part != "__init__.py" for part in path.relative_to(SRC).parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                found.append((f"{rel}:{node.name}", node, not (private_module or node.name.startswith("_"))))
    return found


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """A function's lines without its docstring."""
    n = node.end_lineno - node.lineno + 1  # type: ignore[operator]
    if ast.get_docstring(node, clean=False) is not None:
        doc = node.body[0]
        n -= doc.end_lineno - doc.lineno + 1  # type: ignore[operator]
    return n


def _parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = node.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    return len([n for n in names if n not in ("self", "cls")])


def test_no_function_is_longer_than_the_limit():
    """Functions are split by step (the former 700-line limit per module made modules cut to fit a number)."""
    long = {name: n for name, node, _ in _functions() if (n := _code_lines(node)) > MAX_FUNCTION_LINES}
    assert long == {}


def test_no_public_callable_takes_more_than_the_limit_of_parameters():
    """Wide signatures become records (RenderSpec, RigOptions, MeasureOptions); private kernels excepted."""
    wide = {name: n for name, node, public in _functions() if public and (n := _parameters(node)) > MAX_PARAMETERS}
    assert wide == {}


def test_the_length_and_width_checks_measure_what_they_say():
    tree = ast.parse('def f(self, a, /, b, *c, d, **e):\n    """Doc\n    string."""\n    x = 1\n    return x\n')
    node = tree.body[0]
    assert isinstance(node, ast.FunctionDef)
    assert _code_lines(node) == 3 and _parameters(node) == 3  # a, b, d: *c, **e and self not counted


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
