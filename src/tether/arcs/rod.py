"""The rod test: whether the segment from a target point to ``lss`` along an orientation
stays in the free space, vectorized over many rods (``docs/formulas.md``, "Free orientations
at a point"). It is independent of the free arcs' construction, which it checks."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tether._util.threads import map_batches
from tether.arcs import free
from tether.arcs.free import as_points, check_lss, edge_columns, query_edges
from tether.environment import Environment
from tether.tolerances import ANGLE_TOL

__all__ = ["MOVE_REACH", "rod_is_free", "rod_is_free_many", "rod_is_free_rows", "rod_rows",
           "wedge_columns"]

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
    pts = as_points(points)
    ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
    if len(pts) > free.POINT_BATCH:  # bounded memory: (point, edge) candidate rows per batch
        return np.concatenate(map_batches(  # in threads: numpy's big calls release the GIL
            lambda lo, hi: rod_is_free_many(env, pts[lo:hi], ang[lo:hi], lss), len(pts),
            free.POINT_BATCH))
    if not env.is_internal:  # computed in the normalized frame, without straight vertices
        frame = env.frame
        return rod_is_free_many(env.internal, frame.to_internal(pts), ang, lss * frame.scale)
    ux, uy = np.cos(ang), np.sin(ang)
    # the rod lies in the disc of radius lss/2 about its midpoint: only edges within that
    # reach of the midpoint can touch it (a quarter of the candidates of a query at the target)
    half = 0.5 * lss
    mid = np.column_stack((pts[:, 0] + half * ux, pts[:, 1] + half * uy))
    pidx, eidx, _ = query_edges(env.edge_index(half), mid)
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
    ax, ay, dx, dy, _, elen_all, _, _ = edge_columns(env)
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
    ax, ay, dx, dy, dd, _, _, _ = edge_columns(env)
    ux, uy = np.cos(angles), np.sin(angles)
    half = 0.5 * lss
    move = (dp + half * du) * (1 + 1e-6) + 1e-12 * lss
    ok = move <= MOVE_REACH * lss
    k = np.flatnonzero(ok)
    mid = np.column_stack((points[k, 0] + half * ux[k], points[k, 1] + half * uy[k]))
    pidx, eidx, _ = query_edges(env.edge_index(half + MOVE_REACH * lss), mid)
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
