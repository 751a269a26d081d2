"""The package's shape: its layers hold (import-linter's contracts in pyproject.toml) and no module imports
itself back through others (no import circle, function-level imports included).

The same checks by hand: ``lint-imports`` in the repository's root, and this file's ``circles()``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import grimp
import pytest
from importlinter.cli import EXIT_STATUS_SUCCESS, lint_imports

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    return grimp.build_graph("ipyros", cache_dir=None)


def circles(graph: grimp.ImportGraph) -> list[list[str]]:
    """The import circles among ipyros's modules: the strongly connected components of more than one module
    (Tarjan's algorithm over every import the code makes, at the top or in a function)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for imported in graph.find_modules_directly_imported_by(module):
            if not imported.startswith("ipyros"):
                continue
            if imported not in index:
                visit(imported)
                low[module] = min(low[module], low[imported])
            elif imported in on_stack:
                low[module] = min(low[module], index[imported])
        if low[module] == index[module]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == module:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for module in sorted(m for m in graph.modules if m.startswith("ipyros")):
        if module not in index:
            visit(module)
    return found


def test_no_module_imports_itself_back(graph):
    # A package's __init__ re-exporting its modules is not a circle: it imports them, they never import it.
    assert circles(graph) == []


def test_the_layer_contracts_hold(monkeypatch, capsys):
    monkeypatch.chdir(ROOT)  # the contracts are in pyproject.toml
    assert lint_imports(no_cache=True) == EXIT_STATUS_SUCCESS, capsys.readouterr().out


def test_the_circle_finder_finds_a_circle():
    """It can fail: a graph with a two-module circle, and one with a longer one, are both found."""
    graph = grimp.ImportGraph()
    for name in ("ipyros.a", "ipyros.b", "ipyros.c", "ipyros.d"):
        graph.add_module(name)
    graph.add_import(importer="ipyros.a", imported="ipyros.b")
    graph.add_import(importer="ipyros.b", imported="ipyros.a")
    graph.add_import(importer="ipyros.b", imported="ipyros.c")
    graph.add_import(importer="ipyros.c", imported="ipyros.d")
    assert circles(graph) == [["ipyros.a", "ipyros.b"]]
    graph.add_import(importer="ipyros.d", imported="ipyros.a")
    assert circles(graph) == [["ipyros.a", "ipyros.b", "ipyros.c", "ipyros.d"]]


def ipyros_imports(path: Path) -> list[tuple[str, str]]:
    """``(module, name)`` for each ``from ipyros.module import name`` in the file at ``path``."""
    found = []
    for statement in ast.walk(ast.parse(path.read_text())):
        if isinstance(statement, ast.ImportFrom) and (statement.module or "").startswith("ipyros"):
            found += [(statement.module, alias.name) for alias in statement.names]
    return found


def source_of(module: str) -> str:
    path = ROOT / module.replace(".", "/")
    return (path.with_suffix(".py") if path.with_suffix(".py").exists() else path / "__init__.py").read_text()


def defines(source: str, name: str) -> bool:
    """Whether a module's source defines or imports ``name`` at its top level (read, not imported: no ROS here)."""
    found: set[str] = set()
    for node in ast.parse(source).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            found.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            found.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            found.update(t.id for t in targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.If):  # try/except imports and the like: looked into one level
            found.update(n.name for n in ast.walk(node) if isinstance(n, (ast.FunctionDef, ast.ClassDef)))
            found.update(a.asname or a.name for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))
                         for a in n.names)
        elif isinstance(node, ast.Try):
            found.update(a.asname or a.name for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))
                         for a in n.names)
            found.update(t.id for n in ast.walk(node) if isinstance(n, ast.Assign) for t in n.targets
                         if isinstance(t, ast.Name))
    return name in found


def test_scripts_outside_the_package_import_what_exists(graph):
    """The bench's nodes, the tests and their peers run as scripts and import ipyros by module path:
    a module moved in the package must not leave them behind (the bench ran nothing after the layers moved)."""
    missing = []
    for path in sorted((*ROOT.glob("bench/**/*.py"), *ROOT.glob("tests/**/*.py"))):
        for module, name in ipyros_imports(path):
            if module not in graph.modules:
                missing.append(f"{path.relative_to(ROOT)}: no module {module}")
            elif f"{module}.{name}" not in graph.modules and not defines(source_of(module), name):
                missing.append(f"{path.relative_to(ROOT)}: {module} has no {name}")
    assert not missing, "\n".join(missing)


UNIT = Path(__file__).resolve().parent
#: What the unit layer checks of the project as a whole, not of one module: beside this file, not in a layer's folder.
PROJECT_WIDE = {"test_bench_figures.py", "test_layers.py", "test_readme.py", "test_types.py"}


def test_the_unit_tests_mirror_the_package():
    """``tests/unit/<layer>/test_<module>.py``: each test file in a layer's folder is named after a module (or a
    package) of that layer, ``test_<module>_<concern>.py`` where two layers' modules share a name (pytest needs one
    basename a file: ``tools/test_graph_cache.py`` beside ``core/test_graph.py``); every module of ``core/`` has
    one. A newcomer finds a module's tests by its path, and a module's tests by the module's."""
    misplaced = []
    for test in sorted(UNIT.glob("*/test_*.py")):
        layer = ROOT / "ipyros" / test.parent.name
        stem = test.stem.removeprefix("test_")
        modules = {p.stem for p in layer.glob("*.py")} | {p.name for p in layer.iterdir() if (p / "__init__.py").exists()}
        modules |= {f"magics_{p.stem}" for p in (layer / "magics").glob("*.py")}  # ipython/magics/plot.py
        if not layer.is_dir() or not any(stem == m or stem.startswith(m + "_") for m in modules):
            misplaced.append(str(test.relative_to(UNIT)))
    loose = sorted(p.name for p in UNIT.glob("test_*.py") if p.name not in PROJECT_WIDE)
    untested = sorted(p.stem for p in (ROOT / "ipyros" / "core").glob("*.py")
                      if p.stem != "__init__" and not (UNIT / "core" / f"test_{p.stem}.py").exists())
    assert not misplaced, f"named after no module of their layer's folder: {misplaced}"
    assert not loose, f"test files of one module outside its layer's folder: {loose}"
    assert not untested, f"modules of core/ with no tests/unit/core/test_<module>.py: {untested}"
