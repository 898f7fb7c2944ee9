"""Deprecated: moved to :mod:`tether.io.ros` (ROS occupancy maps; :mod:`tether.io` also has
``load_map`` and ``save_map``).

This module re-exports the old names for one release and warns when imported.
"""

import warnings

from tether.io.ros import (
    DEFAULT_MIN_HOLE_CELLS,
    FREE,
    OCCUPIED,
    UNKNOWN,
    Conversion,
    OccupancyGrid,
    close_pinches,
    free_component,
    rasterize,
    read_grid,
    read_ros_map,
    vectorize,
)

__all__ = [
    "DEFAULT_MIN_HOLE_CELLS", "FREE", "OCCUPIED", "UNKNOWN", "Conversion", "OccupancyGrid",
    "close_pinches", "free_component", "rasterize", "read_grid", "read_ros_map", "vectorize",
]

warnings.warn("tether.occupancy is deprecated and will be removed in the next release: import "
              "from tether.io.ros", DeprecationWarning, stacklevel=2)
