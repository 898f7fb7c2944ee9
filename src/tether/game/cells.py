"""Which rod orientations are free from *every* point of a square or a triangle
(``docs/certified.md``, "The checks", check 1).

For a square ``Q`` (the star of a mesh vertex, or a triangle of the certified field) and an
orientation bin ``B = [a − δ/2, a + δ/2]``, the cell is *free* when the rod
``[p, p + lss·u(θ)]`` lies in the free space for every target point ``p ∈ Q ∩ free space`` and
every ``θ ∈ B``. The test is exact up to a stated, conservative tolerance:

1. ``Q ∩ free space`` is cut into convex pieces ``T``: the square itself when it lies inside the
   free space, else the triangles of the constrained Delaunay triangulation of the intersection.
2. The rods from a convex piece ``T`` at orientation ``θ`` sweep the convex set
   ``T ⊕ [0, lss·u(θ)]``. Such a rod enters an obstacle iff some wall segment ``W`` meets the
   interior of that set (walls are the boundary between free space and obstacles, and ``T``
   lies in the free space; a rod that only touches a wall, or runs along it, is free, as
   everywhere in tether). That happens iff ``θ`` is the direction of a point of
   ``M ∩ D(lss)``, ``M = W ⊕ (−T)`` (a convex polygon, the hull of the 8 (or 6) differences
   ``w − t`` of the ends of ``W`` and the vertices of ``T``), ``D(lss)`` the closed disk.
3. The directions of ``M ∩ D(lss)`` form one closed interval of at most ``π``: when ``W`` does
   not touch ``T``, the angular span of the vertices of ``M`` inside the disk and of the
   points where the chords of those vertices cross the circle (every extreme point of
   ``M ∩ D`` is one of them, and all of them lie in ``M ∩ D``); when ``W`` touches ``T``
   (distance at most the map's length tolerance), the span of the nonzero vertices of ``M``
   (the cone of ``M`` at the origin).
4. A bin is blocked when it meets a blocked interval widened by :data:`ANGLE_MARGIN`.

Every step errs only toward *blocked*: pieces cover ``Q ∩ free space``; a near-touching wall
is taken as touching (its cone contains the exact span); a numerically crossing wall blocks the
whole circle.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from tether.environment import Environment

__all__ = ["ANGLE_MARGIN", "blocked_spans", "cell_free_bins", "convex_pieces", "grow_triangles",
           "triangle_blocked_any", "triangle_meets", "walls_near"]

#: Widening (radians) of every blocked interval before it is turned into bins.
ANGLE_MARGIN = 1e-9
_BATCH = 200_000


def convex_pieces(env: Environment, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Convex pieces covering ``box ∩ free space`` for each box ``(xmin, ymin, xmax, ymax)``.

    Returns ``(owner, verts)``: ``verts[m]`` (shape (m, 4, 2)) are the vertices of piece ``m``
    (a triangle repeats its last vertex), ``owner[m]`` the index of its box. Boxes outside the
    free space get no piece.
    """
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    corners = np.stack([boxes[:, [0, 1]], boxes[:, [2, 1]], boxes[:, [2, 3]], boxes[:, [0, 3]]],
                       axis=1)
    return convex_pieces_of(env, corners)


def convex_pieces_of(env: Environment, polys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`convex_pieces` for convex polygons given by their 4 vertices (shape (n, 4, 2); a
    triangle repeats one)."""
    polys = np.asarray(polys, dtype=float)
    geoms = shapely.polygons(np.concatenate([polys, polys[:, :1]], axis=1))
    poly = env.polygon
    inside = shapely.contains(poly, geoms)
    meets = shapely.intersects(poly, geoms)
    whole = np.flatnonzero(inside)
    owners = [whole]
    verts = [polys[whole]]
    part = np.flatnonzero(meets & ~inside)
    if len(part):
        cut = shapely.intersection(geoms[part], poly)
        # a cut thinner than the length tolerance (a cell edge lying on a wall, or a float
        # sliver) holds no point that the neighbouring cell does not hold: no piece
        ext = polys[part]
        side = np.max(ext.max(axis=1) - ext.min(axis=1), axis=1)
        thick = shapely.area(cut) > 4 * env.length_tol * side
        part, cut = part[thick], cut[thick]
        tri = shapely.constrained_delaunay_triangles(cut)
        parts, idx = shapely.get_parts(tri, return_index=True)
        kind = shapely.get_type_id(parts)
        keep = kind == 3  # polygons (triangles); lines/points of degenerate cuts carry no area
        parts, idx = parts[keep], idx[keep]
        if len(parts):
            coords, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts),
                                                   return_index=True)
            counts = np.bincount(ring, minlength=len(parts))
            ok = counts == 4  # closed triangles: 3 vertices + the closing one
            first = np.cumsum(counts) - counts
            sel = first[ok][:, None] + np.arange(3)[None, :]
            t = coords[sel]
            owners.append(part[idx[ok]])
            verts.append(np.concatenate([t, t[:, 2:3]], axis=1))
    return np.concatenate(owners), np.concatenate(verts, axis=0)


def blocked_spans(T: np.ndarray, W: np.ndarray, lss: float, touch: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The closed interval of rod orientations blocked by wall ``W`` for rods from piece ``T``.

    Parameters
    ----------
    T : ndarray (n, 4, 2)
        Convex pieces (vertices in order; a triangle repeats one).
    W : ndarray (n, 2, 2)
        Wall segments, one per piece.
    lss : float
        Rod length, map units.
    touch : float
        Distance (map units) at or below which a wall counts as touching the piece.

    Returns
    -------
    lo, hi : ndarray (n,)
        Blocked orientations ``[lo, hi]`` (radians, ``hi − lo <= π`` unless the whole circle).
    any_ : ndarray (n,) of bool
        Whether anything is blocked (``False`` where ``M ∩ D(lss)`` is empty).
    """
    n = len(T)
    P = (W[:, :, None, :] - T[:, None, :, :]).reshape(n, 8, 2)  # vertices of M (and more)
    gT = shapely.polygons(np.concatenate([T, T[:, :1]], axis=1))
    gW = shapely.linestrings(W)
    dist = shapely.distance(gT, gW)
    ref = P.mean(axis=1)
    ref_ang = np.arctan2(ref[:, 1], ref[:, 0])
    norm = np.hypot(P[..., 0], P[..., 1])
    ang = np.mod(np.arctan2(P[..., 1], P[..., 0]) - ref_ang[:, None] + math.pi, math.tau) - math.pi
    near = dist <= touch
    # touching: the cone of M at the origin, spanned by its nonzero vertices
    use = norm > touch
    lo_t = np.where(use, ang, np.inf).min(axis=1)
    hi_t = np.where(use, ang, -np.inf).max(axis=1)
    # apart: vertices inside the disk and chord-circle crossings
    inside = norm <= lss
    lo_a = np.where(inside, ang, np.inf).min(axis=1)
    hi_a = np.where(inside, ang, -np.inf).max(axis=1)
    i, j = np.triu_indices(8, 1)
    A = P[:, i, :]
    D = P[:, j, :] - A
    a2 = (D * D).sum(-1)
    b = (A * D).sum(-1)
    c = (A * A).sum(-1) - lss * lss
    disc = b * b - a2 * c
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(np.maximum(disc, 0.0))
        for sgn in (-1.0, 1.0):
            s = (-b + sgn * root) / a2
            ok = (disc >= 0) & (a2 > 0) & (s >= 0) & (s <= 1)
            X = A + s[..., None] * D
            ax = np.mod(np.arctan2(X[..., 1], X[..., 0]) - ref_ang[:, None] + math.pi,
                        math.tau) - math.pi
            lo_a = np.minimum(lo_a, np.where(ok, ax, np.inf).min(axis=1))
            hi_a = np.maximum(hi_a, np.where(ok, ax, -np.inf).max(axis=1))
    lo = np.where(near, lo_t, lo_a)
    hi = np.where(near, hi_t, hi_a)
    any_ = np.isfinite(lo) & (dist <= lss + touch)
    whole = near & (~np.isfinite(lo_t) | (hi_t - lo_t > math.pi + 1e-9))
    lo = np.where(whole, -math.pi, lo) + ref_ang
    hi = np.where(whole, math.pi, hi) + ref_ang
    return lo, hi, any_ | whole


def walls_near(env: Environment, verts: np.ndarray, lss: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (piece, wall) pairs that can block a rod from a convex piece ``verts`` (m, 4, 2):
    the walls meeting the piece's box grown by ``lss`` (map units). Returns ``(piece, wall,
    walls)``, ``walls`` (k, 2, 2) the wall segments the indices refer to."""
    A, B, _, _ = env.oriented_edges
    walls = np.stack([A, B], axis=1)
    tree = shapely.STRtree(shapely.linestrings(walls))
    lo_xy = verts.min(axis=1) - lss
    hi_xy = verts.max(axis=1) + lss
    piece, wall = tree.query(shapely.box(lo_xy[:, 0], lo_xy[:, 1], hi_xy[:, 0], hi_xy[:, 1]),
                             predicate="intersects")
    return piece, wall, walls


def cell_free_bins(env: Environment, boxes: np.ndarray, lss: float, n_a: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Free orientation bins of each box: ``free[c, k]`` is true when the rod is free from every
    point of ``box_c ∩ free space`` at every orientation of bin ``k`` (``[k·δ − δ/2, k·δ + δ/2]``,
    ``δ = 2π/n_a``); see the module docstring.

    Returns ``(free, occupied)``: ``free`` (shape (m, n_a)) and ``occupied`` (m,), whether the
    box meets the free space at all (a box that does not is never a target's cell).
    """
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    m = len(boxes)
    owner, verts = convex_pieces(env, boxes)
    occupied = np.zeros(m, dtype=bool)
    occupied[owner] = True
    piece, wall, walls = walls_near(env, verts, lss)
    delta = math.tau / n_a
    touch = env.length_tol
    diff = np.zeros((m, 3 * n_a + 1), dtype=np.int32)
    for s in range(0, len(piece), _BATCH):
        pc, wl = piece[s:s + _BATCH], wall[s:s + _BATCH]
        lo, hi, hit = blocked_spans(verts[pc], walls[wl], lss, touch)
        pc, lo, hi = pc[hit], lo[hit] - ANGLE_MARGIN, hi[hit] + ANGLE_MARGIN
        k0 = np.ceil(lo / delta - 0.5).astype(np.int64)
        k1 = np.floor(hi / delta + 0.5).astype(np.int64)
        k1 = np.minimum(k1, k0 + n_a - 1)
        shift = np.floor_divide(k0, n_a) * n_a  # k0 into [0, n_a): the span stays in 2 copies
        k0, k1 = k0 - shift, k1 - shift
        np.add.at(diff, (owner[pc], k0), 1)
        np.add.at(diff, (owner[pc], k1 + 1), -1)
    cover = np.cumsum(diff[:, :-1], axis=1)
    blocked = (cover[:, :n_a] + cover[:, n_a:2 * n_a] + cover[:, 2 * n_a:]) > 0
    free = ~blocked & occupied[:, None]
    return free, occupied


def grow_triangles(tri: np.ndarray, r: float) -> np.ndarray:
    """Each triangle (n, 3, 2, counter-clockwise, map units) with its three edges pushed
    outward by ``r`` (map units): a triangle that contains ``T ⊕ D(r)``, every point within
    ``r`` of ``T``. ``T ⊕ D(r)`` lies in each of the three half-planes ``n_i·x <= n_i·P_i +
    r`` (``n_i`` the outward unit normal of edge ``i``), whose intersection is the grown
    triangle; its vertex at ``P_i`` is ``P_i + r·(n_{i-1} + n_i)/(1 + n_{i-1}·n_i)``, moved by
    ``r / sin(α_i/2)`` (``α_i`` the angle at ``P_i``).

    Examples
    --------
    >>> import numpy as np
    >>> from tether.game.cells import grow_triangles
    >>> t = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
    >>> grow_triangles(t, 0.1).round(4).tolist()
    [[[-0.1, -0.1], [1.2414, -0.1], [-0.1, 1.2414]]]
    """
    tri = np.asarray(tri, dtype=float)
    e = np.roll(tri, -1, axis=1) - tri  # edge i: P_i -> P_{i+1}
    n = np.stack([e[..., 1], -e[..., 0]], axis=-1)  # outward for counter-clockwise
    n = n / np.hypot(n[..., 0], n[..., 1])[..., None]
    prev = np.roll(n, 1, axis=1)  # edge i-1 ends at P_i
    cos = (prev * n).sum(axis=-1)
    return tri + r * (prev + n) / (1.0 + cos)[..., None]


def triangle_meets(env: Environment, tri: np.ndarray) -> np.ndarray:
    """Whether each triangle (n, 3, 2, map units) meets the free space with a part thicker
    than the length tolerance (the ``meets`` of :func:`triangle_blocked_any`)."""
    tri = np.asarray(tri, dtype=float)
    owner, _ = convex_pieces_of(env, np.concatenate([tri, tri[:, 2:3]], axis=1))
    meets = np.zeros(len(tri), dtype=bool)
    meets[owner] = True
    return meets


def triangle_blocked_any(env: Environment, tri: np.ndarray, a0: np.ndarray, a1: np.ndarray,
                         lss: float) -> tuple[np.ndarray, np.ndarray]:
    """Whether some rod from ``T ∩ free space`` at an orientation of ``[a0, a1]`` is blocked.

    Parameters
    ----------
    tri : ndarray (n, 3, 2)
        Triangles, map units.
    a0, a1 : ndarray (n,)
        Lifted orientation intervals (radians); ``a1 − a0 >= 2π`` is the whole circle.
    lss : float
        Rod length, map units.

    Returns
    -------
    blocked, meets : ndarray (n,) of bool
        ``blocked``: some wall blocks some orientation of the interval from some point of the
        triangle's free part (exact, widened by :data:`ANGLE_MARGIN`); ``meets``: the triangle
        meets the free space (with a part thicker than the length tolerance).
    """
    tri = np.asarray(tri, dtype=float)
    n = len(tri)
    quads = np.concatenate([tri, tri[:, 2:3]], axis=1)
    owner, verts = convex_pieces_of(env, quads)
    meets = np.zeros(n, dtype=bool)
    meets[owner] = True
    blocked = np.zeros(n, dtype=bool)
    if not len(owner):
        return blocked, meets
    piece, wall, walls = walls_near(env, verts, lss)
    for s in range(0, len(piece), _BATCH):
        pc, wl = piece[s:s + _BATCH], wall[s:s + _BATCH]
        lo, hi, hit = blocked_spans(verts[pc], walls[wl], lss, env.length_tol)
        t = owner[pc][hit]  # the pairs with a blocked span (finite ends)
        lo, hi = lo[hit] - ANGLE_MARGIN, hi[hit] + ANGLE_MARGIN
        full = (a1[t] - a0[t]) >= math.tau
        # shift the blocked interval so that it starts within [a0, a0 + 2π)
        k = np.floor((lo - a0[t]) / math.tau)
        lo, hi = lo - k * math.tau, hi - k * math.tau
        meet = (lo <= a1[t]) | (hi >= a0[t] + math.tau)
        blocked[t[full | meet]] = True
    return blocked, meets
