"""The package's shape: modules stay readable (at most 500 lines) and every public name has one definition."""

import ast
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "bayestissue"
MAX_LINES = 500
#: The command-line subcommands implement one interface by design: each ``cli/<command>.py`` module defines
#: ``register(subparsers)`` and ``run(args)``, which ``cli/__init__.py`` calls by module (as every emcee move defines
#: ``propose``). No other name may be defined twice.
INTERFACE = {("cli", "register"), ("cli", "run")}


def _modules():
    return sorted(PACKAGE.rglob("*.py"))


def test_no_module_over_500_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in _modules() if (n := p.read_text().count("\n")) > MAX_LINES}
    assert long == {}


def test_every_public_name_is_defined_once():
    where = defaultdict(set)
    for path in _modules():
        package = path.relative_to(PACKAGE).parts[0]
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names = [node.name]
            elif isinstance(node, ast.Assign):
                names = [t.id for t in node.targets if isinstance(t, ast.Name)]
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                names = [node.target.id]
            else:
                continue
            for name in names:
                if not name.startswith("_") and (package, name) not in INTERFACE:
                    where[name].add(str(path.relative_to(PACKAGE)))
    twice = {name: sorted(paths) for name, paths in where.items() if len(paths) > 1}
    assert twice == {}


def test_test_module_basenames_are_unique():
    """pytest's default (prepend) import mode imports test modules by basename: two ``test_x.py`` in different
    folders break collection of the whole suite."""
    tests = Path(__file__).resolve().parent
    seen = defaultdict(list)
    for path in tests.rglob("test_*.py"):
        seen[path.name].append(str(path.relative_to(tests)))
    assert {name: where for name, where in seen.items() if len(where) > 1} == {}
