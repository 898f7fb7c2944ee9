"""Fixtures of the tests of the scripts under ``docs/`` (the evidence and table scripts)."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="session")
def doc_script() -> Callable[[str], ModuleType]:
    """A loader of the script ``docs/NAME.py`` as a module (its ``main`` not run)."""
    return _load
