"""A uniform-grid index of the map's edges, for "which edges are within reach of these points".

Every query in tether is of one shape: many points, one reach (the rod length). A grid whose
cells are a quarter of the reach, with each edge registered in every cell within reach of it,
answers that query for a million points with a few numpy operations and no Python loop. A
point's candidates are the edges within ``reach + cell / sqrt(2)`` of its cell's centre
(``1.18 reach``): on the floor plans 32 per point at 1,000 vertices, against 41 with cells of
half the reach, for a grid still of a few thousand cells.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np
import shapely

from tether._util.arrays import ragged_arange

__all__ = [
    "EdgeIndex", "MAX_BLOCKS_PER_SEGMENT", "MAX_CELLS", "SegmentGrid", "pair_distances",
    "point_segment_distance", "point_segment_distance_xy", "segment_pairs", "segment_tree",
    "segments_near", "z_order"
]

#: Upper bound on the number of grid cells (memory guard for tiny reaches on large maps).
MAX_CELLS = 4_000_000


@dataclass(frozen=True, eq=False)
class EdgeIndex:
    """Edges registered in grid cells; ``query`` returns candidate (point, edge) pairs.

    Every edge within ``reach`` of a point is among its candidates (a superset: callers test
    exactly).
    """

    origin: np.ndarray
    cell: float
    shape: tuple[int, int]
    start: np.ndarray  # CSR offsets, length ncells + 1
    edges: np.ndarray  # edge ids, grouped by cell

    @classmethod
    def build(cls, a: np.ndarray, b: np.ndarray, reach: float) -> EdgeIndex:
        """Index segments ``a[i]-b[i]`` (shape (n, 2)) for queries of radius ``reach``."""
        lo = np.minimum(a, b).min(axis=0) - reach
        hi = np.maximum(a, b).max(axis=0) + reach
        span = hi - lo
        cell = max(reach / 4.0, math.sqrt(span[0] * span[1] / MAX_CELLS), 1e-300)
        nx = max(1, math.ceil(span[0] / cell))
        ny = max(1, math.ceil(span[1] / cell))
        half_diag = cell * math.sqrt(0.5)
        # every (edge, grid cell) pair of the edge's padded box, edges in order (all at once)
        e_lo = (np.minimum(a, b) - reach - lo) / cell
        e_hi = (np.maximum(a, b) + reach - lo) / cell
        x0 = np.maximum(0, e_lo[:, 0].astype(np.int64))
        y0 = np.maximum(0, e_lo[:, 1].astype(np.int64))
        nxe = np.maximum(0, np.minimum(nx, e_hi[:, 0].astype(np.int64) + 1) - x0)
        nye = np.maximum(0, np.minimum(ny, e_hi[:, 1].astype(np.int64) + 1) - y0)
        eid = np.repeat(np.arange(len(a)), nxe * nye)
        k = ragged_arange(np.zeros(len(a), np.int64), nxe * nye)
        gx = x0[eid] + k // nye[eid]
        gy = y0[eid] + k % nye[eid]
        centers = lo + (np.column_stack((gx, gy)) + 0.5) * cell
        keep = _segment_distance_many(centers, a[eid], b[eid]) <= reach + half_diag
        cid, eid = (gx * ny + gy)[keep], eid[keep]
        order = np.argsort(cid, kind="stable")
        counts = np.bincount(cid, minlength=nx * ny)
        start = np.concatenate(([0], np.cumsum(counts)))
        return cls(lo, cell, (nx, ny), start, eid[order])

    def query(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Candidate pairs for points ``pts`` (shape (m, 2)).

        Returns
        -------
        point_idx, edge_idx : ndarray of int
            Row ``k`` says edge ``edge_idx[k]`` may be within reach of point ``point_idx[k]``;
            rows are grouped by point, in increasing point order.
        """
        nx, ny = self.shape
        g = np.floor((pts - self.origin) / self.cell).astype(np.int64)
        gx = np.clip(g[:, 0], 0, nx - 1)
        gy = np.clip(g[:, 1], 0, ny - 1)
        c = gx * ny + gy
        first = self.start[c]
        count = self.start[c + 1] - first
        pidx = np.repeat(np.arange(len(pts)), count)
        # position of each row within its point's run, added to that cell's first entry
        run_start = np.cumsum(count) - count
        within = np.arange(len(pidx)) - np.repeat(run_start, count)
        eidx = self.edges[np.repeat(first, count) + within]
        return pidx, eidx


def _segment_distance_many(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each point ``p[k]`` to the segment ``a[k]-b[k]`` (all (m, 2), map units;
    a point segment gives the distance to its point)."""
    d = b - a
    dd = (d[:, None, :] @ d[:, :, None])[:, 0, 0]  # the bits of d @ d
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dd == 0, 0.0,
                     np.clip(((p - a)[:, None, :] @ d[:, :, None])[:, 0, 0] / dd, 0.0, 1.0))
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)



#: Upper bound on a segment grid's registrations per segment, on average (memory guard: the
#: cells grow until the segments' blocks fit).
MAX_BLOCKS_PER_SEGMENT = 16


class SegmentGrid:
    """Segments ``a[k]-b[k]`` bucketed for "which segments have a bounding box meeting these
    boxes": many boxes of about one size at a time (``STRtree.query`` on rectangles, the
    same pairs).

    For boxes of half-width ``r`` the plane is cut into square cells of side ``c >= 2 r / m``
    and every segment is registered once in each block of ``(m + 1) x (m + 1)`` cells its
    bounding box meets. A box spans at most ``m + 1`` cells a side: one block holds every
    segment whose bounding box meets it, so a query is one lookup per box (no duplicates, no
    merge), then the exact test. The blocks of a size are built on its first query and
    kept (sizes rounded up to 1 %).
    """

    def __init__(self, a: np.ndarray, b: np.ndarray) -> None:
        self.ax, self.ay = np.ascontiguousarray(a[:, 0]), np.ascontiguousarray(a[:, 1])
        bx, by = b[:, 0], b[:, 1]
        #: bounding boxes
        self.x0, self.x1 = np.minimum(self.ax, bx), np.maximum(self.ax, bx)
        self.y0, self.y1 = np.minimum(self.ay, by), np.maximum(self.ay, by)
        #: directions ``b - a`` and squared lengths, as a point-segment distance computes them
        self.ex, self.ey = bx - self.ax, by - self.ay
        self.den = self.ex * self.ex + self.ey * self.ey
        self._blocks: dict[float, _Blocks] = {}
        self._building = threading.Lock()
        self._median: float | None = None

    def __len__(self) -> int:
        return len(self.ax)

    def meeting(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (box index, segment index) of the boxes ``[lo[i], hi[i]]`` (shape (m, 2)
        each) and the segments whose bounding box meets them (bounds included, compared as
        given), each once, grouped by box in increasing order."""
        bi, si = self.candidates(lo, hi)
        meet = self.meets(lo, hi, bi, si)
        meet = np.flatnonzero(meet)
        return bi[meet], si[meet]

    def candidates(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (box index, segment index) among which are those of :meth:`meeting` (and
        more), grouped by box in increasing order, segments increasing within a box."""
        if len(lo) == 0 or len(self) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        bi, si = self.prepare(0.5 * float(np.max(hi - lo, initial=0.0))).query(lo, hi)
        return bi, si.astype(np.int64)

    def prepare(self, half: float) -> _Blocks:
        """The blocks for boxes of half-width ``half`` (map units), built on first use and
        kept (sizes rounded up to 1 %): e.g. built in a thread ahead of the queries."""
        size = 2.0 ** (math.ceil(64 * math.log2(half)) / 64) if half > 0 else 0.0
        blocks = self._blocks.get(size)
        if blocks is None:
            with self._building:  # queries in threads: one build per size
                blocks = self._blocks.get(size)
                if blocks is None:
                    blocks = self._blocks[size] = _Blocks.build(self, size, self._cell())
        return blocks

    def meets(self, lo: np.ndarray, hi: np.ndarray, bi: np.ndarray, si: np.ndarray
              ) -> np.ndarray:
        """Whether segment ``si[k]``'s bounding box meets box ``bi[k]`` (bounds included)."""
        meet = self.x0[si] <= hi[:, 0][bi]
        meet &= self.x1[si] >= lo[:, 0][bi]
        meet &= self.y0[si] <= hi[:, 1][bi]
        meet &= self.y1[si] >= lo[:, 1][bi]
        return meet

    def _cell(self) -> float:
        """The blocks' least cell side (map units): twice the segments' median extent (the
        larger of width and height), where registrations and candidates per box cost about
        alike (measured on the floor plans; boxes wider than that get cells of their
        width)."""
        if self._median is None:
            self._median = 2.0 * float(np.median(np.maximum(self.x1 - self.x0,
                                                            self.y1 - self.y0)))
        return self._median


@dataclass(frozen=True, eq=False)
class _Blocks:
    """The blocks of a :class:`SegmentGrid` for boxes of width at most ``reach`` a side
    (CSR): the plane is cut into square cells of side ``cell`` from ``origin`` (map units),
    and cell ``(i, j)`` holds every segment whose bounding box, grown by ``reach`` to the
    left and below, meets it. The cell of a box's lower left corner then holds every
    segment whose bounding box meets the box. Only cells holding segments are kept: cell
    number ``k = i * shape[1] + j`` is ``block[t]`` (increasing) and its segments are
    ``seg[start[t]:start[t + 1]]``, increasing (sparse: the grid may have millions of cells,
    a small map a few hundred segments)."""

    origin: tuple[float, float]
    cell: float
    reach: float
    shape: tuple[int, int]
    block: np.ndarray
    start: np.ndarray
    seg: np.ndarray
    #: when the grid is small: ``slot[k]`` is ``t`` for block number ``k = block[t]``, -1
    #: for an empty block (a lookup in place of a binary search)
    slot: np.ndarray | None = None

    @classmethod
    def build(cls, grid: SegmentGrid, r: float, cell: float = 0.0) -> _Blocks:
        """The blocks for boxes of half-width at most ``r``, in cells of side at least
        ``cell`` and the boxes' width (grown for rounding)."""
        x0, y0 = float(grid.x0.min()), float(grid.y0.min())
        x1, y1 = float(grid.x1.max()), float(grid.y1.max())
        # box bounds are rounded to the coordinates' precision: the reach allows for that
        ulp = 4 * np.finfo(float).eps * max(abs(x0), abs(y0), abs(x1), abs(y1), 1e-300)
        reach = 1.01 * (2 * r + 2 * ulp)
        ox, oy = x0 - reach, y0 - reach
        span_x, span_y = x1 - ox, y1 - oy
        cell = max(reach, cell, math.sqrt(span_x * span_y / MAX_CELLS),
                   max(span_x, span_y) / MAX_CELLS, 1e-300)
        while True:
            gx0 = np.maximum(((grid.x0 - reach - ox) / cell).astype(np.int64), 0)
            gy0 = np.maximum(((grid.y0 - reach - oy) / cell).astype(np.int64), 0)
            nbx = ((grid.x1 - ox) / cell).astype(np.int64) - gx0 + 1  # cells a side
            nby = ((grid.y1 - oy) / cell).astype(np.int64) - gy0 + 1
            if int((nbx * nby).sum()) <= MAX_BLOCKS_PER_SEGMENT * len(nbx) + 1_000_000:
                break
            cell *= 2
        shape = (int(span_x / cell) + 1, int(span_y / cell) + 1)
        bits = max(1, (len(gx0) - 1).bit_length())
        key = _block_keys(gx0 * shape[1] + gy0, nbx, nby, shape[1], bits)
        key.sort()  # (block, segment) as one integer: a sort of values, fast
        # taken apart in place (the same arrays, fewer temporaries: the keys are up to 16
        # a segment): the segment is the key's low bits (bits <= 31: its low 32 bits
        # masked), the block what the shift leaves
        seg = key.astype(np.int32)
        seg &= np.int32((1 << bits) - 1)
        key >>= bits
        head = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        start = np.append(head, len(key))
        block = key[head]
        del key  # (its length is seg's)
        slot = None
        if shape[0] * shape[1] <= len(seg) + 4096:  # a table no larger than ``seg``
            slot = np.full(shape[0] * shape[1], -1, np.int32)
            slot[block] = np.arange(len(block), dtype=np.int32)
        return cls((ox, oy), cell, reach, shape, block, start, seg, slot)

    def contents(self, k: int) -> np.ndarray:
        """The segments of block number ``k`` (increasing; empty if none)."""
        t = int(np.searchsorted(self.block, k))
        if t == len(self.block) or self.block[t] != k:
            return self.seg[:0]
        return self.seg[self.start[t]:self.start[t + 1]]

    def query(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The segments of each box's block: (box index, segment index). A segment whose
        bounding box meets the box (as compared in floating point) is among them: cell
        numbers grow with the coordinates."""
        (ox, oy), c = self.origin, self.cell
        if np.any(hi - lo > self.reach / 1.01):
            raise ArithmeticError("a box wider than the blocks' reach")
        bi = np.clip(np.floor((lo[:, 0] - ox) / c), 0, self.shape[0] - 1).astype(np.int64)
        bj = np.clip(np.floor((lo[:, 1] - oy) / c), 0, self.shape[1] - 1).astype(np.int64)
        b = bi * self.shape[1] + bj
        if self.slot is not None:
            t = self.slot[b].astype(np.int64)
            held = t >= 0
            t[~held] = 0
        else:
            t = np.searchsorted(self.block, b)
            t = np.minimum(t, len(self.block) - 1)
            held = self.block[t] == b
        first = self.start[t]
        n = np.where(held, self.start[t + 1] - first, 0)
        return np.repeat(np.arange(len(lo)), n), self.seg[ragged_arange(first, n)]


def _block_keys(first: np.ndarray, nbx: np.ndarray, nby: np.ndarray, stride: int, bits: int
                ) -> np.ndarray:
    """Every (block, segment) pair as the integer ``block << bits | segment`` (segments
    below ``2 ** bits``; shifts, not divisions, take it apart): segment ``k``'s blocks are
    ``first[k] + i * stride + j`` for ``i < nbx[k]``, ``j < nby[k]``. Segments of one shape
    ``(nbx, nby)`` at a time (a few shapes hold nearly all segments)."""
    n = len(first)
    base = (first << bits) | np.arange(n)
    code = nbx * (int(nby.max()) + 1) + nby
    order = np.argsort(code, kind="stable")
    run = np.flatnonzero(np.r_[True, code[order][1:] != code[order][:-1], True])
    out = np.empty(int((nbx * nby).sum()), np.int64)  # written in place, run by run
    at = 0
    for lo, hi in zip(run[:-1].tolist(), run[1:].tolist(), strict=True):
        segs = order[lo:hi]
        p, q = int(nbx[segs[0]]), int(nby[segs[0]])
        offs = ((np.arange(p) * stride)[:, None] + np.arange(q)).ravel() << bits
        np.add(base[segs][:, None], offs, out=out[at:at + len(segs) * len(offs)].reshape(
            len(segs), len(offs)))
        at += len(segs) * len(offs)
    return out


def z_order(pts: np.ndarray, cell: float) -> np.ndarray:
    """An order of the points (m, 2) along a Z curve over square cells of side ``cell`` (map
    units; stable within a cell): runs of it are compact patches of the plane, so a batch of
    queries reads a small part of a grid's arrays (cache hits)."""
    if len(pts) == 0:
        return np.zeros(0, np.int64)
    g = np.clip((pts - pts.min(axis=0)) / cell, 0, 2**31 - 1).astype(np.int64)
    return np.argsort(_spread_bits(g[:, 0]) | (_spread_bits(g[:, 1]) << 1), kind="stable")


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """Bit ``i`` of each value (below ``2**32``) moved to bit ``2 i``."""
    v = v.astype(np.uint64)
    for shift, mask in ((16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF),
                        (4, 0x0F0F0F0F0F0F0F0F), (2, 0x3333333333333333),
                        (1, 0x5555555555555555)):
        v = (v | (v << np.uint64(shift))) & np.uint64(mask)
    return v


def segment_tree(a: np.ndarray, b: np.ndarray) -> shapely.STRtree:
    """An STRtree of the segments ``a[k]-b[k]``."""
    return shapely.STRtree(shapely.linestrings(np.stack((a, b), axis=1)))


def segments_near(pts: np.ndarray, a: np.ndarray, b: np.ndarray, reach: float,
                  tree: shapely.STRtree | SegmentGrid
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs (point, segment) closer than ``reach`` (map units) for points (m, 2) and
    segments ``a[k]-b[k]`` indexed by ``tree`` (an STRtree or, faster, a
    :class:`SegmentGrid`; the same pairs): point indices, segment indices, distances."""
    if len(pts) == 0 or len(a) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    qi, si = segment_pairs(pts, reach, tree)  # envelopes only; exact distances below
    if isinstance(tree, SegmentGrid):
        d = pair_distances(pts[:, 0][qi], pts[:, 1][qi], tree, si)
    else:
        d = point_segment_distance_xy(pts[:, 0][qi], pts[:, 1][qi], a[:, 0][si],
                                      a[:, 1][si], b[:, 0][si], b[:, 1][si])
    near = np.flatnonzero(d <= reach)
    return qi[near], si[near], d[near]


def segment_pairs(pts: np.ndarray, reach: float, tree: shapely.STRtree | SegmentGrid
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (point, segment) of the points (m, 2) and the segments indexed by ``tree``
    whose bounding box meets the point's box ``[p - reach, p + reach]``: an STRtree's
    answer, or a :class:`SegmentGrid`'s (the same pairs, without making the boxes)."""
    if isinstance(tree, SegmentGrid):
        return tree.meeting(pts - reach, pts + reach)
    box = shapely.box(pts[:, 0] - reach, pts[:, 1] - reach, pts[:, 0] + reach,
                      pts[:, 1] + reach)
    qi, si = tree.query(box)
    return qi, si


def pair_distances(px: np.ndarray, py: np.ndarray, grid: SegmentGrid, si: np.ndarray
                   ) -> np.ndarray:
    """:func:`point_segment_distance_xy` from points ``(px[k], py[k])`` to the grid's
    segments ``si[k]`` (the same numbers: the segments' directions and squared lengths are
    the grid's, computed alike once per segment), in place on few temporaries."""
    ax, ay, ex, ey, den = grid.ax[si], grid.ay[si], grid.ex[si], grid.ey[si], grid.den[si]
    u = px - ax
    u *= ex
    t = py - ay
    t *= ey
    u += t
    with np.errstate(invalid="ignore", divide="ignore"):
        u /= den
    u[~(den > 0)] = 0.0
    np.clip(u, 0.0, 1.0, out=u)
    np.multiply(u, ey, out=t)
    t += ay
    t -= py
    u *= ex
    u += ax
    u -= px
    return np.hypot(u, t, out=u)


def point_segment_distance_xy(px: np.ndarray, py: np.ndarray, ax: np.ndarray,
                              ay: np.ndarray, bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    """:func:`point_segment_distance` on coordinate columns (the same numbers, without the
    (k, 2) temporaries)."""
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(den > 0, ((px - ax) * abx + (py - ay) * aby) / den, 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.hypot(ax + u * abx - px, ay + u * aby - py)


def point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise distance from points ``p`` to segments ``a-b`` (all shape (k, 2))."""
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(den > 0, np.einsum("ij,ij->i", p - a, ab) / den, 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.hypot(*(a + u[:, None] * ab - p).T)
