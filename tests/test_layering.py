"""The data flows one way and modules talk through public names.

* No module under ``eigentwist/`` imports :mod:`eigentwist.cli`, except the command line
  itself (``eigentwist/cli/``) and ``eigentwist/__main__.py`` (``python -m eigentwist``,
  the command line's entry point).
* No module uses another module's private names: neither ``from X import _name`` nor
  ``something._name`` (``self._name``, ``cls._name`` and ``super()._name`` excepted: a
  class's own attributes, and a printer overriding its base class's ``_print_*``).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "eigentwist"
ENTRY_POINTS = {"eigentwist.__main__"}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _absolute(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _own_object(value: ast.AST) -> bool:
    if isinstance(value, ast.Name):
        return value.id in ("self", "cls")
    return isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "super"


def _tree(source) -> ast.AST:
    """``source`` parsed (a module's text), or the tree itself (:func:`parsed`)."""
    return source if isinstance(source, ast.AST) else ast.parse(source)


@functools.cache
def parsed(path: Path) -> ast.Module:
    """A source file's tree, parsed once for both checks below (the generated evaluators
    are ~0.4 MB each)."""
    return ast.parse(path.read_text(encoding="utf-8"))


def violations(source, module: str, is_package: bool = False) -> list[str]:
    """Layering and privacy violations of one module's source (text or tree), as readable lines."""
    out = []
    in_cli = module == "eigentwist.cli" or module.startswith("eigentwist.cli.") or module in ENTRY_POINTS
    for node in ast.walk(_tree(source)):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(node, module, is_package)
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
            if base != module:
                out += [
                    f"line {node.lineno}: from {base} import {a.name} (private name of another module)"
                    for a in node.names
                    if _private(a.name)
                ]
        elif isinstance(node, ast.Attribute) and _private(node.attr) and not _own_object(node.value):
            out.append(f"line {node.lineno}: {ast.unparse(node)} (private attribute of another object)")
        if not in_cli and any(t == "eigentwist.cli" or t.startswith("eigentwist.cli.") for t in targets):
            out.append(f"line {node.lineno}: imports the command line ({', '.join(targets)})")
    return sorted(set(out))


SOURCES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_module_respects_the_layers(path):
    bad = violations(parsed(path), module_name(path), path.name == "__init__.py")
    assert not bad, f"{path.relative_to(PACKAGE.parent)}:\n  " + "\n  ".join(bad)


@pytest.mark.parametrize(
    "source, module, is_package",
    [
        ("from ..cli.common import format_table", "eigentwist.diagnose.verdict", False),
        ("import eigentwist.cli.main", "eigentwist.runtime.loader", False),
        ("from eigentwist import cli", "eigentwist.report.build", False),
        ("from .. import cli", "eigentwist.report", True),
        ("def f():\n    from ..diagnose.select import _clean\n", "eigentwist.cli.compare", False),
        ("def f(ev):\n    return ev._c_threads()\n", "eigentwist.runtime.gravity", False),
        ("from . import _helpers", "eigentwist.diagnose.fit", False),
    ],
)
def test_the_checker_catches_cli_imports_and_private_names(source, module, is_package):
    assert violations(source, module, is_package)


@pytest.mark.parametrize(
    "source, module",
    [
        ("from .common import format_table", "eigentwist.cli.report"),
        ("from eigentwist.cli.main import main", "eigentwist.__main__"),
        ("class A:\n    def f(self):\n        return self._x + type(self).__name__\n", "eigentwist.runtime.evaluator"),
        (
            "class P(Base):\n    def g(self, e):\n        return super()._print_Pow(e)\n",
            "eigentwist.codegen.numpy_backend",
        ),
        ("def _own():\n    pass\n_own()\n", "eigentwist.text"),
    ],
)
def test_the_checker_allows_own_names(source, module):
    assert not violations(source, module)


# ------------------------------------------------------------ import circles
MODULES = {module_name(p): p for p in SOURCES}


def _type_checking_lines(tree: ast.AST) -> set[int]:
    """Line numbers of the statements under ``if TYPE_CHECKING:`` (not run: no edge)."""
    lines = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for stmt in node.body:
                lines.update(range(stmt.lineno, (stmt.end_lineno or stmt.lineno) + 1))
    return lines


def _resolve(target: str, modules) -> str | None:
    """The module of ``modules`` that importing ``target`` runs (the longest known prefix)."""
    parts = target.split(".")
    for n in range(len(parts), 0, -1):
        name = ".".join(parts[:n])
        if name in modules:
            return name
    return None


def imports_of(source, module: str, is_package: bool, modules) -> set[str]:
    """Modules of ``modules`` that ``module`` imports, at module level or inside functions,
    with the packages whose ``__init__`` such an import runs (not the root package, whose
    ``__init__`` imports nothing at module level); ``if TYPE_CHECKING:`` imports excluded."""
    tree = _tree(source)
    skip = _type_checking_lines(tree)
    out = set()
    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(node, module, is_package)
            targets = [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        for t in targets:
            hit = _resolve(t, modules)
            while hit and hit.count("."):
                out.add(hit)
                hit = hit.rpartition(".")[0]
    out.discard(module)
    package = module if is_package else module.rpartition(".")[0]
    # a module's own package runs first whoever imports it: importing it back is no new edge
    while package.count("."):
        out.discard(package)
        package = package.rpartition(".")[0]
    return out


def import_circles(graph: dict) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _graph() -> dict:
    return {m: imports_of(parsed(p), m, p.name == "__init__.py", MODULES) for m, p in MODULES.items()}


def test_no_import_circles():
    circles = import_circles(_graph())
    assert not circles, "import circles between modules:\n  " + "\n  ".join(" <-> ".join(c) for c in circles)


def test_the_circle_checker_finds_a_function_level_circle():
    modules = {"eigentwist.a", "eigentwist.b", "eigentwist.c"}
    graph = {
        "eigentwist.a": imports_of("from .b import f\n", "eigentwist.a", False, modules),
        "eigentwist.b": imports_of("def g():\n    from .c import h\n", "eigentwist.b", False, modules),
        "eigentwist.c": imports_of("import eigentwist.a\n", "eigentwist.c", False, modules),
    }
    assert import_circles(graph) == [["eigentwist.a", "eigentwist.b", "eigentwist.c"]]
    graph["eigentwist.c"] = imports_of(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import eigentwist.a\n", "eigentwist.c", False, modules
    )
    assert import_circles(graph) == []
