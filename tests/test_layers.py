"""Architecture: data flows one way, io → signal → model → identify → library → front ends.

Every taptune module's imports (also the lazy ones inside functions) are read with
``ast``; no module may import a layer above its own. The CLI's fast path must not load
Qt, matplotlib or sounddevice.
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


def imported(path: Path, name: str):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import: resolve against this module's package
                base = name.split(".")[: -node.level] if not path.name == "__init__.py" else name.split(".")[: len(name.split(".")) - node.level + 1]
                yield ".".join(base + ([node.module] if node.module else []))
            elif node.module:
                yield node.module


@pytest.mark.parametrize("name, path", list(modules()), ids=lambda v: v if isinstance(v, str) else "")
def test_no_module_imports_a_layer_above_its_own(name, path):
    own = room(name)
    if own not in RANK:  # taptune/__init__.py, __main__.py
        return
    for target in imported(path, name):
        other = room(target)
        if other in RANK:
            assert RANK[other] <= RANK[own], f"{name} imports {target}: {other} is above {own}"


def test_cli_help_loads_no_heavy_library():
    code = (
        "import sys; from taptune.cli import main; main(['--help']);"
        "heavy = [m for m in ('PySide6', 'matplotlib', 'sounddevice', 'numpy', 'scipy') if m in sys.modules];"
        "print('HEAVY', heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO).stdout
    assert "HEAVY []" in out
