"""The package's layering contract, checked on the source (see ``docs/architecture.md``).

Every import in ``src/tether`` is read from the syntax tree, function-local ones included, and
checked against the layer table below, bottom to top:

* a module imports only from its own layer and the layers below (the one sanctioned upward
  edge: a result's ``plot`` method importing :mod:`tether.plot` lazily);
* no name starting with ``_`` is imported from another file (a helper a sibling needs drops
  its underscore);
* matplotlib is imported only under :mod:`tether.plot`;
* the module graph, function-local imports included, has no cycle;
* nothing in ``src`` imports a deprecated shim module (a deprecated name kept by a module
  ``__getattr__`` that forwards it to its new home is listed in ``ALIASES``).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import networkx as nx
import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: Module (or package) name -> layer; the longest matching prefix decides. Fractions order the
#: packages of one layer where one may use the other (the map model below its readers).
LAYERS: dict[str, float] = {
    # L0 errors, tolerances, plumbing
    "tether.errors": 0, "tether.tolerances": 0, "tether._util": 0, "tether.spatial": 0,
    # L1 the map model, its readers and writers, the bundled examples
    "tether.environment": 1, "tether.io": 1.5, "tether.examples": 1.7,
    # L2 exact free arcs and rod kinematics
    "tether.arcs": 2, "tether.rates": 2, "tether.bounds": 2, "tether.motion": 2,
    # L3 critical curves
    "tether.curves": 3,
    # L4 the decomposition
    "tether.decomposition": 4,
    # L5 analysis: G, elimination, escape points, start assessment
    "tether.analysis": 5,
    # L6 simulation, L7 the game, L8 registries and sweeps
    "tether.sim": 6, "tether.game": 7, "tether.strategies": 8, "tether.sweep": 8,
    # L8.5 the follower for a robot's loop (uses the controllers by name)
    "tether.follow": 8.5,
    # L9 figures, L10 the command line
    "tether.plot": 9,
    "tether.cli": 10,
}

#: Deprecated modules kept one release: they re-export from their new home and warn.
SHIMS: set[str] = {
    "tether.animate", "tether.assess", "tether.escape", "tether.floorplan", "tether.graph",
    "tether.occupancy", "tether.plot_kernel", "tether.plot_sweep",
}

#: Deprecated names kept one release by a module-level ``__getattr__`` that warns and forwards
#: to their new home above: (module, new home). The forwarding import (only inside
#: ``__getattr__``) is neither an upward import nor an edge of the import graph, since the
#: module's own code never runs it; the list empties with SHIMS.
ALIASES: set[tuple[str, str]] = {
    ("tether.environment", "tether.io"),  # load_map, from_dict, from_geojson, from_wkt
    ("tether.sim.controller", "tether.strategies"),  # CONTROLLERS
    ("tether.sim.targets", "tether.strategies"),  # TARGETS, make_target
}

#: Violations not yet removed by the refactoring (each step of issue 23 empties some).
KNOWN: set[tuple[str, str, str]] = set()

#: Import cycles not yet broken (as sorted tuples of modules).
KNOWN_CYCLES: set[tuple[str, ...]] = set()


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted((SRC / "tether").rglob("*.py"))}


def _resolve(mod: str, level: int, name: str | None, is_package: bool) -> str:
    """The absolute module of a (possibly relative) ``from`` import."""
    if level == 0:
        return name or ""
    base = mod.split(".") if is_package else mod.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def _imports(mod: str, path: Path):
    """(imported module, imported name or None, enclosing function name or None) per import."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_package = path.name == "__init__.py"
    out = []

    def walk(node, func):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                walk(child, child.name)
                continue
            if isinstance(child, ast.Import):
                out.extend((a.name, None, func) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                target = _resolve(mod, child.level, child.module, is_package)
                out.extend((target, a.name, func) for a in child.names)
            walk(child, func)

    walk(tree, None)
    return out


def _layer(name: str) -> float | None:
    best = None
    for prefix, layer in LAYERS.items():
        if (name == prefix or name.startswith(prefix + ".")) and (
                best is None or len(prefix) > len(best[0])):
            best = (prefix, layer)
    return None if best is None else best[1]


def _target_module(modules: dict[str, Path], target: str, name: str | None) -> str:
    """The module an import reaches: ``from pkg import sub`` reaches ``pkg.sub``."""
    if name is not None and f"{target}.{name}" in modules:
        return f"{target}.{name}"
    return target


@functools.cache
def _violations() -> tuple[set[tuple[str, str, str]], nx.DiGraph]:
    modules = _modules()
    found: set[tuple[str, str, str]] = set()
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for mod, path in modules.items():
        for target, name, func in _imports(mod, path):
            if target.split(".")[0] == "matplotlib" and not (
                    mod == "tether.plot" or mod.startswith("tether.plot.")):
                found.add(("matplotlib", mod, target))
            if target != "tether" and not target.startswith("tether."):
                continue
            reached = _target_module(modules, target, name)
            if func == "__getattr__" and (mod, reached) in ALIASES:
                continue  # a deprecated name forwarded to its new home
            if reached in modules and reached != mod:
                graph.add_edge(mod, reached)
            if name and name.startswith("_") and not name.startswith("__") and reached != mod:
                found.add(("private", mod, f"{target}.{name}"))
            if reached in SHIMS and mod not in SHIMS:
                found.add(("shim", mod, reached))
            if mod == "tether" or mod in SHIMS:
                continue  # the facade and the shims sit above everything
            if reached == "tether":
                if name != "__version__":
                    found.add(("facade", mod, f"tether.{name}"))
                continue
            mine, theirs = _layer(mod), _layer(reached)
            if mine is None or theirs is None:
                found.add(("unlisted", mod, reached))
            elif theirs > mine and not (func == "plot" and theirs == LAYERS["tether.plot"]):
                found.add(("upward", mod, reached))
    return found, graph


def test_every_module_has_a_layer():
    unlisted = sorted(m for m in _modules() if m != "tether" and m not in SHIMS
                      and _layer(m) is None)
    assert not unlisted, f"modules missing from LAYERS: {unlisted}"


def test_imports_follow_the_layers():
    found, _ = _violations()
    new = sorted(found - KNOWN)
    assert not new, "imports breaking the contract:\n" + "\n".join(map(str, new))


def test_known_violations_are_still_there():
    """An entry of KNOWN that no longer occurs must be removed (the list only shrinks)."""
    found, _ = _violations()
    stale = sorted(KNOWN - found)
    assert not stale, "fixed, remove from KNOWN:\n" + "\n".join(map(str, stale))


def test_no_import_cycle():
    _, graph = _violations()
    cycles = {tuple(sorted(c)) for c in nx.strongly_connected_components(graph) if len(c) > 1}
    assert cycles <= KNOWN_CYCLES, f"import cycles (function-local imports count): {cycles}"
    assert KNOWN_CYCLES <= cycles, f"broken, remove from KNOWN_CYCLES: {KNOWN_CYCLES - cycles}"


@pytest.mark.parametrize("source, expected", [
    ("from tether.plot import x", ("tether.plot", "x", None)),
    ("def f():\n    from tether.plot import x", ("tether.plot", "x", "f")),
    ("import matplotlib.pyplot as plt", ("matplotlib.pyplot", None, None)),
])
def test_the_walker_sees_every_import(tmp_path, source, expected):
    """The walker itself: top-level and function-local imports, relative ones resolved."""
    path = tmp_path / "m.py"
    path.write_text(source)
    assert _imports("tether.sweep", path) == [expected]


def test_relative_imports_are_resolved(tmp_path):
    path = tmp_path / "__init__.py"
    path.write_text("from .kernel import Kernel\nfrom . import grid\n")
    assert _imports("tether.game", path) == [("tether.game.kernel", "Kernel", None),
                                             ("tether.game", "grid", None)]


def test_the_architecture_page_names_every_module():
    """``docs/architecture.md`` (where a reader finds a concept) names every module."""
    page = (SRC.parent / "docs" / "architecture.md").read_text()
    missing = []
    for mod, path in _modules().items():
        if mod == "tether" or mod in SHIMS or path.name == "__main__.py":
            continue
        rel = path.relative_to(SRC).as_posix()
        named = (rel in page or f"`{path.name}`" in page if path.name != "__init__.py"
                 else f"{rel.rsplit('/', 1)[0]}/" in page)
        if not named:
            missing.append(rel)
    assert not missing, f"modules the architecture page does not name: {missing}"


def test_every_module_declares_its_public_names():
    """``__all__`` in every module (shims re-export theirs), each name defined there."""
    import importlib
    import warnings

    missing, unknown = [], []
    for mod, path in _modules().items():
        if mod in SHIMS or path.name == "__main__.py":
            continue
        if "__all__" not in path.read_text():
            missing.append(mod)
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            module = importlib.import_module(mod)
        unknown += [f"{mod}.{n}" for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"modules without __all__: {missing}"
    assert not unknown, f"names in __all__ that do not exist: {unknown}"
