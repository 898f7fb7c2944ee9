"""Noding: the arrangement's input lines (the map's rings and the critical curves' polylines)
split at every intersection, so that they meet only at their ends.

GEOS's floating-point noder (``shapely.node``) runs first; if it fails to converge (nearly
coincident or tangent curves), snap rounding on a grid tied to the curve tolerance, which is
robust by construction. Large inputs are noded in two vertical strips, one per thread
(:func:`strip_cut`): every line crossing the cut ``x = x0`` gets a vertex exactly on it, and
each strip's pieces are noded on their own. Pieces of different strips meet only on the cut,
at those shared vertices, so the union of the two nodings is a noding of the whole: the same
lines, the same intersections (up to the rounding of an intersection computed on a segment's
half rather than the whole segment), with one more degree-2 vertex where a line crosses the
cut. Whether the input is split depends on its size only, never on the number of threads.

Snap rounding (:func:`node_snapped`) is local: a part depends only on the input within a few
grid cells of it, so tiles can snap round an input and deliver the whole's parts bit for bit
(:mod:`tether.decomposition.tiles`).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.errors import GEOSException

from tether._util.threads import in_background
from tether.errors import ArrangementError, InvalidParameterError

__all__ = ["CUT_WINDOW", "NODINGS", "SNAP_GRIDS", "STRIP_MIN_SEGMENTS", "check_noding",
           "cut_position", "geos_message",
           "node_floating", "node_lines", "node_snapped", "strip_cut"]

#: Snap-rounding grids tried when floating-point noding fails, as fractions of the curve
#: tolerance: coarser grids only if a finer one fails too.
SNAP_GRIDS = (0.25, 1.0, 4.0)

#: Inputs of at least this many segments are noded in two strips (:func:`strip_cut`); GEOS's
#: noder takes ~4 us per segment, and a 1,000-vertex floor plan has ~480,000 segments.
STRIP_MIN_SEGMENTS = 100_000

#: The cut is placed in the widest gap between the x coordinates of the vertices ranked in
#: this central fraction (by x): balanced strips, and no vertex close to the cut.
CUT_WINDOW = (0.45, 0.55)


#: How an arrangement is noded: ``"auto"``, GEOS's floating-point noder, snap rounding where
#: it fails; ``"snap"``, snap rounding from the start (the same result where the
#: floating-point noder fails, without the minutes it can take to fail on a large map).
NODINGS = ("auto", "snap")


def check_noding(noding: str) -> str:
    """``noding`` validated: one of :data:`NODINGS`.

    Raises
    ------
    InvalidParameterError
        If it is not.
    """
    if noding not in NODINGS:
        raise InvalidParameterError(f"noding must be one of {', '.join(NODINGS)}, got "
                                    f"{noding!r}")
    return noding


def node_lines(lines: np.ndarray, tol: float, segments: int = 0, noding: str = "auto"
               ) -> tuple[np.ndarray, float]:
    """The noded parts (an array of linestrings) of ``lines`` (linestrings, map units) and the
    snap-rounding grid used (0: exact floating-point noding). ``segments`` (the lines' segment
    count) selects the strip split (:data:`STRIP_MIN_SEGMENTS`). Snap rounding is GEOS's
    fixed-precision overlay on a grid of ``SNAP_GRIDS * tol`` map units: every vertex moves by
    at most half a grid cell, well inside the curves' own tolerance ``tol``; with ``noding``
    ``"snap"`` (:data:`NODINGS`) from the start, else where the floating-point noder fails.

    Raises
    ------
    ArrangementError
        If even the coarsest grid fails (the map is beyond tether's resolution).
    """
    if noding == "auto":
        try:
            return _node_floating_strips(lines, segments), 0.0
        except GEOSException:
            pass  # the whole input, snap rounded below
    err = None
    for frac in SNAP_GRIDS:
        grid = frac * tol
        try:
            return node_snapped(lines, grid), grid
        except GEOSException as exc:
            err = exc
    raise ArrangementError(f"the arrangement of {len(lines)} curves could not be noded even "
                           f"on a {SNAP_GRIDS[-1] * tol:.2g} grid (map beyond the curve "
                           f"tolerance {tol:.2g}): {geos_message(err)}")


def _node_floating_strips(lines: np.ndarray, segments: int) -> np.ndarray:
    """GEOS's floating-point noding of ``lines``, in two strips from
    :data:`STRIP_MIN_SEGMENTS` segments (raises GEOSException if it fails)."""
    if segments >= STRIP_MIN_SEGMENTS:
        strips = strip_cut(lines)
        if strips is not None:
            try:
                right = in_background(_node_floating, strips[1])
                left = _node_floating(strips[0])
                return np.concatenate([left, right()])
            except GEOSException:
                pass  # the whole input, below
    return _node_floating(lines)


def node_floating(lines: np.ndarray) -> np.ndarray:
    """GEOS's floating-point noding of ``lines`` (linestrings, map units): the noded parts,
    no snap rounding (raises GEOSException: the tiles' noder, which then snap rounds in tiles)."""
    return _node_floating(lines)


def node_snapped(lines: np.ndarray, grid: float) -> np.ndarray:
    """The snap-rounded noding of ``lines`` (linestrings, map units) on a ``grid`` (map
    units): every vertex rounded to the grid, then GEOS's fixed-precision union (OverlayNG
    with its snap-rounding noder), which nodes the lines at every *hot pixel* (grid cell
    holding a vertex or an intersection) they pass through and makes duplicate edges one,
    keeping the first's direction. The parts are the edges of that graph, one linestring
    from node to node: a line's own ends stay nodes (as with :func:`node_floating`), lines
    are never merged at a degree-2 node. Raises GEOSException if GEOS fails."""
    snapped = shapely.set_precision(lines, grid)
    return shapely.get_parts(shapely.union_all(snapped, grid_size=grid))


def _node_floating(lines: np.ndarray) -> np.ndarray:
    """GEOS's floating-point noding of ``lines``: the noded parts (raises GEOSException)."""
    return shapely.get_parts(shapely.node(shapely.multilinestrings(lines)))


def geos_message(exc: BaseException | None) -> str:
    """The first line of a GEOS error, without its class prefix."""
    return str(exc).splitlines()[0] if exc is not None else "unknown error"


def cut_position(x: np.ndarray) -> float | None:
    """A cut ``x0`` (map units) strictly between two vertex x coordinates ``x``: in the widest
    gap among the vertices ranked within :data:`CUT_WINDOW`; None if there is no gap."""
    xs = np.unique(x)
    if len(xs) < 2:
        return None
    lo = int(CUT_WINDOW[0] * (len(xs) - 1))
    hi = max(int(CUT_WINDOW[1] * (len(xs) - 1)), lo + 1)
    gap = np.diff(xs[lo:hi + 1])
    i = lo + int(np.argmax(gap))
    x0 = 0.5 * (xs[i] + xs[i + 1])
    return float(x0) if xs[i] < x0 < xs[i + 1] else None


def strip_cut(lines: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The pieces of ``lines`` (linestrings) left and right of a vertical cut
    (:func:`cut_position`): every segment crossing the cut is split at a vertex whose x is
    exactly the cut's, shared by the two pieces. None if the lines have no cut."""
    xy, line = shapely.get_coordinates(lines, return_index=True)
    x0 = cut_position(xy[:, 0])
    if x0 is None:
        return None
    k = np.flatnonzero(line[1:] == line[:-1])  # segments k -> k + 1
    s = k[(xy[k, 0] < x0) != (xy[k + 1, 0] < x0)]  # those crossing the cut (no vertex on it)
    a, b = np.take(xy, s, axis=0), np.take(xy, s + 1, axis=0)
    # from the end left of the cut: a segment and its reverse (a curve doubling back on itself,
    # or on another) get the same cut vertex, and their pieces stay identical
    flip = a[:, 0] > x0
    a[flip], b[flip] = b[flip], a[flip].copy()
    t = (x0 - a[:, 0]) / (b[:, 0] - a[:, 0])
    cut = np.column_stack([np.full(len(s), x0), a[:, 1] + t * (b[:, 1] - a[:, 1])])
    # each cut vertex twice: the end of one piece and the start of the next
    at = np.repeat(s + 1, 2)
    pxy = np.insert(xy, at, np.repeat(cut, 2, axis=0), axis=0)
    starts = np.zeros(len(xy), bool)
    starts[0] = True
    starts[1:] = line[1:] != line[:-1]
    flag = np.insert(starts, at, np.tile([False, True], len(s)))
    piece = np.cumsum(flag) - 1
    # a piece's side: its vertices off the cut all lie on one side (the cut ones add 0)
    right = np.bincount(piece, weights=pxy[:, 0] - x0) > 0
    pieces = np.asarray(shapely.linestrings(pxy, indices=piece), dtype=object)
    return pieces[~right], pieces[right]
