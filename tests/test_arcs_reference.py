"""The vectorized rod test and clearance search against their earlier forms, kept here as
references: the rewrites must give the very same booleans and distances (bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

from tether.arcs import _edge_columns, _in_cone, check_lss, rod_is_free_many
from tether.decomposition import _clearance, _segment_tree, _segments_near
from tether.floorplan import floor_plan
from tether.tolerances import ANGLE_TOL


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
    qi, sj, d = _segments_near(pts, sa, sb, reach, _segment_tree(sa, sb))
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
    got = _clearance(pts, owner, sa, sb, sowner, _segment_tree(sa, sb), reach)
    assert np.array_equal(got, _clearance_reference(pts, owner, sa, sb, sowner, reach))
    assert (got < reach).any() and (got == reach).any()
