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

import contextvars
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from tether._util.memory import MemoryBudget, format_size, memory_budget
from tether.environment import Environment
from tether.errors import ResourceLimitError
from tether.spatial import EdgeIndex, point_segment_distance
from tether.tolerances import REL_CURVE_TOL

__all__ = ["AUTO_PLAN", "BASE_BYTES", "BYTES_PER_CELL", "BYTES_PER_EXACT_CELL",
           "BYTES_PER_EXACT_VERTEX", "BYTES_PER_VERTEX_STEP", "TILED", "TILED_REFERENCE",
           "MemoryEstimate", "TilePlan", "TiledEstimate", "check_exact", "check_memory",
           "estimate_cells", "estimate_memory", "estimate_tiled", "tiled_checks"]

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


#: The reference run of the tiled path's constants (:data:`TILED`): ``floor_plan(2000,
#: seed=0)``, lss = width / 15, decomposed in tiles on 2 workers, measured by ``python
#: benchmarks/bench_memory.py --sizes 1000 2000`` (``docs/memory_lean_runs.json``, the rows
#: ``lean2 2178157``) and ``benchmarks/bench_scale.py`` (``docs/scale.md``, the worker's peak); its
#: pairs within lss ``P``, estimated cells ``P² / n``, polyline vertices ``V`` (of
#: :func:`tether.curves.draw.vertex_estimates`'s curves, counted) and counts.
TILED_REFERENCE = {"n": 2000, "pairs": 101_901, "vertices": 1_080_875, "regions": 459_746,
                   "pieces": 903_014, "cells": 3_735_668, "edges": 7_256_658}

#: The tiled path's constants (``docs/memory.md``), each with its source. Counts grow from
#: those of :data:`TILED_REFERENCE` as a power of what drives them (the power through the
#: runs at 1,000 and 2,000 vertices): regions and pieces ``P``, cells and edges ``P² / n``.
#: Bytes are what the main process holds per object once ``decompose`` has returned (the
#: regions' columns and packed polygons, the cells', the pieces' with their crossings' arcs,
#: the curves per polyline vertex), G and the eliminations (bench_memory at 2,000 vertices),
#: and the temporaries above them: of ``decompose`` per polyline vertex (its peak less what
#: it returns), of G's build per edge, of the elimination per cell. A worker holds one
#: task's input segments (``V`` times ``sent`` over the tasks) and their parts and faces.
TILED = {
    "regions_power": 1.117,  # 106,553 -> 459,746 regions as P 27,541 -> 101,901
    "pieces_power": 1.108,  # 209,768 -> 903,014
    "cells_power": 0.930,  # 624,190 -> 3,735,668 as P²/n 758,507 -> 5,191,907
    "edges_power": 0.924,  # 1,226,425 -> 7,256,658
    "bytes_per_region": 303.0,  # columns, packed polygon, structure (bench_memory, 2,000)
    "bytes_per_piece": 540.0,  # columns and packed line (146), the crossings' arcs (393)
    "bytes_per_cell": 9.0,
    "bytes_per_vertex": 82.0,  # the curves, per polyline vertex (85 MB / 1,080,875)
    # decompose's peak (2,132 MB) less the base and what it returns (714 MB), per vertex
    "decompose_bytes_per_vertex": 1314.0,
    "bytes_per_edge": 39.5,  # G's int32 CSR arrays
    "graph_build_bytes_per_edge": 58.0,  # G build's tracemalloc peak (422 MB) a edge
    "elimination_bytes_per_cell": 84.0,  # the elimination's (299 MB), the result's included
    "margin": 1.1,  # the estimate over the model, as the untiled estimate's 10 %
    "vertices_per_vertex_step": 6.4,  # V / (n / step): 5.9 at 1,000, 6.4 at 2,000 vertices
    "sent": 1.4,  # input segments sent to the noding tasks over V (docs/scale.md, 2,000)
    "worker_base_bytes": 100 << 20,  # interpreter, numpy, shapely of a spawned worker
    "worker_bytes_per_segment": 3700.0,  # (1,117 MB - 100) / 302,000 segments a task, +10 %
}


@dataclass(frozen=True)
class TilePlan:
    """How a decomposition is tiled, for the estimate: ``count`` tiles (None: ``"auto"``,
    about ``segments_per_tile`` input segments a tile, at most ``max_tiles``); the numbers
    of :mod:`tether.decomposition.tiles` (given by the caller: this layer sits below it)."""

    count: int | None
    segments_per_tile: int
    max_tiles: int

    def tiles_for(self, segments: float) -> int:
        """The tiles of a map of ``segments`` input segments."""
        if self.count is not None:
            return self.count
        return min(max(math.ceil(segments / self.segments_per_tile), 1), self.max_tiles)


@dataclass(frozen=True)
class TiledEstimate:
    """The estimated peaks of a decomposition in tiles and its analysis (bytes): ``main``
    the calling process's (its ``decompose`` and G and elimination stages: ``decompose``,
    ``analysis``), ``worker`` one worker's, over ``tiles`` tiles of ``segments`` input
    segments in all, and the projected ``counts`` (regions, pieces, cells, edges)."""

    main: float
    worker: float
    decompose: float
    analysis: float
    tiles: int
    segments: float
    counts: dict


def estimate_tiled(n: int, pairs: int, vertices: float, plan: TilePlan) -> TiledEstimate:
    """The peaks of a tiled decomposition and its analysis from the map's ``n`` vertices, its
    ``pairs`` (vertex, edge) pairs within lss and the curves' ``vertices`` (estimated, or
    counted after the critical intervals), by the constants of :data:`TILED`.

    Examples
    --------
    At the reference run's own figures the model gives its measured counts:

    >>> ref = TILED_REFERENCE
    >>> est = estimate_tiled(ref["n"], ref["pairs"], ref["vertices"], TilePlan(None, 250_000, 64))
    >>> est.counts["regions"], est.tiles, round(est.main / 2**30, 1)
    (459746, 5, 2.3)
    """
    t, ref = TILED, TILED_REFERENCE
    p = pairs / ref["pairs"]
    c = estimate_cells(n, pairs) / estimate_cells(ref["n"], ref["pairs"])
    counts = {"regions": ref["regions"] * p ** t["regions_power"],
              "pieces": ref["pieces"] * p ** t["pieces_power"],
              "cells": ref["cells"] * c ** t["cells_power"],
              "edges": ref["edges"] * c ** t["edges_power"]}
    held = (t["bytes_per_region"] * counts["regions"] + t["bytes_per_piece"] * counts["pieces"]
            + t["bytes_per_cell"] * counts["cells"] + t["bytes_per_vertex"] * vertices)
    dec = BASE_BYTES + held + t["decompose_bytes_per_vertex"] * vertices
    graph = t["bytes_per_edge"] * counts["edges"]
    analysis = BASE_BYTES + held + graph + max(
        t["graph_build_bytes_per_edge"] * counts["edges"],
        t["elimination_bytes_per_cell"] * counts["cells"])
    segments = t["sent"] * vertices
    tiles = plan.tiles_for(vertices)
    worker = t["worker_base_bytes"] + t["worker_bytes_per_segment"] * segments / tiles
    m = t["margin"]
    return TiledEstimate(m * max(dec, analysis), m * worker, m * dec, m * analysis, tiles,
                         segments, {k: round(v) for k, v in counts.items()})


#: The tiling of the decomposition under way in this context (None: untiled), set by
#: :func:`tiled_checks`: the late check (:func:`check_exact`, called inside
#: :func:`tether.curves.critical_curves`) then checks the tiled estimate.
_TILING: contextvars.ContextVar[TilePlan | None] = contextvars.ContextVar("tiling",
                                                                          default=None)


@contextmanager
def tiled_checks(plan: TilePlan | None) -> Iterator[None]:
    """Within the block, :func:`check_exact` checks the estimate of a decomposition tiled by
    ``plan`` (None: untiled)."""
    token = _TILING.set(plan)
    try:
        yield
    finally:
        _TILING.reset(token)


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


def check_memory(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL,
                 tiles: TilePlan | None = None) -> None:
    """Refuse, in one line, a decomposition whose estimated memory exceeds the budget.

    The budget is :func:`tether._util.memory.memory_budget` (``--memory-limit``,
    ``TETHER_MEMORY_LIMIT``, else the machine's limits), for each process. Untiled (``tiles``
    None), the estimate is :func:`estimate_memory`'s; in tiles, :func:`estimate_tiled`'s for
    the calling process and for one worker. The message gives the estimate, the budget and
    what would fit: the largest ``lss``, the smallest curve tolerance (by the same
    estimate), tiles (more of them, or tiles at all).

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
    if tiles is None:
        if est.bytes <= budget.bytes:
            return
        raise ResourceLimitError(_refusal(env, est, budget, dist))
    tiled = _tiled(env, est, tiles)
    if max(tiled.main, tiled.worker) <= budget.bytes:
        return
    raise ResourceLimitError(_tiled_refusal(env, est, tiled, tiles, budget, dist))


#: The tiling of the untiled refusal's suggestion (``--tiles auto``: about this many input
#: segments a tile, at most this many tiles: :mod:`tether.decomposition.tiles`' numbers)
AUTO_PLAN = TilePlan(None, 250_000, 64)


def _tiled(env: Environment, est: MemoryEstimate, plan: TilePlan) -> TiledEstimate:
    """:func:`estimate_tiled` of the map at ``est``'s lss and tolerance (the vertices from
    the polyline step)."""
    vertices = TILED["vertices_per_vertex_step"] * env.n / est.step
    return estimate_tiled(env.n, est.pairs, vertices, plan)


def _refusal(env: Environment, est: MemoryEstimate, budget: MemoryBudget,
             dist: np.ndarray) -> str:
    """The one-line refusal: the estimate, the budget and what would fit."""
    fits = []
    tiled = _tiled(env, est, AUTO_PLAN)
    if max(tiled.main, tiled.worker) <= budget.bytes:
        fits.append(f"tiles (--tiles auto: about {format_size(tiled.main)} in this process "
                    f"and {format_size(tiled.worker)} in each worker)")
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


def _tiled_refusal(env: Environment, est: MemoryEstimate, tiled: TiledEstimate,
                   plan: TilePlan, budget: MemoryBudget, dist: np.ndarray) -> str:
    """The one-line refusal of a tiled decomposition: the two estimates, the budget and what
    would fit (more tiles for the workers; a shorter lss or a coarser tolerance for the
    calling process, which holds the result, G and the elimination whatever the tiles)."""
    fits = []
    room = budget.bytes / TILED["margin"] - TILED["worker_base_bytes"]
    need = (math.ceil(TILED["worker_bytes_per_segment"] * tiled.segments / room)
            if room > 0 else None)
    if tiled.main <= budget.bytes and need is not None and need <= plan.max_tiles:
        nx = math.ceil(math.sqrt(need))
        fits.append(f"{need} tiles or more (e.g. --tiles {nx}x{math.ceil(need / nx)})")

    def fits_at(lss: float, rel_tol: float) -> bool:
        pairs = int(np.searchsorted(dist, lss, side="left"))
        got = _tiled(env, _estimate(env, lss, rel_tol, pairs), plan)
        return max(got.main, got.worker) <= budget.bytes

    lss_max = _bisect(lambda x: fits_at(x, est.rel_tol), 1e-3 * env.diameter, est.lss)
    if lss_max is not None:
        fits.append(f"lss <= {_rounded(lss_max, math.floor):g}")
    tol_min = _bisect(lambda x: fits_at(est.lss, 1.0 / x), 1e3, 1.0 / est.rel_tol)
    if tol_min is not None:
        fits.append(f"a curve tolerance rel_tol >= {_rounded(1.0 / tol_min, math.ceil, 2):g} "
                    f"(tether.decompose's rel_tol; default {REL_CURVE_TOL:g})")
    fit = " or ".join(fits) if fits else "nothing at this size (a smaller map)"
    c = tiled.counts
    return (f"map {env.name!r} at lss {est.lss:g} in {tiled.tiles} tiles would need about "
            f"{format_size(tiled.main)} of memory in this process and "
            f"{format_size(tiled.worker)} in each worker (estimated from its {env.n:,} "
            f"vertices and {est.pairs:,} vertex-wall pairs within lss: about "
            f"{c['regions']:,} regions, {c['cells']:,} cells, {c['edges']:,} edges of G, "
            f"{tiled.segments:,.0f} input segments), more than the budget "
            f"{budget.describe()}; what would fit: {fit}; or raise the budget with "
            "--memory-limit SIZE")


def _rounded(x: float, how: Any, digits: int = 4) -> float:
    """``x`` to ``digits`` significant digits, rounded by ``how`` (``math.floor``: down, so
    that a named largest value still fits; ``math.ceil``: up)."""
    if x <= 0 or not math.isfinite(x):
        return x
    scale = 10.0 ** (digits - 1 - math.floor(math.log10(x)))
    return how(x * scale) / scale


def _bisect(fits: Any, lo: float, hi: float) -> float | None:
    """The largest ``x`` in ``[lo, hi]`` with ``fits(x)`` (``fits`` true up to a point,
    false above; to 0.1 %), None if ``fits(lo)`` is false."""
    if not fits(lo):
        return None
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


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
    plan = _TILING.get()
    if plan is not None:  # in tiles: the tiled estimate, with the vertices counted
        tiled = estimate_tiled(env.n, pairs, vertices, plan)
        if max(tiled.main, tiled.worker) > budget.bytes:
            raise ResourceLimitError(
                f"the critical curves of map {env.name!r} at lss {lss:g} (internal units) "
                f"would need about {vertices:,.0f} polyline vertices, and the decomposition "
                f"in {tiled.tiles} tiles about {format_size(tiled.main)} of memory in this "
                f"process and {format_size(tiled.worker)} in each worker, more than the "
                f"budget {budget.describe()}: use a smaller lss, a coarser curve tolerance, "
                "more tiles, or raise the budget with --memory-limit SIZE")
        return
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
