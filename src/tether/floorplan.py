"""Deprecated: moved to :mod:`tether.examples.floorplan`.

This module re-exports the old names for one release and warns when imported.
"""

import warnings

from tether.examples.floorplan import (
    CLEARANCE,
    DOOR,
    JUNCTION_GAP,
    PILLAR,
    ROOM_H,
    ROOM_W,
    WALL,
    floor_plan,
)

__all__ = ["CLEARANCE", "DOOR", "JUNCTION_GAP", "PILLAR", "ROOM_H", "ROOM_W", "WALL",
           "floor_plan"]

warnings.warn("tether.floorplan is deprecated and will be removed in the next release: import "
              "from tether.examples.floorplan", DeprecationWarning, stacklevel=2)
