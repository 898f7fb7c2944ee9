"""tether: keep a moving target in sight at a fixed distance inside a polygonal map.

The pipeline (see ``design.md``)::

    Environment -> free arcs -> critical curves -> Decomposition -> Analysis -> Controller

Pure computation never imports matplotlib; :mod:`tether.plot` does.
"""

from tether.arcs import Arc, FreeArcs, free_arcs, free_arcs_many, rod_is_free, rod_is_free_many
from tether.environment import Environment
from tether.errors import (
    InvalidMapError,
    InvalidParameterError,
    OutsideFreeSpaceError,
    TetherError,
)
from tether.io import load_map

__version__ = "0.1.0"

__all__ = [
    "Arc",
    "Environment",
    "FreeArcs",
    "InvalidMapError",
    "InvalidParameterError",
    "OutsideFreeSpaceError",
    "TetherError",
    "free_arcs",
    "free_arcs_many",
    "load_map",
    "rod_is_free",
    "rod_is_free_many",
]
