"""Where an unseen target can be: line of sight in the free space, geodesic distances through
the map's reflex vertices, and the set of positions reachable since the last sighting.

**Line of sight.** A segment is clear when it properly crosses no edge of the map (both ends on
strictly opposite sides of the edge's line, and the edge's ends on strictly opposite sides of
the segment's line); touching at an end point is allowed, so a segment may end at a vertex.
A segment that runs exactly through a vertex or along an edge is a measure-zero event the test
does not see (it counts as clear).

**Geodesic distances.** In a polygon with holes a shortest path bends only at reflex vertices
(the visibility graph, Lozano-Pérez & Wesley 1979). :class:`Geodesics` keeps the graph of the
reflex vertices (two are joined when the segment between them is clear and its midpoint lies in
the closed free space) and the visibility of every grid cell's centre from every reflex vertex;
the distance from a source ``s`` to a point ``x`` is then exact (up to rounding):
``min(|s − x| if clear, min_k D(s, v_k) + |v_k − x| over the v_k that see x)``, with ``D``
from Dijkstra (:func:`scipy.sparse.csgraph.dijkstra`).

**The reachable set** ``{x : d(s, x) <= vt·(t − t_seen) + r0}`` is kept on a square grid of
cells of side ``h`` (the cells whose centre is in the free space). The distance is exact at
each centre, so the set's only error is the grid's: a point within reach lies at most
``h/√2`` from a centre, and that centre's geodesic distance exceeds the point's by at most
``h/√2`` when the segment between them is clear (a cell cut by a wall may have its centre on
the other side: near walls, :meth:`Geodesics.distance` at the point itself is the exact test).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from tether.environment import Environment
from tether.errors import InvalidParameterError

__all__ = ["Geodesics", "RAY_EPS", "ReachGrid", "clear_segments", "first_blocking_edge",
           "visible_from"]

#: Angular offset (rad) of the rays cast just past each vertex by :func:`visible_from`.
RAY_EPS = 1e-9

#: Segment/edge pairs tested per numpy block (memory ~ 10 arrays of this many floats).
_BLOCK = 400_000


def _crossings(p: np.ndarray, q: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """(m, n) whether segment ``p[i]–q[i]`` properly crosses edge ``A[j]–B[j]``."""
    dx, dy = (q - p).T[:, :, None]
    px, py = p.T[:, :, None]
    ax, ay = A.T[:, None, :]
    bx, by = B.T[:, None, :]
    o1 = dx * (ay - py) - dy * (ax - px)
    o2 = dx * (by - py) - dy * (bx - px)
    ex, ey = bx - ax, by - ay
    o3 = ex * (py - ay) - ey * (px - ax)
    o4 = ex * (q[:, 1:2] - ay) - ey * (q[:, 0:1] - ax)
    return (o1 * o2 < 0) & (o3 * o4 < 0)


def clear_segments(env: Environment, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whether each segment ``p[i]–q[i]`` crosses no edge of ``env`` (see the module's line of
    sight); ``p`` may be one point (shape (2,)) for all. Shape (m,) booleans.

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.follow.reachable import clear_segments
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])
    >>> clear_segments(ell, np.array([3.0, 1.0]), np.array([[1.0, 1.0], [1.0, 3.5]])).tolist()
    [True, False]
    """
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    p = np.broadcast_to(np.asarray(p, dtype=float), q.shape)
    A, B, _, _ = env.oriented_edges
    out = np.empty(len(q), dtype=bool)
    step = max(1, _BLOCK // max(len(A), 1))
    for i in range(0, len(q), step):
        out[i:i + step] = ~_crossings(p[i:i + step], q[i:i + step], A, B).any(axis=1)
    return out


def first_blocking_edge(env: Environment, p: np.ndarray, q: np.ndarray) -> int | None:
    """The edge that segment ``p–q`` crosses nearest ``p`` (its index ``i`` of ``Ei``), or
    ``None`` when the segment is clear."""
    p = np.asarray(p, dtype=float).reshape(1, 2)
    q = np.asarray(q, dtype=float).reshape(1, 2)
    A, B, _, _ = env.oriented_edges
    hit = np.flatnonzero(_crossings(p, q, A, B)[0])
    if not len(hit):
        return None
    d = q[0] - p[0]
    e = B[hit] - A[hit]
    den = d[0] * e[:, 1] - d[1] * e[:, 0]
    s = ((A[hit, 0] - p[0, 0]) * e[:, 1] - (A[hit, 1] - p[0, 1]) * e[:, 0]) / den
    return int(hit[int(np.argmin(s))])


def _ray_hits(s: np.ndarray, dirs: np.ndarray, A: np.ndarray, B: np.ndarray, tol: float
              ) -> np.ndarray:
    """Distance along each unit ray ``s + t·dirs[i]`` to the first edge it meets at ``t > tol``
    (end points included), inf when none."""
    ex, ey = (B - A).T
    ax, ay = A[:, 0] - s[0], A[:, 1] - s[1]
    dx, dy = dirs[:, 0:1], dirs[:, 1:2]
    den = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ax * ey - ay * ex) / den
        w = (ax * dy - ay * dx) / den
    ok = (den != 0) & (t > tol) & (w >= 0) & (w <= 1)
    return np.where(ok, t, np.inf).min(axis=1)


def visible_from(env: Environment, source: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Whether ``source`` sees each of ``points`` (n, 2), through the visibility polygon.

    Rays are cast from ``source`` to every vertex of the map and :data:`RAY_EPS` rad to each
    side; between two consecutive rays no vertex lies, so the visible boundary there is one
    straight piece of an edge, and a point is visible when it is no farther than that piece
    along its own direction (relative tolerance 1e-9). Hits closer than ``1e-9·diameter`` are
    ignored, so the source may be a vertex (a reflex vertex sees along its free cone).
    Equivalent to :func:`clear_segments` but for ``3·n`` rays instead of ``n`` tests per point.

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.follow.reachable import visible_from
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])
    >>> visible_from(ell, np.array([3.0, 1.0]), np.array([[1.0, 1.0], [1.0, 3.5]])).tolist()
    [True, False]
    """
    s = np.asarray(source, dtype=float).reshape(2)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(pts):
        return np.zeros(0, dtype=bool)
    A, B, _, _ = env.oriented_edges
    V = env.vertices
    base = np.arctan2(V[:, 1] - s[1], V[:, 0] - s[0])
    ang = np.unique(np.r_[base - RAY_EPS, base, base + RAY_EPS] % math.tau)
    dirs = np.column_stack((np.cos(ang), np.sin(ang)))
    tol = 1e-9 * env.diameter
    hit = s + np.minimum(_ray_hits(s, dirs, A, B, tol), 4 * env.diameter)[:, None] * dirs
    rel = pts - s
    dist = np.hypot(rel[:, 0], rel[:, 1])
    theta = np.arctan2(rel[:, 1], rel[:, 0]) % math.tau
    i = (np.searchsorted(ang, theta, side="right") - 1) % len(ang)
    j = (i + 1) % len(ang)
    P, Q = hit[i] - s, hit[j] - s
    e = Q - P
    with np.errstate(divide="ignore", invalid="ignore"):
        u = rel / dist[:, None]
        den = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
        reach = (P[:, 0] * e[:, 1] - P[:, 1] * e[:, 0]) / den
    flat = ~np.isfinite(reach) | (np.abs(den) < 1e-12 * np.hypot(e[:, 0], e[:, 1]))
    reach = np.where(flat, np.minimum(np.hypot(*P.T), np.hypot(*Q.T)), reach)
    return (dist <= tol) | (dist <= reach * (1 + 1e-9))


class ReachGrid:
    """The square grid of cells of side ``h`` (map units) whose centres lie in the free space.

    ``centers`` (m, 2); ``neighbours`` (m, 8) indices of the 8-neighbours joined to each cell
    by a clear segment (−1 where none).
    """

    def __init__(self, env: Environment, h: float) -> None:
        if not (math.isfinite(h) and h > 0):
            raise InvalidParameterError(f"grid cell must be a number > 0 (got {h!r})")
        x0, y0, x1, y1 = env.bounds
        nx_, ny_ = int(math.ceil((x1 - x0) / h)), int(math.ceil((y1 - y0) / h))
        if nx_ * ny_ > 4_000_000:
            raise InvalidParameterError(
                f"grid cell {h:g} is too small for this map ({nx_}x{ny_} cells; at most 4e6)")
        gx, gy = np.meshgrid(x0 + (np.arange(nx_) + 0.5) * h, y0 + (np.arange(ny_) + 0.5) * h)
        inside = env.contains(gx.ravel(), gy.ravel())
        self.h = float(h)
        self.shape = (ny_, nx_)
        self.origin = (float(x0), float(y0))
        self.flat = np.flatnonzero(inside)  # lattice index of each cell
        self.centers = np.column_stack((gx.ravel()[inside], gy.ravel()[inside]))
        lookup = np.full(nx_ * ny_, -1)
        lookup[self.flat] = np.arange(len(self.flat))
        self.lookup = lookup
        self.neighbours = self._neighbours(env)

    def __len__(self) -> int:
        return len(self.centers)

    def _neighbours(self, env: Environment) -> np.ndarray:
        ny_, nx_ = self.shape
        row, col = np.divmod(self.flat, nx_)
        out = np.full((len(self.flat), 8), -1)
        steps = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
        for k, (dr, dc) in enumerate(steps):
            r, c = row + dr, col + dc
            ok = (r >= 0) & (r < ny_) & (c >= 0) & (c < nx_)
            j = np.full(len(row), -1)
            j[ok] = self.lookup[r[ok] * nx_ + c[ok]]
            has = j >= 0
            idx = np.flatnonzero(has)
            clear = clear_segments(env, self.centers[idx], self.centers[j[idx]])
            out[idx[clear], k] = j[idx[clear]]
        return out

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """The cell index holding each point (−1 outside the grid's free cells)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ny_, nx_ = self.shape
        c = np.floor((pts[:, 0] - self.origin[0]) / self.h).astype(int)
        r = np.floor((pts[:, 1] - self.origin[1]) / self.h).astype(int)
        ok = (r >= 0) & (r < ny_) & (c >= 0) & (c < nx_)
        out = np.full(len(pts), -1)
        out[ok] = self.lookup[r[ok] * nx_ + c[ok]]
        return out

    def dilate(self, cells: np.ndarray, steps: int) -> np.ndarray:
        """``cells`` (booleans, shape (m,)) grown by ``steps`` 8-neighbour steps."""
        out = cells.copy()
        nb = self.neighbours
        padded = np.empty(len(out) + 1, dtype=bool)
        for _ in range(steps):
            padded[:-1] = out
            padded[-1] = False
            out = out | padded[nb].any(axis=1)
        return out


class Geodesics:
    """Exact shortest-path distances in the free space of ``env`` through its reflex vertices,
    from any source to the cells of ``grid`` (see the module docstring).

    ``nodes`` (k, 2) are the reflex vertices; ``node_dist`` (k, k) their all-pairs geodesic
    distances (inf between components that cannot see each other through the graph, which in a
    connected free space does not happen).

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.follow.reachable import Geodesics, ReachGrid
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])
    >>> geo = Geodesics(ell, ReachGrid(ell, 0.5))
    >>> d = geo.distance(np.array([3.5, 1.0]), np.array([[1.0, 3.5], [1.0, 1.0]]))
    >>> bend = np.hypot(1.5, 1.0) + np.hypot(1.0, 1.5)   # round the corner (2, 2)
    >>> bool(np.isclose(d[0], bend)), float(d[1])
    (True, 2.5)
    """

    def __init__(self, env: Environment, grid: ReachGrid) -> None:
        self.env = env
        self.grid = grid
        self.nodes = env.vertices[env.reflex_indices]
        k = len(self.nodes)
        vis = np.zeros((k, k), dtype=bool)
        if k > 1:
            i, j = np.triu_indices(k, 1)
            ok = clear_segments(env, self.nodes[i], self.nodes[j])
            mid = 0.5 * (self.nodes[i] + self.nodes[j])
            inside = env.contains(mid[:, 0], mid[:, 1])
            ok &= inside
            vis[i[ok], j[ok]] = vis[j[ok], i[ok]] = True
        w = np.linalg.norm(self.nodes[:, None, :] - self.nodes[None, :, :], axis=2)
        self._graph = csr_matrix(np.where(vis, w, 0.0))
        self.node_dist = dijkstra(self._graph, directed=False) if k else np.zeros((0, 0))
        #: (k, m) whether reflex vertex i sees cell j
        self.node_sees_cell = self._sees(self.nodes, grid.centers)
        #: (k, m) distance from reflex vertex i to cell j where it sees it, inf elsewhere
        self._node_cell = np.where(self.node_sees_cell, np.linalg.norm(
            grid.centers[None, :, :] - self.nodes[:, None, :], axis=2), np.inf)

    def _sees(self, sources: np.ndarray, points: np.ndarray) -> np.ndarray:
        out = np.zeros((len(sources), len(points)), dtype=bool)
        for i, s in enumerate(sources):
            out[i] = visible_from(self.env, s, points)
        return out

    def node_distances(self, source: np.ndarray) -> np.ndarray:
        """Geodesic distance from ``source`` (a free point) to every reflex vertex, shape (k,)."""
        s = np.asarray(source, dtype=float).reshape(2)
        k = len(self.nodes)
        if not k:
            return np.zeros(0)
        direct = np.where(clear_segments(self.env, s, self.nodes),
                          np.linalg.norm(self.nodes - s, axis=1), np.inf)
        return np.min(direct[:, None] + self.node_dist, axis=0)

    def field(self, source: np.ndarray) -> np.ndarray:
        """Geodesic distance from ``source`` to every cell centre of the grid, shape (m,)."""
        s = np.asarray(source, dtype=float).reshape(2)
        c = self.grid.centers
        direct = np.where(visible_from(self.env, s, c), np.linalg.norm(c - s, axis=1), np.inf)
        if not len(self.nodes):
            return direct
        via = (self._node_cell + self.node_distances(s)[:, None]).min(axis=0)
        return np.minimum(direct, via)

    def distance(self, source: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Geodesic distance from ``source`` to arbitrary free ``points`` (n, 2), exact."""
        s = np.asarray(source, dtype=float).reshape(2)
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        direct = np.where(visible_from(self.env, s, pts), np.linalg.norm(pts - s, axis=1),
                          np.inf)
        if not len(self.nodes):
            return direct
        dn = self.node_distances(s)
        sees = self._sees(self.nodes, pts)
        far = np.linalg.norm(pts[None, :, :] - self.nodes[:, None, :], axis=2)
        return np.minimum(direct, np.where(sees, dn[:, None] + far, np.inf).min(axis=0))
