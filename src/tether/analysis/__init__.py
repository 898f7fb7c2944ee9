"""The paper's result and the analysis of a start: the connectivity graph G, the elimination of
escapable cells and the existence verdict (Prop. 1), the escape points and the start
assessment (``docs/formulas.md``, "The verdict"; ``docs/strategy.md``).

Modules: ``connectivity`` (G), ``elimination`` (escapable cells, :func:`analyze`,
:class:`Verdict`), ``escape_points`` (:class:`EscapeTable`, the sweeps, ``L_g`` and the
paper's ``L``), ``assessment`` (:func:`assess`, :func:`is_safe`, the second set of critical
curves), ``critical`` (critical rod lengths of a map, internal).
"""

from typing import TYPE_CHECKING

from tether._util.lazy import lazy_attributes
from tether.analysis.connectivity import ConnectivityGraph, build_graph
from tether.analysis.elimination import Elimination, Verdict, analyze

#: Names of the start analysis, loaded on first use: they need scipy (through
#: :mod:`tether.bounds`), which ``analyze`` does not (0.3 s saved on ``tether analyze``).
_LAZY = {
    **dict.fromkeys(["Assessment", "EscapePoint", "assess", "critical_distance_field", "is_safe"],
                    "tether.analysis.assessment"),
    **dict.fromkeys(["EscapeTable", "escape_table", "escape_table_of", "l_paper", "l_safe"],
                    "tether.analysis.escape_points"),
}

if TYPE_CHECKING:
    from tether.analysis.assessment import (
        Assessment,
        EscapePoint,
        assess,
        critical_distance_field,
        is_safe,
    )
    from tether.analysis.escape_points import (
        EscapeTable,
        escape_table,
        escape_table_of,
        l_paper,
        l_safe,
    )

__all__ = [
    "Assessment", "ConnectivityGraph", "Elimination", "EscapePoint", "EscapeTable", "Verdict",
    "analyze", "assess", "build_graph", "critical_distance_field", "escape_table",
    "escape_table_of", "is_safe", "l_paper", "l_safe",
]


__getattr__, __dir__ = lazy_attributes("tether.analysis", globals(), _LAZY)
