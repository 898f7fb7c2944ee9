"""The decomposition's memory, estimated before the work that needs it, against the memory
budget (``docs/memory.md``).

The peak memory of ``tether analyze`` grows with the decomposition's size: its noded curves,
faces and polygons follow the polyline vertices of the critical curves, its cells (and G,
and the arcs at the pieces' crossings) the number of free arcs over the regions. Both are
known only after the critical curves (seconds to minutes on a big map), so they are estimated
first from what costs milliseconds: the map's vertices ``n``, the pairs (vertex, edge) closer
than ``lss`` (``P``) and the polyline step of the curved curves, ``step = sqrt(8 tol / lss)``
(radians; a circle of radius ``lss`` drawn within ``tol`` has ``2π / step`` vertices)::

    cells ≈ P² / n      (regions grow with P, the arcs over each with P / n)
    peak  ≈ BASE_BYTES + BYTES_PER_VERTEX_STEP * n / step + BYTES_PER_CELL * cells

The constants are fitted (least squares, non-negative) on seeded floor plans of 200 to 1,000
vertices at three rod lengths each, against the peak resident memory of ``tether analyze``
(decompose, self-check, G, elimination and, near a critical length, two more
decompositions), then raised by 10 % so that the estimate is at or above every measured peak
there (``python docs/memory_table.py`` measures them again and writes the table of
``docs/memory.md``). The estimate grows with ``lss`` and shrinks with ``tol``, so the largest
``lss`` and the smallest tolerance that fit are found from it directly.

After the critical intervals, :func:`check_exact` checks the exact vertex estimate against the
same budget (and :func:`tether.curves.check_vertex_budget` against
:data:`tether.curves.MAX_CURVE_VERTICES`, when a program sets it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tether._util.memory import MemoryBudget, format_size, memory_budget
from tether.environment import Environment
from tether.errors import ResourceLimitError
from tether.spatial import EdgeIndex, point_segment_distance
from tether.tolerances import REL_CURVE_TOL

__all__ = ["BASE_BYTES", "BYTES_PER_CELL", "BYTES_PER_EXACT_CELL", "BYTES_PER_EXACT_VERTEX",
           "BYTES_PER_VERTEX_STEP", "MemoryEstimate", "check_exact", "check_memory",
           "estimate_cells", "estimate_memory"]

#: Resident memory of a process that has imported tether and loaded a map, bytes
BASE_BYTES = 64 << 20
#: Peak bytes per map vertex per radian of polyline step (its curves, their faces, polygons)
BYTES_PER_VERTEX_STEP = 8850.0
#: Peak bytes per estimated cell (``P² / n``: the cells, G, the crossings' arcs)
BYTES_PER_CELL = 1660.0
#: Peak bytes per polyline vertex of the exact estimate made after the critical intervals
#: (:func:`tether.curves.draw.vertex_estimates`), with :data:`BYTES_PER_EXACT_CELL` per
#: estimated cell (fitted alike, raised by 20 %: the late check, :func:`check_exact`)
BYTES_PER_EXACT_VERTEX = 940.0
#: Peak bytes per estimated cell in the late check
BYTES_PER_EXACT_CELL = 1445.0


@dataclass(frozen=True)
class MemoryEstimate:
    """The estimated peak memory of decomposing and analyzing one map at one ``lss``.

    ``bytes``: the estimated peak resident memory, ``curve_bytes`` its part that scales with
    ``1 / step`` (the rest is the base and the cells'); ``pairs``: the (vertex, edge) pairs
    closer than lss; ``cells``: the estimated cells; ``step``: the polyline step of the
    curved curves (radians); ``lss`` and ``rel_tol`` as given (map units; relative to the
    map's diameter)."""

    bytes: float
    curve_bytes: float
    pairs: int
    cells: float
    step: float
    lss: float
    rel_tol: float


def estimate_memory(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL
                    ) -> MemoryEstimate:
    """The peak memory of ``analyze(decompose(env, lss, rel_tol))``, estimated in milliseconds
    from the map's size and ``lss`` (see the module's docstring).

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units.
    rel_tol : float
        Curve tolerance relative to the map's diameter.

    Returns
    -------
    MemoryEstimate

    Examples
    --------
    The estimate grows with the rod's length:

    >>> from tether import Environment
    >>> from tether.curves.budget import estimate_memory
    >>> room = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])
    >>> short, long = estimate_memory(room, 0.5), estimate_memory(room, 2.0)
    >>> short.pairs <= long.pairs and short.bytes < long.bytes
    True
    """
    dist = _pair_distances(env, lss)
    return _estimate(env, lss, rel_tol, int(np.count_nonzero(dist < lss)))


def check_memory(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL) -> None:
    """Refuse, in one line, a decomposition whose estimated memory exceeds the budget.

    The budget is :func:`tether._util.memory.memory_budget` (``--memory-limit``,
    ``TETHER_MEMORY_LIMIT``, else the machine's limits). The message gives the estimate, the
    budget and what would fit: the largest ``lss`` and the smallest curve tolerance (by the same
    estimate).

    Raises
    ------
    ResourceLimitError
        If the estimate exceeds the budget.
    """
    budget = memory_budget()
    if budget.bytes is None:
        return
    dist = np.sort(_pair_distances(env, lss))
    est = _estimate(env, lss, rel_tol, int(np.searchsorted(dist, lss, side="left")))
    if est.bytes <= budget.bytes:
        return
    raise ResourceLimitError(_refusal(env, est, budget, dist))


def _refusal(env: Environment, est: MemoryEstimate, budget: MemoryBudget,
             dist: np.ndarray) -> str:
    """The one-line refusal: the estimate, the budget and what would fit."""
    fits = []
    lss_max = _largest_lss(env, est, budget.bytes, dist)
    if lss_max is not None:
        fits.append(f"lss <= {lss_max:.4g}")
    tol_min = _smallest_tol(est, budget.bytes)
    if tol_min is not None:
        fits.append(f"a curve tolerance rel_tol >= {tol_min:.2g} (tether.decompose's "
                    f"rel_tol; default {REL_CURVE_TOL:g})")
    fit = " or ".join(fits) if fits else "nothing at this size (a smaller map)"
    return (f"map {env.name!r} at lss {est.lss:g} would need about {format_size(est.bytes)} "
            f"of memory (estimated from its {env.n:,} vertices and {est.pairs:,} vertex-wall "
            f"pairs within lss: about {est.cells:,.0f} cells, curves drawn in steps of "
            f"{est.step:.2g} rad), more than the budget "
            f"{budget.describe()}; what would fit: {fit}; or raise the budget with "
            "--memory-limit SIZE")


def _largest_lss(env: Environment, est: MemoryEstimate, budget: float, dist: np.ndarray
                 ) -> float | None:
    """The largest ``lss`` below ``est.lss`` whose estimate fits ``budget`` (bisection on
    the sorted pair distances ``dist``, to 0.1 %), or None if none above the smallest valid
    rod length fits."""
    def fits(lss: float) -> bool:
        pairs = int(np.searchsorted(dist, lss, side="left"))
        return _estimate(env, lss, est.rel_tol, pairs).bytes <= budget

    lo = 1e-3 * env.diameter  # the smallest lss tether accepts (tolerances.LSS range)
    if not fits(lo):
        return None
    hi = est.lss
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def _smallest_tol(est: MemoryEstimate, budget: float) -> float | None:
    """The smallest relative curve tolerance whose estimate fits ``budget`` at ``est.lss``
    (the curves' part scales as ``1 / step``, as ``1 / sqrt(tol)``), or None if the base and
    the cells alone exceed it or the tolerance would be coarser than 1e-3 of the map's
    diameter."""
    room = budget - (est.bytes - est.curve_bytes)
    if room <= 0:
        return None
    scale = est.curve_bytes / room  # the curves' part over what fits
    tol = est.rel_tol * scale * scale * 1.001
    return tol if tol <= 1e-3 else None


def estimate_cells(n: int, pairs: int) -> float:
    """The estimated cells of a map of ``n`` vertices with ``pairs`` (vertex, edge) pairs
    within lss: ``pairs² / n`` (0.7 to 1.2 times the count on the floor plans)."""
    return pairs * pairs / max(n, 1)


def _estimate(env: Environment, lss: float, rel_tol: float, pairs: int) -> MemoryEstimate:
    """The estimate for ``pairs`` (vertex, edge) pairs within ``lss`` (the formula of the
    module's docstring, in the map's own units: ``tol / lss`` does not depend on them)."""
    step = math.sqrt(8.0 * rel_tol * env.diameter / lss)
    cells = estimate_cells(env.n, pairs)
    curve = BYTES_PER_VERTEX_STEP * env.n / step
    return MemoryEstimate(BASE_BYTES + curve + BYTES_PER_CELL * cells, curve, pairs, cells,
                          step, float(lss), float(rel_tol))


def check_exact(env: Environment, lss: float, vertices: float) -> None:
    """The late check, after the critical intervals: ``vertices`` (the exact estimate of
    the polyline vertices, :func:`tether.curves.draw.vertex_estimates`) and the estimated
    cells against the memory budget (``env`` and ``lss`` in any one frame).

    Raises
    ------
    ResourceLimitError
        If the memory exceeds the budget.
    """
    budget = memory_budget()
    if budget.bytes is None:
        return
    pairs = int(np.count_nonzero(_pair_distances(env, lss) < lss))
    need = (BASE_BYTES + BYTES_PER_EXACT_VERTEX * vertices
            + BYTES_PER_EXACT_CELL * estimate_cells(env.n, pairs))
    if need > budget.bytes:
        raise ResourceLimitError(
            f"the critical curves of map {env.name!r} at lss {lss:g} (internal units) would "
            f"need about {vertices:,.0f} polyline vertices, and the decomposition about "
            f"{format_size(need)} of memory, more than the budget {budget.describe()}: use "
            "a smaller lss, a coarser curve tolerance, or raise the budget "
            "with --memory-limit SIZE")


def _pair_distances(env: Environment, lss: float) -> np.ndarray:
    """The distances of the (vertex, edge) pairs closer than ``lss`` (map units; an unsorted
    array, every such pair once; a few more pairs at about ``lss``)."""
    a, b, _, _ = env.oriented_edges
    index = EdgeIndex.build(a, b, lss * (1 + 1e-9) + env.length_tol)
    pidx, eidx = index.query(env.vertices)
    dist = point_segment_distance(env.vertices[pidx], a[eidx], b[eidx])
    return dist[dist < lss]
