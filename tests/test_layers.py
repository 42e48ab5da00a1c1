"""Architecture: data flows one way, io → signal → model → identify → library → front ends.

Every taptune module's imports (also the lazy ones inside functions) are read with
``ast``; no module may import a layer above its own, and no two modules may import each
other, directly or round a longer loop. The CLI's fast path must not load Qt,
matplotlib or sounddevice.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

# Rank of each room; a module may import only its own rank or lower.
RANK = {
    "errors": 0,
    "workers": 0,  # what every worker pool shares
    "io": 1,
    "signal": 2,
    "model": 3,
    "synthetic": 4,
    "identify": 4,
    "machine": 4.5,  # the machine stage: uses io, model and identify
    "library": 5,
    "batch": 7,  # the headless batch front end (cmd_batch is its argument parser)
    "report": 6,
    "cli": 7,
    "gui": 7,
}
PACKAGE = REPO / "taptune"


def room(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "taptune" or len(parts) < 2:
        return None
    return parts[1]


def modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(REPO).with_suffix("")
        name = ".".join(rel.parts).removesuffix(".__init__")
        yield name, path


def import_statements(path: Path, name: str):
    """(node, absolute module name) of every import in the module, lazy ones included."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import: resolve against this module's package
                base = name.split(".")[: -node.level] if not path.name == "__init__.py" else name.split(".")[: len(name.split(".")) - node.level + 1]
                yield node, ".".join(base + ([node.module] if node.module else []))
            elif node.module:
                yield node, node.module


def imported(path: Path, name: str):
    for _, target in import_statements(path, name):
        yield target


@pytest.mark.parametrize("name, path", list(modules()), ids=lambda v: v if isinstance(v, str) else "")
def test_no_module_imports_a_layer_above_its_own(name, path):
    own = room(name)
    if own not in RANK:  # taptune/__init__.py, __main__.py
        return
    for target in imported(path, name):
        other = room(target)
        if other in RANK:
            assert RANK[other] <= RANK[own], f"{name} imports {target}: {other} is above {own}"


def import_graph() -> dict[str, set[str]]:
    """Module → the taptune modules it imports (lazily or not).

    ``from pkg import sub`` imports the submodule ``pkg.sub``, ``from pkg import name`` the
    package ``pkg``. The implicit import of a parent package by Python is left out (every
    submodule would otherwise loop through its package's ``__init__``).
    """
    known = dict(modules())
    graph = {}
    for name, path in known.items():
        targets = set()
        for node, target in import_statements(path, name):
            if isinstance(node, ast.ImportFrom):
                subs = {f"{target}.{a.name}" for a in node.names}
                targets.update(subs & known.keys())
                if subs - known.keys() and target in known:
                    targets.add(target)
            elif target in known:
                targets.add(target)
        graph[name] = targets - {name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected group of more than one module (Tarjan), each as a sorted list."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_cycle_finder_sees_direct_and_longer_loops():
    graph = {"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"e"}, "e": {"c"}, "f": {"a"}}
    assert cycles(graph) == [["a", "b"], ["c", "d", "e"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_import_graph_reads_lazy_and_submodule_imports():
    graph = import_graph()
    assert "taptune.model.eigen" in graph["taptune.model.fe"]  # module level
    assert "taptune.library.exchange" in graph["taptune.library.base"]  # inside a method


def test_no_module_imports_one_that_imports_it_back():
    loops = cycles(import_graph())
    assert not loops, "modules that import each other (also lazily, inside functions): " + "; ".join(
        " ↔ ".join(group) for group in loops
    )


@pytest.mark.parametrize("name, path", list(modules()), ids=lambda v: v if isinstance(v, str) else "")
def test_atomic_file_writing_comes_from_io(name, path):
    """Writing a file atomically is an io concern: nobody fetches it from the library room."""
    for node, target in import_statements(path, name):
        if isinstance(node, ast.ImportFrom) and target != "taptune.io.atomic":
            wrong = [a.name for a in node.names if a.name.startswith("atomic_write")]
            assert not wrong, f"{name} imports {', '.join(wrong)} from {target}: import it from taptune.io.atomic"


def test_cli_help_loads_no_heavy_library():
    code = (
        "import sys; from taptune.cli import main; main(['--help']);"
        "heavy = [m for m in ('PySide6', 'matplotlib', 'sounddevice', 'numpy', 'scipy') if m in sys.modules];"
        "print('HEAVY', heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO).stdout
    assert "HEAVY []" in out
