"""The faces of the noded arrangement: traced on the planar graph of the parts' half-edges
(``shapely.polygonize`` the fallback), the faces on the two sides of every part, and a point
well inside each face with its clearance (inscribed circles where it matters)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely

from tether._util.arrays import ragged_arange, row_ids
from tether._util.threads import map_chunks

__all__ = ["MIC_MIN_BOUND", "FaceRings", "PartLines", "face_points", "local_faces",
           "part_ends", "part_segments", "polygonize_faces", "ring_segments", "trace_faces"]


@dataclass(frozen=True)
class FaceRings:
    """Faces kept as ragged coordinate arrays, not as shapely polygons (a polygon of 9
    points takes ~0.93 KB, its coordinates 160 bytes): face ``i``'s rings (its shell, then
    its holes; each closed) are rings ``face_ptr[i]:face_ptr[i + 1]``, ring ``r``'s points
    ``xy[ring_ptr[r]:ring_ptr[r + 1]]`` (as ``shapely.from_ragged_array`` reads them), and
    ``area`` each face's area (map units², ``shapely.area`` of its polygon: the bits the
    polygon gives). Indexing with an array of face ids makes those faces' polygons (an
    object array; with one id, its polygon), as ``shapely.from_ragged_array`` makes them
    from these coordinates.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], dtype=float)
    >>> faces = FaceRings(square, np.array([0, 5]), np.array([0, 1]), np.array([1.0]))
    >>> len(faces), faces[np.array([0])][0].area
    (1, 1.0)
    """

    xy: np.ndarray
    ring_ptr: np.ndarray
    face_ptr: np.ndarray
    area: np.ndarray

    def __len__(self) -> int:
        return len(self.face_ptr) - 1

    def __getitem__(self, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids, dtype=np.int64)
        if ids.ndim == 0:  # one face: its polygon
            return self[ids[None]][0]
        if len(ids) == 0:
            return np.zeros(0, dtype=object)
        nring = self.face_ptr[ids + 1] - self.face_ptr[ids]
        rings = ragged_arange(self.face_ptr[ids], nring)
        size = self.ring_ptr[rings + 1] - self.ring_ptr[rings]
        xy = np.take(self.xy, ragged_arange(self.ring_ptr[rings], size), axis=0)
        offsets = (np.r_[0, np.cumsum(size)], np.r_[0, np.cumsum(nring)])
        return np.asarray(shapely.from_ragged_array(shapely.GeometryType.POLYGON, xy,
                                                    offsets), dtype=object)

    def polygons(self) -> np.ndarray:
        """Every face's polygon (an object array, made now)."""
        return self[np.arange(len(self))]

    @staticmethod
    def joined(parts: list[FaceRings]) -> FaceRings:
        """The faces of ``parts`` one after the other (renumbered)."""
        if not parts:
            i = np.zeros(1, np.int64)
            return FaceRings(np.zeros((0, 2)), i, i, np.zeros(0))
        rings = np.cumsum([0] + [len(f.ring_ptr) - 1 for f in parts[:-1]])
        points = np.cumsum([0] + [len(f.xy) for f in parts[:-1]])
        return FaceRings(np.concatenate([f.xy for f in parts]),
                         np.r_[np.concatenate([f.ring_ptr[:-1] + o for f, o in
                                               zip(parts, points, strict=True)]),
                               sum(len(f.xy) for f in parts)],
                         np.r_[np.concatenate([f.face_ptr[:-1] + o for f, o in
                                               zip(parts, rings, strict=True)]),
                               sum(len(f.ring_ptr) - 1 for f in parts)],
                         np.concatenate([f.area for f in parts]))


@dataclass(frozen=True)
class PartLines:
    """Noded parts kept as ragged coordinate arrays, not as shapely linestrings (one of 3
    points takes ~0.28 KB, its coordinates 48 bytes): part ``k``'s
    points are the ``count[k]`` rows of ``xy`` after those of the parts before it, and
    ``length[k]`` its length (map units, ``shapely.length`` of its linestring: the bits the
    line gives). Indexing with an array of part ids makes those parts' linestrings (an
    object array; with one id, its linestring), as ``shapely.linestrings`` makes them.

    Examples
    --------
    >>> import numpy as np
    >>> xy = np.array([[0, 0], [3, 4], [0, 0], [1, 0], [1, 1]], dtype=float)
    >>> parts = PartLines(xy, np.array([2, 3]), np.array([5.0, 2.0]))
    >>> len(parts), parts[1].wkt
    (2, 'LINESTRING (0 0, 1 0, 1 1)')
    """

    xy: np.ndarray
    count: np.ndarray
    length: np.ndarray

    def __len__(self) -> int:
        return len(self.count)

    def __getitem__(self, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids, dtype=np.int64)
        if ids.ndim == 0:  # one part: its linestring
            return self[ids[None]][0]
        if len(ids) == 0:
            return np.zeros(0, dtype=object)
        start = np.cumsum(self.count) - self.count
        xy = np.take(self.xy, ragged_arange(start[ids], self.count[ids]), axis=0)
        return np.asarray(shapely.linestrings(xy, indices=np.repeat(
            np.arange(len(ids)), self.count[ids])), dtype=object)

    def lines(self) -> np.ndarray:
        """Every part's linestring (an object array, made now)."""
        return self[np.arange(len(self))]


def _segment_ids(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """An integer id per undirected segment ``a[k]-b[k]``, equal for equal coordinates."""
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    lo = np.where(swap[:, None], b, a)
    hi = np.where(swap[:, None], a, b)
    return row_ids(np.column_stack((lo, hi)))[0]


def _point_ids(pts: np.ndarray) -> np.ndarray:
    """An integer id per point, equal for equal coordinates."""
    return row_ids(pts)[0]


def ring_segments(geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All segments of the rings of polygons (or of linestrings): (a, b, owner index)."""
    rings = shapely.get_rings(geoms, return_index=True) if len(geoms) and \
        shapely.get_type_id(geoms[0]) == 3 else (geoms, np.arange(len(geoms)))
    lines, owner = rings
    coords, idx = shapely.get_coordinates(lines, return_index=True)
    same = idx[1:] == idx[:-1]
    k = np.flatnonzero(same)
    return np.take(coords, k, axis=0), np.take(coords, k + 1, axis=0), owner[idx[k]]


def polygonize_faces(parts: np.ndarray, pa: np.ndarray, pb: np.ndarray, powner: np.ndarray,
                     longest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`trace_faces` by ``shapely.polygonize`` (the fallback): the faces, and which
    faces lie on the two sides of each part, by matching the part's longest segment
    (``longest``: its index in the parts' segments ``pa-pb`` of owner ``powner``) with the
    faces' ring segments (polygonize keeps the noded coordinates exactly)."""
    faces = shapely.get_parts(shapely.polygonize(parts))
    fa, fb, fowner = ring_segments(faces)
    ids = _segment_ids(np.vstack((pa[longest], fa)), np.vstack((pb[longest], fb)))
    part_ids, face_ids = ids[: len(longest)], ids[len(longest):]
    part_faces = np.full((len(parts), 2), -1)
    # the first two faces (in face order) having each part's longest segment in their ring
    order = np.argsort(face_ids, kind="stable")
    sorted_ids, owner_sorted = face_ids[order], fowner[order]
    pos = np.searchsorted(sorted_ids, part_ids)
    for slot in (0, 1):
        at = np.minimum(pos + slot, max(len(sorted_ids) - 1, 0))
        hit = (pos + slot < len(sorted_ids)) & (sorted_ids[at] == part_ids) if len(
            sorted_ids) else np.zeros(len(part_ids), bool)
        part_faces[powner[longest[hit]], slot] = owner_sorted[at[hit]]
    return faces, part_faces


def part_ends(parts: np.ndarray | PartLines) -> tuple[np.ndarray, ...]:
    """The parts' coordinates, each part's number of points, index of its first and of its
    last point there, and an id per end point (first points, then last points), equal for
    equal coordinates. ``parts``: linestrings or :class:`PartLines` (read as they are)."""
    if isinstance(parts, PartLines):
        coords, count = parts.xy, parts.count
    else:
        coords, idx = shapely.get_coordinates(parts, return_index=True)
        count = np.bincount(idx, minlength=len(parts))
    start = np.cumsum(count) - count  # parts have 2 or more points
    last = start + count - 1
    return coords, count, start, last, _point_ids(np.take(coords, np.r_[start, last], axis=0))


def part_segments(ends: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`ring_segments` of the parts from their :func:`part_ends` (the same arrays,
    without reading the coordinates again)."""
    coords, count, start = ends[:3]
    i = ragged_arange(start, count - 1)
    return (np.take(coords, i, axis=0), np.take(coords, i + 1, axis=0),
            np.repeat(np.arange(len(count)), count - 1))


def trace_faces(parts: np.ndarray, ends: tuple | None = None
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """The faces of the noded ``parts`` (polygons) and the faces on the two sides of every
    part (``(nparts, 2)``, the smaller face id first, -1 for none), traced on the planar
    graph of the parts' half-edges in numpy instead of ``shapely.polygonize`` and matching
    rings back to parts (several times slower). As polygonize: dangles and cut edges bound
    no face (their parts get ``(-1, -1)``), rings touching themselves at a node are split
    into simple rings, counter-clockwise rings are shells, clockwise rings holes of the
    smallest shell containing them, the unbounded face is none. Returns None where the
    tracing cannot decide (two half-edges leaving a node in exactly the same direction,
    which noding rules out, or a ring with no point off its cycle's other rings): the caller
    polygonizes then. ``ends``: :func:`part_ends` of the parts, if already computed."""
    n = len(parts)
    coords, count, start, last, ends = ends if ends is not None else part_ends(parts)
    origin, angle = _half_edges(coords, count, start, last, ends)
    nodes = int(ends.max(initial=-1)) + 1
    alive = _drop_dangles(origin, nodes)
    label = off = None
    for _ in range(2):  # the second pass without the cut edges
        nxt = _next_half_edges(origin, angle, alive)
        if nxt is None:
            return None
        label, off = _cycle_labels(nxt, alive)
        cut = alive[0::2] & (label[0::2] == label[1::2])  # one face on both sides
        if not cut.any():
            break
        alive[0::2] &= ~cut
        alive[1::2] &= ~cut
        off = None  # the labels are not those of the half-edges left
    # alive half-edges, cycle after cycle, in order
    seq = _cycle_order(nxt, label, alive) if off is None else _cycles_laid_out(label, off,
                                                                                alive)
    rings = _rings(coords, count, start, last, origin, seq, label[seq])
    if rings is None:
        return None
    faces, side = rings[:2]
    pf = np.sort(side.reshape(n, 2), axis=1)
    one = pf[:, 0] < 0  # -1 (none) goes second
    pf[one] = pf[one][:, ::-1]
    pf[pf[:, 0] == pf[:, 1]] = -1
    return faces, pf


def _half_edges(coords: np.ndarray, count: np.ndarray, start: np.ndarray, last: np.ndarray,
                ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The half-edges of parts (:func:`part_ends` arrays; half-edge ``2k`` runs along part
    ``k``, ``2k + 1`` against it): each one's origin node and the angle of its first step
    from there (radians)."""
    n = len(count)
    origin = np.empty(2 * n, np.int64)
    origin[0::2], origin[1::2] = ends[:n], ends[n:]
    step = np.empty((2 * n, 2))  # each half-edge's first step from its origin
    step[0::2] = coords[start + 1] - coords[start]
    step[1::2] = coords[last - 1] - coords[last]
    for h in np.flatnonzero(~step.any(axis=1)).tolist():  # a repeated point (none seen)
        k, sign = h // 2, 1 - 2 * (h % 2)
        at = start[k] if sign > 0 else last[k]
        j = at + sign
        while not (coords[j] != coords[at]).any():  # parts have length > 0
            j += sign
        step[h] = coords[j] - coords[at]
    return origin, np.arctan2(step[:, 1], step[:, 0])


def _rings(coords: np.ndarray, count: np.ndarray, start: np.ndarray, last: np.ndarray,
           origin: np.ndarray, seq: np.ndarray, lab: np.ndarray) -> tuple | None:
    """The faces bounded by the cycles ``seq`` (half-edges cycle after cycle, in order;
    ``lab``: their cycle) of parts (:func:`part_ends` arrays): pinched cycles split into
    simple rings, counter-clockwise rings shells, clockwise rings holes of the smallest
    shell holding them. Returns the faces (polygons), each half-edge's face (-1: none), the
    ring of each position of ``seq``, each ring's face (-1: none) and coordinates (closed
    rings ``xy[ptr[r]:ptr[r + 1]]``) and which rings are shells; None where a ring has no
    point off its cycle's other rings."""
    n = len(count)
    at = np.where(np.arange(2 * n) % 2 == 0, np.repeat(start, 2), np.repeat(last, 2))
    inner = np.where(np.repeat(count, 2) > 2, np.repeat(start + 1, 2), -1)
    loop = _split_pinched(seq, lab, origin, at, inner)
    if loop is None:
        return None
    ring_of, test_pt = loop
    # each ring's coordinates: every half-edge's points but its last, then the first again
    fwd = seq % 2 == 0
    k = seq // 2
    m = count[k] - 1
    # a half-edge's j-th point: its first point's index, then forwards or backwards
    ci = ragged_arange(np.zeros(len(seq), np.int64), m)
    ci *= np.repeat(np.where(fwd, 1, -1), m)
    ci += np.repeat(np.where(fwd, start[k], last[k]), m)
    ring_pt = np.repeat(ring_of, m)
    if np.any(ring_pt[1:] < ring_pt[:-1]):  # rings split off pinched cycles: numbered last
        order = np.argsort(ring_pt, kind="stable")
        ci, ring_pt = ci[order], ring_pt[order]
    nring = int(ring_of.max(initial=-1)) + 1
    first = np.searchsorted(ring_pt, np.arange(nring))
    ci = np.insert(ci, np.r_[first[1:], len(ci)], ci[first])  # close each ring
    xy = coords[ci]
    size = np.bincount(ring_pt, minlength=nring) + 1
    ring_ptr = np.r_[0, np.cumsum(size)]
    ccw = _rings_ccw(xy, ring_ptr)
    shell = np.flatnonzero(ccw)
    hole = np.flatnonzero(~ccw)
    face_of_ring = np.full(nring, -1)
    face_of_ring[shell] = np.arange(len(shell))
    faces = _ragged_polygons(xy, ring_ptr, shell, np.ones(len(shell), np.int64))
    # holes: in the smallest shell whose interior holds a point of theirs off every pinch
    # (the faces have no holes yet: their polygons are their shells)
    pts = shapely.points(coords[test_pt[hole]])
    hi, si = shapely.STRtree(faces).query(pts, predicate="within")
    area = shapely.area(faces)
    pick = np.lexsort((area[si], hi))
    hi, si = hi[pick], si[pick]
    head = np.r_[True, hi[1:] != hi[:-1]] if len(hi) else np.zeros(0, bool)
    face_of_ring[hole[hi[head]]] = si[head]
    # the faces with holes again: each shell then its holes
    inner = hole[face_of_ring[hole] >= 0]
    if len(inner):
        with_holes = np.unique(face_of_ring[inner])
        rows = np.concatenate((shell[with_holes], inner))
        o = np.argsort(face_of_ring[rows], kind="stable")
        faces[with_holes] = _ragged_polygons(xy, ring_ptr, rows[o], np.bincount(
            face_of_ring[rows], minlength=len(shell))[with_holes])
    side = np.full(2 * n, -1)
    side[seq] = face_of_ring[ring_of]
    return faces, side, ring_of, face_of_ring, xy, ring_ptr, ccw


def _rings_ccw(xy: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """Whether each closed ring ``xy[ptr[r]:ptr[r + 1]]`` runs counter-clockwise: the sign of
    its shoelace sum about its first point where that exceeds the sum's rounding bound
    (nearly all), GEOS's robust ``is_ccw`` for the others (specks of ~1e-16 map units)."""
    nring = len(ptr) - 1
    size = np.diff(ptr)
    ring = np.repeat(np.arange(nring), size)
    d = xy - np.repeat(np.take(xy, ptr[:-1], axis=0), size, axis=0)
    a = d[:-1, 0] * d[1:, 1]
    b = d[1:, 0] * d[:-1, 1]
    # pairs of consecutive points, each summed in its first point's ring: a ring's last
    # point (its first again: d = 0) and the next ring's first (d = 0) add 0 to its sums
    row = ring[:-1]
    total = np.bincount(row, weights=a - b, minlength=nring)
    bound = np.bincount(row, weights=np.abs(a) + np.abs(b), minlength=nring)
    ccw = total > 0
    unsure = np.flatnonzero(np.abs(total) <= 8 * np.diff(ptr) * np.finfo(float).eps * bound)
    if len(unsure):
        idx = ragged_arange(ptr[unsure], ptr[unsure + 1] - ptr[unsure])
        rings = shapely.linearrings(xy[idx], indices=np.repeat(np.arange(len(unsure)),
                                                                size[unsure]))
        ccw[unsure] = shapely.is_ccw(rings)
    return ccw


def _ragged_polygons(xy: np.ndarray, ptr: np.ndarray, rings: np.ndarray,
                     per_polygon: np.ndarray) -> np.ndarray:
    """Polygons from closed rings ``xy[ptr[r]:ptr[r + 1]]``: ``rings`` in order, the first
    ``per_polygon[0]`` of them the first polygon (shell, then holes), and so on; built in one
    call, without intermediate ring objects."""
    size = ptr[rings + 1] - ptr[rings]
    idx = ragged_arange(ptr[rings], size)
    offsets = (np.r_[0, np.cumsum(size)], np.r_[0, np.cumsum(per_polygon)])
    return np.asarray(shapely.from_ragged_array(shapely.GeometryType.POLYGON, xy[idx],
                                                offsets), dtype=object)


def _drop_dangles(origin: np.ndarray, nodes: int) -> np.ndarray:
    """Which half-edges (``origin``: each one's start node, twins ``2k``, ``2k + 1``) remain
    once dangles are removed: parts with an end of degree 1, repeatedly."""
    alive = np.ones(len(origin), bool)
    deg = np.bincount(origin, minlength=nodes)  # alive half-edges leaving each node
    # and the sum of their indices (exact in floats): at a tip, its one half-edge
    total = np.bincount(origin, weights=np.arange(len(origin), dtype=float), minlength=nodes)
    tip = np.flatnonzero(deg == 1)
    while len(tip):
        part = np.unique(total[tip].astype(np.int64) // 2)
        alive[2 * part] = alive[2 * part + 1] = False
        gone = np.concatenate((2 * part, 2 * part + 1))
        end = origin[gone]
        np.subtract.at(deg, end, 1)
        np.subtract.at(total, end, gone.astype(float))
        tip = np.unique(end[deg[end] == 1])
    return alive


def _next_half_edges(origin: np.ndarray, angle: np.ndarray, alive: np.ndarray
                     ) -> np.ndarray | None:
    """The next half-edge of each alive one along its face (the face on its left): at its end
    node, the outgoing half-edge just clockwise of its twin. None if two half-edges leave a
    node in exactly the same direction."""
    live = np.flatnonzero(alive)
    order = _by_origin_then_angle(origin, angle, live)
    o, a = origin[order], angle[order]
    if np.any((o[1:] == o[:-1]) & (a[1:] == a[:-1])):
        return None
    pos = np.empty(len(origin), np.int64)
    pos[order] = np.arange(len(order))
    gstart = np.flatnonzero(np.r_[True, o[1:] != o[:-1]])
    prev = np.arange(-1, len(order) - 1)  # the one before in the sorted order, cyclic per node
    prev[gstart] = np.r_[gstart[1:], len(order)] - 1
    nxt = np.full(len(origin), -1)
    nxt[live] = order[prev[pos[live ^ 1]]]  # from each half-edge's twin, in the sorted order
    return nxt


def _by_origin_then_angle(origin: np.ndarray, angle: np.ndarray, live: np.ndarray
                          ) -> np.ndarray:
    """``live[np.lexsort((angle[live], origin[live]))]`` (``origin``: integers from 0,
    ``angle``: radians in ``[-pi, pi]``), by one sort of ``origin + (angle + pi) / (4 pi)``:
    that key grows with the origin, then with the angle, but may round distinct angles of
    one origin to equal keys. The order is the lexsort's if the angles then strictly
    increase within each origin (no ties: the sorted order is unique), else the lexsort
    is made."""
    o, a = origin[live], angle[live]
    order = live[np.argsort(o + (a + np.pi) * (0.25 / np.pi))]
    o, a = origin[order], angle[order]
    if np.all(o[1:] >= o[:-1]) and not np.any((o[1:] == o[:-1]) & (a[1:] <= a[:-1])):
        return order
    return live[np.lexsort((angle[live], origin[live]))]


def _cycle_labels(nxt: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest half-edge of each alive half-edge's cycle under ``nxt`` (dead ones: their
    own index), and the steps from the half-edge to it along ``nxt`` (0 for itself).
    Pointer doubling: ``label[h]`` is the least of the ``2^k`` half-edges from ``h`` on,
    first met ``off[h]`` steps on, ``jump[h]`` the one after them; once a round changes no
    label, each label is its cycle's least (following ``jump`` from ``h`` the labels cannot
    decrease, so they are equal all around, and those windows cover the cycle)."""
    small = np.int32 if len(nxt) < 2**31 else np.int64  # less memory read per round
    label = np.arange(len(nxt), dtype=small)
    off = np.zeros(len(nxt), small)
    jump = np.where(alive, nxt, np.arange(len(nxt)))
    span = 1
    while True:
        ahead = label[jump]
        take = np.flatnonzero(ahead < label)  # the least only in the window's second half
        if len(take) == 0:
            return label.astype(np.int64), off.astype(np.int64)
        label[take] = ahead[take]
        off[take] = off[jump[take]] + span
        jump = jump[jump]
        span *= 2


def _cycles_laid_out(label: np.ndarray, off: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """:func:`_cycle_order` from the cycles' labels and each half-edge's steps to its label
    (:func:`_cycle_labels`): every half-edge put at its place, no sort."""
    live = np.flatnonzero(alive)
    lab = label[live]
    first = live[lab == live]  # the cycles' least half-edges, increasing
    cycle = np.empty(len(label), np.int64)
    cycle[first] = np.arange(len(first))
    c = cycle[lab]
    size = np.bincount(c, minlength=len(first))
    n = size[c]
    at = (n - off[live]) % np.maximum(n, 1)  # steps from the label to it
    seq = np.empty(len(live), np.int64)
    seq[(np.cumsum(size) - size)[c] + at] = live
    return seq


def _cycle_order(nxt: np.ndarray, label: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """The alive half-edges cycle after cycle (by smallest half-edge), each cycle from its
    smallest half-edge along ``nxt`` (list ranking by pointer doubling)."""
    live = np.flatnonzero(alive)
    succ = nxt.copy()
    tail = np.zeros(len(nxt), bool)
    tail[live] = nxt[live] == label[live]  # the last half-edge of its cycle
    succ[~alive | tail] = np.flatnonzero(~alive | tail)
    dist = np.where(alive & ~tail, 1, 0)  # steps to the cycle's last half-edge
    act = np.flatnonzero(succ[succ] != succ)  # not yet pointing at their cycle's last
    while len(act):  # pointer doubling on the half-edges still jumping (long cycles)
        s = succ[act]
        dist[act] += dist[s]
        succ[act] = succ[s]
        act = act[succ[succ[act]] != succ[act]]
    return live[np.lexsort((-dist[live], label[live]))]


def _split_pinched(seq: np.ndarray, lab: np.ndarray, origin: np.ndarray, at: np.ndarray,
                   inner: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Simple rings from the cycles ``seq`` (half-edges cycle after cycle, in order; ``lab``:
    their cycle): a cycle passing a node twice is cut there into rings (rare: a Python loop
    over those cycles only). Returns the ring of every position of ``seq`` and, per ring, the
    coordinate index of a point of it on no other ring of its cycle (a node passed once, or
    an inner point of a part: ``at`` and ``inner`` per half-edge, -1 for none), None if a
    ring has none."""
    new = np.r_[True, lab[1:] != lab[:-1]] if len(lab) else np.zeros(0, bool)
    ring = np.cumsum(new) - 1
    test = at[seq[new]]
    key = ring * (int(origin.max(initial=0)) + 1) + origin[seq]
    srt = np.sort(key)
    dup = srt[1:][srt[1:] == srt[:-1]]
    pinched = np.unique(dup // (int(origin.max(initial=0)) + 1))
    if len(pinched) == 0:
        return ring, test
    ring = ring.copy()
    tests = test.tolist()
    starts = np.flatnonzero(new)
    stops = np.r_[starts[1:], len(seq)]
    for c in pinched.tolist():
        a, b = int(starts[c]), int(stops[c])
        nodes = origin[seq[a:b]].tolist()
        seen: dict[int, int] = {}
        for v in nodes:
            seen[v] = seen.get(v, 0) + 1
        loops: list[list[int]] = []
        stack: list[int] = []  # positions in seq
        where: dict[int, int] = {}
        for p, v in zip(range(a, b), nodes, strict=True):
            if v in where:
                i = where[v]
                loops.append(stack[i:])
                for q in stack[i:]:
                    del where[int(origin[seq[q]])]
                del stack[i:]
            where[v] = len(stack)
            stack.append(p)
        loops.append(stack)
        for j, lp in enumerate(loops):
            free = [int(at[seq[q]]) for q in lp if seen[int(origin[seq[q]])] == 1]
            free += [int(inner[seq[q]]) for q in lp if inner[seq[q]] >= 0]
            if not free:
                return None
            r = c if j == 0 else len(tests)
            if j:
                tests.append(0)
            ring[lp] = r
            tests[r] = free[0]
    return ring, np.asarray(tests, dtype=np.int64)


def face_points(faces: np.ndarray, tol: float, grid: float = 0.0
                ) -> tuple[np.ndarray, np.ndarray]:
    """A point well inside each face and its distance to the face's boundary (map units).

    ``point_on_surface`` first; faces where it lies closer than ``4 tol`` to the boundary get
    the centre of their maximum inscribed circle instead if that is farther. The circle (the
    costly step) is skipped where it cannot change a result: faces that cannot be resolved
    (:data:`MIC_MIN_BOUND`; the pipeline only compares clearances with ``2 tol`` and, among
    resolved faces, with each other) whose point is clear of the boundary by more than
    rounding and the noding ``grid`` (whether the face is in the free space is then the same
    at either point; specks of ~1e-16 map units, where it is not, get their circle: cheap)."""
    inside = map_chunks(shapely.point_on_surface, faces)  # element-wise: on every core
    pts = shapely.get_coordinates(inside)
    clear = map_chunks(_boundary_distance, np.arange(len(faces)), faces=faces, points=inside)
    thin = np.flatnonzero(clear < 4 * tol)
    speck = clear[thin] < 1e-6 * tol + 2 * grid
    thin = thin[speck | (_inradius_bound(faces[thin]) >= MIC_MIN_BOUND * tol)]
    if len(thin):
        # the costly step (long slivers), face by face: on every core
        circ = map_chunks(shapely.maximum_inscribed_circle, faces[thin], tolerance=0.1 * tol)
        c = shapely.get_coordinates(circ)[::2]
        r = shapely.length(circ)
        better = r > clear[thin]
        pts[thin[better]] = c[better]
        clear[thin[better]] = r[better]
    return pts, clear


def _boundary_distance(rows: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The distance from ``points[rows]`` to the boundaries of ``faces[rows]`` (map units)."""
    return shapely.distance(shapely.boundary(faces[rows]), points[rows])


#: Faces whose inradius bound (:func:`_inradius_bound`) is below this many curve tolerances
#: get no inscribed circle: their inradius is below ``2 tol`` with a margin of 4/3 (the bound
#: holds up to rounding: measured within 4e-8 relative on faces clear of specks, the faces
#: that get the circle anyway; specks of ~1e-16 map units exceed it by up to 2x).
MIC_MIN_BOUND = 1.5


def _inradius_bound(polys: np.ndarray) -> np.ndarray:
    """An upper bound of each polygon's inradius (map units): ``2 area / perimeter`` of its
    convex hull (a convex set containing a disc of radius ``r`` has area at least
    ``r * perimeter / 2``; the polygon's disc lies in its hull). Vectorized, cheap."""
    if len(polys) == 0:
        return np.zeros(0)
    hull = shapely.convex_hull(polys)
    with np.errstate(invalid="ignore", divide="ignore"):
        bound = 2 * shapely.area(hull) / shapely.length(hull)
    return np.nan_to_num(bound, nan=0.0)


def local_faces(coords: np.ndarray, count: np.ndarray, held: Callable, complete: Callable,
                owned: Callable, earlier: Callable) -> tuple | None:
    """The faces of the whole arrangement that a part of it can vouch for: the faces of a
    tile (:func:`tether.decomposition.tiles.trace_tile`), exactly as :func:`trace_faces`
    traces them on all the parts.

    ``coords``, ``count``: the parts' coordinates (part after part) and point counts: every
    part of the whole arrangement whose bounding box meets a region (the *send* region),
    exact copies. A node is *complete* if ``complete(points)`` says it lies in that region:
    every part ending there is given. The *raw walks* (the boundary walks of the planar map
    of all the half-edges, dangles and cut edges included) are local: a walk's step at a
    complete node is the whole's. A raw walk whose bounding box is held by the *trust*
    region (``held(lo, hi)``) passes complete nodes only, so it is one of the whole's. A part
    bounds faces (is not a dangle or a cut edge, as :func:`trace_faces` drops them) iff its
    two sides lie on different raw walks, so the faces are traced on those parts, on the
    cycles all of whose half-edges lie on held raw walks; a face all of whose rings'
    half-edges lie on held raw walks is the whole's face (each step along its
    rings sees every half-edge between it and the next one, both sides on the walk), and it
    is delivered if its *anchor* (the lexicographically smallest point of its shell) is
    ``owned(points)`` and its raw walks' box is not held by an earlier region of the task
    (``earlier(lo, hi)``, None for none: delivered there).

    A face anchored at an owned point but not vouched for here is reported: the raw walk
    through its anchor on its side is not held, and the anchor is the smallest point of that
    walk's stretch (a run of steps at complete nodes, a piece of the whole's walk) with a
    left turn there (the face is convex at its anchor). Every owned point that is such a
    stretch's smallest point with a left turn there is returned, for a retry in a larger
    region. The unbounded face's walk turns right at its smallest point, so it is not
    retried forever; a smallest point of a stretch of it elsewhere stops being one as the
    region grows.

    Returns the delivered faces as ragged arrays (their rings' coordinates, face after face,
    its shell then its holes, and the offsets of rings and of faces, as
    ``shapely.from_ragged_array`` reads them), the half-edges on their rings (``2k`` along
    part ``k``, ``2k + 1`` against it) and each one's face there, the points to retry ((m,
    2)) and the boxes of the walks' stretches seen at each ((m, 4)); None where the tracing
    cannot decide (two half-edges leaving a node in exactly the same direction, or a ring
    with no point of its own: :func:`trace_faces` polygonizes the whole then)."""
    n = len(count)
    if n == 0:
        return _no_faces((np.zeros((0, 2)), np.zeros((0, 4))))
    start = np.cumsum(count) - count
    last = start + count - 1
    ends = _point_ids(np.take(coords, np.r_[start, last], axis=0))
    origin, angle = _half_edges(coords, count, start, last, ends)
    every = np.ones(2 * n, bool)
    raw_next = _next_half_edges(origin, angle, every)
    if raw_next is None:
        return None
    raw, raw_off = _cycle_labels(raw_next, every)
    rseq = _cycles_laid_out(raw, raw_off, every)  # the raw walks, each in order
    wstart = np.flatnonzero(np.r_[True, raw[rseq][1:] != raw[rseq][:-1]])
    plo, phi = np.minimum.reduceat(coords, start), np.maximum.reduceat(coords, start)
    wlo = np.minimum.reduceat(plo[rseq // 2], wstart)  # each walk's box
    whi = np.maximum.reduceat(phi[rseq // 2], wstart)
    wsize = np.diff(np.r_[wstart, 2 * n])
    walk_of = np.empty(2 * n, np.int64)  # each half-edge's walk (in rseq order)
    walk_of[rseq] = np.repeat(np.arange(len(wstart)), wsize)
    on_held = held(wlo, whi)[walk_of]  # each half-edge's raw walk is held
    alive = np.repeat(raw[0::2] != raw[1::2], 2)
    open_seq = rseq[~on_held[rseq]]
    retry = _retry_points(coords, count, start, last, origin, open_seq, raw[open_seq],
                          (plo, phi), complete, owned)
    if not alive.any():  # no part bounds a face here
        return _no_faces(retry)
    nxt = _next_half_edges(origin, angle, alive)
    label, off = _cycle_labels(nxt, alive)
    seq = _cycles_laid_out(label, off, alive)
    # only the cycles all of whose half-edges lie on held raw walks: the whole's cycles (a
    # face's rings are among them, and a shell's holes too, inside it); the others may be
    # pieces of several that no ring of the whole is made of
    open_cycle = np.bincount(label[seq], weights=~on_held[seq], minlength=2 * n) > 0
    seq = seq[~open_cycle[label[seq]]]
    if len(seq) == 0:
        return _no_faces(retry)
    rings = _rings(coords, count, start, last, origin, seq, label[seq])
    if rings is None:
        return None
    faces, side, ring_of, face_of_ring, xy, ring_ptr, ccw = rings
    nring, nf = len(ring_ptr) - 1, len(faces)
    bad = np.bincount(ring_of, weights=~on_held[seq], minlength=nring) > 0
    in_face = np.flatnonzero(face_of_ring >= 0)
    face_bad = np.bincount(face_of_ring[in_face], weights=bad[in_face], minlength=nf) > 0
    shell = np.flatnonzero(ccw)  # face i's shell is ring shell[i]
    take = np.flatnonzero(~face_bad)
    anchor = np.take(xy, _lexmin_rows(xy, ring_ptr)[shell[take]], axis=0)
    take = take[owned(anchor)]
    on = np.flatnonzero(side >= 0)
    if earlier is not None and len(take):  # the faces' walks' boxes, held earlier or not
        mine = np.zeros(nf, bool)
        mine[take] = True
        on_t = on[mine[side[on]]]
        flo = np.full((nf, 2), np.inf)
        fhi = np.full((nf, 2), -np.inf)
        np.minimum.at(flo, side[on_t], wlo[walk_of[on_t]])
        np.maximum.at(fhi, side[on_t], whi[walk_of[on_t]])
        take = take[~earlier(flo[take], fhi[take])]
    new = np.full(nf + 1, -1)
    new[take] = np.arange(len(take))
    he = on[new[side[on]] >= 0]
    # the faces' rings as ragged arrays: face after face, its shell then its holes
    r = in_face[new[face_of_ring[in_face]] >= 0]
    r = r[np.lexsort((r, ~ccw[r], new[face_of_ring[r]]))]
    size = ring_ptr[r + 1] - ring_ptr[r]
    ring_xy = np.take(xy, ragged_arange(ring_ptr[r], size), axis=0)
    per_face = np.bincount(new[face_of_ring[r]], minlength=len(take))
    return (ring_xy, (np.r_[0, np.cumsum(size)], np.r_[0, np.cumsum(per_face)]), he,
            new[side[he]], *retry)


def _no_faces(retry: tuple[np.ndarray, np.ndarray]) -> tuple:
    """:func:`local_faces`'s answer with no face delivered, the points to retry and their
    boxes ``retry``."""
    empty = np.zeros(0, np.int64)
    return np.zeros((0, 2)), (np.zeros(1, np.int64), np.zeros(1, np.int64)), empty, empty, \
        *retry


def _lexmin_rows(xy: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """The row of the lexicographically smallest point ``(x, y)`` of each group
    ``xy[ptr[g]:ptr[g + 1]]`` (groups non-empty; the first such row), without a sort."""
    starts = ptr[:-1]
    group = np.repeat(np.arange(len(starts)), np.diff(ptr))
    x, y = xy[:, 0], xy[:, 1]
    at_min = x == np.minimum.reduceat(x, starts)[group]
    yy = np.where(at_min, y, np.inf)
    hit = np.flatnonzero(at_min & (yy == np.minimum.reduceat(yy, starts)[group]))
    g = group[hit]
    return hit[np.r_[True, g[1:] != g[:-1]]]


def _retry_points(coords: np.ndarray, count: np.ndarray, start: np.ndarray, last: np.ndarray,
                  origin: np.ndarray, seq: np.ndarray, lab: np.ndarray, boxes: tuple,
                  complete: Callable, owned: Callable) -> tuple[np.ndarray, np.ndarray]:
    """The owned points that may anchor a face not vouched for (:func:`local_faces`): on the
    raw walks not held (``seq``: their half-edges, walk after walk, each in order; ``lab``:
    each one's walk), each stretch's smallest point where the walk turns left there; and
    for each point, the box of its stretches (``boxes``: the parts' boxes ``(lo, hi)``),
    ``(xmin, ymin, xmax, ymax)``: the part of its face's walk seen here."""
    n = len(count)
    none = np.zeros((0, 2)), np.zeros((0, 4))
    if len(seq) == 0:
        return none
    first = np.r_[True, lab[1:] != lab[:-1]]
    wid = np.cumsum(first) - 1  # walk of each position
    wstart = np.flatnonzero(first)
    node_xy = np.take(coords, np.r_[start, last], axis=0)
    node_ok = np.zeros(int(origin.max()) + 1, bool)
    node_ok[origin[np.r_[2 * np.arange(n), 2 * np.arange(n) + 1]]] = complete(node_xy)
    brk = ~node_ok[origin[seq ^ 1]]  # the walk's step after this half-edge is not exact
    before = np.cumsum(brk) - brk  # breaks before each position
    within = before - before[wstart][wid]
    total = np.bincount(wid, weights=brk, minlength=len(wstart)).astype(np.int64)
    t = total[wid]
    within = np.where(t > 0, within % np.maximum(t, 1), 0)  # after the last break: the first
    stretch = row_ids(np.column_stack((wid, within)))[0]
    # each part's smallest point, and each stretch's smallest among its half-edges' parts
    k = seq // 2
    pmin = _lexmin_rows(coords, np.r_[start, last[-1] + 1])
    p = np.take(coords, pmin[k], axis=0)
    order = np.lexsort((p[:, 1], p[:, 0], stretch))
    ns = int(stretch.max()) + 1
    best = order[np.searchsorted(stretch[order], np.arange(ns))]
    occ = np.flatnonzero(np.all(p == p[best][stretch], axis=1))  # positions at that point
    # the turn there: inside its part, or at the half-edge's origin (from the one before)
    h, j = seq[occ], pmin[k[occ]]
    fwd = h % 2 == 0
    kk = k[occ]
    inside = (j > start[kk]) & (j < last[kk])
    jm, jp = np.maximum(j - 1, 0), np.minimum(j + 1, len(coords) - 1)
    turn_in = _cross(coords[j] - coords[jm], coords[jp] - coords[j]) * np.where(fwd, 1, -1)
    # (by coordinates: a closed part's smallest point may be read at either of its ends)
    at_origin = ~inside & np.all(coords[j] == coords[np.where(fwd, start[kk], last[kk])],
                                 axis=1)
    prev = np.where(first[occ], _walk_last(first)[wid[occ]], occ - 1)
    g = seq[prev]
    g_end = np.where(g % 2 == 0, last[g // 2], start[g // 2])
    g_in = coords[g_end] - coords[np.where(g % 2 == 0, g_end - 1, g_end + 1)]
    h_out = coords[np.where(fwd, start[kk] + 1, last[kk] - 1)] - coords[j]
    turn_at = _cross(g_in, h_out)
    left = np.where(inside, turn_in > 0, at_origin & (turn_at > 0))
    cand = occ[left]
    cand = cand[owned(p[cand])] if len(cand) else cand
    if len(cand) == 0:
        return none
    slo = np.full((ns, 2), np.inf)
    shi = np.full((ns, 2), -np.inf)
    np.minimum.at(slo, stretch, boxes[0][k])
    np.maximum.at(shi, stretch, boxes[1][k])
    # each point once, with the union of its stretches' boxes
    pts, st = p[cand], stretch[cand]
    o = np.lexsort((pts[:, 1], pts[:, 0]))
    pts, st = pts[o], st[o]
    head = np.flatnonzero(np.r_[True, np.any(pts[1:] != pts[:-1], axis=1)])
    return pts[head], np.hstack((np.minimum.reduceat(slo[st], head),
                                 np.maximum.reduceat(shi[st], head)))


def _walk_last(first: np.ndarray) -> np.ndarray:
    """The last position of each walk (``first``: where each walk starts)."""
    return np.r_[np.flatnonzero(first)[1:], len(first)] - 1


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The z component of ``a x b``, row by row."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
