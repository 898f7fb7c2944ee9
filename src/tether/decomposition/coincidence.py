"""Coincident straight lines of the arrangement's input, made one exactly.

On maps that are not in general position, critical curves coincide: two walls exactly
``2·lss`` apart give one offset line twice, an offset runs along a pillar's wall exactly
``lss`` away, an edge extension runs along another wall. In exact arithmetic these are one line.
In floating point their copies differ by a few units in the last place (more so when the map's
coordinates are not exact in binary, say a lattice of 0.05 m), and the noder then sees two
lines 1e-17 apart: sliver faces, and a shared region boundary no crossing point can be clear
of. Whether that happens depended on the luck of rounding (the same map scaled by 0.1 lost
pieces that it had at scale 1).

:func:`merge_collinear` recognises such copies and makes them exactly equal before noding:
segments whose supporting lines agree within :data:`COLLINEAR_TOL` (normalized units: the map's
diameter is near 1; that is, far below tether's point tolerance of 1e-9 and far above
rounding) are put on one reference line (a wall's, if the group has one: walls never move), and
each gets a vertex at every end of the others that falls inside it, computed once. Overlapping
copies then consist of identical sub-segments, which the noder merges into one part carrying
all their sources. Each vertex moves by at most ``COLLINEAR_TOL``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

__all__ = ["COLLINEAR_TOL", "STUB_PAST_TOLS", "STUB_REACH_TOLS", "merge_collinear",
           "wall_stubs"]

#: Two segments are on one line when their directions agree within this angle (radians) and
#: their distances from the origin within this length (normalized units, diameter near 1).
COLLINEAR_TOL = 1e-11


def merge_collinear(xy: np.ndarray, line: np.ndarray, fixed: np.ndarray,
                    straight: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Make collinear copies exact (see the module's docstring).

    Parameters
    ----------
    xy : ndarray, shape (m, 2)
        The lines' vertices, line after line (normalized units).
    line : ndarray of int, shape (m,)
        The line of each vertex (non-decreasing).
    fixed : ndarray of bool, shape (m,)
        Vertices that must not move (the map's rings).
    straight : ndarray of bool, shape (m,), optional
        Vertices of straight lines (rings, offsets, extensions): only their segments are
        compared (the chords of circles and conchoids are no copies of a line). Default: all.

    Returns
    -------
    xy, line : the vertices with the copies' vertices moved onto their reference lines and
        the inserted vertices, and their lines.
    """
    same = line[1:] == line[:-1]
    if straight is not None:
        same &= straight[1:]
    k = np.flatnonzero(same)  # segment k runs from vertex k to k + 1
    a, b = xy[k], xy[k + 1]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    k, a, b, d, length = k[length > 0], a[length > 0], b[length > 0], d[length > 0], \
        length[length > 0]
    if len(k) < 2:
        return xy, line
    u = d / length[:, None]
    flip = (u[:, 1] < 0) | ((u[:, 1] == 0) & (u[:, 0] < 0))
    u[flip] *= -1
    theta = np.arctan2(u[:, 1], u[:, 0])  # [0, pi]
    wrap = theta > np.pi - COLLINEAR_TOL  # nearly pi: the same direction as nearly 0
    theta[wrap] -= np.pi
    u[wrap] *= -1
    rho = u[:, 0] * a[:, 1] - u[:, 1] * a[:, 0]  # signed distance of the line from 0
    along = u[:, 0] * a[:, 0] + u[:, 1] * a[:, 1], u[:, 0] * b[:, 0] + u[:, 1] * b[:, 1]
    group = _groups(theta, rho, np.minimum(*along), np.maximum(*along))
    moved = xy.copy()
    inserts: list[tuple[int, float, np.ndarray]] = []  # (after vertex, order key, point)
    for members in group:
        _merge_group(members, k, a, b, u, fixed, xy, moved, inserts)
    if not inserts:
        return moved, line
    inserts.sort(key=lambda row: (row[0], row[1]))
    at = np.array([row[0] + 1 for row in inserts])
    pts = np.array([row[2] for row in inserts])
    return np.insert(moved, at, pts, axis=0), np.insert(line, at, line[at - 1])


def _groups(theta: np.ndarray, rho: np.ndarray, lo: np.ndarray, hi: np.ndarray
            ) -> list[np.ndarray]:
    """Groups (index arrays) of segments whose ``theta`` and ``rho`` chain together within
    :data:`COLLINEAR_TOL` (sorted 1-d clustering, twice) and of which two overlap along the
    line (``lo``, ``hi``: the segments' extents along a common direction); vectorized."""
    order = np.argsort(theta, kind="stable")
    tcl = np.empty(len(theta), np.int64)
    tcl[order] = np.cumsum(np.r_[0, np.diff(theta[order]) > COLLINEAR_TOL])
    order = np.lexsort((rho, tcl))
    new = np.r_[True, (np.diff(tcl[order]) != 0) | (np.diff(rho[order]) > COLLINEAR_TOL)]
    gid = np.cumsum(new) - 1
    size = np.bincount(gid)
    keep = size[gid] >= 2
    order, gid = order[keep], gid[keep]
    if len(order) == 0:
        return []
    # within each group by extent: does some member start before an earlier one ends?
    by = np.lexsort((lo[order], gid))
    order, gid = order[by], gid[by]
    start = np.r_[True, gid[1:] != gid[:-1]]
    reach = hi[order].copy()
    for _ in range(64):  # running maximum within groups (doubling)
        prev = np.r_[-np.inf, reach[:-1]]
        prev[start] = -np.inf
        upd = np.maximum(reach, prev)
        if np.array_equal(upd, reach):
            break
        reach = upd
    before = np.r_[-np.inf, reach[:-1]]
    before[start] = -np.inf
    overlaps = np.zeros(int(gid.max()) + 1, bool)
    overlaps[gid[lo[order] < before - COLLINEAR_TOL]] = True
    sel = overlaps[gid]
    order, gid = order[sel], gid[sel]
    heads = np.flatnonzero(np.r_[True, gid[1:] != gid[:-1]]) if len(gid) else np.zeros(0, np.int64)
    return np.split(order, heads[1:]) if len(order) else []


def _merge_group(members: np.ndarray, k: np.ndarray, a: np.ndarray, b: np.ndarray,
                 u: np.ndarray, fixed: np.ndarray, xy: np.ndarray, moved: np.ndarray,
                 inserts: list) -> None:
    """One group of collinear segments: ends onto the reference line, and each segment's
    vertices at the other segments' ends inside it (``moved`` and ``inserts`` updated)."""
    # the reference: a wall's segment if any (walls never move), else the first
    walls = members[fixed[k[members]] & fixed[k[members] + 1]]
    ref = int(walls[0]) if len(walls) else int(members[0])
    origin, direction = a[ref], u[ref]
    s0 = (a[members] - origin) @ direction
    s1 = (b[members] - origin) @ direction
    # every end once, clustered along the line: ends within COLLINEAR_TOL are one point (a
    # wall's vertex if the cluster has one, else the first end's projection)
    verts, params = [], []
    for m, p0, p1 in zip(members.tolist(), s0.tolist(), s1.tolist(), strict=True):
        verts += [int(k[m]), int(k[m]) + 1]
        params += [p0, p1]
    verts_arr, params_arr = np.array(verts), np.array(params)
    order = np.argsort(params_arr, kind="stable")
    cluster = np.empty(len(order), np.int64)
    cluster[order] = np.cumsum(np.r_[0, np.diff(params_arr[order]) > COLLINEAR_TOL])
    reps = []
    for c in range(int(cluster.max()) + 1):
        mine = np.flatnonzero(cluster == c)
        wall = mine[fixed[verts_arr[mine]]]
        i = int(wall[0]) if len(wall) else int(mine[np.argmin(params_arr[mine])])
        reps.append(xy[verts_arr[i]] if fixed[verts_arr[i]] else
                    origin + params_arr[i] * direction)
    for v, c in zip(verts, cluster.tolist(), strict=True):
        if not fixed[v]:
            moved[v] = reps[c]
    # each member: a vertex at every cluster strictly between its two ends, in its direction
    for j, m in enumerate(members.tolist()):
        c0, c1 = int(cluster[2 * j]), int(cluster[2 * j + 1])
        step = 1 if c1 >= c0 else -1
        for rank, c in enumerate(range(c0 + step, c1, step)):
            inserts.append((int(k[m]), rank, reps[c]))


#: A curve's end inside the free space this close to a wall (curve tolerances) is joined to
#: the wall by a stub reaching ``STUB_PAST_TOLS`` past it.
STUB_REACH_TOLS = 1.0
STUB_PAST_TOLS = 4.0


def wall_stubs(ends: np.ndarray, free: np.ndarray, wa: np.ndarray, wb: np.ndarray,
               tol: float, inside: Any = None) -> np.ndarray:
    """Stubs (k, 2, 2) joining curve ends that stop just short of a wall to it.

    A vertex exactly ``lss`` from a wall makes its circle touch the wall at the end of the
    circle's critical part; drawn with an overshoot along the circle, the end curves away
    from the wall and stops ~1e-10 short of it. The noder then leaves it dangling, the
    dangle is dropped, and the pocket between circle and wall (real area) joins the region
    around it. Each end in the free space (``free``) within ``STUB_REACH_TOLS`` curve
    tolerances ``tol`` of a wall segment ``wa[j]-wb[j]`` gets a stub to the wall's nearest
    point and ``STUB_PAST_TOLS`` beyond (into the obstacle, where faces are dropped). A stub
    is no critical curve: faces on both sides with equal structures merge as usual. An end
    closer to its wall than ``1e-3 tol`` goes along the wall's normal, to the side where
    ``inside(points)`` (the free space's test) is False."""
    out = np.zeros((0, 2, 2))
    sel = np.flatnonzero(free)
    if len(sel) == 0 or len(wa) == 0:
        return out
    reach = STUB_REACH_TOLS * tol
    tree = shapely.STRtree(shapely.linestrings(np.stack((wa, wb), axis=1)))
    pi, wi = tree.query(shapely.points(ends[sel]), predicate="dwithin", distance=reach)
    if len(pi) == 0:
        return out
    p = ends[sel[pi]]
    d = wb[wi] - wa[wi]
    t = np.clip(np.einsum("ij,ij->i", p - wa[wi], d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    foot = wa[wi] + t[:, None] * d
    gap = np.hypot(*(foot - p).T)
    # the nearest wall of each end
    order = np.lexsort((gap, pi))
    first = order[np.r_[True, pi[order][1:] != pi[order][:-1]]]
    p, foot, gap, d = p[first], foot[first], gap[first], d[first]
    keep = gap > 0  # an end on the wall is noded with it already
    p, foot, gap, d = p[keep], foot[keep], gap[keep], d[keep]
    normal = np.column_stack((d[:, 1], -d[:, 0])) / np.hypot(*d.T)[:, None]
    if inside is not None:
        flip = np.asarray(inside(foot + STUB_PAST_TOLS * tol * normal), dtype=bool)
        normal[flip] *= -1
    unit = np.where((gap > 1e-3 * tol)[:, None], (foot - p) / np.maximum(gap, 1e-300)[:, None],
                    normal)
    return np.stack((p, foot + STUB_PAST_TOLS * tol * unit), axis=1)

