"""The arc field and its certificate: the checks that make a field of orientation arcs a
sound under-approximation of the surveillance kernel (``docs/certified.md``, where the
argument is written out line by line).

**The field.** A triangle mesh of the free space (:func:`free_mesh`, conforming: every triangle
lies in the free space) carries at each vertex ``i`` an arc of orientations ``[lo_i, lo_i + w_i]``
(radians, ``0 < w_i <= 2π``; ``w = 2π`` is the whole circle, and then ``lo`` only says where a
gap would open). On each triangle the ends are lifted to one branch (:func:`lifted_ends`) and
interpolated linearly. The field holds the states ``{(p, a): a ∈ [lo(p), hi(p)]}``.

**The checks** (:func:`certify`), per triangle ``T``:

1. *Free*: the rod is free from every point of ``T`` at every orientation between the smallest
   ``lo`` and the largest ``hi`` of ``T``'s vertices (exact blocked spans of every wall,
   :func:`tether.game.cells.triangle_blocked_any`).
2. *Open*: ``w >= W_MIN`` at the three vertices; and the lift exists (the gap centres of a
   triangle with a gap do not wind around it).
3. *Ends*: unless the arc is the whole circle at all three vertices, for every target velocity
   ``v = vt·u(θ)`` and every orientation ``a`` in the range of ``lo`` on ``T``,
   ``lss·G_lo·v <= lss·Ωmax(v, a) − MARGIN``, and for every ``a`` in the range of ``hi``,
   ``lss·G_hi·v >= lss·Ωmin(v, a) + MARGIN`` (``G`` the constant gradient of the end on ``T``,
   ``[Ωmin, Ωmax]`` the rod rates the observer's speed ``vo`` allows). The minimum over ``θ``
   and ``a`` is bounded from below by a table of minima over ``a`` and sampled headings,
   each with a proven Lipschitz term (:func:`end_slack`, :func:`window_min`), so the check
   holds on the continuum, not only at samples.

A field that passes every check is *certified*: from any of its states, against any target of
speed at most ``vt``, the observer can keep the state in the field, hence the rod free.

**Sensing delay** (``grow = r = vt·d``, ``docs/certified.md``, "Sensing delay"): the field
then holds the *seen* state ``(q, a)``, ``q`` the target's position ``d`` seconds ago, and
check 1 becomes: the segment from every point ``p`` within ``r`` of ``T`` (the true target)
to every observer ``q + lss·u(a)`` is free. That segment is a rod from ``p`` of length at most
``lss + r`` at an orientation within ``β = asin(r/lss)`` of ``a``
(:func:`sight_widening`), so check 1 runs on the triangle grown by ``r``
(:func:`tether.game.cells.grow_triangles`), the range ``[a0 − β, a1 + β]`` and rods of length
``lss + r``. Checks 2 and 3 are unchanged (the seen target obeys the same speed bound).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse.linalg import spsolve
from scipy.spatial import Delaunay, cKDTree

from tether.environment import Environment
from tether.game.cells import (
    cell_free_bins,
    grow_triangles,
    triangle_blocked_any,
    triangle_meets,
)

__all__ = ["MARGIN", "STAR_SPLITS", "W_MIN", "ArcField", "Checks", "bisect", "certify",
           "end_fails", "end_slack", "first_field", "free_mesh", "hat_gradients",
           "heading_window_min", "lifted_ends", "longest_edge_first", "runs_toward",
           "sight_widening", "star_bins", "window_floor", "window_min", "window_min_at",
           "interpolate_field"]

#: Slack every end condition must keep, in ``lss·rate`` (map units per second): room for the
#: rounding of the checks' own arithmetic.
MARGIN = 1e-3
#: Smallest arc width (radians) a certified field may have.
W_MIN = 1e-3
#: Times at most :func:`first_field` splits the stars of vertices that see no common free
#: orientation (each split halves such a star's edges every second time).
STAR_SPLITS = 6
#: Target headings sampled by the end check (the Lipschitz term covers the rest).
THETA_SAMPLES = 512
#: Triangles per block in :func:`end_slack` (its temporaries are blocks × THETA_SAMPLES).
_ROWS = 4096
_TAU = math.tau
#: Room (map units per second) :func:`end_fails` keeps above ``MARGIN`` before it trusts its
#: cheap bound instead of :func:`end_slack` (the rounding of either is below 1e-14 here).
_FLOOR_ROOM = 1e-9
#: A width at least this is the whole circle (float noise of ``hi − lo``).
FULL = math.tau - 1e-9


@dataclass(eq=False)
class ArcField:
    """Arcs of rod orientations on a triangle mesh of the free space.

    Attributes
    ----------
    points : ndarray (n, 2)
        Mesh vertices, map units.
    tri : ndarray (m, 3) of int
        Triangles (vertex indices, counter-clockwise).
    lo, w : ndarray (n,)
        Each vertex's arc ``[lo, lo + w]``, radians (``w = 2π``: the whole circle).
    """

    points: np.ndarray
    tri: np.ndarray
    lo: np.ndarray
    w: np.ndarray

    @property
    def full(self) -> np.ndarray:
        """Whether each vertex's arc is the whole circle."""
        return self.w >= FULL


@dataclass(eq=False)
class Checks:
    """What :func:`certify` found, per triangle (boolean masks over the field's triangles).

    ``free``, ``open``, ``lo``, ``hi``: the triangles failing each check; ``meets``: those that
    meet the free space (the others are not checked). ``bad``: any failure."""

    free: np.ndarray
    open: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    meets: np.ndarray

    @property
    def bad(self) -> np.ndarray:
        """Triangles failing some check."""
        return self.free | self.open | self.lo | self.hi

    @property
    def passed(self) -> bool:
        """Whether every triangle passes (the field is certified)."""
        return not bool(self.bad.any())

    def counts(self) -> dict[str, int]:
        """Failing triangles per check."""
        return {"free": int(self.free.sum()), "open": int(self.open.sum()),
                "lo": int(self.lo.sum()), "hi": int(self.hi.sum())}


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles into ``[-π, π)``."""
    return np.mod(x + math.pi, _TAU) - math.pi


def free_mesh(env: Environment, h: float, lattice: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A Delaunay mesh of the free space on the ``lattice`` points (map units) at least ``h/2``
    from every wall and points along every wall every ``h/2`` or closer (the walls' vertices
    included). Dense wall points make every wall piece an edge of the mesh (its diametral
    disc holds no other point, so it is in every Delaunay triangulation), and this is checked
    exactly: then the mesh conforms (each triangle lies in the free space or outside it) and
    the triangles whose centroid is free tile the free space.

    Returns ``(points, tri, source)``: ``source[i]`` is the index in ``lattice`` of vertex
    ``i`` (-1 for a wall point).

    Raises
    ------
    ValueError
        If some wall piece is not an edge (a wall angle or passage too sharp for ``h``).
    """
    A, B, _, _ = env.oriented_edges
    pieces = []
    for a, b in zip(A, B, strict=True):
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / (h / 2)))
        piece = a + (np.arange(n + 1)[:, None] / n) * (b - a)
        piece[-1] = b  # exactly the next edge's first point: a + 1·(b − a) may round off b
        pieces.append(piece)
    wall, inverse = np.unique(np.concatenate(pieces), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    d = env.boundary_distance(lattice[:, 0], lattice[:, 1])
    keep = np.flatnonzero(d >= h / 2)
    pts = np.concatenate([lattice[keep], wall])
    source = np.concatenate([keep, np.full(len(wall), -1)])
    # in lattice units from the map's corner: the same coordinates, hence the same choice of
    # diagonals in the lattice's cocircular squares, for the map moved or scaled
    tri = Delaunay((pts - pts.min(axis=0)) / h).simplices
    # every wall piece (consecutive wall points) must be an edge: then no triangle crosses a
    # wall, and those whose centroid is free tile the free space exactly
    ends = len(keep) + inverse
    first = np.cumsum([len(q) for q in pieces]) - np.array([len(q) for q in pieces])
    at = np.concatenate([f + np.arange(len(q) - 1) for f, q in zip(first, pieces, strict=True)])
    need = np.sort(np.stack([ends[at], ends[at + 1]], axis=1), axis=1)
    have = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]), axis=1)
    # int64 keys (_edge_keys): qhull's int32 indices times len(pts) overflowed past 46,340
    # points, and every big mesh was refused
    missing = ~np.isin(_edge_keys(need[:, 0], need[:, 1], len(pts)),
                       _edge_keys(have[:, 0], have[:, 1], len(pts)))
    if missing.any():
        x, y = pts[need[np.argmax(missing), 0]]
        raise ValueError(f"the mesh at h = {h:g} does not follow the wall near ({x:.6g}, "
                         f"{y:.6g}) (an angle or passage too sharp for this spacing)")
    cen = pts[tri].mean(axis=1)
    tri = tri[shapely.contains_xy(env.polygon, cen[:, 0], cen[:, 1])]
    p = pts[tri]
    det = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
           - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    area = 0.5 * np.abs(det).sum()
    if abs(area - env.polygon.area) > 1e-6 * env.polygon.area:  # a sanity check only
        raise ValueError(f"the mesh covers {area:.6g} of the free area {env.polygon.area:.6g} "
                         f"at h = {h:g}")
    tri = np.where((det < 0)[:, None], tri[:, [0, 2, 1]], tri)  # counter-clockwise
    return pts, tri, source


def longest_edge_first(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``tri`` with each row rotated (the cyclic order kept, so counter-clockwise stays so) to
    put its longest edge opposite local vertex 0: the refinement edge of :func:`bisect` for a
    mesh that has not been bisected yet (ties go to the first in the row's order)."""
    xy = points[tri]
    opp = np.stack([np.hypot(*(xy[:, (k + 2) % 3] - xy[:, (k + 1) % 3]).T) for k in range(3)],
                   axis=1)  # the length of the edge opposite each local vertex
    k = np.argmax(opp, axis=1)
    rows = np.arange(len(tri))[:, None]
    return tri[rows, (k[:, None] + np.arange(3)[None, :]) % 3]


def _edge_keys(i: np.ndarray, j: np.ndarray, n: int) -> np.ndarray:
    """One integer per undirected edge ``{i, j}`` of a mesh of ``n`` vertices."""
    return np.minimum(i, j).astype(np.int64) * n + np.maximum(i, j)


def bisect(points: np.ndarray, tri: np.ndarray, marked: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newest-vertex bisection of the triangles ``marked`` (a mask or indices) with closure
    (:mod:`tether.game.refine`'s docstring, and ``docs/certified.md``, "Adaptive refinement").

    Parameters
    ----------
    points : ndarray (n, 2)
        Vertices, map units.
    tri : ndarray (m, 3) of int
        Counter-clockwise triangles, each with its refinement edge opposite local vertex 0.
    marked : ndarray
        The triangles to split (bool mask over ``tri``, or indices).

    Returns
    -------
    new_points : ndarray (n + k, 2)
        ``points`` followed by the ``k`` midpoints.
    new_tri : ndarray of int
        The refined triangles, in the same convention.
    edges : ndarray (k, 2) of int
        The ends of the edge each new vertex halves (vertex ``n + i`` halves ``edges[i]``).

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> tri = np.array([[0, 1, 2], [3, 2, 1]])  # the shared diagonal is both refinement edges
    >>> p, t, e = bisect(pts, tri, [0])  # the closure cuts the neighbour too
    >>> p[4].tolist(), len(t), e.tolist()
    ([0.5, 0.5], 4, [[1, 2]])
    """
    n = len(points)
    tri = np.asarray(tri, dtype=np.int64)
    mask = np.zeros(len(tri), dtype=bool)
    mask[np.asarray(marked)] = True
    # the three edges of each triangle, opposite local vertices 0, 1, 2
    opp = np.stack([_edge_keys(tri[:, (k + 1) % 3], tri[:, (k + 2) % 3], n) for k in range(3)],
                   axis=1)
    keys, te = np.unique(opp, return_inverse=True)
    te = te.reshape(-1, 3)
    cut = np.zeros(len(keys), dtype=bool)
    cut[te[mask, 0]] = True
    while True:  # closure: a triangle with a cut edge cuts its refinement edge too
        need = cut[te].any(axis=1) & ~cut[te[:, 0]]
        if not need.any():
            break
        cut[te[need, 0]] = True
    cut_keys = keys[cut]
    edges = np.stack([cut_keys // n, cut_keys % n], axis=1)
    new_points = np.concatenate([points, (points[edges[:, 0]] + points[edges[:, 1]]) / 2])
    big = len(new_points)  # keys over every vertex, the new ones included
    order = np.argsort(_edge_keys(edges[:, 0], edges[:, 1], big))
    cut_big = _edge_keys(edges[order, 0], edges[order, 1], big)
    mid_big = n + order
    new_tri = tri
    while len(cut_big):  # cut every triangle whose refinement edge is cut (twice at most)
        ref = _edge_keys(new_tri[:, 1], new_tri[:, 2], big)
        k = np.minimum(np.searchsorted(cut_big, ref), len(cut_big) - 1)
        hit = cut_big[k] == ref
        if not hit.any():
            break
        p1, p2, p3 = new_tri[hit].T
        m = mid_big[k[hit]]
        children = np.concatenate([np.stack([m, p1, p2], axis=1), np.stack([m, p3, p1], axis=1)])
        new_tri = np.concatenate([new_tri[~hit], children])
    return new_points, new_tri, edges


def sight_widening(grow: float, lss: float) -> float:
    """The largest angle (radians) between the rod ``lss·u(a)`` and the line of sight
    ``lss·u(a) − e`` from a true target ``e`` away from the seen one, ``|e| <= grow < lss``:
    ``asin(grow/lss)``; 0 without delay."""
    return math.asin(grow / lss) if grow > 0 else 0.0


def first_field(kern, grow: float = 0.0, splits: int = STAR_SPLITS,
                coarse: ArcField | None = None) -> ArcField:
    """The field the search starts from, on :func:`free_mesh` of ``kern``'s lattice
    (``kern``: a :class:`~tether.game.kernel.Kernel`, the conservative grid scheme): at each
    vertex the run of orientations free from every point of the vertex's star and in
    ``kern`` at its nearest lattice point (free ones alone where that run is at most one
    bin) that holds, or comes next counter-clockwise of, the direction away from the nearest
    wall; the gap places of whole-circle vertices from the harmonic
    extension of the gap centres around them (:func:`_smooth_gaps`). With a sensing delay
    (``grow = vt·d > 0``, map units) the stars' boxes hold their triangles grown by ``grow``
    (:func:`~tether.game.cells.grow_triangles`), the rods are
    ``lss + grow`` long and the free bins are eroded by :func:`sight_widening` (check 1 with
    a delay).

    **Split stars.** A vertex whose star sees no common orientation (the run is empty, or a
    single bin: no arc of positive width) cannot carry any arc that check 1 passes on every
    triangle of its star. Its star is then split by :func:`bisect` (newest-vertex bisection
    with closure, the refinement edges from :func:`longest_edge_first`) and the arcs are
    computed again on the finer mesh, up to ``splits`` times: a smaller star sees more (a
    vertex next to an obstacle's corner in a corridor exactly ``lss`` wide, whose star holds
    points of both corridors). The mesh stays conforming and keeps every wall piece as an edge
    or a chain of edges (``docs/certified.md``, (R1)); nothing else changes (without a closed
    vertex, the mesh of :func:`free_mesh` and the same field, bit for bit). The field returned
    may still hold closed arcs when ``splits`` did not open them.

    **From a coarser field** (``coarse``, an :class:`ArcField` of the same map and frame, e.g.
    one certified on a coarser mesh): the arcs are ``coarse`` interpolated at the vertices of
    :func:`free_mesh` (:func:`interpolate_field`) instead of being read from ``kern``'s bins
    (only its lattice is used, and no star is split). None (the default): the field above,
    bit for bit.
    """
    grid = kern.grid
    pts, tri, src = free_mesh(grid.env, grid.h, grid.points)
    if coarse is not None:
        return interpolate_field(coarse, pts, tri)
    for k in range(max(splits, 0) + 1):
        f = _first_arcs(kern, pts, tri, src, grow)
        closed = f.w <= 0
        if not closed.any() or k >= splits:
            break
        if k == 0:
            tri = longest_edge_first(pts, tri)
        pts, tri, _ = bisect(pts, tri, closed[tri].any(axis=1))  # every closed vertex's star
        src = np.concatenate([src, np.full(len(pts) - len(src), -1)])
    return f


def _first_arcs(kern, pts: np.ndarray, tri: np.ndarray, src: np.ndarray, grow: float
                ) -> ArcField:
    """:func:`first_field`'s arcs on the mesh ``(pts, tri)`` (``src``: each vertex's lattice
    index in ``kern``, -1 for a vertex off the lattice, which takes its nearest lattice
    point's kernel bins)."""
    grid = kern.grid
    env = grid.env
    nv = len(pts)
    corners = pts[tri]
    bins, star_free = star_bins(kern, pts, tri, src, grow)
    centre = np.zeros((nv, 2))
    count = np.zeros(nv)
    for j in range(3):
        np.add.at(centre, tri[:, j], corners.mean(axis=1))
        np.add.at(count, tri[:, j], 1)
    probe = np.where((src >= 0)[:, None], pts, centre / np.maximum(count, 1)[:, None])
    ends = shapely.get_coordinates(shapely.shortest_line(shapely.points(probe),
                                                         env.polygon.boundary)).reshape(-1, 2, 2)
    away = ends[:, 0] - ends[:, 1]
    pref = np.mod(np.round(np.arctan2(away[:, 1], away[:, 0]) / grid.delta),
                  grid.n_a).astype(int)
    start, length, full = runs_toward(bins, pref)
    thin = length <= 1  # the grid kernel leaves no arc free from the whole star here: start
    if thin.any():  # from the free bins alone (the search and the checks decide)
        s2, l2, f2 = runs_toward(star_free[thin], pref[thin])
        start[thin], length[thin], full[thin] = s2, l2, f2
    lo = start * grid.delta
    w = np.where(full, _TAU, np.maximum(length - 1, 0) * grid.delta)
    edges = np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]),
                              axis=1), axis=0)
    return ArcField(pts, tri, _smooth_gaps(lo, w, edges), w)


def star_bins(kern, pts: np.ndarray, tri: np.ndarray, src: np.ndarray, grow: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex of the mesh ``(pts, tri)``, the orientation bins of ``kern``'s grid free from
    every point of the vertex's star (``star_free``, (n, n_a) bool; with a sensing delay as in
    :func:`first_field`) and those also in ``kern`` at its lattice point (``src``, -1: the
    nearest one): ``(bins, star_free)``."""
    grid = kern.grid
    nv = len(pts)
    lo_xy = np.full((nv, 2), np.inf)
    hi_xy = np.full((nv, 2), -np.inf)
    corners = pts[tri]
    grown = grow_triangles(corners, grow) if grow > 0 else corners
    for j in range(3):
        np.minimum.at(lo_xy, tri[:, j], grown.min(axis=1))
        np.maximum.at(hi_xy, tri[:, j], grown.max(axis=1))
    star_free, _ = cell_free_bins(grid.env, np.column_stack([lo_xy, hi_xy]), kern.lss + grow,
                                  grid.n_a)
    if grow > 0:  # a bin is kept when every bin within the widening is free
        m = math.ceil(sight_widening(grow, kern.lss) / grid.delta)
        star_free = np.logical_and.reduce([np.roll(star_free, k, axis=1)
                                           for k in range(-m, m + 1)])
    near = np.where(src >= 0, src, cKDTree(grid.points).query(pts)[1])
    return kern.kernel[near] & star_free, star_free


def runs_toward(kernel: np.ndarray, pref: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of ``kernel`` (bins), the circular run of ``True`` holding bin ``pref`` or the
    first one counter-clockwise of it: ``(start, length, full)`` in bins (length 0: none)."""
    n = kernel.shape[1]
    full = kernel.all(axis=1)
    cols = np.arange(n)[None, :]
    seed = np.argmin(np.where(kernel, np.mod(cols - pref[:, None], n), n + 1), axis=1)
    stop_hi = np.where(~kernel, np.mod(cols - seed[:, None], n), n).min(axis=1)
    stop_lo = np.where(~kernel, np.mod(seed[:, None] - cols, n), n).min(axis=1)
    start = np.mod(seed - stop_lo + 1, n)
    length = np.where(full, n, stop_hi + stop_lo - 1)
    length = np.where(kernel[np.arange(len(kernel)), seed], length, 0)
    return start, length, full


def _smooth_gaps(lo: np.ndarray, w: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``lo`` with the gap places of whole-circle vertices replaced by the angle of the
    harmonic extension (graph Laplacian on the mesh ``edges``) of the unit vectors of the gap
    centres ``lo − (2π − w)/2`` of the vertices with a gap: a smooth turn of the gap place,
    which the end conditions can follow where it winds slowly."""
    full = w >= FULL
    if not full.any() or full.all():
        return np.where(full, 0.0, lo)
    z = np.exp(1j * (lo - (_TAU - w) / 2))
    fi = np.flatnonzero(full)
    idx = np.full(len(lo), -1)
    idx[fi] = np.arange(len(fi))
    rows, cols, vals = [], [], []
    rhs = np.zeros(len(fi), dtype=complex)
    deg = np.zeros(len(fi))
    for u, v in ((edges[:, 0], edges[:, 1]), (edges[:, 1], edges[:, 0])):
        u, v = u[full[u]], v[full[u]]
        np.add.at(deg, idx[u], 1.0)
        both = full[v]
        rows.append(idx[u[both]])
        cols.append(idx[v[both]])
        vals.append(-np.ones(int(both.sum())))
        np.add.at(rhs, idx[u[~both]], z[v[~both]])
    rows.append(np.arange(len(fi)))
    cols.append(np.arange(len(fi)))
    vals.append(np.maximum(deg, 1.0))
    m = sparse.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(len(fi), len(fi))).tocsr()
    sol = spsolve(m, rhs) if np.abs(rhs).max() > 0 else np.zeros(len(fi), dtype=complex)
    out = lo.copy()
    out[fi] = np.angle(sol)
    return out


def lifted_ends(lo: np.ndarray, w: np.ndarray, tri: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ends ``lo`` and ``hi`` of each triangle's vertices lifted to one branch (radians,
    (m, 3) each), and whether the gap centres wind around the triangle.

    The gap centres ``c = lo − (2π − w)/2`` are lifted from vertex 0 by the wrapped
    differences along the edges: the lift along an edge is the same in both triangles that
    share it, so the interpolated field is continuous. Where the three wrapped differences do
    not sum to zero the centres wind around the triangle and no continuous lift exists."""
    c = (lo - (_TAU - w) / 2)[tri]
    d01, d12, d20 = _wrap(c[:, 1] - c[:, 0]), _wrap(c[:, 2] - c[:, 1]), _wrap(c[:, 0] - c[:, 2])
    winds = np.abs(d01 + d12 + d20) > 1.0
    cl = np.stack([c[:, 0], c[:, 0] + d01, c[:, 0] - d20], axis=1)
    gap = (_TAU - w)[tri]
    return cl + gap / 2, cl - gap / 2 + _TAU, winds


def hat_gradients(xy: np.ndarray) -> np.ndarray:
    """Gradients (m, 3, 2) of the three linear hat functions of each triangle ``xy`` (m, 3, 2):
    the gradient of a field linear on the triangle is ``Σ_j z_j·∇φ_j``."""
    e1 = xy[:, 1] - xy[:, 0]
    e2 = xy[:, 2] - xy[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    g1 = np.stack([e2[:, 1], -e2[:, 0]], 1) / det[:, None]
    g2 = np.stack([-e1[:, 1], e1[:, 0]], 1) / det[:, None]
    return np.stack([-g1 - g2, g1, g2], axis=1)


def window_min(amin: np.ndarray, amax: np.ndarray, th: np.ndarray, vt: float, vo: float,
               sgn: float, n: int = 4096) -> np.ndarray:
    """A lower bound (map units per second) of ``min over a in [amin, amax]`` of
    ``f(θ − a) = sqrt(vo² − vt²cos²(θ − a)) + sgn·vt·sin(θ − a)``, per row and heading
    ``θ = th[j]`` (``(m, Θ)``; ``amin <= amax``, radians, any branch): :func:`window_min_at`
    of the windows ``[θ − amax, θ − amin]``."""
    return window_min_at(th[None, :] - amax[:, None], th[None, :] - amin[:, None], vt, vo,
                         sgn, n)


def window_min_at(x0: np.ndarray, x1: np.ndarray, vt: float, vo: float, sgn: float,
                  n: int = 4096) -> np.ndarray:
    """A lower bound (map units per second) of ``min over x in [x0, x1]`` of
    ``f(x) = sqrt(vo² − vt²cos²x) + sgn·vt·sin x``, element by element (``x0 <= x1``,
    radians, any branch, arrays of one shape).

    ``f`` is tabulated at ``n`` points of the circle (spacing ``d = 2π/n``), and each window
    ``[x0, x1]``, rounded outward to grid points, is answered by a sparse table of minima
    (two lookups of one power-of-two length covering it; a window of a whole turn or more
    takes the minimum of the table). Every point of the window is within ``d/2`` of a grid
    point of the rounded window, and ``f`` is Lipschitz with constant ``r + vt``
    (``r = vt²/(2·sqrt(vo² − vt²))`` bounds the derivative of the square root), so
    subtracting ``(r + vt)·d/2`` from the table's minimum gives a lower bound."""
    table, f_min, log2, lip = _min_table(float(vt), float(vo), float(sgn), int(n))
    d = _TAU / n
    lo_i = np.floor(x0 / d).astype(np.int64)
    length = np.ceil(x1 / d).astype(np.int64) - lo_i + 1
    full = length >= n
    np.clip(length, 1, n, out=length)
    lo_i = np.mod(lo_i, n)
    lev = log2[length]  # floor(log2(length)): 2**lev <= length < 2**(lev + 1)
    row = lev * (2 * n)
    out = np.minimum(table[row + lo_i], table[row + lo_i + length - (1 << lev)])
    out[full] = f_min
    return out - lip * d / 2


def heading_window_min(amin: np.ndarray, amax: np.ndarray, headings: int, vt: float,
                       vo: float, sgn: float, n: int = 4096) -> np.ndarray:
    """:func:`window_min` at the headings ``θ_j = 2π·j/headings`` (``j = 0..headings − 1``;
    ``headings`` must divide ``n``), ``(m, headings)``: a lower bound of
    ``min over a in [amin, amax]`` of ``f(θ_j − a)``.

    ``θ_j`` is the grid point ``j·s`` (``s = n/headings``), so the window ``[θ_j − amax,
    θ_j − amin]`` rounded outward to grid points is the row's window at ``θ = 0``,
    ``[floor(−amax/d), ceil(−amin/d)]``, moved by ``j·s`` points: its length and level in
    the sparse table are the row's, and only the start moves (the bound of
    :func:`window_min_at`, rounded once per row instead of once per heading)."""
    if n % headings:
        raise ValueError(f"headings = {headings} does not divide n = {n}")
    table, f_min, log2, lip = _min_table(float(vt), float(vo), float(sgn), int(n))
    d = _TAU / n
    lo0 = np.floor(-amax / d).astype(np.int64)
    length = np.ceil(-amin / d).astype(np.int64) - lo0 + 1
    full = length >= n
    np.clip(length, 1, n, out=length)
    lev = log2[length]
    row = (lev * (2 * n))[:, None]
    start = np.mod(lo0[:, None] + (n // headings) * np.arange(headings)[None, :], n) + row
    out = np.minimum(table[start], table[start + (length - (1 << lev))[:, None]])
    out[full] = f_min
    return out - lip * d / 2


def window_floor(vt: float, vo: float, sgn: float, n: int = 4096) -> float:
    """A lower bound (map units per second) of every value :func:`window_min_at` and
    :func:`heading_window_min` return for these ``vt``, ``vo``, ``sgn`` and ``n``: the table's
    minimum of ``f`` minus the same Lipschitz term (each of them is a table minimum over a
    window minus that term, and a window's minimum is at least the whole table's)."""
    _, f_min, _, lip = _min_table(float(vt), float(vo), float(sgn), int(n))
    return f_min - lip * (_TAU / n) / 2


@functools.lru_cache(maxsize=16)
def _min_table(vt: float, vo: float, sgn: float, n: int
               ) -> tuple[np.ndarray, float, np.ndarray, float]:
    """The sparse table of :func:`window_min_at` (read-only, flattened: row ``j`` of length
    ``2n`` holds the minima of ``f`` over ``2**j`` grid points from each index; windows wrap
    once at most), ``f``'s minimum, ``floor(log2(k))`` for ``k = 0..n`` (``k = 0`` unused) and
    the Lipschitz constant ``r + vt``."""
    x = np.arange(n) * (_TAU / n)
    f = np.sqrt(vo * vo - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x)
    levels = [np.concatenate([f, f])]
    while (1 << len(levels)) <= n:
        prev, j = levels[-1], len(levels) - 1
        levels.append(np.minimum(prev[:-(1 << j)], prev[1 << j:]))
    table = np.full((len(levels), 2 * n), np.inf)
    for j, row in enumerate(levels):
        table[j, :len(row)] = row
    table = table.ravel()
    log2 = np.zeros(n + 1, dtype=np.int64)
    log2[1:] = np.frexp(np.arange(1, n + 1))[1] - 1
    table.flags.writeable = False
    log2.flags.writeable = False
    lip = vt * vt / (2 * math.sqrt(vo * vo - vt * vt)) + vt
    return table, float(f.min()), log2, lip


def end_slack(G: np.ndarray, a_lo: np.ndarray, a_hi: np.ndarray, lss: float, vt: float,
              vo: float, upper: bool) -> np.ndarray:
    """A lower bound (map units per second) of the smallest slack of an end condition over
    every target heading ``θ`` and every orientation ``a ∈ [a_lo, a_hi]``, per triangle.

    With ``x = θ − a``, ``lss·Ωmax = sqrt(vo² − vt²cos²x) − vt·sin x`` and
    ``lss·Ωmin = −sqrt(vo² − vt²cos²x) − vt·sin x``. The lower end's slack is
    ``F = sqrt(vo² − vt²cos²x) − vt·sin x − lss·vt·G·u(θ)``, the upper end's
    ``F = sqrt(vo² − vt²cos²x) + vt·sin x + lss·vt·G·u(θ)``: ``F = f(θ − a) + s·lss·vt·G·u(θ)``
    with ``s = ±1`` and ``f`` as in :func:`window_min`, which bounds ``h(θ) = min over a of
    f(θ − a)`` from below at each of :data:`THETA_SAMPLES` headings (spacing ``Δθ``). ``h`` is
    Lipschitz with the constant ``r + vt`` of ``f`` (a minimum of such functions), and
    ``G·u(θ)`` with ``|G|``; every heading is within ``Δθ/2`` of a sample, so
    ``min F >= min over samples of (window_min + s·lss·vt·G·u) − (r + vt + lss·vt·|G|)·Δθ/2``.
    """
    th = np.linspace(0, _TAU, THETA_SAMPLES, endpoint=False)
    dth = _TAU / THETA_SAMPLES
    r = vt * vt / (2 * math.sqrt(vo * vo - vt * vt))
    sgn = 1.0 if upper else -1.0
    out = np.empty(len(G))
    for s in range(0, len(G), _ROWS):  # rows in blocks: (rows, Θ) temporaries stay small
        g = G[s:s + _ROWS]
        gu = g[:, 0:1] * np.cos(th)[None, :] + g[:, 1:2] * np.sin(th)[None, :]
        low = window_min(a_lo[s:s + _ROWS], a_hi[s:s + _ROWS], th, vt, vo, sgn)
        out[s:s + _ROWS] = (low + sgn * lss * vt * gu).min(axis=1)
    return out - (r + vt + lss * vt * np.hypot(G[:, 0], G[:, 1])) * dth / 2


def end_fails(G: np.ndarray, a_lo: np.ndarray, a_hi: np.ndarray, lss: float, vt: float,
              vo: float, upper: bool) -> np.ndarray:
    """``end_slack(...) < MARGIN`` per triangle (the arguments of :func:`end_slack`), with
    :func:`end_slack` computed only where a cheaper lower bound of it does not already reach
    :data:`MARGIN`: every :func:`window_min` value is at least :func:`window_floor` and
    ``s·lss·vt·G·u(θ) >= −lss·vt·|G|``, so ``end_slack >= window_floor − lss·vt·|G| −
    (r + vt + lss·vt·|G|)·Δθ/2``. A triangle whose bound is at least ``MARGIN`` plus
    :data:`_FLOOR_ROOM` (far above the rounding of either computation) passes as it would
    with :func:`end_slack`: the same verdict, bit for bit, at a fraction of the cost where
    most ends are gentle."""
    sgn = 1.0 if upper else -1.0
    k = lss * vt
    r = vt * vt / (2 * math.sqrt(vo * vo - vt * vt))
    g = k * np.hypot(G[:, 0], G[:, 1])
    floor = window_floor(vt, vo, sgn) - g - (r + vt + g) * (_TAU / THETA_SAMPLES) / 2
    out = np.zeros(len(G), bool)
    # written so that NaN fails (a NaN gradient, e.g. of a degenerate triangle, compares
    # False everywhere): "not proven to pass", never "< MARGIN"
    near = np.flatnonzero(~(floor >= MARGIN + _FLOOR_ROOM))
    if len(near):
        out[near] = ~(end_slack(G[near], a_lo[near], a_hi[near], lss, vt, vo, upper)
                      >= MARGIN)
    return out


def certify(field: ArcField, env: Environment, lss: float, vt: float, vo: float,
            grow: float = 0.0) -> Checks:
    """Run the three checks (module docstring) on every triangle of ``field``.

    ``lss`` (map units), ``vt < vo`` (map units per second): the game's rod length and speeds.
    ``grow`` (map units, ``0 <= grow < lss``): ``vt·d`` for a sensing delay ``d`` (module
    docstring); 0 is the check without delay, bit for bit.
    """
    tri = field.tri
    xy = field.points[tri]
    w = field.w[tri]
    lo, hi, winds = lifted_ends(field.lo, field.w, tri)
    partial = (w < FULL).any(axis=1)
    # written so that NaN fails: a NaN width or end compares False everywhere below, and
    # would otherwise pass every check
    finite = np.isfinite(field.lo)[tri].all(axis=1) & np.isfinite(w).all(axis=1)
    bad_open = ~((w >= W_MIN).all(axis=1) & finite) | (winds & partial)
    bad_lo = np.zeros(len(tri), dtype=bool)
    bad_hi = np.zeros(len(tri), dtype=bool)
    sel = np.flatnonzero(partial & ~bad_open)
    if len(sel):
        hat = hat_gradients(xy[sel])
        g_lo = np.einsum("nvk,nv->nk", hat, lo[sel])
        g_hi = np.einsum("nvk,nv->nk", hat, hi[sel])
        bad_lo[sel] = end_fails(g_lo, lo[sel].min(1), lo[sel].max(1), lss, vt, vo, False)
        bad_hi[sel] = end_fails(g_hi, hi[sel].min(1), hi[sel].max(1), lss, vt, vo, True)
    if grow > 0:
        beta = sight_widening(grow, lss)
        blocked, _ = triangle_blocked_any(env, grow_triangles(xy, grow), lo.min(axis=1) - beta,
                                          hi.max(axis=1) + beta, lss + grow)
        meets = triangle_meets(env, xy)
    else:
        blocked, meets = triangle_blocked_any(env, xy, lo.min(axis=1), hi.max(axis=1), lss)
    return Checks(blocked & meets, bad_open & meets, bad_lo & meets, bad_hi & meets, meets)


#: Candidate triangles of the coarse mesh tried per point by :func:`interpolate_field`
#: (nearest centroids first).
_LOCATE_K = 16
#: Barycentric coordinate (unitless) down to which a point counts as inside a triangle.
_INSIDE_TOL = -1e-9


def interpolate_field(coarse: ArcField, points: np.ndarray, tri: np.ndarray) -> ArcField:
    """``coarse`` read at the vertices ``points`` (map units, (n, 2)) of another mesh ``tri`` of
    the same free space: the field on that mesh whose vertex arcs are ``coarse``'s set-valued
    map at each point.

    Each point is located in a triangle of ``coarse`` (among the :data:`_LOCATE_K` of nearest
    centroid, the first holding it to :data:`_INSIDE_TOL` in barycentric coordinates; else the
    one it is least outside of, its coordinates clamped to the triangle: a point on a wall
    between two wall points of the coarse mesh). There the lifted ends
    (:func:`lifted_ends`) are interpolated linearly: ``lo = Σ b_j·lo_j``, ``w = min(Σ b_j·hi_j
    − lo, 2π)``, exactly the field ``coarse`` holds at the point. Where the coarse triangle's
    gap centres wind (no lift) the arc of its vertex of largest coordinate is taken.

    A fine triangle inside one coarse triangle carries the same linear ends on a smaller
    range, so it passes every check the coarse triangle passes; one that straddles coarse
    edges need not (the search repairs it: :mod:`tether.game.patches`).

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> f = ArcField(pts, np.array([[0, 1, 2]]), np.array([0.0, 0.3, 0.6]), np.full(3, 1.0))
    >>> g = interpolate_field(f, np.array([[0.5, 0.5], [0.2, 0.0]]), np.array([[0, 1, 0]]))
    >>> np.round(g.lo, 6).tolist(), np.round(g.w, 6).tolist()
    ([0.45, 0.06], [1.0, 1.0])
    """
    points = np.asarray(points, dtype=float)
    ctri = coarse.tri
    cxy = coarse.points[ctri]
    k = min(_LOCATE_K, len(ctri))
    _, cand = cKDTree(cxy.mean(axis=1)).query(points, k=k)
    cand = cand.reshape(len(points), k)
    a, b, c = cxy[cand, 0], cxy[cand, 1], cxy[cand, 2]  # (n, k, 2)
    v0, v1, v2 = b - a, c - a, points[:, None, :] - a
    det = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    l1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / det
    l2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / det
    bary = np.stack([1 - l1 - l2, l1, l2], axis=-1)  # (n, k, 3)
    worst = bary.min(axis=2)
    pick = np.argmax(np.where(worst >= _INSIDE_TOL, 1.0 + 0 * worst, worst), axis=1)
    rows = np.arange(len(points))
    t = cand[rows, pick]
    bc = np.clip(bary[rows, pick], 0.0, None)
    bc /= bc.sum(axis=1, keepdims=True)
    lo3, hi3, winds = lifted_ends(coarse.lo, coarse.w, ctri)
    lo = (bc * lo3[t]).sum(axis=1)
    w = np.minimum((bc * hi3[t]).sum(axis=1) - lo, _TAU)
    partial = (coarse.w[ctri] < FULL).any(axis=1)
    bad = winds[t] & partial[t]
    if bad.any():
        v = ctri[t[bad], np.argmax(bc[bad], axis=1)]
        lo[bad], w[bad] = coarse.lo[v], coarse.w[v]
    w = np.where(w >= FULL, _TAU, w)
    return ArcField(points, np.asarray(tri), _wrap(lo), w)
