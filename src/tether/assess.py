"""Deprecated: moved to :mod:`tether.analysis.assessment` and :mod:`tether.analysis.escape_points`
(import from :mod:`tether.analysis`).

This module re-exports the old names for one release and warns when imported.
"""

import math
import warnings

from tether.analysis.assessment import (
    Assessment,
    EscapePoint,
    assess,
    critical_distance_field,
    is_safe,
)
from tether.analysis.escape_points import (
    SAMPLES_PER_PIECE,
    VERTEX_GOAL_MARGIN,
    WALL_CODE,
    EscapeTable,
    escape_table,
    escape_table_of,
    l_paper,
    l_safe,
    rod_free_fan,
    sweep_row,
    sweeps,
    wall_contact_points,
    wall_rows,
)

__all__ = [
    "SAMPLES_PER_PIECE", "TWO_PI", "VERTEX_GOAL_MARGIN", "WALL_CODE", "Assessment",
    "EscapePoint", "EscapeTable", "assess", "critical_distance_field", "escape_table",
    "escape_table_of", "is_safe", "l_paper", "l_safe", "rod_free_fan", "sweep_row", "sweeps",
    "wall_contact_points", "wall_rows",
]

#: ``2π`` (use :data:`math.tau`).
TWO_PI = math.tau

warnings.warn("tether.assess is deprecated and will be removed in the next release: import "
              "from tether.analysis (tether.analysis.assessment, tether.analysis.escape_points)",
              DeprecationWarning, stacklevel=2)
