"""One map's arrangement noded in tiles, the tiles processed by any executor.

The plane is cut into a grid of ``nx x ny`` tiles by vertical and horizontal lines placed
strictly between the coordinates of the input vertices (:func:`cut_positions`), so that no
vertex of a ring or a curve polyline, no wall and no straight curve lies on a cut. Every input
segment crossing a cut gets a vertex exactly on it (:func:`clip_to_tiles`; the vertical cuts
first, then the horizontal ones): computed once, from the segment's lexicographically smaller
end (a segment and its reverse get the same vertex), its other coordinate clamped to the
segment's range, and used by the pieces on both sides, so the cut vertices of two neighbouring
tiles are bit-identical. Each tile's pieces are noded on their own (GEOS's floating-point noder) and
each noded part gets its source curves there (:func:`node_tile`); pieces of different tiles
meet only at those shared vertices, so the parts of all tiles together are a noding of the
whole input: the same lines and intersections, with one more degree-2 vertex where a line
crosses a cut (as the two strips of :mod:`tether.decomposition.noding`). The faces are then
traced on all the parts at once (:func:`tether.decomposition.arrangement.traced_arrangement`)
and the regions, structures and pieces follow as for the whole: a tile's cut is no critical
curve, so a face cut in two by it is one face again.

Two exact rules at the cuts. Cut vertices of one cut whose other coordinate differs by at most
:data:`CUT_MERGE_ULPS` units in the last place are made one (the smallest): two lines crossing
each other exactly on a cut, whose vertices there were rounded apart, meet at one node as in
the whole noding. If GEOS's floating-point noder fails in any tile, the whole input is noded
as without tiles (snap rounding then applies to the whole, never to one tile).

A tile's task gets only its pieces and the input segments within the sources' reach of it, and
returns compact arrays (part coordinates and counts, part sources as CSR arrays): never the
map's objects. Tiles run on any :class:`concurrent.futures.Executor` (local processes, a Dask
cluster's ``Client.get_executor()``, or threads); the result does not depend on which.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.errors import GEOSException

from tether._util.arrays import components, first_max_per_group, ragged_arange, row_ids
from tether._util.threads import single_threaded, thread_count
from tether.decomposition.arrangement import SOURCE_BATCH
from tether.decomposition.faces import part_ends, part_segments
from tether.decomposition.noding import node_floating
from tether.errors import InvalidParameterError
from tether.spatial import SegmentGrid, segments_near

__all__ = ["CUT_FRACTION", "CUT_MERGE_ULPS", "MAX_TILES", "TILE_SEGMENTS", "TileGrid",
           "auto_tiles", "check_tiles", "clip_to_tiles", "cut_positions", "dissolve_cut_vertices",
           "node_tile",
           "process_executor", "tile_grid", "tiled_noder"]

#: Input segments per tile aimed at when the tiles are chosen automatically (``"auto"``):
#: GEOS's noder takes ~4 us per segment, so ~1 s of noding per tile.
TILE_SEGMENTS = 250_000

#: The most tiles chosen automatically, and the most a grid may have (``nx * ny``).
MAX_TILES = 64

#: Where a cut lies in the widest gap between two vertex coordinates (as a fraction of the
#: gap from its lower end): not the middle, where a symmetric map's mirror-image curves cross.
CUT_FRACTION = math.sqrt(2.0) - 1.0

#: Cut vertices of one cut closer than this many units in the last place (of their other
#: coordinate) are made one: the same crossing, rounded apart.
CUT_MERGE_ULPS = 8

#: The central fraction of a cut's share of the vertex ranks searched for the widest gap.
_CUT_WINDOW = 0.25


@dataclass(frozen=True)
class TileGrid:
    """The cuts of a grid of tiles (map units, increasing): tile ``(i, j)`` is column ``i``
    (between ``xcuts[i - 1]`` and ``xcuts[i]``, unbounded at the ends) and row ``j``, and has
    the id ``i * ny + j``."""

    xcuts: np.ndarray
    ycuts: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """``(nx, ny)``: columns and rows."""
        return len(self.xcuts) + 1, len(self.ycuts) + 1

    @property
    def count(self) -> int:
        """Number of tiles."""
        return self.shape[0] * self.shape[1]

    def tile_of(self, pts: np.ndarray) -> np.ndarray:
        """The tile id of each point (m, 2); a point on a cut goes above/right of it."""
        return (np.searchsorted(self.xcuts, pts[:, 0], "right") * self.shape[1]
                + np.searchsorted(self.ycuts, pts[:, 1], "right"))


def check_tiles(tiles: Any) -> tuple[int, int] | str:
    """``tiles`` validated: ``"auto"`` or a pair of positive integers ``(nx, ny)`` with at most
    :data:`MAX_TILES` tiles; an ``"NXxNY"`` string is read as the pair.

    Raises
    ------
    InvalidParameterError
        If ``tiles`` is none of these.
    """
    given = tiles
    if isinstance(tiles, str) and tiles != "auto":
        nums = tiles.lower().split("x")
        if len(nums) != 2 or not all(s.strip().isdigit() for s in nums):
            raise InvalidParameterError(f"tiles must be 'auto' or NXxNY (e.g. 3x2), got "
                                        f"{tiles!r}")
        tiles = (int(nums[0]), int(nums[1]))
    if tiles == "auto":
        return "auto"
    try:
        nx, ny = (int(v) for v in tiles)
        ok = (nx, ny) == tuple(tiles)
    except (TypeError, ValueError):
        ok = False
    if not ok or nx < 1 or ny < 1 or nx * ny > MAX_TILES:
        raise InvalidParameterError(f"tiles must be 'auto' or two positive integers (nx, ny) "
                                    f"with nx * ny <= {MAX_TILES}, got {given!r}")
    return nx, ny


def auto_tiles(segments: int, width: float, height: float) -> tuple[int, int]:
    """The grid for ``segments`` input segments over a ``width x height`` box: about
    :data:`TILE_SEGMENTS` segments per tile (at most :data:`MAX_TILES` tiles), the tiles about
    square. Depends on the input's size only, never on the number of workers."""
    n = min(max(math.ceil(segments / TILE_SEGMENTS), 1), MAX_TILES)
    aspect = width / height if width > 0 and height > 0 else 1.0
    nx = min(max(round(math.sqrt(n * aspect)), 1), n)
    ny = math.ceil(n / nx)
    while nx * ny > MAX_TILES:
        ny -= 1
    return nx, ny


def cut_positions(values: np.ndarray, n: int) -> np.ndarray:
    """Up to ``n - 1`` increasing cuts, each strictly between two of ``values`` (map units):
    cut ``k`` in the widest gap between consecutive distinct values ranked within
    :data:`_CUT_WINDOW` of ``k / n`` of them (tiles of about equal vertex counts), at
    :data:`CUT_FRACTION` of that gap. Fewer if there are too few distinct values."""
    u = np.unique(values)
    m = len(u) - 1  # gaps
    cuts = []
    for k in range(1, n):
        lo = max(int(math.floor((k - _CUT_WINDOW) / n * m)), 0)
        hi = min(int(math.ceil((k + _CUT_WINDOW) / n * m)), m)
        if hi <= lo:
            continue
        i = lo + int(np.argmax(np.diff(u[lo:hi + 1])))
        c = u[i] + CUT_FRACTION * (u[i + 1] - u[i])
        if not u[i] < c < u[i + 1]:
            c = 0.5 * (u[i] + u[i + 1])
        if u[i] < c < u[i + 1]:
            cuts.append(c)
    return np.unique(np.asarray(cuts, dtype=float))


def tile_grid(xy: np.ndarray, tiles: tuple[int, int]) -> TileGrid:
    """The grid of ``tiles = (nx, ny)`` over the vertices ``xy`` (:func:`cut_positions` in x
    and in y): no vertex on a cut."""
    return TileGrid(cut_positions(xy[:, 0], tiles[0]), cut_positions(xy[:, 1], tiles[1]))


def clip_to_tiles(xy: np.ndarray, line: np.ndarray, grid: TileGrid
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines (vertices ``xy`` of lines ``line``, consecutive) cut into pieces, one tile
    each: every segment crossing a cut gets a vertex exactly on it, shared by the pieces on
    both sides (:func:`_cut_along`: the vertical cuts first, then the horizontal ones on the
    segments so cut). Zero-length segments are dropped; each segment lies in its tile's
    closed box. Returns the pieces' vertices, their
    CSR pointer (piece ``p`` is ``pxy[ptr[p]:ptr[p + 1]]``) and each piece's tile."""
    xy, line = _cut_along(xy, line, grid.xcuts, 0)
    xy, line = _cut_along(xy, line, grid.ycuts, 1)
    k = np.flatnonzero(line[1:] == line[:-1])  # segments k -> k + 1
    k = k[np.any(xy[k] != xy[k + 1], axis=1)]  # zero-length segments dropped
    if len(k) == 0:
        return np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.int64)
    # no cut strictly inside a segment's box now: the tile holding its lower left corner
    # (above/right of a cut through it) is the one whose closed box holds the segment
    tile = grid.tile_of(np.minimum(np.take(xy, k, axis=0), np.take(xy, k + 1, axis=0)))
    brk = np.r_[True, (line[k[1:]] != line[k[:-1]]) | (tile[1:] != tile[:-1])]
    piece = np.cumsum(brk) - 1
    last = np.flatnonzero(np.r_[brk[1:], True])
    pxy = np.empty((len(k) + len(last), 2))
    pxy[np.arange(len(k)) + piece] = np.take(xy, k, axis=0)
    pxy[last + piece[last] + 1] = np.take(xy, k[last] + 1, axis=0)
    ptr = np.r_[0, np.cumsum(np.bincount(piece, minlength=len(last)) + 1)]
    return pxy, ptr, tile[brk]


def _cut_along(xy: np.ndarray, line: np.ndarray, cuts: np.ndarray, axis: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """The lines with a vertex inserted where a segment crosses a cut ``cuts`` (increasing)
    of coordinate ``axis`` (0: vertical cuts ``x = c``, 1: horizontal): its ``axis``
    coordinate exactly the cut's, the other interpolated from the segment's lexicographically
    smaller end (a segment and its reverse get the same vertex) and clamped to the segment's
    range (never past its ends by rounding). Vertices of one cut whose other coordinates are
    within :data:`CUT_MERGE_ULPS` are made one (:func:`_merge_cut_vertices`). Returns the new
    vertices and their lines."""
    if len(cuts) == 0:
        return xy, line
    k = np.flatnonzero(line[1:] == line[:-1])  # segments k -> k + 1
    a, b = np.take(xy, k, axis=0), np.take(xy, k + 1, axis=0)
    ca, cb = np.searchsorted(cuts, a[:, axis]), np.searchsorted(cuts, b[:, axis])
    count = np.abs(cb - ca)
    if not count.any():
        return xy, line
    s = np.repeat(np.arange(len(k)), count)
    c = ragged_arange(np.minimum(ca, cb)[count > 0], count[count > 0])
    a, b = a[s], b[s]
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    lo, hi = np.where(swap[:, None], b, a), np.where(swap[:, None], a, b)
    cv = cuts[c]
    other = 1 - axis
    u = (cv - lo[:, axis]) / (hi[:, axis] - lo[:, axis])
    p = np.empty((len(s), 2))
    p[:, axis] = cv
    p[:, other] = np.clip(lo[:, other] + u * (hi[:, other] - lo[:, other]),
                          np.minimum(lo[:, other], hi[:, other]),
                          np.maximum(lo[:, other], hi[:, other]))
    _merge_cut_vertices(p[:, other], c)
    t = (cv - a[:, axis]) / (b[:, axis] - a[:, axis])  # the order along the segment a -> b
    o = np.lexsort((t, s))
    at = k[s[o]] + 1
    return np.insert(xy, at, p[o], axis=0), np.insert(line, at, line[at - 1])


def _merge_cut_vertices(along: np.ndarray, cut: np.ndarray) -> None:
    """Make the cut vertices of each cut (ids ``cut``) whose coordinate along the cut
    (``along``) differs from the previous one's by at most :data:`CUT_MERGE_ULPS` units in the
    last place one: each run of such vertices takes the run's smallest coordinate (in
    place)."""
    o = np.lexsort((along, cut))
    v, c = along[o], cut[o]
    near = (c[1:] == c[:-1]) & (v[1:] - v[:-1] <= CUT_MERGE_ULPS * np.spacing(np.abs(v[1:])))
    if not near.any():
        return
    run = np.cumsum(np.r_[True, ~near]) - 1
    along[o] = v[np.flatnonzero(np.r_[True, ~near])][run]


def _segments_by_tile(la: np.ndarray, lb: np.ndarray, grid: TileGrid, reach: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The input segments ``la-lb`` whose bounding boxes, grown by ``reach``, meet each
    tile's (closed) box: segment indices tile after tile, and the CSR pointer over tiles."""
    nx, ny = grid.shape
    lo, hi = np.minimum(la, lb) - reach, np.maximum(la, lb) + reach
    ix0, ix1 = np.searchsorted(grid.xcuts, lo[:, 0]), np.searchsorted(grid.xcuts, hi[:, 0],
                                                                      "right")
    iy0, iy1 = np.searchsorted(grid.ycuts, lo[:, 1]), np.searchsorted(grid.ycuts, hi[:, 1],
                                                                      "right")
    cols, rows = ix1 - ix0 + 1, iy1 - iy0 + 1
    count = cols * rows
    s = np.repeat(np.arange(len(la)), count)
    j = ragged_arange(np.zeros(len(la), np.int64), count)
    tile = (ix0[s] + j // rows[s]) * ny + iy0[s] + j % rows[s]
    o = np.argsort(tile, kind="stable")
    return s[o], np.searchsorted(tile[o], np.arange(nx * ny + 1))


def part_sources(mid: np.ndarray, la: np.ndarray, lb: np.ndarray, lsrc: np.ndarray,
                 reach: float) -> tuple[np.ndarray, np.ndarray]:
    """The sources of parts (``mid``: a point of each part, the middle of its longest
    segment): the source ids ``lsrc`` (-1 = wall) of the input segments ``la-lb`` within
    ``reach`` (map units) of it, as :func:`tether.decomposition.arrangement.arrangement`
    finds them; CSR arrays ``(ptr, src)`` (each part's increasing, distinct)."""
    base = int(lsrc.max(initial=0)) + 2  # sources are -1 (wall) .. max
    tree = SegmentGrid(la, lb)
    keys = []
    for lo in range(0, len(mid), SOURCE_BATCH):  # bounded candidate pairs
        qi, si, _ = segments_near(mid[lo:lo + SOURCE_BATCH], la, lb, reach, tree)
        keys.append((qi + lo).astype(np.int64) * base + lsrc[si] + 1)
    key = np.sort(np.concatenate(keys)) if keys else np.zeros(0, np.int64)
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
    part_of, src = np.divmod(key, base)
    return np.searchsorted(part_of, np.arange(len(mid) + 1)), src - 1


def node_tile(pxy: np.ndarray, ptr: np.ndarray, la: np.ndarray, lb: np.ndarray,
              lsrc: np.ndarray, reach: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int] | None:
    """A tile's task: its pieces (vertices ``pxy``, CSR ``ptr``) noded by GEOS's
    floating-point noder, and each part's sources among the input segments ``la-lb`` (source
    ids ``lsrc``) within ``reach`` of the tile. Returns the parts' vertices and vertex counts,
    their sources (CSR ``(ptr, src)``) and this process's peak resident memory (bytes, 0 where
    unknown); None if the noder fails."""
    n = len(ptr) - 1
    if n == 0:
        empty = np.zeros(0, np.int64)
        return np.zeros((0, 2)), empty, np.zeros(1, np.int64), empty, _peak_rss()
    lines = shapely.linestrings(pxy, indices=np.repeat(np.arange(n), np.diff(ptr)))
    try:
        parts = node_floating(np.asarray(lines, dtype=object))
    except GEOSException:
        return None
    del lines
    parts = parts[shapely.length(parts) > 0]
    ends = part_ends(parts)
    pa, pb, powner = part_segments(ends)
    longest = first_max_per_group(np.hypot(*(pb - pa).T), powner)
    mid = 0.5 * (np.take(pa, longest, axis=0) + np.take(pb, longest, axis=0))
    del pa, pb, powner
    sptr, src = part_sources(mid, la, lb, lsrc, reach)
    return ends[0], ends[1], sptr, src, _peak_rss()


def _peak_rss() -> int:
    """The peak resident memory of the calling process, bytes (0 where unknown)."""
    try:
        import resource
    except ImportError:  # not on Unix
        return 0
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def process_executor(workers: int | None = None) -> ProcessPoolExecutor:
    """Local worker processes for the tiles (``workers``: by default the cores this process
    may use), started fresh (``spawn``: nothing of this process's memory inherited), each
    computing in one thread."""
    return ProcessPoolExecutor(max_workers=workers or thread_count(),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=single_threaded)


def tiled_noder(tiles: tuple[int, int] | str, executor: Executor, tol: float,
                progress: Callable[[str, float], Any] | None = None,
                log: dict | None = None) -> Callable[..., Any]:
    """The ``noder`` of :func:`tether.decomposition.arrangement.arrangement` that nodes its
    input in ``tiles`` (``(nx, ny)`` or ``"auto"``: :func:`auto_tiles`) on ``executor``.
    ``tol``: the curve tolerance (map units; the sources' reach is ``1e-3 tol`` as for the
    whole). ``progress`` gets ``("tiles (NXxNY)", overall fraction)`` as tiles finish, then
    ``("stitch", 0.45)`` (the parts joined, the faces traced on them all); ``log``, if given, gets
    ``tiles`` (the grid's shape), ``worker_peak_bytes`` (the largest peak resident memory a
    tile's process reported) and ``fallback`` (True if the input was noded whole)."""
    report = progress or (lambda stage, frac: None)
    log = {} if log is None else log

    def noder(lines: np.ndarray, source: np.ndarray, segs: tuple) -> tuple | None:
        la, lb, lowner = segs
        xy, line = shapely.get_coordinates(lines, return_index=True)
        shape = tiles
        if shape == "auto":
            span = xy.max(axis=0) - xy.min(axis=0) if len(xy) else np.ones(2)
            shape = auto_tiles(len(la), float(span[0]), float(span[1]))
        grid = tile_grid(xy, shape)
        log["tiles"] = grid.shape
        pxy, pptr, ptile = clip_to_tiles(xy, line, grid)
        del xy, line
        reach = max(1e-3 * tol, 1e-12)
        lsrc = source[lowner]
        near, nptr = _segments_by_tile(la, lb, grid, reach)
        order = np.argsort(ptile, kind="stable")  # pieces tile after tile
        tptr = np.searchsorted(ptile[order], np.arange(grid.count + 1))
        size = np.diff(pptr)
        futures = []
        for t in range(grid.count):
            mine = order[tptr[t]:tptr[t + 1]]
            rows = ragged_arange(pptr[mine], size[mine])
            s = near[nptr[t]:nptr[t + 1]]
            futures.append(executor.submit(node_tile, pxy[rows],
                                           np.r_[0, np.cumsum(size[mine])], la[s], lb[s],
                                           lsrc[s], reach))
        del pxy, near
        got = []
        stage = f"tiles ({grid.shape[0]}x{grid.shape[1]})"
        for i, f in enumerate(futures):
            got.append(f.result())
            report(stage, 0.3 + 0.15 * (i + 1) / len(futures))
        report("stitch", 0.45)
        log["worker_peak_bytes"] = max((r[4] for r in got if r is not None), default=0)
        log["fallback"] = any(r is None for r in got)
        if log["fallback"]:
            return None
        return dissolve_cut_vertices(*_stitched(got), grid)

    return noder


def _stitched(got: list[tuple]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tiles' parts one after the other, as linestrings, and their sources (CSR)."""
    coords = np.concatenate([r[0] for r in got])
    count = np.concatenate([r[1] for r in got])
    parts = np.asarray(shapely.linestrings(coords, indices=np.repeat(np.arange(len(count)),
                                                                     count)), dtype=object)
    src = np.concatenate([r[3] for r in got])
    offsets = np.cumsum([0] + [len(r[3]) for r in got[:-1]])
    ptr = np.concatenate([np.zeros(1, np.int64)] + [r[2][1:] + o for r, o in
                                                    zip(got, offsets, strict=True)])
    return parts, ptr, src.astype(np.int64)


def dissolve_cut_vertices(parts: np.ndarray, ptr: np.ndarray, src: np.ndarray, grid: TileGrid
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts of all tiles with the cut vertices that no other line passes through taken
    out: parts meeting end to end at a vertex lying exactly on a cut, where no other part
    ends (the two halves of one input segment), are joined and that vertex dropped, so the
    faces' rings have the vertices of the whole noding (a face's interior point, read from
    its ring, is then the same). Each joined part's sources are the union of its halves'.
    Returns ``(parts, ptr, src)`` as given, the joined parts after the others."""
    coords, count, start, last, ends = part_ends(parts)
    n = len(parts)
    if n == 0 or grid.count == 1:
        return parts, ptr, src
    node_xy = np.empty((int(ends.max()) + 1, 2))
    node_xy[ends] = np.take(coords, np.r_[start, last], axis=0)
    on_cut = np.isin(node_xy[:, 0], grid.xcuts) | np.isin(node_xy[:, 1], grid.ycuts)
    degree = np.bincount(ends, minlength=len(node_xy))
    gone = on_cut & (degree == 2)
    # a part closed on itself at such a vertex keeps it (its two ends are the vertex's two)
    closed = ends[:n] == ends[n:]
    gone[ends[:n][closed]] = False
    if not gone.any():
        return parts, ptr, src
    end_part = np.tile(np.arange(n), 2)
    at = np.flatnonzero(gone[ends])  # part ends at dissolved vertices, two per vertex
    o = at[np.argsort(ends[at], kind="stable")]
    u, v = end_part[o[0::2]], end_part[o[1::2]]
    comp = components(n, u, v)
    joined = np.zeros(n, bool)
    joined[u] = joined[v] = True
    keep = np.flatnonzero(~joined)
    rows = np.flatnonzero(joined)
    label = np.unique(comp[rows], return_inverse=True)[1].ravel()
    o = np.argsort(label, kind="stable")  # each joined part's halves together
    rows, label = rows[o], label[o]
    merged = shapely.line_merge(shapely.multilinestrings(parts[rows], indices=label))
    xy, idx = shapely.get_coordinates(merged, return_index=True)
    gxy = node_xy[gone]
    ids = row_ids(np.vstack((gxy, xy)))[0]
    dissolved = np.isin(ids[len(gxy):], ids[:len(gxy)])
    head = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    tail = np.r_[head[1:], len(idx)] - 1
    # a closed line merged around a loop starts where line_merge chose: at a kept vertex
    # instead (a dissolved one is never a part's end)
    for h, t in zip(head.tolist(), tail.tolist(), strict=True):
        if dissolved[h] and np.array_equal(xy[h], xy[t]) and not dissolved[h:t].all():
            k = h + int(np.argmin(dissolved[h:t]))
            ring = np.r_[np.arange(k, t), np.arange(h, k + 1)]
            xy[h:t + 1], dissolved[h:t + 1] = xy[ring], dissolved[ring]
    drop = dissolved.copy()
    drop[head] = drop[tail] = False  # a line's ends stay
    new = np.asarray(shapely.linestrings(xy[~drop], indices=idx[~drop]), dtype=object)
    # sources: the union over each joined part's halves
    nsrc = np.diff(ptr)
    base = int(src.max(initial=0)) + 2
    key = np.sort(np.repeat(label, nsrc[rows]).astype(np.int64) * base
                  + src[ragged_arange(ptr[rows], nsrc[rows])] + 1)
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
    grp, jsrc = np.divmod(key, base)
    jptr = np.searchsorted(grp, np.arange(len(new) + 1))
    ksrc = src[ragged_arange(ptr[keep], nsrc[keep])]
    kptr = np.r_[0, np.cumsum(nsrc[keep])]
    return (np.concatenate((parts[keep], new)), np.r_[kptr, kptr[-1] + jptr[1:]],
            np.concatenate((ksrc, jsrc - 1)).astype(np.int64))
