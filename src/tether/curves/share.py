"""Straight critical curves (A, C, D) that lie on one line made to share their vertices, so
that the noder sees their overlapping stretches as identical segments."""

from __future__ import annotations

import numpy as np

from tether._util.arrays import first_per_group
from tether.curves.families import Curve
from tether.tolerances import ANGLE_TOL

__all__ = ["share_lines"]


def share_lines(curves: list[Curve], tol: float) -> list[Curve]:
    """Make straight curves (A, C, D) on one supporting line share their vertices.

    Offsets of parallel edges at the same distance, an edge's extension and a line through two
    reflex vertices on it, ...: such curves coincide, but computed separately they differ in
    the last bits, and how the noder splits two almost coincident segments depends on the map's
    position and rotation. Here every polyline of a line gets all the vertices of the line's
    other curves that lie within its span (the very same coordinates), so that the overlapping
    stretches are identical segments, which the noder merges exactly. ``tol`` (map units) is how
    far apart two lines may be and still be one line, and two vertices along it one vertex.
    """
    straight = [k for k, c in enumerate(curves) if c.kind in "ACD"]
    if len(straight) < 2:
        return curves
    fam_d = np.array([curves[k].family.d[curves[k].index] for k in straight])
    fam_p = np.array([curves[k].family.p[curves[k].index] for k in straight])
    u = fam_d / np.linalg.norm(fam_d, axis=1)[:, None]
    flip = (u[:, 0] < 0) | ((u[:, 0] == 0) & (u[:, 1] < 0))
    u[flip] *= -1
    theta = np.arctan2(u[:, 1], u[:, 0])  # in (-pi/2, pi/2]
    offset = u[:, 0] * fam_p[:, 1] - u[:, 1] * fam_p[:, 0]  # signed distance of the line to 0
    groups = [g for g in _line_groups(theta, offset, tol) if len(g) >= 2]
    if not groups:
        return curves
    members = [straight[g] for group in groups for g in group]  # curve numbers, by group
    polys = [p for k in members for p in curves[k].polylines]
    npoly = np.array([len(curves[k].polylines) for k in members], dtype=np.int64)
    gsize = np.array([len(g) for g in groups], dtype=np.int64)
    poly_group = np.repeat(np.repeat(np.arange(len(groups)), gsize), npoly)
    size = np.array([len(p) for p in polys], dtype=np.int64)
    pstart = np.cumsum(size) - size
    pts = np.vstack(polys)
    # every vertex's position along its group's line: the products of the former loops, one
    # per group (its vertices) and one per polyline (its ends), so the very same bits
    # whatever the BLAS kernel (a row's bits could depend on the matrix's size)
    along = np.empty(len(pts))
    a_poly = np.empty(len(pts))
    gstop = np.cumsum(np.bincount(poly_group, weights=size, minlength=len(groups))
                      ).astype(np.int64).tolist()
    pstop = (pstart + size).tolist()
    j = 0
    for group, r0, r1 in zip(groups, [0] + gstop[:-1], gstop, strict=True):
        base, uu = fam_p[group[0]], u[group[0]]
        along[r0:r1] = (pts[r0:r1] - base) @ uu
        while j < len(polys) and pstop[j] <= r1:
            a_poly[pstop[j] - len(polys[j]):pstop[j]] = (polys[j] - base) @ uu
            j += 1
    row_poly = np.repeat(np.arange(len(polys)), size)
    row_group = poly_group[row_poly]
    # each group's vertices by position along the line (stable), one per tol
    order = np.lexsort((along, row_group))
    s_along, s_group = along[order], row_group[order]
    distinct = np.r_[True, (np.diff(s_along) > tol) | (s_group[1:] != s_group[:-1])]
    order = order[distinct]
    d_along, d_group = along[order], row_group[order]
    # each polyline's extreme vertices (the first of equals) and the group's vertices
    # strictly inside (lo + tol, hi - tol)
    lo = np.minimum.reduceat(a_poly, pstart)
    hi = np.maximum.reduceat(a_poly, pstart)
    first_lo = first_per_group(np.flatnonzero(a_poly == lo[row_poly]), row_poly)
    first_hi = first_per_group(np.flatnonzero(a_poly == hi[row_poly]), row_poly)
    i0 = _grouped_searchsorted(d_group, d_along, poly_group, lo + tol, "right")
    i1 = np.maximum(i0, _grouped_searchsorted(d_group, d_along, poly_group, hi - tol, "left"))
    count = i1 - i0 + 2
    cstart = np.cumsum(count) - count
    k = np.arange(int(count.sum())) - np.repeat(cstart, count)
    backward = a_poly[pstart] > a_poly[pstart + size - 1]
    k = np.where(np.repeat(backward, count), np.repeat(count - 1, count) - k, k)
    src = np.where(k == 0, np.repeat(first_lo, count),
                   np.where(k == np.repeat(count - 1, count), np.repeat(first_hi, count),
                            order[np.minimum(np.repeat(i0 - 1, count) + k, len(order) - 1)]))
    merged = pts[src]
    stops = np.cumsum(count).tolist()
    out = list(curves)
    j = 0  # polyline number
    for kk, n in zip(members, npoly.tolist(), strict=True):
        c = curves[kk]
        fam, i = c.family, c.index
        dd, p = fam.d[i], fam.p[i]
        den = dd @ dd
        cuts = [stops[j - 1] if j else 0] + stops[j:j + n]
        lines = [merged[x:y] for x, y in zip(cuts[:-1], cuts[1:], strict=True)]
        out[kk] = Curve(c.id, c.kind, c.features, c.domain, c.intervals, tuple(lines),
                        tuple((line - p) @ dd / den for line in lines), fam, i, c.frame)
        j += n
    return out


def _grouped_searchsorted(dg: np.ndarray, dv: np.ndarray, qg: np.ndarray, qv: np.ndarray,
                          side: str) -> np.ndarray:
    """``np.searchsorted`` of each ``qv[k]`` among the values of group ``qg[k]``, for values
    ``dv`` sorted by (group ``dg``, value), as an index into ``dv``: the number of values of
    earlier groups and of the group's values below (``left``) or not above (``right``) it.
    One merged sort, exact comparisons."""
    nd = len(dv)
    data_first = side == "right"  # ties: a value equal to the query counts as below it
    tie = np.r_[np.full(nd, not data_first), np.full(len(qv), data_first)]
    order = np.lexsort((tie, np.r_[dv, qv], np.r_[dg, qg]))
    is_data = order < nd
    before = np.cumsum(is_data) - is_data
    out = np.empty(len(qv), np.int64)
    out[order[~is_data] - nd] = before[~is_data]
    return out


def _line_groups(theta: np.ndarray, offset: np.ndarray, tol: float) -> list[list[int]]:
    """Groups of lines (direction angle in (-pi/2, pi/2], signed offset, map units) that are
    one line: angles within ``ANGLE_TOL``-ish of each other and offsets within ``tol``."""
    # directions near +-pi/2 are the same direction: fold them together
    th = np.where(theta > np.pi / 2 - 1e-9, theta - np.pi, theta)
    off = np.where(theta > np.pi / 2 - 1e-9, -offset, offset)
    order = np.argsort(th, kind="stable")
    run = np.r_[0, np.cumsum(np.diff(th[order]) > ANGLE_TOL)]  # runs of close angles
    by_off = np.lexsort((off[order], run))  # each run by offset (stable)
    idx, run = order[by_off], run[by_off]
    cut = np.flatnonzero((np.diff(off[idx]) > tol) | (run[1:] != run[:-1])) + 1
    flat = idx.tolist()
    bounds = [0] + cut.tolist() + [len(flat)]
    return [flat[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
