"""Deprecated: moved to :mod:`tether.analysis.elimination` (import from :mod:`tether.analysis`).

This module re-exports the old names for one release and warns when imported.
"""

import warnings

from tether.analysis.elimination import (
    Elimination,
    Eliminations,
    Verdict,
    analyze,
    cell_rank,
    eliminate,
    escape_story,
    fixed_point,
    fixed_point_arrays,
)

__all__ = [
    "Elimination", "Eliminations", "Verdict", "analyze", "cell_rank", "eliminate",
    "escape_story", "fixed_point", "fixed_point_arrays",
]

warnings.warn("tether.escape is deprecated and will be removed in the next release: import "
              "from tether.analysis (tether.analysis.elimination)", DeprecationWarning,
              stacklevel=2)
