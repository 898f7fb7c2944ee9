"""The paper's result and the analysis of a start: the connectivity graph G, the elimination of
escapable cells and the existence verdict (Prop. 1), the escape points and the start
assessment (``docs/formulas.md``, "The verdict"; ``docs/strategy.md``).

Modules: ``connectivity`` (G), ``elimination`` (escapable cells, :func:`analyze`,
:class:`Verdict`), ``escape_points`` (:class:`EscapeTable`, the sweeps, ``L_g`` and the
paper's ``L``), ``assessment`` (:func:`assess`, :func:`is_safe`, the second set of critical
curves), ``critical`` (critical rod lengths of a map, internal).
"""

from tether.analysis.assessment import (
    Assessment,
    EscapePoint,
    assess,
    critical_distance_field,
    is_safe,
)
from tether.analysis.connectivity import ConnectivityGraph, build_graph
from tether.analysis.elimination import Elimination, Verdict, analyze
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
