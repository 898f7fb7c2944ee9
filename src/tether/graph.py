"""Deprecated: moved to :mod:`tether.analysis.connectivity` (import from :mod:`tether.analysis`).

This module re-exports the old names for one release and warns when imported.
"""

import warnings

from tether.analysis.connectivity import (
    OVERLAP_CHUNK,
    ConnectivityGraph,
    build_graph,
    cell_first,
    cell_ids,
    cell_ids_of,
    cell_regions,
)

__all__ = [
    "OVERLAP_CHUNK", "ConnectivityGraph", "build_graph", "cell_first", "cell_ids",
    "cell_ids_of", "cell_regions",
]

warnings.warn("tether.graph is deprecated and will be removed in the next release: import "
              "from tether.analysis (tether.analysis.connectivity)", DeprecationWarning,
              stacklevel=2)
