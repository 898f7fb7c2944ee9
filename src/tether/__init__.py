"""tether: keep a moving target in sight at a fixed distance inside a polygonal map.

The pipeline, one folder (or file) per stage (``docs/architecture.md``)::

    map (environment, io) -> free arcs (arcs) -> critical curves (curves)
        -> decomposition -> analysis -> simulation (sim) / the game (game) -> plot, cli

The names below are the facade: each is loaded from its stage when first used, so
``import tether`` imports neither shapely nor matplotlib until a name needs them.

Examples
--------
>>> import tether
>>> env = tether.examples.load("rectangle")
>>> verdict = tether.analyze(tether.decompose(env, 1.0))
>>> verdict.strategy_exists, verdict.verified
(False, True)
>>> tether.analyze(tether.decompose(env, 0.5)).strategy_exists
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from tether._util.lazy import lazy_attributes
from tether.errors import (
    ArrangementError,
    InvalidMapError,
    InvalidParameterError,
    NonFiniteResultError,
    OutputPathError,
    OutsideFreeSpaceError,
    ResourceLimitError,
    TetherError,
)

__version__ = "0.1.0"

#: Facade name -> the module that defines it (loaded on first use).
_LAZY = {
    "Environment": "tether.environment",
    "load_map": "tether.io",
    "save_map": "tether.io",
    "Arc": "tether.arcs",
    "FreeArcs": "tether.arcs",
    "free_arcs": "tether.arcs",
    "free_arcs_many": "tether.arcs",
    "rod_is_free": "tether.arcs",
    "rod_is_free_many": "tether.arcs",
    "critical_curves": "tether.curves",
    "Decomposition": "tether.decomposition",
    "decompose": "tether.decomposition",
    "check": "tether.decomposition",
    "self_check": "tether.decomposition",
    "Verdict": "tether.analysis",
    "analyze": "tether.analysis",
    "simulate": "tether.sim.simulate",
    "World": "tether.sim.protocols",
    "Kernel": "tether.game",
    "surveillance_kernel": "tether.game",
    "make_target": "tether.strategies",
    "Follower": "tether.follow",
}

#: Subpackages reachable as attributes (``tether.examples.load(...)``) without an import.
_SUBPACKAGES = ("analysis", "curves", "decomposition", "environment", "examples", "game", "io",
                "plot", "sim", "strategies")

__all__ = [
    "Arc",
    "ArrangementError",
    "Decomposition",
    "Environment",
    "Follower",
    "FreeArcs",
    "InvalidMapError",
    "InvalidParameterError",
    "Kernel",
    "NonFiniteResultError",
    "OutputPathError",
    "OutsideFreeSpaceError",
    "ResourceLimitError",
    "TetherError",
    "Verdict",
    "World",
    "analyze",
    "check",
    "critical_curves",
    "decompose",
    "free_arcs",
    "free_arcs_many",
    "load_map",
    "make_target",
    "rod_is_free",
    "rod_is_free_many",
    "save_map",
    "self_check",
    "simulate",
    "surveillance_kernel",
]

if TYPE_CHECKING:  # what static tools see; at run time the names load lazily
    from tether.analysis import Verdict, analyze
    from tether.arcs import Arc, FreeArcs, free_arcs, free_arcs_many, rod_is_free, rod_is_free_many
    from tether.curves import critical_curves
    from tether.decomposition import Decomposition, check, decompose, self_check
    from tether.environment import Environment
    from tether.follow import Follower
    from tether.game import Kernel, surveillance_kernel
    from tether.io import load_map, save_map
    from tether.sim.protocols import World
    from tether.sim.simulate import simulate
    from tether.strategies import make_target


__getattr__, __dir__ = lazy_attributes("tether", globals(), _LAZY, _SUBPACKAGES)
