"""The vectorized rod test, blocked intervals, their merge into free arcs and the clearance
search against their earlier forms, kept here as references: the rewrites must give the very
same booleans, intervals, arcs and distances (bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

from tether.arcs import (
    TWO_PI,
    ArcTable,
    blocked_intervals,
    check_lss,
    rod_is_free_many,
    rod_is_free_rows,
    rod_rows,
)
from tether.arcs.free import _GROUP, _facing_index, _merge, _order_by_point_angle
from tether.arcs.free import edge_columns as _edge_columns
from tether.decomposition.pieces import _clearance
from tether.environment import Environment
from tether.examples.floorplan import floor_plan
from tether.spatial import segment_tree, segments_near
from tether.tolerances import ANGLE_TOL


def _in_cone(env, v, x):
    """Whether unit directions ``x`` lie in the closed free cone at vertices ``v`` (the cone
    test of the rod test before ``_leaves_cone``)."""
    d_out, d_in = env.cone
    do, di = d_out[v], d_in[v]
    tol = ANGLE_TOL

    def cr(p, q):
        return p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]

    turn = cr(do, di)
    convex_in = (cr(do, x) >= -tol) & (cr(x, di) >= -tol)
    reflex_in = ~((cr(di, x) > tol) & (cr(x, do) > tol))
    straight_in = cr(do, x) >= -tol
    return np.where(turn > tol, convex_in, np.where(turn < -tol, reflex_in, straight_in))


def _rod_reference(env, points, angles, lss):
    """``rod_is_free_many`` as it was before the column rewrite (one batch, internal map)."""
    lss = check_lss(lss)
    pts = np.asarray(points, dtype=float)
    ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
    tol = env.length_tol
    free = np.asarray(env.contains(pts[:, 0], pts[:, 1]), dtype=bool).copy()
    A, B, tag_a, _ = env.oriented_edges
    ux, uy = np.cos(ang), np.sin(ang)
    mid = pts + (0.5 * lss) * np.column_stack((ux, uy))
    pidx, eidx = env.edge_index(0.5 * lss).query(mid)
    ux, uy = ux[pidx], uy[pidx]
    px, py = pts[pidx, 0], pts[pidx, 1]
    wx, wy = A[eidx, 0] - px, A[eidx, 1] - py
    ca = ux * wy - uy * wx
    cb = ux * (B[eidx, 1] - py) - uy * (B[eidx, 0] - px)
    k = np.flatnonzero(~(((ca > tol) & (cb > tol)) | ((ca < -tol) & (cb < -tol))))
    pidx, eidx, ca = pidx[k], eidx[k], ca[k]
    u = np.column_stack((ux[k], uy[k]))
    w = np.column_stack((wx[k], wy[k]))
    e = B[eidx] - A[eidx]
    den = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
    s_num = w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]
    elen = np.sqrt(np.einsum("ij,ij->i", e, e))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = s_num / den
        t = -ca / den
    inside_edge = (np.abs(den) > ANGLE_TOL * elen) & (t * elen > tol) & ((1 - t) * elen > tol)
    at_start = (np.abs(s) <= tol) & (den > 0)
    cross = inside_edge & (((s > tol) & (s < lss - tol)) | at_start)
    along = np.einsum("ij,ij->i", w, u)
    at_v = (np.abs(ca) <= tol) & (along > tol) & (along <= lss + tol)
    through = at_v & (along < lss - tol)
    blocked = cross.copy()
    hit = np.flatnonzero(at_v)
    if len(hit):
        v = tag_a[eidx[hit]]
        bad = ~_in_cone(env, v, -u[hit]) | (through[hit] & ~_in_cone(env, v, u[hit]))
        blocked[hit] |= bad
    free[pidx[blocked]] = False
    return free


def _rods(env, lss, m, rng):
    """Random rods (some outside the map), and rods aimed at, through and ending on vertices."""
    lo, hi = np.array(env.bounds[:2]), np.array(env.bounds[2:])
    p = lo + rng.random((m, 2)) * (hi - lo)
    a = rng.uniform(-4, 10, m)
    v = env.vertices[rng.integers(0, len(env.vertices), m)]
    b = rng.uniform(0, 2 * np.pi, m)
    along = lss * rng.choice([0.3, 0.999999, 1.0, 1.0000001, 1.5], m)
    q = v - along[:, None] * np.column_stack((np.cos(b), np.sin(b)))
    return np.vstack((p, q)), np.concatenate((a, b))


@pytest.mark.slow
@pytest.mark.parametrize("n, seed", [(40, 1), (120, 2), (300, 3)])
def test_rod_is_free_many_matches_reference(n, seed):
    env = floor_plan(n, seed=seed).internal
    assert _edge_columns(env)[0].shape == (len(env.oriented_edges[0]),)
    rng = np.random.default_rng(seed)
    for lss in (0.02, 0.05, 0.2):
        pts, ang = _rods(env, lss, 6000, rng)
        got = rod_is_free_many(env, pts, ang, lss)
        assert np.array_equal(got, _rod_reference(env, pts, ang, lss))
        assert 0 < got.sum() < len(got)


def _clearance_reference(pts, owner, sa, sb, sowner, reach):
    """Each point's distance to the nearest segment of another part, at most ``reach``: one
    search within ``reach`` (no stages)."""
    clear = np.full(len(pts), reach)
    qi, sj, d = segments_near(pts, sa, sb, reach, segment_tree(sa, sb))
    other = sowner[sj] != owner[qi]
    np.minimum.at(clear, qi[other], d[other])
    return clear


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clearance_matches_one_search(seed):
    rng = np.random.default_rng(seed)
    # random polylines (parts) of short and some long segments
    k = 3000
    sa = rng.random((k, 2))
    step = rng.normal(0, 0.004, (k, 2)) * np.where(rng.random(k) < 0.05, 30, 1)[:, None]
    sb = sa + step
    sowner = rng.integers(0, 400, k)
    take = rng.integers(0, k, 2000)
    pts = 0.5 * (sa[take] + sb[take])
    owner = sowner[take]
    reach = 0.01
    got = _clearance(pts, owner, sa, sb, sowner, segment_tree(sa, sb), reach)
    assert np.array_equal(got, _clearance_reference(pts, owner, sa, sb, sowner, reach))
    assert (got < reach).any() and (got == reach).any()


def _blocked_reference(env, pts, lss):
    """``blocked_intervals`` as it was before the facing index: every candidate of the full
    edge index, the point's coordinates gathered."""
    ax, ay, dx, dy, dd, sdd, tag_a, tag_b = _edge_columns(env)
    pidx, eidx = env.edge_index(lss).query(pts)
    wx = ax[eidx] - pts[:, 0][pidx]
    wy = ay[eidx] - pts[:, 1][pidx]
    ex, ey = dx[eidx], dy[eidx]
    side = ex * (-wy) - ey * (-wx)
    k = np.flatnonzero(side > env.length_tol * sdd[eidx])
    pidx, eidx, wx, wy, ex, ey = pidx[k], eidx[k], wx[k], wy[k], ex[k], ey[k]
    de = dd[eidx]
    b = ex * wx + ey * wy
    c = (wx * wx + wy * wy) - lss * lss
    disc = b * b - de * c
    k = np.flatnonzero(disc > 0)
    pidx, eidx, wx, wy, ex, ey, de, b = (x[k] for x in (pidx, eidx, wx, wy, ex, ey, de, b))
    sq = np.sqrt(disc[k])
    r1 = (-b - sq) / de
    r2 = (-b + sq) / de
    t1 = np.maximum(r1, 0.0)
    t2 = np.minimum(r2, 1.0)
    k = np.flatnonzero(t1 < t2)
    pidx, eidx, wx, wy, ex, ey, de, r1, r2, t1, t2 = (
        x[k] for x in (pidx, eidx, wx, wy, ex, ey, de, r1, r2, t1, t2))
    p1x, p1y = wx + t1 * ex, wy + t1 * ey
    p2x, p2y = wx + t2 * ex, wy + t2 * ey
    start = np.mod(np.arctan2(p1y, p1x), TWO_PI)
    length = np.arctan2(p1x * p2y - p1y * p2x, p1x * p2x + p1y * p2y)
    chord = (t2 - t1) * np.sqrt(de)
    wide = (length > ANGLE_TOL) | ((length > 0.0) & (chord > env.length_tol))
    e = eidx[wide]
    return {"point": pidx[wide], "edge": e, "start": start[wide], "length": length[wide],
            "cw_code": np.where(r1[wide] <= 0, env.n + tag_a[e], e),
            "ccw_code": np.where(r2[wide] >= 1, env.n + tag_b[e], e)}


def _interval_points(env, lss, m, rng):
    """Points where the side and reach tests are close calls: random (some beyond the map and
    the grid), on the grid's lines, within the length tolerance of an edge's line (both
    sides), at distance lss of a vertex, near an edge's end."""
    lo, hi = np.array(env.bounds[:2]), np.array(env.bounds[2:])
    span = hi - lo
    rand = lo - 0.6 * span + rng.random((m, 2)) * 2.2 * span
    ix = env.edge_index(lss)
    g = rng.integers(0, ix.shape, (m, 2))
    # the corners of grid cells (on the grid's lines or just inside a cell), their sides
    f = rng.choice([0.0, 1e-12, 0.5, 1 - 1e-12], (m, 2))
    grid = ix.origin + (g + f) * ix.cell
    A, B, _, _ = env.oriented_edges
    e = rng.integers(0, len(A), m)
    d = B[e] - A[e]
    nrm = np.column_stack((-d[:, 1], d[:, 0])) / np.hypot(d[:, 0], d[:, 1])[:, None]
    h = env.length_tol * rng.choice([-2.0, -1.0, 0.0, 0.999999, 1.0, 1.000001, 2.0, 1e3], m)
    t = rng.choice([-0.01, 0.0, 0.3, 1.0, 1.01], m)
    on_line = A[e] + t[:, None] * d + h[:, None] * nrm
    v = env.vertices[rng.integers(0, len(env.vertices), m)]
    a = rng.uniform(0, TWO_PI, m)
    r = lss * rng.choice([0.999999, 1.0, 1.0000001, 0.5], m)
    ring = v + r[:, None] * np.column_stack((np.cos(a), np.sin(a)))
    return np.vstack((rand, grid, on_line, ring))


def _rotated(env, angle):
    """The map turned by ``angle`` radians about the origin (no edge left axis-aligned: the
    facing index's corner test then depends on every corner)."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, s], [-s, c]])
    return Environment(env.boundary @ rot, tuple(h @ rot for h in env.holes), env.name)


@pytest.mark.parametrize("n, seed, angle", [(40, 1, 0.0), (120, 2, 0.0), (300, 3, 0.0),
                                            (120, 4, 0.3), (300, 5, 2.0)])
@pytest.mark.slow
def test_blocked_intervals_match_reference(n, seed, angle):
    env = _rotated(floor_plan(n, seed=seed), angle) if angle else floor_plan(n, seed=seed)
    env = env.internal
    rng = np.random.default_rng(seed)
    for lss in (0.01, 0.05, 0.2):
        pts = _interval_points(env, lss, 4000, rng)
        got, ref = blocked_intervals(env, pts, lss), _blocked_reference(env, pts, lss)
        assert got.keys() == ref.keys()
        for key, col in ref.items():
            assert got[key].dtype == col.dtype and np.array_equal(got[key], col), key
        assert len(ref["point"]) > len(pts) // 4
        # the facing index drops candidates (else the test would compare nothing new)
        assert len(_facing_index(env, lss).edges) < len(env.edge_index(lss).edges)


def _merge_reference(iv, npts):
    """``_merge`` as it was before the codes were gathered at the gap rows only."""
    order = _order_by_point_angle(iv["point"], iv["start"])
    pt = iv["point"][order]
    S = iv["start"][order]
    E = S + iv["length"][order]
    cw = iv["cw_code"][order]
    ccw = iv["ccw_code"][order]
    m = len(S)
    full = np.ones(npts, dtype=bool)
    full[pt] = False
    if m == 0:
        z = np.zeros(0)
        zi = np.zeros(0, dtype=np.int64)
        return ArcTable(zi, z, z, zi, zi, full)
    key = E + pt * _GROUP
    arg = np.maximum.accumulate(np.where(key >= np.maximum.accumulate(key), np.arange(m), 0))
    M = E[arg]
    new_run = np.r_[True, pt[1:] != pt[:-1]]
    last = np.r_[new_run[1:], True]
    first_of = np.flatnonzero(new_run)
    last_of = np.flatnonzero(last)
    grp = np.cumsum(new_run) - 1
    nxt = np.arange(1, m + 1)
    nxt[last_of] = first_of
    g_start = M.copy()
    g_end = S[nxt] + np.where(last, TWO_PI, 0.0)
    s_code = ccw[arg]
    e_code = cw[nxt]
    W = (M[last_of] - TWO_PI)[grp]
    s_code = np.where(g_start < W, ccw[arg[last_of]][grp], s_code)
    g_start = np.maximum(g_start, W)
    k = np.flatnonzero(g_end - g_start > ANGLE_TOL)
    start = np.mod(g_start[k], TWO_PI)
    end = np.mod(g_end[k], TWO_PI)
    o = _order_by_point_angle(pt[k], start)
    return ArcTable(pt[k][o], start[o], end[o], s_code[k][o], e_code[k][o], full)


@pytest.mark.slow
@pytest.mark.parametrize("n, seed, angle", [(40, 1, 0.0), (300, 3, 0.0), (120, 4, 0.3)])
def test_merge_matches_reference(n, seed, angle):
    """The free arcs of the merge, bit for bit (signed zeros included), on the intervals of
    close-call points (arcs wrapping past 2pi, intervals sharing ends at vertices)."""
    env = _rotated(floor_plan(n, seed=seed), angle) if angle else floor_plan(n, seed=seed)
    env = env.internal
    rng = np.random.default_rng(seed)
    wraps = 0
    for lss in (0.01, 0.05, 0.2):
        pts = _interval_points(env, lss, 4000, rng)
        iv = blocked_intervals(env, pts, lss)
        got, ref = _merge(iv, len(pts)), _merge_reference(iv, len(pts))
        for f in ("point", "start", "end", "start_code", "end_code", "full"):
            a, b = getattr(got, f), getattr(ref, f)
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f
        wraps += int(np.sum(ref.end < ref.start))
        assert len(ref.point) > 0 and not ref.full.all()
    assert wraps > 0  # some arcs cross angle 0: the wrapped gap's start feature is tested


@pytest.mark.slow
@pytest.mark.parametrize("n, seed", [(40, 5), (300, 6)])
def test_rod_rows_serve_moved_rods(n, seed):
    """The rows of ``rod_rows`` for a rod and a motion bound answer, for rods moved within that
    bound, as the plain rod test; targets flagged inside stay inside."""
    env = floor_plan(n, seed=seed).internal
    rng = np.random.default_rng(seed)
    for lss in (0.02, 0.1):
        pts, ang = _rods(env, lss, 3000, rng)
        m = len(pts)
        # motions from none to beyond MOVE_REACH (those rods get no rows)
        dp = lss * rng.choice([0.0, 1e-9, 1e-5, 1e-3, 0.05, 0.3], m)
        du = rng.choice([0.0, 1e-9, 1e-5, 1e-3, 0.1, 0.5], m)
        pidx, eidx, ok, inside = rod_rows(env, pts, ang, lss, dp, du)
        assert not np.any(inside & ~ok) and ok.sum() > m // 2 and inside.sum() > m // 10
        assert np.all(np.isin(pidx, np.flatnonzero(ok)))
        for _ in range(4):  # rods moved up to their bound (at the bound, or within)
            r = rng.choice([1.0, 0.5, 1e-3], m)[:, None] * rng.random((m, 1)) ** 0.1
            phi = rng.uniform(0, 2 * np.pi, m)
            moved = pts + (r[:, 0] * dp)[:, None] * np.column_stack((np.cos(phi), np.sin(phi)))
            a = ang + du * rng.uniform(-1, 1, m)
            want = rod_is_free_many(env, moved, a, lss)
            got = rod_is_free_rows(env, moved, a, lss, pidx, eidx, inside)
            assert np.array_equal(got[ok], want[ok])
            assert np.all(env.contains(moved[inside, 0], moved[inside, 1]))
        assert 0 < want.sum() < m
