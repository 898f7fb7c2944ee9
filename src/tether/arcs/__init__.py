"""Exact free orientation arcs of the rod at target points, and the rod test (``docs/formulas.md``,
"Free orientations at a point").

For a target ``p`` and rod length ``lss``, the rod at orientation ``a`` is the segment from ``p``
to ``p + lss (cos a, sin a)``. Each edge ``Ei`` seen from its free side blocks the closed interval
of orientations under which the disc of radius ``lss`` about ``p`` meets the edge; the free arcs
are the gaps of the union of those intervals, each end labelled with the feature that bounds it:
``E<i>`` (the observer end touches edge ``i``) or ``V<j>`` (the rod grazes reflex vertex ``j``).

* :mod:`tether.arcs.free` — the free arcs (:func:`free_arcs`, :func:`free_arcs_many`) and their
  records (:class:`Arc`, :class:`FreeArcs`, :class:`ArcTable`);
* :mod:`tether.arcs.rod` — the rod test (:func:`rod_is_free`, :func:`rod_is_free_many`), an
  independent check of the arcs.

Feature names and codes (:class:`~tether.environment.features.Feature`) belong to the map and
are re-exported here. Batch sizes are read from the submodules: set
``tether.arcs.free.POINT_BATCH`` to change them.
"""

import math

from tether.arcs.free import (
    POINT_BATCH,
    Arc,
    ArcTable,
    FreeArcs,
    blocked_intervals,
    check_inside,
    check_lss,
    free_arcs,
    free_arcs_many,
    join_tables,
    near_edge_lines,
    table_entry,
)
from tether.arcs.rod import (
    MOVE_REACH,
    rod_is_free,
    rod_is_free_many,
    rod_is_free_rows,
    rod_rows,
    wedge_columns,
)
from tether.environment.features import Feature, feature_code, feature_name

#: 2π, kept for old imports (the code uses :data:`math.tau`).
TWO_PI = math.tau

__all__ = [
    "Arc", "ArcTable", "Feature", "FreeArcs", "MOVE_REACH", "POINT_BATCH", "blocked_intervals",
    "check_inside", "check_lss", "feature_code", "feature_name", "free_arcs", "free_arcs_many",
    "join_tables", "near_edge_lines", "rod_is_free", "rod_is_free_many", "rod_is_free_rows",
    "rod_rows", "table_entry", "wedge_columns",
]
