"""The critical parts of the candidate curves: the parameter intervals where the event rod is
semi-free. Freeness changes only at exact breakpoints (the rod sweeping across a vertex, an end
of the rod crossing an edge); each candidate is tested either side of every breakpoint and
between consecutive ones, and every change is pinned by bisection. Straight parts lying on a
wall all along are dropped (:func:`off_walls`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from tether._util.threads import map_batches
from tether.arcs import free as arcs_free
from tether.arcs import rod_is_free_many, rod_is_free_rows, rod_rows
from tether.arcs.free import query_edges
from tether.curves.families import Family, take
from tether.environment import Environment

__all__ = ["ON_WALL_TOLS", "ROD_PAD", "ROD_SPLITS", "SAMPLE_BLOCK", "critical_intervals",
           "insert_after", "off_walls", "rods_free", "wall_band"]


#: Uniform semi-free test samples per curve (the domain's ends and middle) besides the samples
#: at the exact breakpoints; the breakpoints are where freeness can change, so these only
#: catch a curve without breakpoints. (Before, 96 uniform samples per rod length of curve were
#: taken, ~740,000 at 400 map vertices; :func:`critical_intervals` still takes them with
#: ``per_lss``, which the tests use as an independent check.)
_BASE_SAMPLES = 2
#: Where between two consecutive samples the extra one goes (not the middle: on maps with
#: symmetric features the middle of two breakpoints is often a degenerate parameter, e.g. a rod
#: lying along a wall, semi-free at that one parameter only).
_SPLIT = 0.3819660112501051
_BISECTIONS = 30


#: Semi-free test samples per block of curves in :func:`critical_intervals` (about: the
#: blocks are sized from the samples per curve of the block before). Every array of the
#: computation (breakpoint pairs, samples, transitions and their candidate edge rows) grows
#: with the samples, so this bounds its memory: at 2,000 map vertices the conchoids' 2.9
#: million samples at once peaked ~500 MB above what was held, ~4 times that at 4,000. The
#: curves are independent (every step is row by row): the same intervals in any blocks.
SAMPLE_BLOCK = 400_000
#: Curves in the first block (the later ones are sized by :data:`SAMPLE_BLOCK`)
_FIRST_BLOCK = 1024


def critical_intervals(env: Environment, fam: Family, per_lss: float = 0.0
                        ) -> list[list[tuple[float, float]]]:
    """Parameter intervals of each curve where its event rod is semi-free.

    Freeness is constant between consecutive exact breakpoints (:func:`_breakpoints`): each
    curve is tested just either side of every breakpoint, inside every longer stretch between
    two consecutive samples, and at its domain's ends (``_BASE_SAMPLES``; at least
    24 and ``per_lss`` per rod length of curve when ``per_lss`` > 0: the former dense
    sampling, kept as an independent check). The curves are taken in blocks of about
    :data:`SAMPLE_BLOCK` samples (bounded memory; the same intervals)."""
    m = len(fam)
    out: list[list[tuple[float, float]]] = []
    a, size = 0, min(m, _FIRST_BLOCK)
    while a < m:
        b = min(a + size, m)
        ivs, samples = _block_intervals(env, fam.rows(np.arange(a, b)), per_lss)
        out += ivs
        # the next block sized from this one's samples per curve, growing at most 4 times
        per_curve = max(samples, 1) / (b - a)
        size = int(min(max(SAMPLE_BLOCK / per_curve, 1), 4 * (b - a)))
        a = b
    return out


def _block_intervals(env: Environment, fam: Family, per_lss: float
                     ) -> tuple[list[list[tuple[float, float]]], int]:
    """:func:`critical_intervals` of every curve of ``fam`` at once, and the number of
    samples tested."""
    m = len(fam)
    out: list[list[tuple[float, float]]] = [[] for _ in range(m)]
    L = fam.lss
    cidx = np.arange(m)
    if per_lss > 0:
        counts = np.maximum(24, np.ceil(fam.length_scale(cidx) / L * per_lss)).astype(int)
    else:
        counts = np.full(m, _BASE_SAMPLES)
    c = np.repeat(cidx, counts)
    k = np.arange(len(c)) - np.repeat(np.cumsum(counts) - counts, counts)
    frac = k / np.repeat(counts - 1, counts)
    t = fam.lo[c] + frac * (fam.hi[c] - fam.lo[c])
    # samples just either side of every exact breakpoint: freeness is constant between them,
    # so no free stretch, however short, falls between two samples
    bc, bt = _breakpoints(env, fam)
    span = (fam.hi - fam.lo)[bc]
    extra_c = np.repeat(bc, 4)
    extra_t = (bt[:, None] + span[:, None] * np.array([-1e-5, -1e-8, 1e-8, 1e-5])).ravel()
    inside = (extra_t > fam.lo[extra_c]) & (extra_t < fam.hi[extra_c])
    c = np.concatenate((c, extra_c[inside]))
    t = np.concatenate((t, extra_t[inside]))
    order = np.lexsort((t, c))
    c, t = c[order], t[order]
    # and one inside every stretch between two consecutive samples of a curve (not between
    # the close samples around one breakpoint: their transition is pinned as is)
    gap = 1e-4 * (fam.hi - fam.lo)[c[:-1]]
    mid = np.flatnonzero((c[1:] == c[:-1]) & (t[1:] - t[:-1] > gap))
    c, t = insert_after(c, t, mid, t[mid] + _SPLIT * (t[mid + 1] - t[mid]))
    counts = np.bincount(c, minlength=m)
    first = np.cumsum(counts) - counts
    if fam.kind in "CDE":  # open ends at the vertex / domain ends: sample just inside
        eps = 1e-9 * (fam.hi[c] - fam.lo[c])
        t = np.clip(t, fam.lo[c] + eps, fam.hi[c] - eps)
    free = _semi_free(env, fam, c, t)
    # transitions between consecutive samples of the same curve: pin them by bisection
    same = c[1:] == c[:-1]
    trans = np.flatnonzero(same & (free[1:] != free[:-1]))
    fa = free[trans]
    edge_t = _bisect(env, fam.rows(c[trans]), t[trans], t[trans + 1], fa)
    # runs of free samples: a run starts at a curve's first sample or after a transition and
    # ends at a curve's last sample or before one; transitions give the exact ends
    bound = np.full(len(c), np.nan)
    bound[trans] = edge_t
    is_first = np.zeros(len(c), bool)
    is_first[first[counts > 0]] = True
    is_last = np.r_[is_first[1:], True]
    starts = np.flatnonzero(free & (is_first | ~np.r_[True, free[:-1]]))
    ends = np.flatnonzero(free & (is_last | ~np.r_[free[1:], True]))
    lo_t = np.where(is_first[starts], fam.lo[c[starts]], bound[np.maximum(starts - 1, 0)])
    hi_t = np.where(is_last[ends], fam.hi[c[ends]], bound[ends])
    for cr, a, b in zip(c[starts].tolist(), lo_t.tolist(), hi_t.tolist(), strict=True):
        out[cr].append((a, b))
    if fam.kind == "B":  # the circle is closed: join a run through angle 0
        for ivs in out:
            if len(ivs) > 1 and ivs[0][0] == fam.lo[0] and ivs[-1][1] == fam.hi[0]:
                ivs[0] = (ivs[-1][0] - 2 * math.pi, ivs[0][1])
                ivs.pop()
    return out, len(c)


def _bisect(env: Environment, sub: Family, ta: np.ndarray, tb: np.ndarray, fa: np.ndarray
            ) -> np.ndarray:
    """The last free parameter of each transition ``k`` of curve ``k`` of ``sub`` between
    ``ta[k]`` (free iff ``fa[k]``) and ``tb[k]``, by ``_BISECTIONS`` halvings. Every round
    tests rods within the interval: their candidate edges are found once, for every rod of
    the interval (:func:`tether.arcs.rod_rows`; the rods moving too far keep the plain test),
    and the targets that stay inside the free space: the same booleans as
    :func:`rod_is_free_many` every round."""
    L = sub.lss
    dp, du = sub.motion_bound(ta, tb)
    q = sub.points(None, ta)
    pidx, eidx, ok, inside = rod_rows(env, q, sub.rod_angles(None, ta), L, dp, du)
    far = np.flatnonzero(~ok)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (ta + tb)
        pts, ang = sub.points(None, mid), sub.rod_angles(None, mid)
        fm = rod_is_free_rows(env, pts, ang, L, pidx, eidx, inside)
        if len(far):
            fm[far] = rod_is_free_many(env, pts[far], ang[far], L)
        move_a = fm == fa
        ta = np.where(move_a, mid, ta)
        tb = np.where(move_a, tb, mid)
    return np.where(fa, ta, tb)


def _semi_free(env: Environment, fam: Family, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Whether the event rod of curve ``c[k]`` at ``t[k]`` is semi-free, for samples sorted by
    (curve, parameter); equal samples (a breakpoint found twice: a line through a vertex
    crosses both of its edges) are tested once (the test is row by row: the same answers)."""
    is_new = np.r_[True, (c[1:] != c[:-1]) | (t[1:] != t[:-1])]
    cn, tn = c[is_new], t[is_new]
    free = rods_free(env, fam.points(cn, tn), fam.rod_angles(cn, tn), fam.lss)
    return free[np.cumsum(is_new) - 1]


#: The rod test of :func:`rods_free` finds each rod's candidate edges about this many points
#: along it (the middles of its equal sub-segments), not about its midpoint only: the rows
#: per rod fall about as ``1 / ROD_SPLITS`` (an edge index of reach ``lss / 2`` holds, per
#: rod, every edge in a disc of about the rod's length; the sub-segments' discs cover a band
#: about the rod). At 2,000 floor-plan vertices the disc held 17.6 edges per rod, growing
#: with the map (the rod length grows with a plan's width): most of the curves' time.
ROD_SPLITS = 4
#: Slack added to the sub-segments' reach, in rod lengths, beyond the length tolerance twice:
#: far above the rounding of the test's crossing and vertex positions (edges within about
#: the length tolerance of the rod block it; ``ANGLE_TOL`` bounds how far a computed
#: crossing can move along the rod, ~1e-7 map diameters).
ROD_PAD = 1.0 / 256


def rods_free(env: Environment, points: np.ndarray, angles: np.ndarray, lss: float
              ) -> np.ndarray:
    """:func:`tether.arcs.rod_is_free_many` on the internal map: the same booleans, with
    each rod's candidate edges those within reach of :data:`ROD_SPLITS` points along it.

    The rod test's rows are row by row: a rod is blocked iff a row of it is (a crossing of
    an edge's interior, or a vertex on the rod leaving its cone), and every such edge lies
    within about the length tolerance of the rod. Every point of the rod, and of the rod
    lengthened by the tolerance at both ends, is within ``lss / (2 ROD_SPLITS)`` plus the
    tolerance of one of the points queried, so rows within that reach plus twice the
    tolerance and ``ROD_PAD lss`` hold every row that can block (some edges twice: the same
    booleans). Batches of ``tether.arcs.free.POINT_BATCH`` rods, in threads (bounded memory).

    Parameters
    ----------
    env : Environment
        The internal map (:attr:`Environment.internal`).
    points : ndarray, shape (m, 2)
        Target points, map units.
    angles : ndarray, shape (m,)
        Rod orientations, radians.
    lss : float
        Rod length, map units.

    Returns
    -------
    ndarray of bool, shape (m,)
    """
    batch = arcs_free.POINT_BATCH
    if len(points) > batch:
        return np.concatenate(map_batches(
            lambda lo, hi: rods_free(env, points[lo:hi], angles[lo:hi], lss), len(points),
            batch))
    step = lss / ROD_SPLITS
    index = env.edge_index(0.5 * step + 2 * env.length_tol + ROD_PAD * lss)
    ux, uy = np.cos(angles), np.sin(angles)
    pidx, eidx = [], []
    for j in range(ROD_SPLITS):
        at = (j + 0.5) * step
        p, e, _ = query_edges(index, np.column_stack((points[:, 0] + at * ux,
                                                      points[:, 1] + at * uy)))
        pidx.append(p)
        eidx.append(e)
    return rod_is_free_rows(env, points, angles, lss, np.concatenate(pidx),
                            np.concatenate(eidx))


def insert_after(c: np.ndarray, t: np.ndarray, at: np.ndarray, t_new: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Samples ``(c, t)`` sorted by (curve, parameter) with a sample ``(c[at[k]], t_new[k])``
    inserted after each sample ``at[k]`` (increasing, distinct; ``t[at[k]] <= t_new[k] <=
    t[at[k] + 1]``, same curve): the arrays a stable sort of all of them gives, without the
    sort."""
    n = len(c) + len(at)
    pos = np.arange(len(c)) + np.searchsorted(at, np.arange(len(c)))  # earlier insertions
    new = at + 1 + np.arange(len(at))
    c2, t2 = np.empty(n, c.dtype), np.empty(n, t.dtype)
    c2[pos], t2[pos] = c, t
    c2[new], t2[new] = c[at], t_new
    return c2, t2


def _breakpoints(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """Parameters where a curve's event rod can start or stop being semi-free.

    A, B, E: where the event rod passes through a vertex (the rod sweeps across it); C, D
    (rods on a fixed line): where the rod's target end or tip crosses an edge. Returns
    (curve index, parameter) arrays (E: the edge crossings, then the vertices; the samples
    placed at them are sorted, so only the set of breakpoints matters).
    """
    V = env.vertices
    L = fam.lss
    m = len(fam)
    if m == 0:
        return np.zeros(0, int), np.zeros(0)
    cs, ts = [], []
    pair_c, pair_v = _breakpoint_pairs(env, fam)
    for lo in range(0, len(pair_c), 200_000):  # bounded memory
        cc, vk = pair_c[lo:lo + 200_000], pair_v[lo:lo + 200_000]
        if fam.kind == "A":  # rod = foot + λ n, foot = A + s d
            a0 = take(fam.p, cc) - L * take(fam.w, cc)
            rel = take(V, vk) - a0
            lam = np.einsum("ij,ij->i", rel, take(fam.w, cc))
            d = take(fam.d, cc)
            t = np.einsum("ij,ij->i", rel, d) / np.einsum("ij,ij->i", d, d)
            ok = (lam > 0) & (lam <= L)
            # and where the target end q(s) = p + s d crosses an edge
            e = take(V, env.next_vertex[vk]) - take(V, vk)
            rel_q = take(V, vk) - take(fam.p, cc)
            den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                sq = (rel_q[:, 0] * e[:, 1] - rel_q[:, 1] * e[:, 0]) / den
                uq = (rel_q[:, 0] * d[:, 1] - rel_q[:, 1] * d[:, 0]) / den
            hit = (np.abs(den) > 1e-300) & (uq >= 0) & (uq <= 1)
            cs.append(cc[hit])
            ts.append(sq[hit])
        elif fam.kind == "B":  # rod from V_j + L u(φ) to V_j
            rel = take(V, vk) - take(fam.p, cc)
            r = np.hypot(rel[:, 0], rel[:, 1])
            t = np.mod(np.arctan2(rel[:, 1], rel[:, 0]), 2 * math.pi)
            ok = (r > 0) & (r <= L)
            # and where the target end crosses an edge: |V_k + u e - V_j| = L
            e = take(V, env.next_vertex[vk]) - take(V, vk)
            ee = np.einsum("ij,ij->i", e, e)
            b = np.einsum("ij,ij->i", e, rel)
            disc = b * b - ee * (np.einsum("ij,ij->i", rel, rel) - L * L)
            root = np.sqrt(np.maximum(disc, 0.0))
            for sign in (-1.0, 1.0):
                u = (-b + sign * root) / ee
                hit = (disc > 0) & (u >= 0) & (u <= 1)
                x = rel[hit] + u[hit, None] * e[hit]
                cs.append(cc[hit])
                ts.append(np.mod(np.arctan2(x[:, 1], x[:, 0]), 2 * math.pi))
        elif fam.kind == "E":  # where the target end crosses the line of edge vk
            ec, et = _conchoid_edge_crossings(env, fam, cc, vk)
            cs.append(ec)
            ts.append(et)
            continue
        else:  # C, D: the line o + τ w crosses edge (V_k, next) at τ; breakpoints τ and τ + L
            nk = env.next_vertex[vk]
            e = take(V, nk) - take(V, vk)
            w = take(fam.d, cc)
            rel = take(V, vk) - take(fam.p, cc)
            den = w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                tau = (rel[:, 0] * e[:, 1] - rel[:, 1] * e[:, 0]) / den
                u = (rel[:, 0] * w[:, 1] - rel[:, 1] * w[:, 0]) / den
            ok = (np.abs(den) > 1e-300) & (u >= 0) & (u <= 1)
            cs += [cc[ok], cc[ok]]
            ts += [tau[ok], tau[ok] + L]
            continue
        cs.append(cc[ok])
        ts.append(t[ok])
    if fam.kind == "E":  # and where the event rod passes through a vertex
        pair_c, pair_v = _conchoid_vertex_pairs(env, fam)
        for lo in range(0, len(pair_c), 200_000):  # bounded memory
            cc, vk = pair_c[lo:lo + 200_000], pair_v[lo:lo + 200_000]
            # the line through V_k and the pole meets the base edge at Q(t)
            rel = take(V, vk) - take(fam.p, cc)
            a_rel = take(fam.w, cc) - take(fam.p, cc)
            d = take(fam.d, cc)
            den = rel[:, 0] * d[:, 1] - rel[:, 1] * d[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (a_rel[:, 0] * rel[:, 1] - a_rel[:, 1] * rel[:, 0]) / den
            ok = (np.abs(den) > 1e-300) & (np.hypot(rel[:, 0], rel[:, 1]) <= 2 * L)
            cs.append(cc[ok])
            ts.append(t[ok])
    c, t = np.concatenate(cs), np.concatenate(ts)
    # only breakpoints within 1e-5 of its span of a curve's domain place samples in it (most
    # conchoid ones fall outside: a tenth are kept at 1,000 map vertices); 2e-5 to spare
    span = (fam.hi - fam.lo)[c]
    near = (t > fam.lo[c] - 2e-5 * span) & (t < fam.hi[c] + 2e-5 * span)
    return c[near], t[near]


def _breakpoint_pairs(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """The (curve, vertex) pairs :func:`_breakpoints` must test: vertex ``k`` and its edge
    ``(V_k, V_next)`` near the curve. Every breakpoint within ``1e-4`` of its domain's span of
    the domain (the only ones whose samples fall inside it) comes from a pair whose edge's
    bounding box meets the curve's box: A, the target segment padded by ``lss`` (a vertex on
    the rod is within ``lss`` of the target); B, the vertex's box padded by ``lss``; C, D, the
    line's stretch ``[lo - lss, hi]`` (breakpoints ``τ`` and ``τ + lss``); E, the pole's box
    padded by ``lss`` (the edge crossings, of edges within ``lss`` of the pole; the vertices
    are :func:`_conchoid_vertex_pairs`'). The test was of every curve against every vertex
    (quadratic)."""
    V = env.vertices
    L = fam.lss
    m = len(fam)
    span = fam.hi - fam.lo
    tiny = 1e-9 * env.diameter
    if fam.kind in "ACD":
        lo_t = fam.lo - 1e-4 * span - (L if fam.kind in "CD" else 0.0)
        hi_t = fam.hi + 1e-4 * span
        a = fam.p + lo_t[:, None] * fam.d
        b = fam.p + hi_t[:, None] * fam.d
        pad = (L if fam.kind == "A" else 0.0) + tiny
        x0, y0 = np.minimum(a, b).T - pad
        x1, y1 = np.maximum(a, b).T + pad
    else:  # B: vertex circle of radius lss; E: edges within lss of the pole
        pad = L + tiny
        x0, y0 = fam.p.T - pad
        x1, y1 = fam.p.T + pad
    tree = env.memo.get("edge_box_tree")
    if tree is None:
        seg = np.stack((V, V[env.next_vertex]), axis=1)
        tree = env.memo["edge_box_tree"] = shapely.STRtree(shapely.linestrings(seg))
    if m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ci, vi = tree.query(shapely.box(x0, y0, x1, y1))
    order = np.lexsort((vi, ci))
    return ci[order].astype(np.int64), vi[order].astype(np.int64)


def _conchoid_vertex_pairs(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """The (conchoid, vertex) pairs :func:`_breakpoints` must test for an event rod through a
    vertex, in (curve, vertex) order: a breakpoint ``t`` is where the line through the pole
    and ``Q(t)`` passes through a vertex within ``2 lss`` of the pole, so a vertex of a
    breakpoint in the domain (padded by ``1e-3`` of its span, 50 times the margin the samples
    need) lies in the double sector of radius ``2 lss`` about the pole spanned by the
    directions to ``Q(t)`` (under 4 % of the pole's box at 1,000 map vertices, against about
    a quarter for these sectors' boxes, which are queried)."""
    V = env.vertices
    m = len(fam)
    if m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    x0, y0, x1, y1 = _sector_boxes(fam, 1e-3)
    tiny = 1e-9 * env.diameter
    px, py = fam.p[:, 0], fam.p[:, 1]
    tree = env.memo.get("vertex_tree")
    if tree is None:
        tree = env.memo["vertex_tree"] = shapely.STRtree(shapely.points(V))
    # the sector toward the base edge and the opposite one (the event rod's far side)
    ca, va = tree.query(shapely.box(px + x0 - tiny, py + y0 - tiny, px + x1 + tiny,
                                    py + y1 + tiny))
    cb, vb = tree.query(shapely.box(px - x1 - tiny, py - y1 - tiny, px - x0 + tiny,
                                    py - y0 + tiny))
    key = np.concatenate((ca, cb)).astype(np.int64) * len(V) + np.concatenate((va, vb))
    key.sort()
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # in both: once
    return np.divmod(key, len(V))


def _sector_boxes(fam: Family, pad: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bounding boxes (x0, y0, x1, y1, relative to the pole) of each conchoid's sector of
    radius ``2 lss`` spanned by the directions from the pole to ``Q(t)``, ``t`` over the
    domain padded by ``pad`` of its span: the pole, the two end directions and the axis
    directions between them. A sector of 90 degrees or more (the base line close to the
    pole) gets the whole box ``[-2 lss, 2 lss]^2``."""
    R = 2 * fam.lss
    span = fam.hi - fam.lo
    q1 = fam.w + (fam.lo - pad * span)[:, None] * fam.d - fam.p
    q2 = fam.w + (fam.hi + pad * span)[:, None] * fam.d - fam.p
    with np.errstate(divide="ignore", invalid="ignore"):
        u1 = q1 / np.hypot(q1[:, 0], q1[:, 1])[:, None]
        u2 = q2 / np.hypot(q2[:, 0], q2[:, 1])[:, None]
    turn = np.sign(u1[:, 0] * u2[:, 1] - u1[:, 1] * u2[:, 0])
    zero = np.zeros(len(fam))
    xs, ys = [zero, R * u1[:, 0], R * u2[:, 0]], [zero, R * u1[:, 1], R * u2[:, 1]]
    for ex, ey in ((1, 0), (0, 1), (-1, 0), (0, -1)):
        # the axis direction lies between u1 and u2 (rounding: a slack, and a sector of no
        # turn at all takes every axis)
        between = ((turn * (u1[:, 0] * ey - u1[:, 1] * ex) >= -1e-9)
                   & (turn * (ex * u2[:, 1] - ey * u2[:, 0]) >= -1e-9))
        xs.append(np.where(between, R * ex, 0.0))
        ys.append(np.where(between, R * ey, 0.0))
    x0, y0 = np.minimum.reduce(xs), np.minimum.reduce(ys)
    x1, y1 = np.maximum.reduce(xs), np.maximum.reduce(ys)
    wide = ~(np.einsum("ij,ij->i", u1, u2) > 0)  # also nan directions
    x0[wide], y0[wide], x1[wide], y1[wide] = -R, -R, R, R
    return x0, y0, x1, y1


def _conchoid_edge_crossings(env: Environment, fam: Family, cc: np.ndarray, vk: np.ndarray,
                             grid: int = 33) -> tuple[np.ndarray, np.ndarray]:
    """Parameters where a conchoid's target end q(s) crosses the line of edge ``vk`` (only
    edges within lss of the pole: the conchoid stays within lss of it). Sign changes of the
    side function on a grid, refined by bisection."""
    V = env.vertices
    c, a, e = cc, take(V, vk), take(V, env.next_vertex[vk]) - take(V, vk)
    frac = np.linspace(0.0, 1.0, grid)
    # a pair whose edge line leaves the whole grid of its conchoid strictly on one side (by a
    # margin above rounding) shows no sign change on it: dropped before the grid (most pairs;
    # before the distance test, which then measures a tenth of them)
    x0, y0, x1, y1 = _conchoid_grid_boxes(fam, frac)
    side = [e[:, 0] * (y - a[:, 1]) - e[:, 1] * (x - a[:, 0])
            for x, y in ((x0[c], y0[c]), (x0[c], y1[c]), (x1[c], y0[c]), (x1[c], y1[c]))]
    margin = 1e-9 * np.hypot(e[:, 0], e[:, 1]) * (np.abs(a).max(axis=1) + fam.lss)
    low, high = np.minimum.reduce(side), np.maximum.reduce(side)
    keep = ~((low > margin) | (high < -margin))
    c, a, e = c[keep], a[keep], e[keep]
    rel = take(fam.p, c) - a
    u = np.clip(np.einsum("ij,ij->i", rel, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    near = np.hypot(*(rel - u[:, None] * e).T) <= fam.lss
    c, a, e = c[near], a[near], e[near]
    if len(c) == 0:
        return np.zeros(0, int), np.zeros(0)
    lo, hi = fam.lo[c], fam.hi[c]

    t = lo[:, None] + frac[None, :] * (hi - lo)[:, None]
    # the side function on the grid, each pair's rows broadcast (Family.points' arithmetic)
    w, d, p = take(fam.w, c), take(fam.d, c), take(fam.p, c)
    qx = w[:, :1] + t * d[:, :1]
    qy = w[:, 1:] + t * d[:, 1:]
    rx, ry = p[:, :1] - qx, p[:, 1:] - qy
    norm = np.sqrt(rx * rx + ry * ry)
    qx, qy = qx + fam.lss * rx / norm, qy + fam.lss * ry / norm
    f = e[:, :1] * (qy - a[:, 1:]) - e[:, 1:] * (qx - a[:, :1])
    r, k = np.nonzero(np.sign(f[:, :-1]) * np.sign(f[:, 1:]) < 0)
    ta = lo[r] + frac[k] * (hi - lo)[r]
    tb = lo[r] + frac[k + 1] * (hi - lo)[r]
    fa = np.sign(f[r, k])
    sub, ar, er = fam.rows(c[r]), a[r], e[r]  # the same rows every round: gathered once
    for _ in range(_BISECTIONS):
        mid = 0.5 * (ta + tb)
        q = sub.points(None, mid)
        same = np.sign(er[:, 0] * (q[:, 1] - ar[:, 1]) - er[:, 1] * (q[:, 0] - ar[:, 0])) == fa
        ta = np.where(same, mid, ta)
        tb = np.where(same, tb, mid)
    return c[r], 0.5 * (ta + tb)


def _conchoid_grid_boxes(fam: Family, frac: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each conchoid's target-end points at the grid ``lo + frac (hi - lo)`` (the arithmetic
    of :func:`_conchoid_edge_crossings`), reduced to their bounding box (x0, y0, x1, y1)."""
    lo, hi = fam.lo, fam.hi
    t = lo[:, None] + frac[None, :] * (hi - lo)[:, None]
    w, d, p = fam.w, fam.d, fam.p
    qx = w[:, :1] + t * d[:, :1]
    qy = w[:, 1:] + t * d[:, 1:]
    rx, ry = p[:, :1] - qx, p[:, 1:] - qy
    norm = np.sqrt(rx * rx + ry * ry)
    qx, qy = qx + fam.lss * rx / norm, qy + fam.lss * ry / norm
    return qx.min(axis=1), qy.min(axis=1), qx.max(axis=1), qy.max(axis=1)


#: A straight curve's critical part within this many point tolerances of the walls all
#: along lies on a wall (see :func:`off_walls`).
ON_WALL_TOLS = 4.0


def wall_band(env: Environment) -> Any:
    """The walls grown by ``ON_WALL_TOLS`` point tolerances (a prepared polygon)."""
    band = shapely.buffer(shapely.boundary(env.polygon), ON_WALL_TOLS * env.length_tol)
    shapely.prepare(band)
    return band


def off_walls(fam: Family, intervals: list[list[tuple[float, float]]], band: Any
               ) -> list[list[tuple[float, float]]]:
    """The critical intervals of straight curves without those lying on a wall all along.

    An offset exactly ``lss`` from a wall facing its edge, or an extension along a collinear
    wall, runs on the wall itself: it bounds no region (the free space is on one side only),
    but whether the exact rod test calls it critical is decided by rounding (its event rod
    touches a wall all along), so the map moved or scaled showed one curve more or less.
    Such intervals are dropped; any stretch of the curve off the walls is kept whole."""
    rows = [(c, k) for c, ivs in enumerate(intervals) for k in range(len(ivs))]
    if not rows:
        return intervals
    c = np.array([r[0] for r in rows], dtype=np.int64)
    lo, hi = np.array([intervals[a][k] for a, k in rows], dtype=float).T
    ends = np.stack((fam.points(c, lo), fam.points(c, hi)), axis=1)
    # both ends in the band first (points: cheap), then the whole segment
    on = (shapely.contains_xy(band, ends[:, 0, 0], ends[:, 0, 1])
          & shapely.contains_xy(band, ends[:, 1, 0], ends[:, 1, 1]))
    k = np.flatnonzero(on)
    on[k] = np.asarray(shapely.within(shapely.linestrings(ends[k]), band), dtype=bool)
    if not on.any():
        return intervals
    out = [list(ivs) for ivs in intervals]
    for a, k in sorted((rows[i] for i in np.flatnonzero(on).tolist()), reverse=True):
        del out[a][k]
    return out
