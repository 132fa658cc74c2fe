"""One way for the tests to load a study script (``studies/<name>.py``, not a package) as a fresh module."""

import importlib.util
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[1] / "studies"


def load_study(name: str):
    """``studies/<name>.py`` executed as a new module named ``<name>_under_test`` (each call a fresh copy, so that a
    test's monkeypatching of one copy reaches no other test)."""
    spec = importlib.util.spec_from_file_location(f"{name}_under_test", STUDIES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
