"""Exact free orientation arcs of the rod at target points (``docs/formulas.md``,
"Free orientations at a point"), and the rod test.

For a target ``p`` and rod length ``lss``, the rod at orientation ``a`` is the segment from ``p``
to ``p + lss (cos a, sin a)``. Each edge ``Ei`` seen from its free side blocks the closed interval
of orientations under which the disc of radius ``lss`` about ``p`` meets the edge; the free arcs
are the gaps of the union of those intervals, each end labelled with the feature that bounds it:
``E<i>`` (the observer end touches edge ``i``) or ``V<j>`` (the rod grazes reflex vertex ``j``).

Feature codes: internally, edge ``i`` has code ``i`` and vertex ``j`` has code ``n + j``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from tether._util.arrays import ragged_arange
from tether._util.threads import map_batches
from tether.environment import Environment
from tether.errors import InvalidParameterError, OutsideFreeSpaceError
from tether.spatial import EdgeIndex
from tether.tolerances import ANGLE_TOL, LSS_MAX_REL, LSS_MIN_REL

__all__ = [
    "Arc", "ArcTable", "Feature", "FreeArcs", "MOVE_REACH", "POINT_BATCH",
    "blocked_intervals", "check_inside", "check_lss", "feature_code", "feature_name", "free_arcs",
    "free_arcs_many", "join_tables", "near_edge_lines", "rod_is_free", "rod_is_free_many",
    "rod_is_free_rows", "rod_rows", "table_entry", "wedge_columns"
]

TWO_PI = math.tau  # kept for old imports; the code uses math.tau
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


class Feature(NamedTuple):
    """A map feature bounding a free arc: wall ``("E", i)`` (edge ``i``) or reflex vertex
    ``("V", i)``; ``str()`` gives its name, ``"E1"`` or ``"V2"``. :func:`feature_name` and
    :func:`feature_code` are the codecs between names and the integer codes (edge ``i`` is
    code ``i``, vertex ``i`` code ``n + i``)."""

    kind: str
    index: int

    def __str__(self) -> str:
        return f"{self.kind}{self.index}"

    @classmethod
    def parse(cls, name: str) -> Feature:
        """The feature named ``name`` (``"E1"``, ``"V2"``); ValueError if it is not one."""
        kind, digits = name[:1], name[1:]
        if kind not in ("E", "V") or not digits.isdigit():
            raise ValueError(f"not a feature name: {name!r}")
        return cls(kind, int(digits))

    @classmethod
    def of(cls, env: Environment, code: int) -> Feature:
        """The feature of code ``code`` in ``env``'s numbering."""
        code = int(code)
        return cls("E", code) if code < env.n else cls("V", code - env.n)

    def code(self, env: Environment) -> int:
        """The feature's code in ``env``'s numbering."""
        return self.index if self.kind == "E" else env.n + self.index


def feature_name(env: Environment, code: int) -> str:
    """Name of a feature code: ``E<i>`` for ``code < n``, else ``V<code - n>`` (``str`` of
    :meth:`Feature.of`)."""
    code = int(code)
    return f"E{code}" if code < env.n else f"V{code - env.n}"


def feature_code(env: Environment, name: str) -> int:
    """Inverse of :func:`feature_name` (:meth:`Feature.code` of :meth:`Feature.parse`)."""
    return Feature.parse(name).code(env)


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
    ax, ay, dx, dy, dd, sdd, tag_a, tag_b = _edge_columns(env)
    pidx, eidx, count = _query(_facing_index(env, lss), pts)
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
    ax, ay, dx, dy, dd, sdd, _, _ = _edge_columns(env)
    pidx, eidx, _ = _query(env.edge_index(lss), pts)
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
    ax, ay, dx, dy, _, sdd, _, _ = _edge_columns(env)
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


def _query(index: EdgeIndex, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def _edge_columns(env: Environment) -> tuple[np.ndarray, ...]:
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


def _as_points(points: Any) -> np.ndarray:
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
    pts = _as_points(points)
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
    return table_entry(env, table, 0, tuple(map(float, _as_points(point)[0])), check_lss(lss))


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


# ---------------------------------------------------------------------- rod test
def rod_is_free_many(env: Environment, points: Any, angles: Any, lss: float) -> np.ndarray:
    """Whether each rod ``[p, p + lss u(a)]`` lies in the closed free space (vectorized).

    This test is independent of the arc computation: it intersects the rod segment with the
    edges (a transversal crossing of an edge's interior before the tip blocks) and checks, at
    every vertex the rod passes through or ends on, that the rod stays in the vertex's free cone.
    Contact (tip on an edge, rod grazing a vertex) is free. Rods closer than the length tolerance
    to a vertex count as passing through it.

    Parameters
    ----------
    points : array_like, shape (m, 2)
        Target points, map units. Points outside the closed free space give ``False``.
    angles : array_like, shape (m,)
        Rod orientations, radians.
    lss : float
        Rod length, map units.

    Returns
    -------
    ndarray of bool, shape (m,)

    Examples
    --------
    >>> from tether import Environment, rod_is_free_many
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> rod_is_free_many(room, [(0.75, 1.5), (0.75, 1.5)], [0.0, 1.5708], 1.0).tolist()
    [False, True]
    """
    lss = check_lss(lss)
    pts = _as_points(points)
    ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
    if len(pts) > POINT_BATCH:  # bounded memory: (point, edge) candidate rows per batch
        return np.concatenate(map_batches(  # in threads: numpy's big calls release the GIL
            lambda lo, hi: rod_is_free_many(env, pts[lo:hi], ang[lo:hi], lss), len(pts),
            POINT_BATCH))
    if not env.is_internal:  # computed in the normalized frame, without straight vertices
        frame = env.frame
        return rod_is_free_many(env.internal, frame.to_internal(pts), ang, lss * frame.scale)
    ux, uy = np.cos(ang), np.sin(ang)
    # the rod lies in the disc of radius lss/2 about its midpoint: only edges within that
    # reach of the midpoint can touch it (a quarter of the candidates of a query at the target)
    half = 0.5 * lss
    mid = np.column_stack((pts[:, 0] + half * ux, pts[:, 1] + half * uy))
    pidx, eidx, _ = _query(env.edge_index(half), mid)
    return _rods_free(env, pts, ux, uy, lss, pidx, eidx)


def _rods_free(env: Environment, pts: np.ndarray, ux: np.ndarray, uy: np.ndarray, lss: float,
               pidx: np.ndarray, eidx: np.ndarray, inside: np.ndarray | None = None
               ) -> np.ndarray:
    """The rod test of :func:`rod_is_free_many` (internal map) on candidate rows: rod
    ``pidx[k]`` (target ``pts``, direction ``(ux, uy)``) against edge ``eidx[k]``. The rows
    must hold every edge within ``lss / 2`` plus the length tolerance of the rod's midpoint;
    more rows give the same booleans. ``inside``: the rods whose target is known to lie in
    the free space (not tested again)."""
    free = np.ones(len(pts), dtype=bool)
    free[pidx[_rows_blocked(env, pts, ux, uy, lss, pidx, eidx)]] = False
    # the point-in-map test only for the rods not blocked already (the same booleans)
    k = np.flatnonzero(free if inside is None else free & ~inside)
    free[k] = np.asarray(env.contains(pts[k, 0], pts[k, 1]), dtype=bool)
    return free


def _rows_blocked(env: Environment, pts: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                  lss: float, pidx: np.ndarray, eidx: np.ndarray) -> np.ndarray:
    """The candidate rows (of :func:`_rods_free`) whose edge blocks their rod (the rows
    kept by the side rejection, as indices into ``pidx``)."""
    tol = env.length_tol
    A, B, tag_a, _ = env.oriented_edges
    ax, ay, dx, dy, _, elen_all, _, _ = _edge_columns(env)
    rows = np.arange(len(pidx))
    # cheap rejection first: an edge with both ends strictly on one side of the rod's line can
    # neither cross it nor put its start vertex on it. Coordinate columns throughout (no (k, 2)
    # temporaries): the very numbers of the row-wise forms (x0*y0 + x1*y1 is einsum's sum)
    ux, uy = ux[pidx], uy[pidx]
    px, py = pts[:, 0][pidx], pts[:, 1][pidx]
    wx, wy = ax[eidx] - px, ay[eidx] - py
    ca = ux * wy - uy * wx
    cb = ux * (B[:, 1][eidx] - py) - uy * (B[:, 0][eidx] - px)
    k = np.flatnonzero(~(((ca > tol) & (cb > tol)) | ((ca < -tol) & (cb < -tol))))
    rows, eidx, ca, ux, uy, wx, wy = (x[k] for x in (rows, eidx, ca, ux, uy, wx, wy))
    ex, ey = dx[eidx], dy[eidx]  # B - A
    # 1. transversal crossing of the open edge strictly before the tip
    den = ux * ey - uy * ex
    s_num = wx * ey - wy * ex  # distance along the rod = s_num / den
    elen = elen_all[eidx]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = s_num / den
        t = -ca / den  # position on the edge
    # |den| = |e| sin(angle between rod and edge): rods within ANGLE_TOL of parallel to the
    # edge run along it (contact), they do not cross it
    inside_edge = (np.abs(den) > ANGLE_TOL * elen) & (t * elen > tol) & ((1 - t) * elen > tol)
    # a crossing at the target itself (a target within tol of the edge) blocks only if the rod
    # heads into the obstacle (u·n < 0, i.e. den > 0); farther along, any crossing blocks
    at_start = (np.abs(s) <= tol) & (den > 0)
    cross = inside_edge & (((s > tol) & (s < lss - tol)) | at_start)
    # 2. the rod through (or ending at) vertex A = start of this oriented edge
    along = wx * ux + wy * uy
    at_v = (np.abs(ca) <= tol) & (along > tol) & (along <= lss + tol)
    through = at_v & (along < lss - tol)
    blocked = cross
    hit = np.flatnonzero(at_v)  # only the few rods that meet the vertex need its cone
    if len(hit):
        blocked[hit] |= _leaves_cone(env, tag_a[eidx[hit]], ux[hit], uy[hit], through[hit])
    return rows[blocked]


#: How far a rod may move for :func:`rod_rows` (its midpoint, in rod lengths): the rows come
#: from one edge index of reach ``(1/2 + MOVE_REACH) lss``.
MOVE_REACH = 0.125


def rod_rows(env: Environment, points: np.ndarray, angles: np.ndarray, lss: float,
             dp: np.ndarray, du: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Candidate rows ``(rod, edge)`` that serve the rod test of :func:`rod_is_free_rows` for
    every rod ``k`` moved from ``(points[k], angles[k])`` by at most ``dp[k]`` (target end, map
    units) and ``du[k]`` (direction, radians), on the internal map: for loops testing rods that
    move little (a bisection), found once instead of at every test.

    The rows are those of an edge index about the midpoint, less the edges that the rod test's
    side rejection drops for every moved rod (both ends farther than the tolerance plus the
    motion's bound on one side of the rod's line; with a margin far above rounding): the
    moved rods' tests give the very booleans of :func:`rod_is_free_many`. Returns ``pidx,
    eidx``, ``ok`` (rods moving more than ``MOVE_REACH lss`` get no rows) and ``inside``: the
    rods whose moved targets all lie in the free space (inside, and no edge within ``dp``).
    """
    tol = env.length_tol
    ax, ay, dx, dy, dd, _, _, _ = _edge_columns(env)
    ux, uy = np.cos(angles), np.sin(angles)
    half = 0.5 * lss
    move = (dp + half * du) * (1 + 1e-6) + 1e-12 * lss
    ok = move <= MOVE_REACH * lss
    k = np.flatnonzero(ok)
    mid = np.column_stack((points[k, 0] + half * ux[k], points[k, 1] + half * uy[k]))
    pidx, eidx, _ = _query(env.edge_index(half + MOVE_REACH * lss), mid)
    pidx = k[pidx]
    ux, uy, px, py = ux[pidx], uy[pidx], points[pidx, 0], points[pidx, 1]
    wx, wy = ax[eidx] - px, ay[eidx] - py
    ex, ey = dx[eidx], dy[eidx]
    vx, vy = wx + ex, wy + ey
    ca = ux * wy - uy * wx
    cb = ux * vy - uy * vx
    # |side of X for a moved rod - side for this rod| <= du |X - p| + dp; 1e-9 for rounding
    slack = tol + dp[pidx] * (1 + 1e-6) + 1e-9 * lss
    ra = slack + (du[pidx] * (1 + 1e-6) + 1e-9) * np.hypot(wx, wy)
    rb = slack + (du[pidx] * (1 + 1e-6) + 1e-9) * np.hypot(vx, vy)
    keep = ~(((ca > ra) & (cb > rb)) | ((ca < -ra) & (cb < -rb)))
    # the rows hold every edge within MOVE_REACH lss of the target (half lss from the
    # midpoint): the target's clearance, if below that reach
    s = np.clip(-(wx * ex + wy * ey) / dd[eidx], 0.0, 1.0)
    clear = np.full(len(points), MOVE_REACH * lss * (1 - 1e-6))
    np.minimum.at(clear, pidx, np.hypot(wx + s * ex, wy + s * ey))
    inside = ok & (clear > dp * (1 + 1e-6) + 1e-9 * (lss + env.diameter))
    k = np.flatnonzero(inside)
    inside[k] = np.asarray(env.contains(points[k, 0], points[k, 1]), dtype=bool)
    return pidx[keep], eidx[keep], ok, inside


def rod_is_free_rows(env: Environment, points: np.ndarray, angles: np.ndarray, lss: float,
                     pidx: np.ndarray, eidx: np.ndarray, inside: np.ndarray | None = None
                     ) -> np.ndarray:
    """:func:`rod_is_free_many` on the internal map with candidate rows given (from
    :func:`rod_rows`, for rods within its motion of these): the same booleans. ``inside``
    (optional, bool per rod): targets known to lie in the free space (not tested again)."""
    return _rods_free(env, points, np.cos(angles), np.sin(angles), lss, pidx, eidx, inside)


def _leaves_cone(env: Environment, v: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                 through: np.ndarray) -> np.ndarray:
    """Whether rods at vertices ``v`` leave the closed free cone there: rods of unit direction
    ``(ux, uy)`` ending at ``v`` (the direction back along the rod, ``-u``, must lie in the
    cone) or passing through it (``through``: ``u`` too). Both directions from one pair of
    cross products: ``cross(d, -u) = -cross(d, u)`` exactly in floating point."""
    do_x, do_y, di_x, di_y, turn = _cone_columns(env)
    tol = ANGLE_TOL
    a = do_x[v] * uy - do_y[v] * ux  # cross(d_out, u)
    b = ux * di_y[v] - uy * di_x[v]  # cross(u, d_in)
    k = turn[v]
    back_in = np.where(k > 0, (a <= tol) & (b <= tol),
                       np.where(k < 0, ~((b > tol) & (a > tol)), a <= tol))
    ahead_in = np.where(k > 0, (a >= -tol) & (b >= -tol),
                        np.where(k < 0, ~((b < -tol) & (a < -tol)), a >= -tol))
    out = ~back_in | (through & ~ahead_in)
    touch = np.flatnonzero(through & env.touching[v])
    if len(touch):
        out[touch] |= ~_through_one_wedge(env, v[touch], ux[touch], uy[touch])
    return out


def _through_one_wedge(env: Environment, v: np.ndarray, ux: np.ndarray, uy: np.ndarray
                       ) -> np.ndarray:
    """Whether rods passing through touching vertices ``v`` (unit directions ``(ux, uy)``)
    stay in one free wedge there: where rings touch, the free space near the point is several
    wedges (between the obstacles meeting there), each the cone of a vertex of one ring cut by
    the other ring's obstacle. Each cone test alone takes a rod from one wedge to another
    (both directions lie in both rings' cones); but the obstacles meet at the point, so no rod
    passes between them: it is free only if ``-u`` and ``u`` lie in one closed wedge."""
    members, wo, wi, kind = wedge_columns(env)
    tol = ANGLE_TOL
    ok = np.zeros(len(v), dtype=bool)
    for col in range(members.shape[1]):
        w = members[v, col]
        k = np.flatnonzero(w >= 0)
        if not len(k):
            continue
        w = w[k]
        a = wo[w, 0] * uy[k] - wo[w, 1] * ux[k]  # cross(d_out, u)
        b = ux[k] * wi[w, 1] - uy[k] * wi[w, 0]  # cross(u, d_in)
        t = kind[w]
        ahead = np.where(t > 0, (a >= -tol) & (b >= -tol),
                         np.where(t < 0, ~((b < -tol) & (a < -tol)), a >= -tol))
        back = np.where(t > 0, (a <= tol) & (b <= tol),
                        np.where(t < 0, ~((b > tol) & (a > tol)), a <= tol))
        ok[k] |= ahead & back
    return ok


def wedge_columns(env: Environment) -> tuple[np.ndarray, ...]:
    """The free wedges at the points where rings touch, computed once per map. Wedge ``w``
    (one per touching vertex ``w``) runs CCW from ``d_out`` of vertex ``w`` to ``d_in`` of the
    touching vertex whose obstacle comes next CCW around the point (the obstacles' wedges are
    disjoint: a valid map). Returns ``members`` (n, g): the touching vertices at each vertex's
    point (-1 padded, all -1 for other vertices), the wedges' ``d_out`` and ``d_in`` (n, 2)
    and their turn (1 convex, -1 reflex, 0 straight, as :func:`_cone_columns`)."""
    got = env.memo.get("wedge_columns")
    if got is not None:
        return got
    d_out, d_in = env.cone
    n = env.n
    wo, wi = d_out.copy(), d_in.copy()
    first = env.coincident
    groups: dict[int, list[int]] = {}
    for j in np.flatnonzero(env.touching).tolist():
        groups.setdefault(int(first[j]), []).append(j)
    g = max((len(x) for x in groups.values()), default=1)
    members = np.full((n, g), -1, dtype=np.int64)
    for vs in groups.values():
        # each obstacle's wedge runs CCW from d_in to d_out: order them by d_in's angle
        ang = [math.atan2(d_in[j, 1], d_in[j, 0]) for j in vs]
        order = [vs[i] for i in np.argsort(ang, kind="stable")]
        for i, j in enumerate(order):
            wi[j] = d_in[order[(i + 1) % len(order)]]
        for j in vs:
            members[j, :len(vs)] = vs
    turn = wo[:, 0] * wi[:, 1] - wo[:, 1] * wi[:, 0]
    dot = wo[:, 0] * wi[:, 0] + wo[:, 1] * wi[:, 1]
    # a wedge wider than pi with cross ~ 0 is straight only if d_out and d_in are opposite
    kind = np.where(turn > ANGLE_TOL, 1,
                    np.where(turn < -ANGLE_TOL, -1, np.where(dot < 0, 0, 1)))
    got = env.memo["wedge_columns"] = (members, wo, wi, kind)
    return got


def _cone_columns(env: Environment) -> tuple[np.ndarray, ...]:
    """Per vertex, computed once per map: the free cone's ``d_out`` and ``d_in``
    (:attr:`Environment.cone`; x and y apart) and its turn: 1 convex, -1 reflex, 0 straight
    (``cross(d_out, d_in)`` beyond ``ANGLE_TOL``)."""
    got = env.memo.get("cone_columns")
    if got is None:
        d_out, d_in = env.cone
        turn = d_out[:, 0] * d_in[:, 1] - d_out[:, 1] * d_in[:, 0]
        kind = np.where(turn > ANGLE_TOL, 1, np.where(turn < -ANGLE_TOL, -1, 0))
        got = env.memo["cone_columns"] = (
            np.ascontiguousarray(d_out[:, 0]), np.ascontiguousarray(d_out[:, 1]),
            np.ascontiguousarray(d_in[:, 0]), np.ascontiguousarray(d_in[:, 1]), kind)
    return got


def rod_is_free(env: Environment, point: Any, angle: float, lss: float) -> bool:
    """Whether the rod from ``point`` at orientation ``angle`` (radians), of length ``lss``
    (map units), lies in the closed free space. See :func:`rod_is_free_many`.

    Examples
    --------
    >>> from tether import Environment, rod_is_free
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> rod_is_free(room, (0.75, 1.5), 1.5708, 1.0)  # up: the far wall is 1.5 away
    True
    >>> rod_is_free(room, (1.0, 1.5), 0.0, 1.0)  # right: the wall is 0.5 away
    False
    """
    return bool(rod_is_free_many(env, point, [angle], lss)[0])
