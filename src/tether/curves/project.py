"""Projection of points onto the critical parts of curves, many at once: exact on lines and
circles, Gauss-Newton from the nearest polyline segment on conchoids."""

from __future__ import annotations

import numpy as np

from tether._util.arrays import first_nearest, ragged_arange
from tether.curves.families import Curve, Family, take

__all__ = ["project_many"]


def project_many(curves: list[Curve], cid: np.ndarray, q: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorized :meth:`Curve.project`: for each row ``k`` the nearest point of the critical
    part of ``curves[cid[k]]`` to ``q[k]`` (shape (m, 2), map units). Returns parameters (m,),
    points (m, 2) and unit normals (m, 2), exact up to the Gauss-Newton convergence of the
    conchoids (12 steps from the nearest polyline segment, as :meth:`Curve.project`)."""
    cid = np.asarray(cid, dtype=int)
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    t = np.zeros(len(cid))
    pts = np.zeros((len(cid), 2))
    nrm = np.zeros((len(cid), 2))
    kinds = np.array([c.kind for c in curves])[cid] if len(cid) else np.zeros(0, str)
    index = np.array([c.index for c in curves], dtype=int)
    fams = {c.kind: c.family for c in curves}
    for kind, fam in fams.items():
        rows = np.flatnonzero(kinds == kind)
        if len(rows) == 0:
            continue
        c = index[cid[rows]]
        if kind in "ACD":
            d = take(fam.d, c)
            tt = np.einsum("ij,ij->i", q[rows] - take(fam.p, c), d) / np.einsum("ij,ij->i", d, d)
            t[rows] = tt
            pts[rows] = take(fam.p, c) + tt[:, None] * d
            nrm[rows] = np.column_stack((-d[:, 1], d[:, 0])) / np.hypot(d[:, 0], d[:, 1])[:, None]
        elif kind == "B":
            r = q[rows] - take(fam.p, c)
            tt = np.arctan2(r[:, 1], r[:, 0])
            u = np.column_stack((np.cos(tt), np.sin(tt)))
            t[rows], pts[rows], nrm[rows] = tt, take(fam.p, c) + fam.lss * u, u
        else:
            t[rows], pts[rows], nrm[rows] = _project_conchoids(curves, cid[rows], q[rows])
    return t, pts, nrm


def _project_conchoids(curves: list[Curve], cid: np.ndarray, q: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`project_many` for conchoid rows: the nearest polyline segment of each row's curve
    brackets the answer, then Gauss-Newton on ``(q(t) - q)·q'(t) = 0`` inside the bracket."""
    uc, inv = np.unique(cid, return_inverse=True)
    # every polyline segment of the involved curves, grouped by curve
    seg_a, seg_b, seg_lo, seg_hi, seg_c = [], [], [], [], []
    for k, c in enumerate(uc.tolist()):
        for ts, p in zip(curves[c].params, curves[c].polylines, strict=True):
            seg_a.append(p[:-1])
            seg_b.append(p[1:])
            seg_lo.append(ts[:-1])
            seg_hi.append(ts[1:])
            seg_c.append(np.full(len(p) - 1, k))
    a, b = np.vstack(seg_a), np.vstack(seg_b)
    lo_all, hi_all, sc = map(np.concatenate, (seg_lo, seg_hi, seg_c))
    row, seg = _near_segment_pairs(a, b, sc, len(uc), inv, q)
    ab = b[seg] - a[seg]
    u = np.clip(np.einsum("ij,ij->i", q[row] - a[seg], ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    dist = np.hypot(*(a[seg] + u[:, None] * ab - q[row]).T)
    best = first_nearest(row, dist)  # nearest segment per row
    s = seg[best]
    lo, hi = lo_all[s], hi_all[s]
    t = lo + u[best] * (hi - lo)
    fam = curves[int(cid[0])].family
    c = np.array([curves[k].index for k in cid.tolist()], dtype=int)
    dlo = fam.lo[c]
    dhi = fam.hi[c]
    sub = fam.rows(c)  # the same rows every step: gathered once
    for _ in range(12):
        tangent = _tangents(sub, None, t, dlo, dhi)
        tt = np.einsum("ij,ij->i", tangent, tangent)
        step = np.where(tt > 0, np.einsum("ij,ij->i", sub.points(None, t) - q, tangent)
                        / np.maximum(tt, 1e-300), 0.0)
        t_new = np.clip(t - step, lo, hi)
        done = np.abs(t_new - t) <= 1e-15 * np.maximum(1.0, np.abs(t))
        t = t_new
        if done.all():
            break
    tangent = _tangents(sub, None, t, dlo, dhi)
    tangent = tangent / np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-300)[:, None]
    return t, sub.points(None, t), np.column_stack((-tangent[:, 1], tangent[:, 0]))


#: Consecutive polyline segments per block in the pruned nearest-segment search.
_SEG_BLOCK = 16


def _near_segment_pairs(a: np.ndarray, b: np.ndarray, sc: np.ndarray, ncurves: int,
                        inv: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (row, segment) pairs among which each point ``q[row]`` finds its nearest segment
    of curve ``inv[row]`` (segments ``a[k]-b[k]`` grouped by curve ``sc[k]``), in (row,
    segment) order: every segment of the blocks of ``_SEG_BLOCK`` consecutive segments whose
    bounding box is not farther from the point than some block's first vertex (an upper bound
    of the nearest distance). Every segment at the nearest distance is kept, so the nearest
    one, and the first among equals, are those of the search over all segments."""
    count = np.bincount(sc, minlength=ncurves)
    first = np.cumsum(count) - count
    nblk = -(-count // _SEG_BLOCK)  # blocks per curve
    bfirst = np.cumsum(nblk) - nblk
    bcurve = np.repeat(np.arange(ncurves), nblk)
    bstart = first[bcurve] + _SEG_BLOCK * (np.arange(len(bcurve)) - bfirst[bcurve])
    bstop = np.minimum(bstart + _SEG_BLOCK, (first + count)[bcurve])
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    bx0, by0 = (np.minimum.reduceat(lo[:, j], bstart) for j in (0, 1))
    bx1, by1 = (np.maximum.reduceat(hi[:, j], bstart) for j in (0, 1))
    nb = nblk[inv]
    rowb = np.repeat(np.arange(len(inv)), nb)
    blk = ragged_arange(bfirst[inv], nb)
    qx, qy = q[rowb, 0], q[rowb, 1]
    gap = np.hypot(np.maximum(np.maximum(bx0[blk] - qx, qx - bx1[blk]), 0.0),
                   np.maximum(np.maximum(by0[blk] - qy, qy - by1[blk]), 0.0))
    vertex = a[bstart[blk]]
    ub = np.full(len(inv), np.inf)
    np.minimum.at(ub, rowb, np.hypot(vertex[:, 0] - qx, vertex[:, 1] - qy))
    slack = 1e-9 * ub + 1e-12  # rounding of the bounds against the distances
    keep = np.flatnonzero(gap <= (ub + slack)[rowb])
    rowb, blk = rowb[keep], blk[keep]
    size = bstop[blk] - bstart[blk]
    return np.repeat(rowb, size), ragged_arange(bstart[blk], size)


def _tangents(fam: Family, c: np.ndarray | None, t: np.ndarray, dlo: np.ndarray,
              dhi: np.ndarray) -> np.ndarray:
    """dq/dt of conchoids by finite differences inside the domain (as ``Curve._tangent``;
    ``c`` as in :meth:`Family.points`)."""
    h = 1e-7 * np.maximum(np.maximum(1.0, np.abs(t)), dhi - dlo)
    a, b = np.maximum(t - h, dlo), np.minimum(t + h, dhi)
    return (fam.points(c, b) - fam.points(c, a)) / (b - a)[:, None]
