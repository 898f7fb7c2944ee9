"""The free arc around the current rod, fast enough for a control loop (``docs/formulas.md``,
"Free orientations at a point").

:func:`tether.arcs.free_arcs` computes every arc at a point with numpy (about 250 µs); a
controller needs only the two ends of the arc that holds the rod, at one point, every step.
:class:`LocalArcs` precomputes a grid of the edges within reach of each cell and evaluates the
blocked intervals ``B_i(p)`` of the few nearby edges in plain Python floats (a few µs each).

The first blocked orientation counter-clockwise from a free rod ``a`` is ``min_i (lo_i − a) mod
2π`` over the blocked intervals ``[lo_i, hi_i]``, and likewise clockwise: so the arc's ends need
no merging. Angles in radians, lengths in map units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tether.environment import Environment
from tether.spatial import EdgeIndex

__all__ = ["ArcEnds", "Blocked", "LocalArcs", "ends_of", "free_many"]



@dataclass(frozen=True)
class Blocked:
    """Blocked interval of one edge at a point: CCW from ``lo`` to ``hi`` (radians), with the
    features bounding it (``lo_feature`` is its CW end, ``hi_feature`` its CCW end)."""

    lo: float
    hi: float
    lo_feature: str
    hi_feature: str


@dataclass(frozen=True)
class ArcEnds:
    """The free arc holding rod ``a`` at a point.

    ``ccw_gap`` is how far the rod may turn CCW before it touches ``ccw_feature`` (the arc's
    end feature), ``cw_gap`` how far CW before ``cw_feature`` (the arc's start feature);
    ``inf`` when no obstacle is in reach (FULL). ``free`` is false when ``a`` lies in a blocked
    interval; then the gaps say how far the nearest free orientation is on each side.
    """

    free: bool
    ccw_gap: float
    ccw_feature: str | None
    cw_gap: float
    cw_feature: str | None


class LocalArcs:
    """Blocked intervals of the edges near a point, for one map and rod length."""

    def __init__(self, env: Environment, lss: float, pad: float = 0.0) -> None:
        self.env = env
        self.lss = float(lss)
        A, B, tag_a, tag_b = env.oriented_edges
        self._a = [tuple(map(float, x)) for x in A]
        self._b = [tuple(map(float, x)) for x in B]
        first = env.coincident  # touching rings: one name per point (as tether.arcs)
        self._va = [env.vertex_name(int(first[t])) for t in tag_a]
        self._vb = [env.vertex_name(int(first[t])) for t in tag_b]
        self._edge = [env.edge_name(i) for i in self._edge_ids(env)]
        reach = self.lss + max(pad, 0.0)
        idx = EdgeIndex.build(A, B, reach)
        self._origin = (float(idx.origin[0]), float(idx.origin[1]))
        self._cell = float(idx.cell)
        self._shape = idx.shape
        self._cells = [tuple(int(e) for e in idx.edges[idx.start[c]:idx.start[c + 1]])
                       for c in range(idx.shape[0] * idx.shape[1])]

    @staticmethod
    def _edge_ids(env: Environment) -> list[int]:
        # oriented_edges lists the edges in feature order (edge i is E<i>)
        return list(range(env.n))

    def edges_near(self, x: float, y: float) -> tuple[int, ...]:
        """Edges that may be within ``lss + pad`` of ``(x, y)`` (a superset)."""
        ix = int((x - self._origin[0]) / self._cell)
        iy = int((y - self._origin[1]) / self._cell)
        nx, ny = self._shape
        if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
            return ()
        return self._cells[ix * ny + iy]

    def blocked(self, x: float, y: float) -> list[Blocked]:
        """Blocked intervals ``B_i(p)`` of the edges within ``lss`` of ``p = (x, y)``."""
        L = self.lss
        out = []
        for i in self.edges_near(x, y):
            ax, ay = self._a[i]
            bx, by = self._b[i]
            ex, ey = bx - ax, by - ay
            wx, wy = ax - x, ay - y
            if ex * (y - ay) - ey * (x - ax) <= 0.0:  # p not strictly on the free side
                continue
            e2 = ex * ex + ey * ey
            bq = wx * ex + wy * ey
            c = wx * wx + wy * wy - L * L
            disc = bq * bq - e2 * c
            if disc <= 0.0:
                continue
            sq = math.sqrt(disc)
            r1, r2 = (-bq - sq) / e2, (-bq + sq) / e2
            t1, t2 = max(0.0, r1), min(1.0, r2)
            if t1 >= t2:
                continue
            lo = math.atan2(wy + t1 * ey, wx + t1 * ex) % math.tau
            hi = math.atan2(wy + t2 * ey, wx + t2 * ex) % math.tau
            out.append(Blocked(lo, hi, self._va[i] if r1 <= 0.0 else self._edge[i],
                               self._vb[i] if r2 >= 1.0 else self._edge[i]))
        return out

    def ends(self, x: float, y: float, a: float) -> ArcEnds:
        """The ends of the free arc holding rod ``a`` at ``(x, y)`` (see :class:`ArcEnds`)."""
        return ends_of(self.blocked(x, y), a)

    def arc(self, x: float, y: float, a: float) -> tuple[float, float] | None:
        """The free arc holding rod ``a`` at ``(x, y)`` as CCW ``(start, end)`` (rad), ``None``
        when no obstacle is in reach (FULL)."""
        e = self.ends(x, y, a)
        if not math.isfinite(e.ccw_gap):
            return None
        return (a - e.cw_gap) % math.tau, (a + e.ccw_gap) % math.tau


def ends_of(blocked: list[Blocked], a: float) -> ArcEnds:
    """:class:`ArcEnds` of orientation ``a`` among blocked intervals (plain floats)."""
    ccw, cw = math.inf, math.inf
    fccw = fcw = None
    inside = False
    for b in blocked:
        width = (b.hi - b.lo) % math.tau
        off = (a - b.lo) % math.tau
        if 0.0 < off < width:
            inside = True
        d = (b.lo - a) % math.tau
        if d < ccw:
            ccw, fccw = d, b.lo_feature
        d = (a - b.hi) % math.tau
        if d < cw:
            cw, fcw = d, b.hi_feature
    if inside:
        # blocked: how far the nearest free orientation is on each side (union of intervals)
        ccw, fccw, cw, fcw = _exits(blocked, a)
    return ArcEnds(not inside, ccw, fccw, cw, fcw)


def _wrap0(off: float) -> float:
    """An angle offset in [0, 2π) that is 2π less rounding is 0: interval ends computed from
    the same vertex by two edges may differ in the last bit."""
    return 0.0 if off > math.tau - 1e-12 else off


def _exits(blocked: list[Blocked], a: float) -> tuple[float, str | None, float, str | None]:
    """From a blocked ``a``: CCW distance to the CCW end of the blocked union holding it, and CW
    distance to its CW end, with their features."""
    up, fup = 0.0, None
    moved = True
    while moved:
        moved = False
        for b in blocked:
            width = (b.hi - b.lo) % math.tau
            off = _wrap0((a + up - b.lo) % math.tau)
            if off < width + 1e-12 and (width - off) > 1e-15:
                up += width - off
                fup = b.hi_feature
                moved = True
        if up >= math.tau:
            return math.inf, None, math.inf, None
    down, fdown = 0.0, None
    moved = True
    while moved:
        moved = False
        for b in blocked:
            width = (b.hi - b.lo) % math.tau
            off = _wrap0((a - down - b.lo) % math.tau)
            if off > 1e-15 and off <= width + 1e-12:
                down += off
                fdown = b.lo_feature
                moved = True
        if down >= math.tau:
            return math.inf, None, math.inf, None
    return up, fup, down, fdown


def free_many(local: LocalArcs, pts: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Whether each rod is free by the local test (for cross-checks against ``rod_is_free``)."""
    return np.array([local.ends(float(p[0]), float(p[1]), float(t)).free
                     for p, t in zip(pts, angles, strict=True)])
