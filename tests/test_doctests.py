"""The ``Examples`` sections of the package's docstrings, run as doctests (fast tier).

One test per module of ``src/tether`` whose source holds an example (``>>>``). Modules are
imported by their package name (never by path, so importlib mode imports nothing twice), and
the deprecated shims, which warn at import, are never imported. Each example must stay fast
(well under a second) and deterministic: they are the users' first reading of the API.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest
from test_layers import SHIMS

SRC = Path(__file__).resolve().parents[1] / "src"

#: Never imported here: the deprecated shims (they warn at import) and ``python -m tether.cli``
#: (it runs the command line).
SKIP = SHIMS | {"tether.cli.__main__"}

FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = sorted(
    name for path in (SRC / "tether").rglob("*.py")
    if (name := _module_name(path)) not in SKIP and ">>> " in path.read_text(encoding="utf-8")
)


def test_some_modules_have_examples():
    assert len(MODULES) >= 10


@pytest.mark.parametrize("name", MODULES)
def test_examples(name: str) -> None:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    report: list[str] = []
    tests = [t for t in finder.find(module, name) if t.examples]
    assert tests, f"{name} has '>>> ' in its source but no docstring example"
    for test in tests:
        runner.run(test, out=report.append)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, "".join(report)
