"""The arrangement: the map's rings and the critical curves' polylines (collinear copies made
one, stubs to the walls), noded (:mod:`tether.decomposition.noding`), its faces traced
(:mod:`tether.decomposition.faces`) and each noded part's source curves; and the chains of
parts that separate two regions (:class:`Chains`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from tether._util.arrays import first_max_per_group, ragged_arange
from tether._util.memo import Memo, memo_field
from tether._util.memory import release_memory
from tether._util.threads import in_background
from tether.curves import Curve
from tether.decomposition.coincidence import merge_collinear, wall_stubs
from tether.decomposition.faces import (
    FaceRings,
    PartLines,
    part_ends,
    part_segments,
    polygonize_faces,
    trace_faces,
)
from tether.decomposition.noding import node_lines
from tether.environment import Environment
from tether.spatial import SegmentGrid, segments_near

__all__ = ["Arrangement", "Chains", "SOURCE_BATCH", "arrangement", "traced_arrangement"]


@dataclass
class Arrangement:
    """The noded curves and rings: their parts, the faces on both sides of each, the curves
    each part comes from, and the faces' polygons."""

    #: noded linestrings, or (noded in tiles) :class:`PartLines`: ragged arrays with the
    #: parts' lengths, the linestrings made only where needed (``parts[ids]``)
    parts: np.ndarray | PartLines
    part_faces: np.ndarray  # (nparts, 2) face ids, -1 for none
    #: curve ids (-1 = wall) of each part, CSR: part ``k``'s are
    #: ``source_ids[source_ptr[k]:source_ptr[k + 1]]`` (increasing)
    source_ptr: np.ndarray
    source_ids: np.ndarray
    #: polygons, or (faces traced in tiles) :class:`FaceRings`: ragged arrays with the
    #: faces' areas, the polygons made only where needed (``faces[ids]``)
    faces: np.ndarray | FaceRings
    grid: float = 0.0  # the snap-rounding grid of the noding (map units), 0: exact
    #: values derived on demand and kept (indexes, name tables): see :class:`Memo`
    memo: Memo = memo_field()

    @property
    def part_sources(self) -> list[tuple[int, ...]]:
        """The curve ids (-1 = wall) of each part, as tuples."""
        flat = self.source_ids.tolist()
        ptr = self.source_ptr.tolist()
        return [tuple(flat[a:b]) for a, b in zip(ptr[:-1], ptr[1:], strict=True)]

    def segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, SegmentGrid]:
        """All segments of the parts (a, b, part index) and their grid (for
        :func:`segments_near`), built once."""
        got = self.memo.get("segments")
        if got is None:
            a, b, owner = self.memo.pop("part_segments", None) or part_segments(
                part_ends(self.parts))
            got = (a, b, owner, SegmentGrid(a, b))
            self.memo["segments"] = got
        return got

    def part_lengths(self) -> np.ndarray:
        """Each part's length (map units, ``shapely.length`` of its linestring), built
        once."""
        got = self.memo.get("part_length")
        if got is None:
            got = self.memo["part_length"] = shapely.length(self.parts)
        return got

    def end_ids(self) -> tuple[np.ndarray, np.ndarray]:
        """An id per end point of every part (first, last), equal for equal coordinates,
        built once."""
        got = self.memo.get("end_ids")
        if got is None:
            ids = part_ends(self.parts)[4]
            got = self.memo["end_ids"] = (ids[: len(self.parts)], ids[len(self.parts):])
        return got

    def sources(self) -> tuple[np.ndarray, np.ndarray]:
        """The parts' sources as CSR arrays ``(ptr, src)``: part ``k``'s sources are
        ``src[ptr[k]:ptr[k + 1]]`` (increasing)."""
        return self.source_ptr, self.source_ids

    def chain_sources(self, chains: Chains) -> tuple[np.ndarray, np.ndarray]:
        """The curves (no walls) of each chain, sorted, distinct, as CSR arrays ``(ptr,
        src)``: chain ``i``'s are ``src[ptr[i]:ptr[i + 1]]``; vectorized over all chains."""
        ptr, src = self.sources()
        parts = chains.parts
        chain = np.repeat(np.arange(len(chains), dtype=np.int64), chains.size)
        nsrc = ptr[parts + 1] - ptr[parts]
        rows = ragged_arange(ptr[parts], nsrc)
        base = int(src.max(initial=0)) + 2  # sources are -1 (wall) .. max
        key = np.sort(np.repeat(chain, nsrc) * base + src[rows] + 1)  # np.unique hashes: slow
        key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
        c, s = np.divmod(key, base)
        s = s - 1
        c, s = c[s >= 0], s[s >= 0]
        return np.searchsorted(c, np.arange(len(chains) + 1)), s


@dataclass
class Chains:
    """Chains of arrangement parts (CSR): chain ``i`` separates regions ``pair[i, 0] <
    pair[i, 1]`` and is made of the parts ``parts[ptr[i]:ptr[i + 1]]`` (increasing). Chains
    are sorted by region pair, then first part."""

    pair: np.ndarray
    ptr: np.ndarray
    parts: np.ndarray

    def __len__(self) -> int:
        return len(self.pair)

    @property
    def size(self) -> np.ndarray:
        """Number of parts of each chain."""
        return np.diff(self.ptr)


def _input_lines(env: Environment, curves: list[Curve], tol: float | None = None
                 ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """The arrangement's input: the map's rings (closed) and every curve polyline of at least
    two distinct points, as linestrings (built in one call), each line's source curve id
    (-1: a ring), and the lines' segments (as :func:`ring_segments` of the lines). Collinear
    copies are made one (:func:`tether.decomposition.coincidence.merge_collinear`); with the curve
    tolerance ``tol``, curve ends stopping just short of a wall get a stub to it
    (:func:`tether.decomposition.coincidence.wall_stubs`), a line of their curve's."""
    polys = [np.vstack((r, r[:1])) for r in env.rings]
    src = [-1] * len(polys)
    straight = [True] * len(polys)  # rings and the straight kinds' polylines
    for c in curves:
        polys.extend(c.polylines)
        src.extend([c.id] * len(c.polylines))
        straight.extend([c.kind in "ACD"] * len(c.polylines))
    size = np.fromiter((len(p) for p in polys), np.int64, len(polys))
    coords = np.vstack(polys)
    line = np.repeat(np.arange(len(polys)), size)
    # a polyline is kept if some coordinate differs from its first point
    first = np.repeat(np.cumsum(size) - size, size)
    moves = np.bincount(line, weights=np.any(coords != coords[first], axis=1),
                        minlength=len(polys))
    ok = (size >= 2) & (moves > 0)
    rows = ok[line]
    new_index = np.cumsum(ok) - 1
    xy, idx = coords[rows], new_index[line[rows]]
    # coincident straight copies (exactly coincident curves, rounded apart) made one exactly
    xy, idx = merge_collinear(xy, idx, idx < len(env.rings),
                              np.asarray(straight)[ok][idx])
    source = np.asarray(src)[ok]
    if tol is not None:
        xy, idx, source = _with_wall_stubs(env, xy, idx, source, tol)
    lines = shapely.linestrings(xy, indices=idx)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    return np.asarray(lines, dtype=object), source, (xy[k], xy[k + 1], idx[k])


def _with_wall_stubs(env: Environment, xy: np.ndarray, idx: np.ndarray, source: np.ndarray,
                     tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines (vertices ``xy`` of lines ``idx``, sources ``source``) with the stubs of
    :func:`tether.decomposition.coincidence.wall_stubs` added as lines of their curves."""
    head = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    tail = np.r_[head[1:] - 1, len(idx) - 1]
    curve = source[idx[head]] >= 0
    ends = np.concatenate((xy[head[curve]], xy[tail[curve]]))
    owner = np.tile(source[idx[head[curve]]], 2)
    free = np.asarray(env.polygon.contains(shapely.points(ends)), dtype=bool) \
        if len(ends) else np.zeros(0, bool)
    nr = len(env.rings)
    wall = idx[:-1] == idx[1:]
    wall &= idx[:-1] < nr
    w = np.flatnonzero(wall)
    stubs = wall_stubs(ends, free, xy[w], xy[w + 1], tol,
                       lambda q: env.polygon.contains(shapely.points(q)))
    if len(stubs) == 0:
        return xy, idx, source
    # each stub's curve: the end it starts from
    at = {tuple(p): o for p, o in zip(ends.tolist(), owner.tolist(), strict=True)}
    new_src = np.array([at[tuple(p)] for p in stubs[:, 0].tolist()])
    base = int(idx.max()) + 1
    return (np.vstack((xy, stubs.reshape(-1, 2))),
            np.concatenate((idx, np.repeat(np.arange(base, base + len(stubs)), 2))),
            np.concatenate((source, new_src)))


def arrangement(env: Environment, curves: list[Curve], tol: float,
                noder: Callable[..., Any] | None = None, noding: str = "auto") -> Arrangement:
    """Node the critical curves and the map's rings into parts and trace the faces they bound.

    ``noder``, if given, nodes the input tile by tile
    (:func:`tether.decomposition.tiles.tiled_noder`): called as ``noder(lines, source,
    (la, lb, lowner))`` with the input lines, each line's source curve (-1: a ring) and the
    lines' segments, it returns the parts, their sources as CSR arrays, the faces traced
    tile by tile and the snap-rounding grid ``(parts, ptr, src, traced, grid)`` (``traced``:
    None to trace them here; ``grid`` 0: floating-point noding), or None to node the input
    whole (as without it). ``noding``: how the input is noded whole
    (:data:`tether.decomposition.noding.NODINGS`; a ``noder`` is made with its own)."""
    lines, source, (la, lb, lowner) = _input_lines(env, curves, tol)
    if noder is not None:
        got = noder(lines, np.asarray(source, dtype=np.int64), (la, lb, lowner))
        if got is not None:
            return traced_arrangement(*got)
    # the sources' segment grid built while GEOS nodes (it releases the GIL); for the reach
    # of floating-point noding (snap rounding's wider reach builds its own blocks)
    tree = SegmentGrid(la, lb)
    ready = in_background(tree.prepare, max(1e-3 * tol, 1e-12)) if len(la) else (lambda: None)
    parts, grid = node_lines(lines, tol, len(la), noding)
    ready()
    release_memory()  # the noder's temporaries (~0.5 GB at 1,000 map vertices), before tracing
    parts = parts[shapely.length(parts) > 0]
    ends = part_ends(parts)
    faces, part_faces, (pa, pb, powner), longest = _faces(parts, ends)
    # which input lines each part came from: input segments near the middle of its longest
    # segment (a segment grid: distances to whole long polylines would dominate the time)
    mid = 0.5 * (np.take(pa, longest, axis=0) + np.take(pb, longest, axis=0))
    source = np.asarray(source, dtype=np.int64)
    base = int(source.max(initial=0)) + 2  # sources are -1 (wall) .. max
    keys = []  # (part, source) pairs as one integer key; in batches: their candidate pairs
    for lo in range(0, len(mid), SOURCE_BATCH):  # (1.3 M at 1,000 v) set the stage's peak
        qi, si, _ = segments_near(mid[lo:lo + SOURCE_BATCH], la, lb,
                                  max(1e-3 * tol + 2 * grid, 1e-12), tree)
        keys.append(powner[longest[qi + lo]].astype(np.int64) * base + source[lowner[si]] + 1)
    del tree
    # distinct (part, source) pairs in (part, source) order
    key = np.sort(np.concatenate(keys)) if keys else np.zeros(0, np.int64)
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # np.unique hashes: slow
    part_of, src = np.divmod(key, base)
    ptr = np.searchsorted(part_of, np.arange(len(parts) + 1))
    arr = Arrangement(parts, part_faces, ptr, src - 1, faces, grid)
    arr.memo["end_ids"] = (ends[4][: len(parts)], ends[4][len(parts):])  # as end_ids()
    arr.memo["part_segments"] = (pa, pb, powner)  # for segments(): not made again
    return arr


def _faces(parts: np.ndarray, ends: tuple) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray]:
    """The faces of the noded ``parts`` (of :func:`part_ends` ``ends``) and the faces on both
    sides of each part (traced, polygonized if the tracing cannot decide), the parts'
    segments ``(pa, pb, powner)`` and the index of each part's longest segment there."""
    pa, pb, powner = part_segments(ends)
    seg_len = np.hypot(*(pb - pa).T)
    longest = first_max_per_group(seg_len, powner)  # the longest segment of each part
    traced = trace_faces(parts, ends)
    if traced is not None:
        faces, part_faces = traced
    else:
        faces, part_faces = polygonize_faces(parts, pa, pb, powner, longest)
    return faces, part_faces, (pa, pb, powner), longest


def traced_arrangement(parts: np.ndarray | PartLines, ptr: np.ndarray, src: np.ndarray,
                       traced: tuple | None = None, grid: float = 0.0) -> Arrangement:
    """The arrangement of parts noded elsewhere (tile by tile: exact floating-point noding,
    ``grid`` 0, or snap rounded on a ``grid`` of that many map units; linestrings, or
    :class:`PartLines`, their lengths kept in the memo as ``"part_length"``), each part's
    sources given as CSR arrays (``src[ptr[k]:ptr[k + 1]]``, increasing, -1 = wall): its faces
    traced as :func:`arrangement` traces them, or ``traced`` (the faces (:class:`FaceRings`,
    their areas kept in the memo as ``"face_area"``) and the faces on the two sides of each
    part, traced tile by tile: :func:`tether.decomposition.tiles.trace_tile`, and the faces'
    points and free arcs, :class:`tether.decomposition.structure.FaceArcs`, or None: kept in the
    memo as ``"face_arcs"`` for the decomposition)."""
    ends = part_ends(parts)
    fa = None
    if traced is None:  # traced whole, here: on linestrings
        faces, part_faces, segs, _ = _faces(
            parts.lines() if isinstance(parts, PartLines) else parts, ends)
    else:
        (faces, part_faces, fa), segs = traced, part_segments(ends)
    arr = Arrangement(parts, part_faces, ptr, src, faces, grid)
    arr.memo["end_ids"] = (ends[4][: len(parts)], ends[4][len(parts):])  # as end_ids()
    arr.memo["part_segments"] = segs  # for segments(): not made again
    if fa is not None:
        arr.memo["face_arcs"] = fa
    if isinstance(faces, FaceRings):  # the regions are numbered from these: no polygon
        arr.memo["face_area"] = faces.area
    if isinstance(parts, PartLines):  # the lengths the absorb rules compare: no line
        arr.memo["part_length"] = parts.length
    return arr


#: Parts whose sources are looked up per batch (bounds the candidate pairs' memory).
SOURCE_BATCH = 65536
