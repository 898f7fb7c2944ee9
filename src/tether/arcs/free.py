"""The exact free arcs of the rod at target points: the blocked interval of every edge in
reach, merged; each arc end labelled with the feature bounding it (see :mod:`tether.arcs`).

Feature codes: internally, edge ``i`` has code ``i`` and vertex ``j`` has code ``n + j``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from tether._util.arrays import ragged_arange
from tether._util.threads import map_batches
from tether.environment import Environment
from tether.environment.features import feature_name
from tether.errors import InvalidParameterError, OutsideFreeSpaceError
from tether.spatial import EdgeIndex
from tether.tolerances import ANGLE_TOL, LSS_MAX_REL, LSS_MIN_REL

__all__ = [
    "Arc", "ArcTable", "FreeArcs", "POINT_BATCH", "as_points", "blocked_intervals", "check_inside",
    "check_lss", "edge_columns", "free_arcs", "free_arcs_many", "join_tables", "near_edge_lines",
    "query_edges", "table_entry",
]

_GROUP = 16.0  # > 3*pi: offsets separating points' angle ranges in the merge


def check_lss(lss: Any, env: Environment | None = None) -> float:
    """Return ``lss`` as a float, or raise :class:`InvalidParameterError` if not finite and > 0.

    With ``env``, ``lss`` must also lie within ``[LSS_MIN_REL, LSS_MAX_REL]`` times the map's
    diameter (:mod:`tether.tolerances`): a rod a million times shorter than the map would need
    curves of billions of points, one far longer than the map sees the same geometry.
    """
    if isinstance(lss, bool):
        raise InvalidParameterError(f"lss must be a number, got {lss!r}")
    try:
        val = float(lss)
    except (TypeError, ValueError, OverflowError):
        raise InvalidParameterError(f"lss must be a number, got {lss!r}") from None
    if not math.isfinite(val) or val <= 0:
        raise InvalidParameterError(f"lss must be a finite length > 0, got {lss!r}")
    if env is not None:
        d = env.diameter
        lo, hi = LSS_MIN_REL * d, LSS_MAX_REL * d
        if not lo <= val <= hi:
            raise InvalidParameterError(
                f"lss {val:g} is out of range for map {env.name!r} of diameter {d:.6g}: "
                f"use {lo:.3g} <= lss <= {hi:.3g} ({LSS_MIN_REL:g} to {LSS_MAX_REL:g} times "
                "the diameter)")
    return val


@dataclass(frozen=True)
class Arc:
    """One free arc of orientations, CCW from ``start`` to ``end`` (radians in [0, 2pi))."""

    start: float
    end: float
    start_feature: str
    end_feature: str

    @property
    def length(self) -> float:
        """Angular length in radians, in (0, 2pi)."""
        return (self.end - self.start) % math.tau

    def contains(self, a: float, tol: float = ANGLE_TOL) -> bool:
        """Whether orientation ``a`` (radians) lies in the closed arc, up to ``tol``."""
        return (a - self.start + tol) % math.tau <= self.length + 2 * tol

    def to_dict(self) -> dict:
        """The arc as JSON-ready values (angles in radians)."""
        return {
            "start": self.start,
            "end": self.end,
            "start_feature": self.start_feature,
            "end_feature": self.end_feature,
        }


@dataclass(frozen=True)
class FreeArcs:
    """The free orientations at one target point.

    ``full`` means no obstacle is within reach (the rod turns freely, ``arcs`` is empty); an
    empty ``arcs`` with ``full`` false means no orientation is free.
    """

    point: tuple[float, float]
    lss: float
    full: bool
    arcs: tuple[Arc, ...]

    @property
    def empty(self) -> bool:
        """Whether no orientation is free."""
        return not self.full and not self.arcs

    @property
    def structure(self) -> frozenset[tuple[str, str]] | str:
        """The labelled structure: the set of ``(start_feature, end_feature)`` pairs, or
        ``"FULL"`` / ``"EMPTY"``."""
        if self.full:
            return "FULL"
        if not self.arcs:
            return "EMPTY"
        return frozenset((a.start_feature, a.end_feature) for a in self.arcs)

    def contains(self, a: float) -> bool:
        """Whether orientation ``a`` (radians) is free, up to the angle tolerance."""
        return self.full or any(arc.contains(a) for arc in self.arcs)

    def to_dict(self) -> dict:
        """The free arcs as JSON-ready values (the ``tether arcs --json`` fields)."""
        return {
            "point": list(self.point),
            "lss": self.lss,
            "full": self.full,
            "arcs": [a.to_dict() for a in self.arcs],
        }


@dataclass(frozen=True)
class ArcTable:
    """Free arcs of many points at once, as flat arrays (the vectorized form).

    Row ``k`` is an arc of point ``point[k]``: CCW from ``start[k]`` to ``end[k]`` (radians in
    [0, 2pi)), bounded by features ``start_code[k]`` and ``end_code[k]``. Rows are sorted by point,
    then by start. ``full[i]`` says point ``i`` has no obstacle within reach.
    """

    point: np.ndarray
    start: np.ndarray
    end: np.ndarray
    start_code: np.ndarray
    end_code: np.ndarray
    full: np.ndarray

    def rows_of(self, i: int) -> slice:
        """Rows of point ``i``."""
        lo, hi = np.searchsorted(self.point, [i, i + 1])
        return slice(int(lo), int(hi))


def blocked_intervals(env: Environment, pts: np.ndarray, lss: float) -> dict[str, np.ndarray]:
    """Blocked orientation intervals ``B_i(p)`` for all edges within reach of each point.

    ``env`` is taken as is (call it with :attr:`Environment.internal` and internal points).

    Returns a dict of arrays, one row per nonempty interval: ``point`` (index), ``edge``,
    ``start`` (radians in [0, 2pi), CW end), ``length`` (radians, in (0, pi)),
    ``cw_code`` and ``ccw_code`` (feature codes of the CW and CCW ends; a vertex where rings
    touch is coded as the first vertex at its point, :attr:`Environment.coincident`), sorted
    by point.
    Tangencies (intervals narrower than ``ANGLE_TOL`` whose edge part inside the disc is
    shorter than ``env.length_tol``) are dropped.
    """
    ax, ay, dx, dy, dd, sdd, tag_a, tag_b = edge_columns(env)
    pidx, eidx, count = query_edges(_facing_index(env, lss), pts)
    # w = A - p, columns apart (no (k, 2) temporaries); the point's coordinates repeated along
    # its run of rows (a repeat, cheaper than a gather)
    wx = ax[eidx] - np.repeat(pts[:, 0], count)
    wy = ay[eidx] - np.repeat(pts[:, 1], count)
    ex, ey, de = dx[eidx], dy[eidx], dd[eidx]
    # the side, reach and overlap tests on every candidate row, then one compaction (the
    # tests are row by row: the kept rows' numbers are those of compacting after each test;
    # the side and reach tests drop few rows)
    side = ey * wx - ex * wy  # cross(d, p - a), exactly ex * (-wy) - ey * (-wx): > 0 free side
    b = ex * wx + ey * wy
    c = (wx * wx + wy * wy) - lss * lss
    disc = b * b - de * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):  # rows dropped below
        r1 = (-b - sq) / de
        r2 = (-b + sq) / de
    t1 = np.maximum(r1, 0.0)
    t2 = np.minimum(r2, 1.0)
    k = np.flatnonzero((side > env.length_tol * sdd[eidx]) & (disc > 0) & (t1 < t2))
    del side, b, c, disc, sq  # (the batch's peak: the candidate rows' columns)
    # the rows' geometry taken to the k rows now; their point, edge and roots only at the
    # rows kept in the end (w)
    wx, wy, ex, ey, t1, t2 = (x[k] for x in (wx, wy, ex, ey, t1, t2))
    p1x, p1y = wx + t1 * ex, wy + t1 * ey
    p2x, p2y = wx + t2 * ex, wy + t2 * ey
    start = np.mod(np.arctan2(p1y, p1x), math.tau)
    length = np.arctan2(p1x * p2y - p1y * p2x, p1x * p2x + p1y * p2y)
    # a tangency (the circle grazes the edge, or the point sits at distance lss of a vertex up
    # to rounding) blocks nothing. It is told by the length of the edge's part inside the disc
    # (the chord), not by the angle alone: seen from a point near the line of an edge, a long
    # chord subtends an angle ~ h * chord / lss^2 (h: distance to the line) that falls below
    # ANGLE_TOL far from any tangency. Dropping those intervals would move the structure's
    # boundary off the critical curves C(Vj, Ei) and B(Vj) near their common end (issue #9).
    chord = (t2 - t1) * np.sqrt(de[k])
    wide = (length > ANGLE_TOL) | ((length > 0.0) & (chord > env.length_tol))
    w = k[wide]
    e = eidx[w]
    # a vertex where rings touch is named by the first vertex at that point: grazing it, the
    # edges of both rings end their intervals at the very same angle (which one reaches
    # farther is rounding), and both vertices are the one feature of the free space there
    first = env.coincident
    return {
        "point": pidx[w],
        "edge": e,
        "start": start[wide],
        "length": length[wide],
        "cw_code": np.where(r1[w] <= 0, env.n + first[tag_a[e]], e),
        "ccw_code": np.where(r2[w] >= 1, env.n + first[tag_b[e]], e),
    }


def near_edge_lines(env: Environment, pts: np.ndarray, lss: float) -> np.ndarray:
    """Whether each point (internal frame, (m, 2)) lies on the free side of an edge within
    reach ``lss`` but no farther than ``env.length_tol`` from the edge's supporting line: there
    :func:`blocked_intervals` takes the point as on the line and skips the edge (its interval
    has no width on the line), so the free arcs at such a point can differ from those on both
    sides of the line by a sliver arc. A point that stands for a whole face must not lie there
    (:func:`tether.decomposition.pipeline` moves such points off the line)."""
    out = np.zeros(len(pts), dtype=bool)
    if len(pts) == 0:
        return out
    ax, ay, dx, dy, dd, sdd, _, _ = edge_columns(env)
    pidx, eidx, _ = query_edges(env.edge_index(lss), pts)
    wx = ax[eidx] - pts[pidx, 0]
    wy = ay[eidx] - pts[pidx, 1]
    side = dy[eidx] * wx - dx[eidx] * wy
    band = (side > 0) & (side <= env.length_tol * sdd[eidx])
    k = np.flatnonzero(band)
    if len(k) == 0:
        return out
    e = eidx[k]
    t = np.clip(-(dx[e] * wx[k] + dy[e] * wy[k]) / dd[e], 0.0, 1.0)
    near = np.hypot(wx[k] + t * dx[e], wy[k] + t * dy[e]) < lss
    out[pidx[k[near]]] = True
    return out


def _facing_index(env: Environment, lss: float) -> EdgeIndex:
    """The edge index of :meth:`Environment.edge_index` for ``lss`` without the edges that no
    point of a grid cell sees from their free side (cached per map and ``lss``): about 45 %
    fewer candidate rows for :func:`blocked_intervals`, the same rows after its side test.

    An entry (cell, edge) is dropped when ``cross(d, p - a)`` stays below the side test's
    threshold ``length_tol |d|`` by a margin at every corner of the cell's box grown by a
    margin (the cross product is linear in ``p``: its largest value on the box is at a corner).
    The margins (``1e-9`` of the grid's extent) are far above the rounding of the test in
    floating point, so a dropped entry is one the test rejects for every point in the cell.
    The border cells keep all their edges: the query clips the points beyond the grid to them.
    Within a cell the edges keep their order: the rows come out in the very order of the full
    index's rows that pass the side test."""
    cache = env.memo.setdefault("facing_indexes", {})
    key = float(lss)
    got = cache.get(key)
    if got is not None:
        return got
    full = env.edge_index(lss)
    ax, ay, dx, dy, _, sdd, _, _ = edge_columns(env)
    nx, ny = full.shape
    cid = np.repeat(np.arange(nx * ny), np.diff(full.start))
    e = full.edges
    gx, gy = cid // ny, cid % ny
    extent = float(np.max(np.abs(full.origin)) + max(nx, ny) * full.cell)
    grow = 1e-9 * extent
    x0 = full.origin[0] + gx * full.cell - grow
    y0 = full.origin[1] + gy * full.cell - grow
    x1, y1 = x0 + (full.cell + 2 * grow), y0 + (full.cell + 2 * grow)
    ex, ey = dx[e], dy[e]
    side = np.maximum(np.maximum(ex * (y0 - ay[e]) - ey * (x0 - ax[e]),
                                 ex * (y1 - ay[e]) - ey * (x0 - ax[e])),
                      np.maximum(ex * (y0 - ay[e]) - ey * (x1 - ax[e]),
                                 ex * (y1 - ay[e]) - ey * (x1 - ax[e])))
    border = (gx == 0) | (gy == 0) | (gx == nx - 1) | (gy == ny - 1)
    keep = border | (side > (env.length_tol - grow) * sdd[e])
    start = np.r_[0, np.cumsum(np.bincount(cid[keep], minlength=nx * ny))]
    got = cache[key] = EdgeIndex(full.origin, full.cell, full.shape, start, e[keep])
    return got


def query_edges(index: EdgeIndex, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`EdgeIndex.query` (the same rows, with less overhead on small chunks) that also
    returns each point's number of rows."""
    nx, ny = index.shape
    g = np.floor((pts - index.origin) / index.cell).astype(np.int64)
    # np.minimum/np.maximum: np.clip's own overhead is most of the time on small chunks
    c = (np.minimum(np.maximum(g[:, 0], 0), nx - 1) * ny
         + np.minimum(np.maximum(g[:, 1], 0), ny - 1))
    first = index.start[c]
    count = index.start[c + 1] - first
    return np.repeat(np.arange(len(pts)), count), index.edges[ragged_arange(first, count)], count


def edge_columns(env: Environment) -> tuple[np.ndarray, ...]:
    """Per oriented edge, computed once per map: start ``A`` (x, y), direction ``d = B - A``
    (x, y), ``d·d``, ``sqrt(d·d)`` and the vertex indices at ``A`` and ``B``."""
    got = env.memo.get("edge_columns")
    if got is None:
        A, B, tag_a, tag_b = env.oriented_edges
        d = B - A
        dd = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        got = env.memo["edge_columns"] = (
            np.ascontiguousarray(A[:, 0]), np.ascontiguousarray(A[:, 1]),
            np.ascontiguousarray(d[:, 0]), np.ascontiguousarray(d[:, 1]), dd, np.sqrt(dd),
            tag_a, tag_b)
    return got


def _merge(iv: dict[str, np.ndarray], npts: int) -> ArcTable:
    """Free arcs = gaps of the union of the blocked intervals on each point's circle."""
    order = _order_by_point_angle(iv["point"], iv["start"])
    pt = iv["point"][order]
    S = iv["start"][order]
    E = S + iv["length"][order]
    m = len(S)
    full = np.ones(npts, dtype=bool)
    full[pt] = False
    if m == 0:
        z = np.zeros(0)
        zi = np.zeros(0, dtype=np.int64)
        return ArcTable(zi, z, z, zi, zi, full)
    # running arg-max of the interval ends within each point's run; the offset only separates
    # the runs for the comparison, the values themselves are taken unshifted
    key = E + pt * _GROUP
    arg = np.maximum.accumulate(np.where(key >= np.maximum.accumulate(key), np.arange(m), 0))
    M = E[arg]
    last = np.empty(m, dtype=bool)  # (no np.r_: its overhead counts on small chunks)
    np.not_equal(pt[1:], pt[:-1], out=last[:-1])
    last[-1] = True
    last_of = np.flatnonzero(last)
    first_of = np.concatenate(([0], last_of[:-1] + 1))
    size = np.diff(last_of, prepend=-1)
    # candidate gaps: after every row, to the next row's start (the last row: around the circle)
    nxt = np.arange(1, m + 1)
    nxt[last_of] = first_of
    g_end = S[nxt] + np.where(last, math.tau, 0.0)
    # the largest end may wrap past 2pi and cover the beginning of the circle up to W
    W = np.repeat(M[last_of] - math.tau, size)
    g_start = np.maximum(M, W)
    k = np.flatnonzero(g_end - g_start > ANGLE_TOL)  # rows inside a component leave no gap
    # the gaps' end features: the CCW end of the interval reaching farthest (or of the one
    # wrapping past 2pi, where it covers the gap's start), the CW end of the next interval
    wraps = M[k] < W[k]
    ends_at = np.where(wraps, np.repeat(arg[last_of], size)[k] if wraps.any() else 0, arg[k])
    s_code = iv["ccw_code"][order[ends_at]]
    e_code = iv["cw_code"][order[nxt[k]]]
    start = np.mod(g_start[k], math.tau)
    end = np.mod(g_end[k], math.tau)
    o = _order_by_point_angle(pt[k], start)
    return ArcTable(pt[k][o], start[o], end[o], s_code[o], e_code[o], full)


def _order_by_point_angle(point: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``np.lexsort((angle, point))`` for integer points >= 0 and angles in [0, 2pi), about
    ten times faster: one stable sort on ``8 point + angle``, verified (angles of one point
    that round to one key may come out of order: then the lexsort)."""
    if len(point) == 0:
        return np.zeros(0, np.int64)
    order = np.argsort(point * 8.0 + angle, kind="stable")
    p, a = point[order], angle[order]
    if np.all((p[1:] > p[:-1]) | ((p[1:] == p[:-1]) & (a[1:] >= a[:-1]))):
        return order
    return np.lexsort((angle, point))


def as_points(points: Any) -> np.ndarray:
    """Target points as a float array of shape (m, 2) (one point (2,) becomes (1, 2))."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim == 1:
        pts = pts.reshape(1, -1)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InvalidParameterError("points must have shape (m, 2)")
    if not np.all(np.isfinite(pts)):
        raise InvalidParameterError("points must be finite")
    return pts


def check_inside(env: Environment, pts: np.ndarray) -> None:
    """Raise :class:`OutsideFreeSpaceError` unless every point is strictly inside the free
    space (farther than the length tolerance from the boundary)."""
    inside = env.contains(pts[:, 0], pts[:, 1])
    inside &= env.boundary_distance(pts[:, 0], pts[:, 1]) > env.length_tol
    if not np.all(inside):
        i = int(np.flatnonzero(~inside)[0])
        x, y = pts[i]
        where = "on the boundary of" if env.contains(x, y) else "outside"
        raise OutsideFreeSpaceError(f"target point ({x:.6g}, {y:.6g}) is {where} the free space")


#: Points handled per batch by the vectorized arc and rod tests: each point brings one row
#: per edge within reach, so this bounds their working memory (not their speed).
POINT_BATCH = 20_000


def free_arcs_many(env: Environment, points: Any, lss: float, check: bool = True) -> ArcTable:
    """Exact free arcs at many target points, vectorized.

    Parameters
    ----------
    env : Environment
    points : array_like, shape (m, 2)
        Target points strictly inside the free space, map units.
    lss : float
        Rod length, map units, > 0.
    check : bool
        Verify that every point is strictly inside the free space (skip only for points known
        to be inside).

    Returns
    -------
    ArcTable

    Raises
    ------
    InvalidParameterError
        If ``lss`` is not a finite positive number or points are malformed.
    OutsideFreeSpaceError
        If a point is outside the free space or on its boundary.

    Examples
    --------
    A 1.5 × 3 room and a rod of length 1: at the centre two arcs (up and down), near a corner
    one:

    >>> from tether import Environment, free_arcs_many
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> table = free_arcs_many(room, [(0.75, 1.5), (0.2, 0.2)], 1.0)
    >>> table.point.tolist()  # the point each arc belongs to
    [0, 0, 1]
    >>> [round(float(s), 4) for s in table.start]
    [0.7227, 3.8643, 6.0818]
    """
    lss = check_lss(lss)
    pts = as_points(points)
    if check:
        check_inside(env, pts)
    if len(pts) > POINT_BATCH:  # bounded memory: (point, edge) candidate rows per batch
        return join_tables(map_batches(  # in threads: numpy's big calls release the GIL
            lambda lo, hi: free_arcs_many(env, pts[lo:hi], lss, check=False), len(pts),
            POINT_BATCH))
    inner, frame = env.internal, env.frame
    table = _merge(blocked_intervals(inner, frame.to_internal(pts), lss * frame.scale), len(pts))
    if inner is env:
        return table
    cm = env.code_map  # internal feature codes to the file's
    return ArcTable(table.point, table.start, table.end, cm[table.start_code],
                    cm[table.end_code], table.full)


def join_tables(parts: list[ArcTable], release: Callable[[], Any] | None = None) -> ArcTable:
    """The tables of consecutive batches of points as one table (the points of ``parts[k]``
    numbered after those of ``parts[k - 1]``). Empties ``parts`` and joins column by column,
    each column's batches freed once joined (and ``release`` called, if given: e.g. to return
    the freed memory to the system): the peak is the batches and one joined column, not
    twice the table."""
    cols = {f: [getattr(t, f) for t in parts] for f in _TABLE_FIELDS}
    parts.clear()
    offset = 0
    for i, (point, full) in enumerate(zip(cols["point"], cols["full"], strict=True)):
        cols["point"][i] = point + offset  # one batch's column at a time
        offset += len(full)
    joined = {}
    for f in _TABLE_FIELDS:
        joined[f] = np.concatenate(cols.pop(f))
        if release is not None:
            release()
    return ArcTable(**joined)


_TABLE_FIELDS = ("point", "start", "end", "start_code", "end_code", "full")


def free_arcs(env: Environment, point: Any, lss: float) -> FreeArcs:
    """Exact free arcs at one target point; see :func:`free_arcs_many`.

    Returns
    -------
    FreeArcs
        The arcs sorted by start angle, each end labelled ``E<i>`` or ``V<j>``.

    Examples
    --------
    >>> from tether import Environment, free_arcs
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> fa = free_arcs(room, (0.75, 1.5), 1.0)
    >>> [(round(arc.start, 4), round(arc.end, 4), arc.start_feature, arc.end_feature)
    ...  for arc in fa.arcs]
    [(0.7227, 2.4189, 'E1', 'E3'), (3.8643, 5.5605, 'E3', 'E1')]
    >>> fa.contains(1.5708), fa.contains(0.0)  # pointing up, pointing right (radians)
    (True, False)
    """
    table = free_arcs_many(env, point, lss)
    return table_entry(env, table, 0, tuple(map(float, as_points(point)[0])), check_lss(lss))


def table_entry(env: Environment, table: ArcTable, i: int, point: tuple[float, float],
                lss: float) -> FreeArcs:
    """The :class:`FreeArcs` of point ``i`` of an :class:`ArcTable`."""
    rows = table.rows_of(i)
    arcs = tuple(
        Arc(float(s), float(e), feature_name(env, sc), feature_name(env, ec))
        for s, e, sc, ec in zip(table.start[rows], table.end[rows],
                                table.start_code[rows], table.end_code[rows], strict=True)
    )
    return FreeArcs(point, lss, bool(table.full[i]), arcs)
