"""House rules read from the source: no module uses another module's private names, one import name.

- No module in controller/, emulators/, dbc/, hil/ or tools/ imports a private
  name (``_x``) of another module: not ``from m import _x``, not ``import m._x``,
  not ``m._x`` on a module it imported.
- Nothing (tests included) imports the old top-level names ``dbc``,
  ``controller``, ``emulators``, ``hil``: only ``wheelleg.*``.
Both checks parse the files (ast); each has a test on a bad snippet that it fails.
"""
from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
RUNTIME = ("controller", "emulators", "dbc", "hil", "tools")
OLD_TOP_LEVEL = frozenset({"dbc", "controller", "emulators", "hil"})


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _imported_modules(tree: ast.AST) -> dict[str, str]:
    """Local name -> module, for every name an import binds to a module."""
    modules = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname:
                    modules[alias.asname] = alias.name
                else:
                    root = alias.name.split(".")[0]
                    modules[root] = root
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                if _is_module(full):
                    modules[alias.asname or alias.name] = full
    return modules


def _dotted(node: ast.AST) -> list[str] | None:
    """``a.b.c`` -> ['a', 'b', 'c']; None when the chain does not start at a plain name."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return [node.id, *reversed(parts)]


def private_uses(source: str, filename: str = "<snippet>") -> list[str]:
    """Every use of another module's private name in ``source``: 'file:line: what'."""
    tree = ast.parse(source, filename)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 and not node.module:  # `from . import _x`: a package's own private submodule
                continue
            module = node.module or ""
            for alias in node.names:
                if _private(alias.name) or any(_private(p) for p in module.split(".")):
                    found.append(f"{filename}:{node.lineno}: from {'.' * node.level}{module} import {alias.name}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if any(_private(p) for p in alias.name.split(".")):
                    found.append(f"{filename}:{node.lineno}: import {alias.name}")
    modules = _imported_modules(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            chain = _dotted(node.value)
            if chain and chain[0] in modules:
                found.append(f"{filename}:{node.lineno}: {'.'.join(chain)}.{node.attr}")
    return found


def old_top_level_imports(source: str, filename: str = "<snippet>") -> list[str]:
    """Imports of ``dbc``, ``controller``, ``emulators`` or ``hil`` as top-level packages."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        found += [f"{filename}:{node.lineno}: {name}" for name in names if name.split(".")[0] in OLD_TOP_LEVEL]
    return found


def _files(*folders: str) -> list[Path]:
    return sorted(p for folder in folders for p in (REPO / folder).rglob("*.py"))


def _check(files: list[Path], checker) -> list[str]:
    found = []
    for path in files:
        found += checker(path.read_text(encoding="utf-8"), str(path.relative_to(REPO)))
    return found


def test_no_module_uses_a_private_name_of_another():
    files = _files(*RUNTIME)
    assert len(files) > 50  # the folders are where this test thinks they are
    assert _check(files, private_uses) == []


def test_nothing_imports_the_old_top_level_names():
    files = _files(*RUNTIME, "tests") + sorted(REPO.glob("*.py"))
    assert len(files) > 80
    assert _check(files, old_top_level_imports) == []


@pytest.mark.parametrize("snippet, expected", [
    ("from wheelleg.hil.record.trace import _plain\n", "from wheelleg.hil.record.trace import _plain"),
    ("from wheelleg.hil.record import trace\ntrace._plain(1)\n", "trace._plain"),
    ("import wheelleg.hil.record.trace as t\nt._columns([])\n", "t._columns"),
    ("import wheelleg.hil.record.trace\nwheelleg.hil.record.trace._plain(1)\n", "wheelleg.hil.record.trace._plain"),
    ("import queue\nq = queue.Queue()\nqueue._sentinel\n", "queue._sentinel"),
    ("from wheelleg.hil import _secret\n", "from wheelleg.hil import _secret"),
    ("from can._private import x\n", "from can._private import x"),
])
def test_the_private_name_check_fails_on_a_bad_snippet(snippet, expected):
    found = private_uses(snippet)
    assert len(found) == 1 and found[0].endswith(expected), found


def test_the_private_name_check_passes_what_is_allowed():
    snippet = ("from __future__ import annotations\nimport can\n"
               "from wheelleg.hil.record.trace import TraceReader\n"
               "class Bus(can.BusABC):\n    def _recv_internal(self, timeout):\n        return self._x, can.__name__\n"
               "TraceReader._load\n"  # a class's own protected member, not a module's private name
               "from . import _core\n")  # a package's own private (e.g. compiled) submodule
    assert private_uses(snippet) == []


@pytest.mark.parametrize("snippet", ["import hil.cli\n", "from controller import params\n", "import dbc\n",
                                     "from emulators.plant import Plant\n"])
def test_the_import_name_check_fails_on_a_bad_snippet(snippet):
    assert len(old_top_level_imports(snippet)) == 1


def test_the_import_name_check_passes_wheelleg_imports():
    assert old_top_level_imports("import wheelleg.hil.cli\nfrom wheelleg.controller import params\n"
                                 "from wheelleg import dbc\n") == []
