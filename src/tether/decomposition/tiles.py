"""One map's arrangement noded in tiles, the tiles processed by any executor.

The plane is cut into a grid of ``nx x ny`` tiles by vertical and horizontal lines placed
strictly between the coordinates of the input vertices (:func:`cut_positions`). No input
segment is split at a cut: splitting one moves the line a crossing is computed on by a few
units in the last place, and where three curves meet at one point (an edge's offset, a
vertex's arc and a corner curve, tangent at one point by construction) GEOS's noder makes a
tiny cluster of nodes there whose shape follows those last bits, and a sliver face whose
region, and so the pieces around it, changed with them.

Instead each tile's task gets, whole and as runs of consecutive segments of one line
(:func:`runs_of`), every input segment whose bounding box meets the tile's box grown by twice
the margin (:data:`TILE_MARGIN`): its *trust box* is the tile's box grown by the margin once.
GEOS computes a crossing from the two whole input segments (exactly the same in either order),
so a noded part lying in the trust box, which every segment that can cross it reaches, is the
whole noding's part bit for bit: its ends, its vertices, its direction (a duplicate from
another line is dropped as in the whole: the first line's copy is kept). Each part is delivered
once, by the tile holding its *anchor* (its lexicographically smaller end,
:meth:`TileGrid.tile_of`), with its sources found as the whole finds them. A part the tile
cannot vouch for (longer than the margin, crossing out of the trust box) is retried: the parts
at its ends in that tile are delivered by a task on the box around it grown by twice the
margin, then four times, ... until each is trusted (:func:`tiled_noder`). The parts of all
tasks are then exactly the whole noding's parts, with the same sources, in another order.

The faces are traced in tiles as well (:func:`trace_tile`, a second round of tasks on a grid
of the parts): a task gets the parts whose boxes meet its tile grown by twice a margin, and
delivers the faces it can vouch for whose *anchor* (the lexicographically smallest point of
the face's shell) lies in its tile. The boundary walks of the planar map of all the
half-edges (dangles and cut edges included: *raw walks*) are local, the step at a node seeing
only the parts ending there; a raw walk inside the tile grown by the margin is the whole's,
and a face all of whose rings lie on such walks is the whole's face, ring for ring
(:func:`tether.decomposition.faces.local_faces`). The anchors of the faces a task cannot vouch
for are retried in larger regions around them, as the noding's parts are; the faces and the
faces on the two sides of every part are then the whole's, in another order, and the regions,
structures and pieces follow as for the whole
(:func:`tether.decomposition.arrangement.traced_arrangement`).

The exactness holds for GEOS's first noding pass. GEOS repeats the noding on its own output
until no new crossing appears (new crossings arise only within a few units in the last place
of clustered nodes); a later pass sees the parts of the whole input only within the margin of
the part, so it could differ where a node-free stretch of a line longer than the margin runs
through such a cluster near a tile's border. Where the whole's floating-point noder would
fail but every tile's succeeds, the tiled result is the floating-point noding and the
untiled one snap rounded.

**Snap rounding in tiles.** If GEOS's floating-point noder fails in any task, the tasks not
started are cancelled and the input is snap rounded in tiles, never noded whole in this
process: the input's own segments (no strip cut: the untiled fallback rounds the whole
input), on the grid ``SNAP_GRIDS[0] * tol`` of
:func:`tether.decomposition.noding.node_lines`, the same for every task (a coarser one, for
all tasks again, only if a task fails on a finer one). Each task rounds its runs' vertices
to the grid and nodes them with GEOS's fixed-precision union
(:func:`tether.decomposition.noding.node_snapped`, as the whole): *hot pixels* (grid cells)
at every rounded vertex and at every crossing of two rounded segments, each segment noded at
every hot pixel it passes through and at vertices within a fraction of a pixel, in one pass
(snap rounding does not iterate), duplicate edges made one keeping the first's direction, and
one part per edge, from node to node (a line's own ends stay nodes, lines are never merged at
a degree-2 node). A part therefore depends only on the input segments it comes from (within
0.71 pixel of it) and on the hot pixels within a pixel of those, which vertices and crossings
of segments within about two pixels of the part make. The margin is at least
:data:`SNAP_MARGIN_PIXELS` pixels (and ``4 reach``, the sources' reach ``1e-3 tol + 2 grid``
as for the whole), so a part in the trust region sees exactly the whole's segments near it,
whole and in the input's order: its vertices and ends are the whole's, bit for bit, and so is
its direction (the first copy of a duplicated edge is the first line's in both). A run's ends
(a line's ends in the task only) lie beyond the margin of the trust region, so no node made
by the cut lies in it and no part is split there that the whole does not split. The parts
delivered, with the same ownership and retries as above, are the untiled snap-rounded
noding's parts (``node_lines`` on the same input, when it snap rounds on the same grid) bit
for bit, with the same sources, in another order; the faces, regions, pieces and G follow as
for the whole, the noding's grid passed on to the faces' points
(:func:`tether.decomposition.structure.face_arcs`) and to the arrangement
(:attr:`tether.decomposition.arrangement.Arrangement.grid`). The two can differ only where the
whole and the tiles do not round on the same grid or do not both round: the whole's
floating-point noder succeeding where a task's fails (then the whole is the floating-point
noding), or GEOS's snap rounding failing on a grid in a task but not in the whole, or the
reverse. If a task fails even on the coarsest grid, :class:`tether.errors.ArrangementError`
(as the whole's noding would raise).

A task gets only its runs and returns compact arrays (part coordinates and counts, part
sources as CSR arrays, the anchors to retry): never the map's objects. Tasks run on any
:class:`concurrent.futures.Executor` (local processes, a Dask cluster's
``Client.get_executor()``, or threads); the result does not depend on which.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import shapely
from shapely.errors import GEOSException

from tether._util.arrays import first_max_per_group, ragged_arange, row_ids
from tether._util.memory import release_memory
from tether._util.threads import single_threaded, thread_count
from tether.curves import Curve
from tether.decomposition import noding
from tether.decomposition.arrangement import SOURCE_BATCH, Chains
from tether.decomposition.faces import (
    FaceRings,
    PartLines,
    local_faces,
    part_ends,
    part_segments,
)
from tether.decomposition.noding import SNAP_GRIDS, node_floating, node_snapped
from tether.decomposition.pieces import Candidates, chain_crossings, joined_crossings
from tether.decomposition.structure import FaceArcs, StructureRows, face_arcs
from tether.errors import ArrangementError, InvalidParameterError
from tether.spatial import SegmentGrid, segments_near

__all__ = ["CUT_FRACTION", "FACE_MARGIN", "MASK_CELLS", "MAX_TILES", "PIECE_TILE_CHAINS",
           "SNAP_MARGIN_PIXELS", "SNAP_MAX_TILES", "SNAP_TILE_SEGMENTS", "TILE_MARGIN",
           "TILE_SEGMENTS",
           "CellMask", "TileGrid", "auto_tiles", "check_tiles", "cut_positions", "grown",
           "mask_around", "node_tile", "part_sources", "pieces_tile", "process_executor",
           "runs_of", "segments_by_tile", "tile_box", "tile_grid", "tiled_crossings",
           "tiled_noder", "trace_tile", "trimmed"]

#: Input segments per tile aimed at when the tiles are chosen automatically (``"auto"``):
#: GEOS's noder takes ~4 us per segment, so ~1 s of noding per tile.
TILE_SEGMENTS = 250_000

#: Input segments per tile aimed at when snap-rounding tasks are tiled automatically: most
#: of a snap-rounding task's time is GEOS's hot-pixel k-d tree queried with each segment's
#: bounding box, bound by cache misses (the tree of a 250,000-segment task is tens of MB),
#: so smaller trees take less time a segment, more than the wider margins sent cost: a task
#: of the 4,000-vertex floor plan (262,537 segments) noded as 2 x 2 and 3 x 3 sub-tiles took
#: 0.65 and 0.56 times its CPU time whole, for 1.23 and 1.31 times its segments
#: (``docs/scale.md``); the 2,000-vertex plan's tasks took 26.0 CPU s in 10 x 6 tiles and
#: 30.5 s in 7 x 5 (``benchmarks/bench_tiles.py``). The tiled parts do not depend on the
#: grid.
SNAP_TILE_SEGMENTS = 20_000

#: The most snap-rounding tiles chosen automatically (more than :data:`MAX_TILES`: the
#: 4,000-vertex plan's ~2 million input segments would be held to 55 tiles of ~40,000).
SNAP_MAX_TILES = 128

#: Chains per tile aimed at when the pieces' tiles are chosen automatically (``"auto"``,
#: :func:`tiled_crossings`): one :data:`tether.decomposition.pieces.PIECE_BATCH` per task,
#: so a task's peak is about one batch's rounds and its result.
PIECE_TILE_CHAINS = 100_000

#: The most tiles chosen automatically, and the most a grid may have (``nx * ny``).
MAX_TILES = 64

#: Where a cut lies in the widest gap between two vertex coordinates (as a fraction of the
#: gap from its lower end): not the middle, where a symmetric map's mirror-image curves cross.
CUT_FRACTION = math.sqrt(2.0) - 1.0

#: The margin of a tile's trust box, as a fraction of the smaller of the mean tile width and
#: height: a task nodes the input segments within twice the margin of its tile and delivers
#: the parts within the margin (:func:`node_tile`).
TILE_MARGIN = 0.125

#: The margin of a face task's trust box (:func:`trace_tile`), as a fraction of the smaller
#: of the mean tile width and height: a face task gets the parts within twice the margin of
#: its tile (so about ``(1 + 4 FACE_MARGIN)²`` of its share) and vouches for the faces within
#: the margin; larger faces are retried around the part of their walk it saw. Faces are
#: much smaller than tiles: on a 1,000-vertex floor plan in 2 x 2 tiles, 1/8, 1/16 and 1/32
#: sent 1.60, 1.32 and 1.21 times the parts (retries included), in 8.3, 6.9 and 6.4 s of
#: task work (the tasks run one after the other in one process).
FACE_MARGIN = 0.03125

#: The least margin of a tile's trust box in snap-rounding tasks, in grid cells (pixels): a
#: snap-rounded part depends on the hot pixels within a pixel of the input segments it comes
#: from (themselves within 0.71 pixel of it), made by vertices and crossings of segments
#: within about two pixels of it; eight leave room for GEOS's nearness tests.
SNAP_MARGIN_PIXELS = 8

#: The most cells along a side of a retry's trust region (:class:`CellMask`).
MASK_CELLS = 256

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


def auto_tiles(segments: int, width: float, height: float, per_tile: int = TILE_SEGMENTS,
               cap: int = MAX_TILES) -> tuple[int, int]:
    """The grid for ``segments`` input segments over a ``width x height`` box: about
    ``per_tile`` (:data:`TILE_SEGMENTS`) segments per tile (at most ``cap`` tiles,
    :data:`MAX_TILES`), the tiles about square. Depends on the input's size only, never on
    the number of workers."""
    n = min(max(math.ceil(segments / per_tile), 1), cap)
    aspect = width / height if width > 0 and height > 0 else 1.0
    nx = min(max(round(math.sqrt(n * aspect)), 1), n)
    ny = math.ceil(n / nx)
    while nx * ny > cap:
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


def tile_box(grid: TileGrid, tile: int) -> np.ndarray:
    """Tile ``tile``'s closed box ``(xmin, ymin, xmax, ymax)`` (map units; infinite at the
    grid's outer edges): the points :meth:`TileGrid.tile_of` puts in it, and the cuts around
    it."""
    i, j = divmod(tile, grid.shape[1])
    xs = np.r_[-np.inf, grid.xcuts, np.inf]
    ys = np.r_[-np.inf, grid.ycuts, np.inf]
    return np.array([xs[i], ys[j], xs[i + 1], ys[j + 1]])


def grown(box: np.ndarray, margin: float) -> np.ndarray:
    """The box ``(xmin, ymin, xmax, ymax)`` grown by ``margin`` (map units) on every side."""
    return np.asarray(box, float) + np.array([-margin, -margin, margin, margin])


def segments_by_tile(lo: np.ndarray, hi: np.ndarray, grid: TileGrid, reach: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The input segments (bounding boxes ``lo``-``hi``, (m, 2)) whose boxes, grown by
    ``reach`` (map units), meet each tile's closed box: segment indices tile after tile
    (increasing within a tile), and the CSR pointer over tiles."""
    nx, ny = grid.shape
    lo, hi = lo - reach, hi + reach
    ix0 = np.searchsorted(grid.xcuts, lo[:, 0])
    ix1 = np.searchsorted(grid.xcuts, hi[:, 0], "right")
    iy0 = np.searchsorted(grid.ycuts, lo[:, 1])
    iy1 = np.searchsorted(grid.ycuts, hi[:, 1], "right")
    rows = iy1 - iy0 + 1
    count = (ix1 - ix0 + 1) * rows
    s = np.repeat(np.arange(len(lo)), count)
    j = ragged_arange(np.zeros(len(lo), np.int64), count)
    tile = (ix0[s] + j // rows[s]) * ny + iy0[s] + j % rows[s]
    o = np.argsort(tile, kind="stable")
    return s[o], np.searchsorted(tile[o], np.arange(nx * ny + 1))


@dataclass(frozen=True)
class CellMask:
    """A set of cells of a square grid (map units): cell ``(j, i)`` is the closed square
    ``[x0 + i c, x0 + (i + 1) c] x [y0 + j c, y0 + (j + 1) c]`` (``origin = (x0, y0)``,
    ``cell = c``), in the set where ``marked[j, i]``. A retry's trust region
    (:func:`node_tile`): a box's cells are those its corners fall in (``floor``, the same
    monotone arithmetic wherever it runs)."""

    origin: np.ndarray
    cell: float
    marked: np.ndarray

    def _ranges(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cell ranges ``(i0, j0)``-``(i1, j1)`` (inclusive, as floats, clipped to one
        cell outside the grid) of the boxes ``lo``-``hi``."""
        rows, cols = self.marked.shape
        top = np.array([cols, rows], float)
        return (np.clip(np.floor((lo - self.origin) / self.cell), -1, top),
                np.clip(np.floor((hi - self.origin) / self.cell), -1, top))

    def _count(self, c0: np.ndarray, c1: np.ndarray) -> np.ndarray:
        """The marked cells in the ranges ``c0``-``c1`` (inclusive, within the grid)."""
        t = _summed(self.marked)
        i0, j0 = c0[:, 0].astype(np.int64), c0[:, 1].astype(np.int64)
        i1, j1 = c1[:, 0].astype(np.int64) + 1, c1[:, 1].astype(np.int64) + 1
        return t[j1, i1] - t[j0, i1] - t[j1, i0] + t[j0, i0]

    def holds(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Whether each box ``lo``-``hi`` ((m, 2) each) lies in marked cells only."""
        c0, c1 = self._ranges(lo, hi)
        rows, cols = self.marked.shape
        inside = np.all(c0 >= 0, axis=1) & (c1[:, 0] < cols) & (c1[:, 1] < rows)
        out = np.zeros(len(lo), bool)
        k = np.flatnonzero(inside)
        area = np.prod(c1[k] - c0[k] + 1, axis=1)
        out[k] = self._count(c0[k], c1[k]) == area
        return out

    def meets(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Whether each box ``lo``-``hi`` ((m, 2) each) has a marked cell."""
        c0, c1 = self._ranges(lo, hi)
        rows, cols = self.marked.shape
        c0 = np.maximum(c0, 0)
        c1 = np.minimum(c1, np.array([cols - 1, rows - 1], float))
        out = np.zeros(len(lo), bool)
        k = np.flatnonzero(np.all(c0 <= c1, axis=1))
        out[k] = self._count(c0[k], c1[k]) > 0
        return out

    def dilated(self, cells: int) -> CellMask:
        """The cells within ``cells`` cells (in x and in y) of a marked one."""
        rows, cols = self.marked.shape
        t = _summed(self.marked)
        j, i = np.arange(rows), np.arange(cols)
        j0, j1 = np.clip(j - cells, 0, rows), np.clip(j + cells + 1, 0, rows)
        i0, i1 = np.clip(i - cells, 0, cols), np.clip(i + cells + 1, 0, cols)
        s = (t[np.ix_(j1, i1)] - t[np.ix_(j0, i1)] - t[np.ix_(j1, i0)] + t[np.ix_(j0, i0)])
        return CellMask(self.origin, self.cell, s > 0)


def _summed(marked: np.ndarray) -> np.ndarray:
    """The summed-area table of ``marked`` (one row and column of zeros in front)."""
    t = np.zeros((marked.shape[0] + 1, marked.shape[1] + 1), np.int64)
    t[1:, 1:] = marked.cumsum(axis=0).cumsum(axis=1)
    return t


def mask_around(boxes: np.ndarray, pad: float, room: float) -> CellMask:
    """The cells within ``pad`` (map units) of the boxes ``(xmin, ymin, xmax, ymax)`` (rows),
    on a grid of about :data:`MASK_CELLS` cells a side at most (cells at least ``pad / 2``)
    that leaves ``room`` (map units) and 4 cells around them, so that a dilation by
    ``ceil(room / cell) + 1`` cells (:meth:`CellMask.dilated`) stays off the grid's edge."""
    lo, hi = boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)
    size = float((hi - lo).max()) + 2 * (pad + room)
    cell = max(pad / 2, size / MASK_CELLS)
    # room for a dilation by ceil(room / cell) + 1 cells, and a cell for floor's rounding
    origin = lo - pad - room - 4 * cell
    shape = np.ceil((hi + pad + room + 4 * cell - origin) / cell).astype(np.int64) + 1
    rows, cols = int(shape[1]), int(shape[0])
    grid = CellMask(origin, cell, np.zeros((rows, cols), bool))
    c0, c1 = grid._ranges(boxes[:, :2], boxes[:, 2:])
    d = math.ceil(pad / cell)
    c0 = np.maximum(c0 - d, 0).astype(np.int64)
    c1 = np.minimum(c1 + d + 1, [cols, rows]).astype(np.int64)
    diff = np.zeros((rows + 1, cols + 1), np.int64)
    np.add.at(diff, (c0[:, 1], c0[:, 0]), 1)
    np.add.at(diff, (c0[:, 1], c1[:, 0]), -1)
    np.add.at(diff, (c1[:, 1], c0[:, 0]), -1)
    np.add.at(diff, (c1[:, 1], c1[:, 0]), 1)
    return CellMask(origin, cell, diff.cumsum(axis=0).cumsum(axis=1)[:rows, :cols] > 0)


def _holds(region: np.ndarray | CellMask, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Whether each box ``lo``-``hi`` lies in ``region``: a closed box ``(xmin, ymin, xmax,
    ymax)`` or a :class:`CellMask`."""
    if isinstance(region, CellMask):
        return region.holds(lo, hi)
    return ((lo[:, 0] >= region[0]) & (lo[:, 1] >= region[1])
            & (hi[:, 0] <= region[2]) & (hi[:, 1] <= region[3]))


def runs_of(seg: np.ndarray, la: np.ndarray, lb: np.ndarray, lowner: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The segments ``seg`` (increasing indices into the input segments ``la-lb`` of the lines
    ``lowner``, a line's segments consecutive) as runs: the longest sequences of consecutive
    segments of one line, each a polyline of the input's own vertices (no segment split).
    Returns the runs' vertices, their CSR pointer (run ``r`` is ``xy[ptr[r]:ptr[r + 1]]``)
    and each run's line."""
    if len(seg) == 0:
        return np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.int64)
    brk = np.r_[True, (np.diff(seg) != 1) | (lowner[seg[1:]] != lowner[seg[:-1]])]
    run = np.cumsum(brk) - 1
    last = np.flatnonzero(np.r_[brk[1:], True])
    xy = np.empty((len(seg) + len(last), 2))
    xy[np.arange(len(seg)) + run] = np.take(la, seg, axis=0)
    xy[last + run[last] + 1] = np.take(lb, seg[last], axis=0)
    ptr = np.r_[0, np.cumsum(np.bincount(run, minlength=len(last)) + 1)]
    return xy, ptr, lowner[seg[brk]]


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


def node_tile(xy: np.ndarray, ptr: np.ndarray, run_src: np.ndarray,
              trust: np.ndarray | CellMask, reach: float,
              own: tuple[TileGrid, int] | np.ndarray,
              done: tuple[np.ndarray | CellMask, ...] = (),
              sources: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
              grid: float = 0.0) -> tuple | None:
    """A tile's task: its runs (vertices ``xy``, CSR ``ptr``: every input segment whose box
    meets the trust region grown by the margin, whole; each run's source curve ``run_src``,
    -1 for a wall) noded by GEOS's floating-point noder (``grid`` 0) or snap rounded on a
    ``grid`` (map units, :func:`tether.decomposition.noding.node_snapped`), and the parts it
    owns and can vouch for.

    A part is vouched for (*trusted*) if its bounding box lies in ``trust`` (a closed box
    ``(xmin, ymin, xmax, ymax)``, or a retry's :class:`CellMask`): every input segment that
    can cross it is among the runs, so its ends and vertices are the whole noding's, bit for
    bit. The task owns the parts *anchored* (lexicographically smaller end) in its tile
    (``own = (grid, tile)``) or, in a retry, at one of the points ``own`` ((m, 2)), and in
    none of the regions ``done`` (a retry's earlier trust regions, whose parts were
    delivered there). Each part delivered gets its sources among the runs' segments (or the
    segments ``sources = (a, b, source id)``) within ``reach`` of the middle of its longest
    segment (:func:`part_sources`, as the whole does).

    Returns the delivered parts' vertices and vertex counts, their sources (CSR ``(ptr,
    src)``), the *missed* points (the ends, in the tile or among ``own``, of the parts not
    trusted: anchors whose parts a retry in a larger region must deliver), those parts'
    bounding boxes ((k, 4)), this process's peak resident memory (bytes, 0 where unknown)
    and the delivered parts' lengths (map units, ``shapely.length``: the main process makes
    no linestring to compare them); None if the noder fails."""
    n = len(ptr) - 1
    if n == 0:
        empty = np.zeros(0, np.int64)
        return (np.zeros((0, 2)), empty, np.zeros(1, np.int64), empty, np.zeros((0, 2)),
                np.zeros((0, 4)), _peak_rss(), np.zeros(0))
    lines = shapely.linestrings(xy, indices=np.repeat(np.arange(n), np.diff(ptr)))
    try:
        lines = np.asarray(lines, dtype=object)
        parts = node_snapped(lines, grid) if grid > 0 else node_floating(lines)
    except GEOSException:
        return None
    del lines
    parts = parts[shapely.length(parts) > 0]
    coords, count, start, last = part_ends(parts)[:4]
    a, b = np.take(coords, start, axis=0), np.take(coords, last, axis=0)
    first = (a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] <= b[:, 1]))
    anchor = np.where(first[:, None], a, b)
    box = shapely.bounds(parts)
    blo, bhi = box[:, :2], box[:, 2:]
    trusted = _holds(trust, blo, bhi)
    mine_a, mine_b, owned = _owned((a, b, anchor), own)
    for region in done:
        owned &= ~_holds(region, blo, bhi)
    missed = ~trusted & (mine_a | mine_b)
    miss = np.unique(np.vstack((a[missed & mine_a], b[missed & mine_b])), axis=0)
    keep = np.flatnonzero(trusted & owned)
    length = shapely.length(parts[keep])
    kcount = count[keep]
    kcoords = coords[ragged_arange(start[keep], kcount)]
    del coords, parts
    pa, pb, powner = part_segments((kcoords, kcount, np.cumsum(kcount) - kcount))
    longest = first_max_per_group(np.hypot(*(pb - pa).T), powner)
    mid = 0.5 * (np.take(pa, longest, axis=0) + np.take(pb, longest, axis=0))
    del pa, pb, powner
    if sources is None:
        nseg = np.diff(ptr) - 1
        rows = ragged_arange(ptr[:-1], nseg)  # each run's segments' first vertices
        sources = (np.take(xy, rows, axis=0), np.take(xy, rows + 1, axis=0),
                   np.repeat(run_src, nseg))
    sptr, src = part_sources(mid, *sources, reach)
    return kcoords, kcount, sptr, src, miss, box[missed], _peak_rss(), length


def _owned(ends: tuple[np.ndarray, np.ndarray, np.ndarray],
           own: tuple[TileGrid, int] | np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For parts of first points ``a``, last points ``b`` and anchors ``anchor`` (``ends``):
    whether ``a``, ``b`` and ``anchor`` are this task's, as :func:`node_tile` reads ``own``."""
    if isinstance(own, tuple):
        grid, tile = own
        return tuple(grid.tile_of(p) == tile for p in ends)
    ids = row_ids(np.vstack((own,) + ends))[0]
    mine = np.isin(ids[len(own):], ids[:len(own)]).reshape(3, -1)
    return mine[0], mine[1], mine[2]


def trimmed(task: Callable[..., Any], *args: Any) -> Any:
    """``task(*args)``, then the C heap's freed memory returned to the system
    (:func:`tether._util.memory.release_memory`) before the result is sent: the task's
    temporaries, gigabytes at 4,000 map vertices, are not kept by an idle worker (whatever
    the executor) through the rest of the decomposition. How the tiles' tasks are submitted."""
    out = task(*args)
    release_memory()
    return out


def _worker_start() -> None:
    """The initializer of :func:`process_executor`'s workers: one thread each
    (:func:`tether._util.threads.single_threaded`), and glibc's allocator fixed where its
    dynamic thresholds end up in a busy process (``M_MMAP_THRESHOLD`` 32 MiB, ``M_TRIM_THRESHOLD``
    64 MiB; nothing elsewhere), from the start: a task's largest arrays, its result's among
    them, are mapped on their own and go back to the system as soon as they are freed, which
    :func:`trimmed` cannot do for the result (freed after it is sent); no allocation is slower
    than in a warmed-up process (a 4 MiB threshold cost up to a fifth more CPU time on
    numpy loops)."""
    single_threaded()
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, _MMAP_BYTES)  # M_MMAP_THRESHOLD
        libc.mallopt(-1, 2 * _MMAP_BYTES)  # M_TRIM_THRESHOLD
    except (OSError, AttributeError):  # not glibc
        pass


#: The size from which a worker's allocations are mapped on their own (bytes): glibc's
#: largest dynamic threshold (it rises to the size of a mapped block freed, up to this).
_MMAP_BYTES = 32 * 2**20


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
    computing in one thread, its large blocks returned to the system once freed
    (:func:`_worker_start`)."""
    return ProcessPoolExecutor(max_workers=workers or thread_count(),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=_worker_start)


def tiled_noder(tiles: tuple[int, int] | str, executor: Executor, tol: float,
                progress: Callable[[str, float], Any] | None = None,
                log: dict | None = None, arcs: tuple | None = None, noding: str = "auto"
                ) -> Callable[..., Any]:
    """The ``noder`` of :func:`tether.decomposition.arrangement.arrangement` that nodes its
    input in ``tiles`` (``(nx, ny)`` or ``"auto"``: :func:`auto_tiles`) on ``executor``: the
    whole noding's parts, each delivered by the tile of its anchor (:func:`node_tile`),
    retried in larger regions where a tile cannot vouch for it. An input the untiled noding
    splits into two strips (:func:`tether.decomposition.noding.strip_cut`, from
    :data:`tether.decomposition.noding.STRIP_MIN_SEGMENTS` segments) is split the same way
    and each strip tiled on its own. ``tol``: the curve tolerance (map units; the sources'
    reach is ``1e-3 tol`` as for the whole). The parts' faces are then traced in tiles too
    (:func:`trace_tile`, on a grid of the parts chosen alike), and the noder returns ``(parts,
    ptr, src, traced, grid)`` (``parts``: :class:`tether.decomposition.faces.PartLines`, no
    linestring made; ``traced``: the faces and the parts' faces, None to trace them whole;
    ``grid``: the snap-rounding grid, map units, 0 for floating-point noding). If a task's
    floating-point noder fails, every tile snap rounds the input instead, as the untiled noder
    would (module docstring; :class:`tether.errors.ArrangementError` if even the coarsest
    grid fails); with ``noding="snap"`` (:data:`tether.decomposition.noding.NODINGS`) every
    tile snap rounds from the start, as the untiled noder with ``noding="snap"``.
    ``progress`` gets ``("tiles (NXxNY)", overall fraction)`` as noding tasks finish,
    then ``("stitch", 0.45)``, then ``("face tiles (NXxNY)", fraction)`` as face tasks
    finish; ``log``, if given, gets ``tiles`` (the grid's shape, per strip), ``strips`` (1 or
    2), ``margin`` (map units), ``retries`` (tasks run again in a larger region),
    ``segments_sent`` (input segments sent to the tasks, over the input's count),
    ``worker_peak_bytes`` (the largest peak resident memory a task's process reported),
    ``fallback`` (True if the input was noded whole: no longer happens), ``float_failed``
    (True if a task's floating-point noder failed and the tiles snap rounded; False with
    ``noding="snap"``, where none ran), ``grid`` (the
    snap-rounding grid, map units; 0: floating-point), ``snap_grids_failed`` (grids a task
    failed on before ``grid``), and for the faces ``face_tiles``,
    ``face_margin``, ``face_retries``, ``face_parts_sent`` (parts sent over the parts'
    count) and ``face_fallback`` (True if they were traced whole), and the counts ``parts``
    and ``faces``. With ``arcs = (env,
    lss)`` (the internal map and rod length), the face tasks also compute their faces'
    points and free arcs (:func:`tether.decomposition.structure.face_arcs`), and
    ``traced`` carries them (:class:`tether.decomposition.structure.FaceArcs`) after the
    faces and the parts' faces."""
    report = progress or (lambda stage, frac: None)
    log = {} if log is None else log

    def noder(lines: np.ndarray, source: np.ndarray, segs: tuple) -> tuple | None:
        la, lb, lowner = segs
        if len(la) == 0:
            return None
        log.update(retries=0, fallback=False, worker_peak_bytes=0, segments_sent=0.0,
                   strips=1, grid=0.0, float_failed=False, snap_grids_failed=0)
        got, sent, grid = (None, 0, 0.0) if noding == "snap" else _floating_in_tiles(
            lines, source, segs, tiles, executor, tol, report, log)
        if got is None:  # snap rounded as the whole would be, in tiles
            log["float_failed"] = noding != "snap"
            got, sent, grid = _snapped_in_tiles(source, segs, tiles, executor, tol, report,
                                                log)
        report("stitch", 0.45)
        log["segments_sent"] = sent / len(la)
        coords, count, ptr, src, length = _stitched(got)
        del got
        log["parts"] = len(count)
        parts = PartLines(coords, count, length)  # no linestring made here
        traced = _faces_in_tiles(coords, count, tiles, executor, report, log,
                                 None if arcs is None else (*arcs, tol, grid))
        return parts, ptr, src, traced, grid

    return noder


def _floating_in_tiles(lines: np.ndarray, source: np.ndarray, segs: tuple,
                       tiles: tuple[int, int] | str, executor: Executor, tol: float,
                       report: Callable, log: dict) -> tuple[list | None, int, float]:
    """The input (``lines``, each line's ``source``, their segments ``segs``) noded in tiles
    by GEOS's floating-point noder, in two strips as the whole from
    :data:`tether.decomposition.noding.STRIP_MIN_SEGMENTS` segments: the tasks' results, the
    input segments sent and the grid (0); results None if a task's noder failed."""
    la, lb, lowner = segs
    reach = max(1e-3 * tol, 1e-12)
    strips = noding.strip_cut(lines) if len(la) >= noding.STRIP_MIN_SEGMENTS else None
    if strips is None:  # the input's own segments, each run's sources its line's
        groups, ref = [(la, lb, lowner, source)], None
    else:  # the strips' pieces; the sources among the input's own segments
        groups = [_segments_of(np.asarray(p, dtype=object)) for p in strips]
        ref = (la, lb, source[lowner])
        log["strips"] = 2
    del strips
    got, sent = [], 0
    for g in groups:
        r = _node_in_tiles(g, ref, tiles, executor, reach, report, log)
        if r is None:
            return None, 0, 0.0
        got.extend(r[0])
        sent += r[1]
    return got, sent, 0.0


def _snapped_in_tiles(source: np.ndarray, segs: tuple, tiles: tuple[int, int] | str,
                      executor: Executor, tol: float, report: Callable, log: dict
                      ) -> tuple[list, int, float]:
    """The input (each line's ``source``, the lines' segments ``segs``) snap rounded in
    tiles as :func:`tether.decomposition.noding.node_lines` rounds the whole: no strips, the
    grids ``SNAP_GRIDS * tol`` in turn, the same for all tiles, a coarser one only if a task
    fails on a finer; the sources within ``1e-3 tol + 2 grid`` of a part. Returns the tasks'
    results, the input segments sent and the grid (map units).

    Raises
    ------
    ArrangementError
        If a task fails even on the coarsest grid (as the whole's noding then fails).
    """
    la, lb, lowner = segs
    for frac in SNAP_GRIDS:
        grid = frac * tol
        log["grid"] = grid
        log["strips"] = 1
        r = _node_in_tiles((la, lb, lowner, source), None, tiles, executor,
                           max(1e-3 * tol + 2 * grid, 1e-12), report, log, grid)
        if r is not None:
            return r[0], r[1], grid
        log["snap_grids_failed"] += 1
    raise ArrangementError(f"the arrangement of {len(source)} curves could not be noded in "
                           f"tiles even on a {SNAP_GRIDS[-1] * tol:.2g} grid (map beyond the "
                           f"curve tolerance {tol:.2g}): GEOS's snap rounding failed in a "
                           f"tile")


def _segments_of(lines: np.ndarray) -> tuple[np.ndarray, ...]:
    """The segments of ``lines`` (linestrings) as ``(la, lb, lowner, line_source)`` (sources
    unknown: zeros)."""
    xy, idx = shapely.get_coordinates(lines, return_index=True)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    return xy[k], xy[k + 1], idx[k], np.zeros(len(lines), np.int64)


def _node_in_tiles(group: tuple, ref: tuple | None, tiles: tuple[int, int] | str,
                   executor: Executor, reach: float, report: Callable, log: dict,
                   grid_size: float = 0.0) -> tuple[list, int] | None:
    """One noding input (``group``: its segments ``(la, lb, lowner)`` and each line's source)
    in tiles, with retries: the tasks' results and the number of input segments sent; None
    if a task's noder failed (the tasks not yet started are cancelled). ``ref``: the
    segments ``(a, b, source)`` the sources are found among (None: the input's own);
    ``grid_size``: the snap-rounding grid (map units; 0: floating-point noding), which
    widens the margin to at least :data:`SNAP_MARGIN_PIXELS` grid cells and, with ``"auto"``
    tiles, aims at :data:`SNAP_TILE_SEGMENTS` segments a tile (at most
    :data:`SNAP_MAX_TILES` tiles) instead of :data:`TILE_SEGMENTS`. A floating-point
    task gets the input within twice the margin of its tile (a retry, within the margin of
    its region); a snap-rounding task within the margin and :data:`SNAP_MARGIN_PIXELS`
    cells (or twice ``reach``) more: a snap-rounded part depends on the input within about
    two cells of it, so the parts in the trust region, and the ends missed there, are
    those of the whole input."""
    la, lb, lowner, source = group
    if len(la) == 0:
        return [], 0
    lo, hi = np.minimum(la, lb), np.maximum(la, lb)
    span = hi.max(axis=0) - lo.min(axis=0)
    per_tile, cap = (TILE_SEGMENTS, MAX_TILES) if grid_size == 0 else (SNAP_TILE_SEGMENTS,
                                                                       SNAP_MAX_TILES)
    shape = tiles if tiles != "auto" else auto_tiles(len(la), float(span[0]), float(span[1]),
                                                     per_tile, cap)
    grid = tile_grid(np.vstack((la, lb)), shape)
    nx, ny = grid.shape
    margin = max(TILE_MARGIN * float(min(span[0] / nx, span[1] / ny)), 4 * reach,
                 SNAP_MARGIN_PIXELS * grid_size)
    # the input a task gets beyond its trust region: floating-point, the margin again (the
    # noder's later passes); snap rounded, what a part within the trust region depends on
    pad = margin if grid_size == 0 else max(SNAP_MARGIN_PIXELS * grid_size, 2 * reach)
    log["tiles"], log["margin"] = grid.shape, margin
    rlo = rhi = None
    if ref is not None:
        rlo, rhi = np.minimum(ref[0], ref[1]), np.maximum(ref[0], ref[1])
    sent = 0

    def submit(seg: np.ndarray, rseg: np.ndarray | None, trust: Any, own: Any,
               done: tuple) -> Any:
        nonlocal sent
        sent += len(seg)
        xy, ptr, line = runs_of(seg, la, lb, lowner)
        sources = None if rseg is None else tuple(np.take(c, rseg, axis=0) for c in ref)
        return executor.submit(trimmed, node_tile, xy, ptr, source[line], trust, reach, own,
                               done, sources, grid_size)

    near, nptr = segments_by_tile(lo, hi, grid, margin + pad)
    rnear = rptr = None
    if ref is not None:
        rnear, rptr = segments_by_tile(rlo, rhi, grid, margin + 2 * reach)
    done = {t: (grown(tile_box(grid, t), margin),) for t in range(grid.count)}
    first = {t: submit(near[nptr[t]:nptr[t + 1]],
                       None if ref is None else rnear[rptr[t]:rptr[t + 1]],
                       done[t][0], (grid, t), ())
             for t in _largest_first(np.diff(nptr))}
    del near, rnear
    stage = f"tiles ({nx}x{ny})"

    def follow(level: int, t: int, r: tuple) -> Any:
        # a larger region around the parts the task could not vouch for, at once
        log["worker_peak_bytes"] = max(log["worker_peak_bytes"], r[6])
        if not len(r[4]):
            return None
        trust = mask_around(r[5], margin * 2.0 ** (level + 1), margin)
        f = submit(_segments_near(trust, lo, hi, pad),
                   None if ref is None else _segments_near(trust, rlo, rhi, 2 * reach),
                   trust, r[4], done[t])
        done[t] = (*done[t], trust)
        log["retries"] += 1
        return f

    results = _rounds(first, follow, lambda frac: report(stage, 0.3 + 0.15 * frac))
    if results is None:
        return None
    got = [results[k] for k in sorted(results)]
    return got, sent


def _largest_first(sizes: np.ndarray) -> list[int]:
    """The tiles in the order their tasks are submitted: the largest (``sizes``: segments
    or parts sent) first, ties in tile order, so that a pool's workers do not end on one big
    task while the other waits (the results are taken in tile order all the same)."""
    return [int(t) for t in np.argsort(-np.asarray(sizes), kind="stable")]


def _rounds(first: dict[int, Any], follow: Callable[[int, int, Any], Any],
            report: Callable[[float], Any],
            keep: Callable[[Any, Any], Any] = lambda f, r: r) -> dict | None:
    """The tiles' tasks and their retries (``first``: each tile's first task's future):
    each result is handed to ``follow(level, tile, result)`` as soon as its task ends, which
    submits the tile's next task (a future) or returns None, so the workers never wait for
    the slowest task of a round. Returns ``keep(future, result)`` by ``(level, tile)`` (in
    the order the tasks ended: the callers sort the keys), or None as soon as a task returns
    None (the tasks not yet started are cancelled; no retry of the tasks ended with it is
    submitted). ``report`` gets the fraction of the tasks finished (never backwards)."""
    key_of = {f: (0, t) for t, f in first.items()}
    out, finished, shown = {}, 0, 0.0
    while key_of:
        ended, _ = wait(list(key_of), return_when=FIRST_COMPLETED)
        ended = sorted(ended, key=key_of.__getitem__)
        if any(f.result() is None for f in ended):  # before any retry of those ended
            for g in key_of:
                g.cancel()
            return None
        for f in ended:
            level, t = key_of.pop(f)
            r = f.result()
            finished += 1
            nxt = follow(level, t, r)
            if nxt is not None:
                key_of[nxt] = (level + 1, t)
            out[level, t] = keep(f, r)
            shown = max(shown, finished / (finished + len(key_of)))
            report(shown)
    return out


def _segments_near(trust: CellMask, lo: np.ndarray, hi: np.ndarray, margin: float
                   ) -> np.ndarray:
    """The input segments (bounding boxes ``lo``-``hi``) meeting the cells within ``margin``
    (map units, and one cell more) of the region ``trust``: increasing indices."""
    region = trust.dilated(math.ceil(margin / trust.cell) + 1)
    rows, cols = region.marked.shape
    end = region.origin + trust.cell * np.array([cols, rows])
    k = np.flatnonzero(np.all(hi >= region.origin, axis=1) & np.all(lo <= end, axis=1))
    return k[region.meets(np.take(lo, k, axis=0), np.take(hi, k, axis=0))]


def _stitched(got: list[tuple]) -> tuple[np.ndarray, ...]:
    """The tasks' delivered parts one after the other: their coordinates and point counts,
    their sources (CSR ``(ptr, src)``) and their lengths."""
    coords = np.concatenate([r[0] for r in got])
    count = np.concatenate([r[1] for r in got])
    length = np.concatenate([r[7] for r in got])
    src = np.concatenate([r[3] for r in got])
    offsets = np.cumsum([0] + [len(r[3]) for r in got[:-1]])
    ptr = np.concatenate([np.zeros(1, np.int64)] + [r[2][1:] + o for r, o in
                                                    zip(got, offsets, strict=True)])
    return coords, count, ptr, src.astype(np.int64), length


def trace_tile(coords: np.ndarray, count: np.ndarray, trust: np.ndarray | CellMask,
               complete: np.ndarray | CellMask, own: tuple[TileGrid, int] | np.ndarray,
               done: tuple[np.ndarray | CellMask, ...] = (), arcs: tuple | None = None
               ) -> tuple | None:
    """A tile's task tracing faces (:func:`tether.decomposition.faces.local_faces`): the
    parts (coordinates ``coords``, point counts ``count``: every part of the arrangement
    whose box meets the region ``complete`` grown by a little, so that a node in
    ``complete`` has all its parts here), the trust region ``trust`` (a box ``(xmin, ymin,
    xmax, ymax)`` or a :class:`CellMask`), the anchors owned (``own = (grid, tile)``: those
    in the tile; or points (m, 2)) and the earlier trust regions of this tile (``done``:
    their faces were delivered there). With ``arcs = (env, lss, tol[, grid])`` (the internal
    map, the rod length, the curve tolerance and the noding's snap grid, 0 if left out), the
    faces' points and free arcs too (:func:`tether.decomposition.structure.face_arcs`).

    Returns the faces delivered as ragged arrays (coordinates, and the offsets of rings and
    of polygons, as ``shapely.from_ragged_array`` reads them), the half-edges on their rings
    (``2k`` along part ``k``, ``2k + 1`` against it) and each one's face, the anchors to
    retry ((m, 2)) and the boxes of their faces' walks seen here ((m, 4)), this process's
    peak resident memory (bytes), the faces'
    :class:`tether.decomposition.structure.FaceArcs` (None without ``arcs``) and their areas
    (map units², ``shapely.area`` of their polygons: the main process makes no polygon to
    number the regions); None if the tracing cannot decide (the whole is traced then)."""
    if isinstance(own, tuple):
        grid, tile = own

        def owned(pts: np.ndarray) -> np.ndarray:
            return grid.tile_of(pts) == tile
    else:
        def owned(pts: np.ndarray) -> np.ndarray:
            ids = row_ids(np.vstack((own, pts)))[0]
            return np.isin(ids[len(own):], ids[:len(own)])

    def earlier(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        out = np.zeros(len(lo), bool)
        for region in done:
            out |= _holds(region, lo, hi)
        return out

    got = local_faces(coords, count, lambda lo, hi: _holds(trust, lo, hi),
                      lambda p: _holds(complete, p, p), owned, earlier if done else None)
    if got is None:
        return None
    fa = None
    polys = _polygons(got[0], got[1])
    if arcs is not None:
        env, lss, tol, *rest = arcs
        fa = face_arcs(env, polys, tol, rest[0] if rest else 0.0, lss) if len(polys) \
            else _no_arcs()
    return (*got, _peak_rss(), fa, shapely.area(polys) if len(polys) else np.zeros(0))


def _no_arcs() -> FaceArcs:
    """The :class:`FaceArcs` of no face."""
    i, f = np.zeros(0, np.int64), np.zeros(0)
    return FaceArcs(np.zeros((0, 2)), f, i, np.zeros(0, bool), np.zeros(0, bool), i, i, i)


def _polygons(xy: np.ndarray, offsets: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Polygons from ragged arrays (coordinates, offsets of rings and of polygons)."""
    if len(xy) == 0:
        return np.zeros(0, dtype=object)
    return np.asarray(shapely.from_ragged_array(shapely.GeometryType.POLYGON, xy, offsets),
                      dtype=object)


def _faces_in_tiles(coords: np.ndarray, count: np.ndarray, tiles: tuple[int, int] | str,
                    executor: Executor, report: Callable, log: dict,
                    arcs: tuple | None = None) -> tuple | None:
    """The faces of the parts (coordinates ``coords``, point counts ``count``; as ragged
    arrays with their areas, :class:`tether.decomposition.faces.FaceRings`: the main process
    makes no polygon) and the faces on the two sides of each part, as
    :func:`tether.decomposition.faces.trace_faces` gives them, traced in ``tiles`` on
    ``executor`` (:func:`trace_tile`): each face delivered by the tile holding its anchor,
    retried in larger regions around the anchors a tile could not vouch for, and with
    ``arcs`` (:func:`trace_tile`) their points and free arcs
    (:class:`tether.decomposition.structure.FaceArcs`, else None). None where a task cannot
    decide (the caller traces the whole)."""
    n = len(count)
    if n == 0:
        return None
    start = np.cumsum(count) - count
    plo, phi = np.minimum.reduceat(coords, start), np.maximum.reduceat(coords, start)
    span = phi.max(axis=0) - plo.min(axis=0)
    shape = tiles if tiles != "auto" else auto_tiles(len(coords) - n, float(span[0]),
                                                     float(span[1]))
    # the cuts only decide which tile owns an anchor: placed among the parts' ends
    grid = tile_grid(np.take(coords, np.r_[start, start + count - 1], axis=0), shape)
    nx, ny = grid.shape
    margin = max(FACE_MARGIN * float(min(span[0] / nx, span[1] / ny)),
                 1e-9 * float(span.max()))
    log.update(face_tiles=grid.shape, face_margin=margin, face_retries=0,
               face_parts_sent=0.0, face_fallback=False)
    sent = 0
    near, nptr = segments_by_tile(plo, phi, grid, 2 * margin)
    done = {t: (grown(tile_box(grid, t), margin),) for t in range(grid.count)}
    sel_of = {}

    def submit(sel: np.ndarray, trust: Any, complete: Any, own: Any, done: tuple) -> Any:
        nonlocal sent
        sent += len(sel)
        xy = coords[ragged_arange(start[sel], count[sel])]
        f = executor.submit(trimmed, trace_tile, xy, count[sel], trust, complete, own, done,
                            arcs)
        sel_of[f] = sel
        return f

    first = {t: submit(near[nptr[t]:nptr[t + 1]], done[t][0],
                       grown(tile_box(grid, t), 1.5 * margin), (grid, t), ())
             for t in _largest_first(np.diff(nptr))}
    del near
    stage = f"face tiles ({nx}x{ny})"

    def follow(level: int, t: int, r: tuple) -> Any:
        # a larger region around the faces' walks seen, submitted as soon as the task ends
        retry, seen = r[4], r[5]
        if not len(retry):
            return None
        trust = mask_around(seen, margin * 2.0 ** level, margin)
        complete = trust.dilated(math.ceil(margin / trust.cell))
        f = submit(_segments_near(trust, plo, phi, margin), trust, complete, retry, done[t])
        done[t] = (*done[t], trust)
        log["face_retries"] += 1
        return f

    results = _rounds(first, follow, lambda frac: report(stage, 0.45 + 0.04 * frac),
                      keep=lambda f, r: (sel_of.pop(f), r))
    if results is None:
        log["face_fallback"] = True
        return None
    side = np.full(2 * n, -1, np.int64)
    rings, arc_parts, nfaces = [], [], 0
    for key in sorted(results):  # in the order of levels, then tiles: the faces' numbers
        sel, (xy, offsets, he, face, retry, seen, peak, fa, area) = results.pop(key)
        log["worker_peak_bytes"] = max(log.get("worker_peak_bytes", 0), peak)
        ghe = 2 * sel[he // 2] + he % 2
        if np.any(side[ghe] >= 0):  # a half-edge on faces of two tasks: never seen
            log["face_fallback"] = True
            return None
        side[ghe] = face + nfaces
        rings.append(FaceRings(xy, *offsets, area))
        if fa is not None:
            arc_parts.append((fa, nfaces))
        nfaces += len(area)
    log["face_parts_sent"] = sent / n
    log["faces"] = nfaces
    pf = np.sort(side.reshape(n, 2), axis=1)
    one = pf[:, 0] < 0  # -1 (none) goes second, as trace_faces gives them
    pf[one] = pf[one][:, ::-1]
    pf[pf[:, 0] == pf[:, 1]] = -1
    return FaceRings.joined(rings), pf, None if arcs is None else _joined_arcs(arc_parts)


def _joined_arcs(got: list[tuple[FaceArcs, int]]) -> FaceArcs:
    """The face tasks' :class:`FaceArcs` (each with its first face's number) joined in face
    order: faces and arcs' points renumbered."""
    if not got:
        return _no_arcs()
    oks = np.cumsum([0] + [len(fa.full) for fa, _ in got[:-1]])
    return FaceArcs(np.concatenate([fa.pts for fa, _ in got]),
                    np.concatenate([fa.clear for fa, _ in got]),
                    np.concatenate([fa.keep + first for fa, first in got]),
                    np.concatenate([fa.resolved for fa, _ in got]),
                    np.concatenate([fa.full for fa, _ in got]),
                    np.concatenate([fa.point + o for (fa, _), o in zip(got, oks, strict=True)]),
                    np.concatenate([fa.start_code for fa, _ in got]),
                    np.concatenate([fa.end_code for fa, _ in got]))


# ----------------------------------------------------------------------------- the pieces
def pieces_tile(env: Any, lss: float, curves: list[Curve], chains: Chains, cands: Candidates,
                srcs: tuple[np.ndarray, np.ndarray], reg: tuple[StructureRows, np.ndarray],
                parts: PartLines) -> tuple:
    """A tile's pieces task: :func:`tether.decomposition.pieces.chain_crossings` on the
    tile's chains, numbered for the task (:func:`tiled_crossings` makes its arguments:
    ``chains`` over the parts ``parts``, ``chains.pair`` indexing the region rows ``reg``,
    ``srcs`` indexing ``curves``, the curves those chains run along). Returns
    ``chain_crossings``'s crossings, kept chains (task-local), arcs and lines' WKB, and this
    process's peak resident memory (bytes, 0 where unknown) and the task's CPU seconds
    (this process's, :func:`time.process_time`)."""
    cpu = time.process_time()
    got = chain_crossings(env, lss, curves, chains, cands, srcs, reg,
                          SimpleNamespace(parts=parts))
    return (*got, _peak_rss(), time.process_time() - cpu)


def tiled_crossings(tiles: tuple[int, int] | str, executor: Executor,
                    progress: Callable[[str, float], Any] | None = None,
                    log: dict | None = None, sink: Callable[..., Any] | None = None
                    ) -> Callable[..., tuple]:
    """The ``crossings`` of :func:`tether.decomposition.pieces.make_pieces` that computes
    the pieces' crossings, the arcs at both sides of them and their lines in ``tiles``
    (``(nx, ny)``, or ``"auto"``: about :data:`PIECE_TILE_CHAINS` chains a tile) on
    ``executor``, one task per tile (:func:`pieces_tile`), the main process receiving
    compact arrays (coordinates, flags, the arcs' columns, WKB bytes) and joining them
    (:func:`tether.decomposition.pieces.joined_crossings`): the pieces come tile by tile,
    in chain order within a tile.

    **Ownership.** A chain belongs to the tile (:meth:`TileGrid.tile_of`, on a grid of the
    chains' anchors, :func:`tile_grid`) of its *anchor*, the lexicographically smaller end
    of its first part: a function of the chain, so every chain is computed by exactly one
    task, and near the tile, so a task's curves are mostly the tile's. A chain's pieces
    depend on that chain alone (its candidates, the curves it runs along, the structures of
    its two regions, the map; :func:`tether.decomposition.pieces.chain_crossings`), all of
    which its task gets: the same pieces, arcs and lines as in one process, but the
    crossing's sample and normal, which may move by about 1e-9 (map units) with the chains
    a Gauss-Newton projection runs with (:func:`tether.curves.project_many` stops once every
    row of a call has converged), as with :data:`tether.decomposition.pieces.PIECE_BATCH`.
    A task's curves are copies of the chains' curves whose exact rows (their
    :class:`tether.curves.Family`) are only theirs (the same numbers; the polylines only for
    the conchoids, whose projection starts from them). ``progress`` gets ``("piece tiles
    (NXxNY)", fraction)`` as tasks finish, in tile order; the tasks are submitted a few at a
    time (:func:`_tasks_ahead`), each one's inputs made as it is submitted. ``log``, if
    given, gets ``piece_tiles`` (the
    grid's shape), ``piece_tasks`` (tasks run: tiles with chains),
    ``piece_worker_peak_bytes``, ``piece_task_cpu`` (each task's CPU seconds in its worker,
    in tile order; their balance) and ``piece_wait`` (wall seconds the main process waited
    for the tasks' results). With ``sink``, each task's result is handed to it as it
    comes, in tile order (``sink(crossings, chains, arcs, lines)``: the
    :func:`tether.decomposition.pieces.chain_crossings` result of the tile, its ``kept`` as
    global chain ids) and not kept: the crossings returned are those of no chain (a store
    written tile by tile, :class:`tether.decomposition.store.PartWriter`)."""
    report = progress or (lambda stage, frac: None)
    log = {} if log is None else log

    def crossings(env: Any, lss: float, curves: list[Curve], chains: Chains,
                  cands: Candidates, srcs: tuple[np.ndarray, np.ndarray],
                  reg: tuple[StructureRows, np.ndarray], arr: Any) -> tuple:
        log.update(piece_tiles=(0, 0), piece_tasks=0, piece_worker_peak_bytes=0,
                   piece_task_cpu=[], piece_wait=0.0)
        if len(chains) == 0:
            return joined_crossings([])
        parts = _as_part_lines(arr.parts)
        start = np.cumsum(parts.count) - parts.count
        first = chains.parts[chains.ptr[:-1]]
        a, b = parts.xy[start[first]], parts.xy[start[first] + parts.count[first] - 1]
        lower = (a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] <= b[:, 1]))
        anchor = np.where(lower[:, None], a, b)
        shape = tiles
        if tiles == "auto":
            span = anchor.max(axis=0) - anchor.min(axis=0)
            shape = auto_tiles(len(chains), float(span[0]), float(span[1]),
                               PIECE_TILE_CHAINS)
        grid = tile_grid(anchor, shape)
        tile = grid.tile_of(anchor)
        order = np.argsort(tile, kind="stable")  # chains tile by tile, in order within one
        bounds = np.searchsorted(tile[order], np.arange(grid.count + 1))
        log["piece_tiles"] = grid.shape
        tasks = [order[bounds[t]:bounds[t + 1]] for t in range(grid.count)
                 if bounds[t + 1] > bounds[t]]
        log["piece_tasks"] = len(tasks)
        ahead = _tasks_ahead(executor)
        sizes = (chains.size, cands.count)  # every chain's, counted once, not once a task

        def submit(ids: np.ndarray) -> Any:
            return executor.submit(trimmed, pieces_tile, env, lss,
                                   *_task_inputs(ids, curves, chains, cands, srcs, reg, parts,
                                                 start, sizes))

        # at most ``ahead`` tasks' inputs made and waiting (each a copy of its chains' data)
        futures = {k: submit(tasks[k]) for k in range(min(ahead, len(tasks)))}
        results = []
        stage = f"piece tiles ({grid.shape[0]}x{grid.shape[1]})"
        for k, ids in enumerate(tasks):
            waited = time.perf_counter()
            got, kept, arcs, lines, peak, cpu = futures.pop(k).result()
            log["piece_wait"] += time.perf_counter() - waited
            log["piece_task_cpu"].append(round(cpu, 2))
            if k + ahead < len(tasks):
                futures[k + ahead] = submit(tasks[k + ahead])
            log["piece_worker_peak_bytes"] = max(log["piece_worker_peak_bytes"], peak)
            if sink is None:
                results.append((got, ids[kept], arcs, lines))
            else:
                sink(got, ids[kept], arcs, lines)
            del got, kept, arcs, lines
            report(stage, 0.85 + 0.14 * (k + 1) / len(tasks))
        return joined_crossings(results)

    return crossings


def _tasks_ahead(executor: Executor) -> int:
    """How many pieces tasks :func:`tiled_crossings` keeps submitted: twice the workers of a
    local pool (``max_workers``) and one more, so that none waits for work while the main
    process holds few tasks' inputs; every task at once for another executor (a Dask
    cluster's: its size is not known here)."""
    workers = getattr(executor, "_max_workers", None)
    return 2 * workers + 1 if isinstance(workers, int) and workers > 0 else MAX_TILES


def _as_part_lines(parts: Any) -> PartLines:
    """The arrangement's parts as :class:`PartLines` (as they are, or read from
    linestrings)."""
    if isinstance(parts, PartLines):
        return parts
    geoms = np.asarray(parts, dtype=object)
    return PartLines(shapely.get_coordinates(geoms), shapely.get_num_coordinates(geoms),
                     shapely.length(geoms))


def _task_inputs(ids: np.ndarray, curves: list[Curve], chains: Chains, cands: Candidates,
                 srcs: tuple[np.ndarray, np.ndarray], reg: tuple[StructureRows, np.ndarray],
                 parts: PartLines, start: np.ndarray,
                 sizes: tuple[np.ndarray, np.ndarray] | None = None) -> tuple:
    """The arguments of :func:`pieces_tile` (after the map and ``lss``) for the chains
    ``ids`` (increasing), numbered for the task: their curves (:func:`_curves_subset`),
    their chains over their own parts, their candidates, their curves' CSR, the structure
    rows of their regions and their parts' coordinates (``start``: each part's first row in
    ``parts.xy``; ``sizes``: ``chains.size`` and ``cands.count``, if made already)."""
    chain_size, cand_count = (chains.size, cands.count) if sizes is None else sizes
    size = chain_size[ids]
    pid = chains.parts[ragged_arange(chains.ptr[ids], size)]  # a part is in one chain
    sub = PartLines(np.take(parts.xy, ragged_arange(start[pid], parts.count[pid]), axis=0),
                    parts.count[pid], parts.length[pid])
    regions, pair = np.unique(chains.pair[ids], return_inverse=True)
    rows, reg_of = reg
    used, reg_local = np.unique(reg_of[regions], return_inverse=True)
    ccount = cand_count[ids]
    crow = ragged_arange(cands.ptr[ids], ccount)
    sptr, ssrc = srcs
    scount = sptr[ids + 1] - sptr[ids]
    mine, src = np.unique(ssrc[ragged_arange(sptr[ids], scount)], return_inverse=True)
    local = Chains(pair.reshape(-1, 2), np.r_[0, np.cumsum(size)], np.arange(len(pid)))
    cand = Candidates(np.r_[0, np.cumsum(ccount)], np.take(cands.q, crow, axis=0),
                      cands.eps[crow])
    return (_curves_subset(curves, mine), local, cand,
            (np.r_[0, np.cumsum(scount)], src.astype(np.int64)),
            (_rows_subset(rows, used), reg_local.astype(np.int64)), sub)


def _rows_subset(rows: StructureRows, ids: np.ndarray) -> StructureRows:
    """The structure rows ``ids`` of ``rows``, numbered ``0..len(ids) - 1``."""
    count = rows.ptr[ids + 1] - rows.ptr[ids]
    return StructureRows(rows.kind[ids], np.r_[0, np.cumsum(count)].astype(rows.ptr.dtype),
                         rows.pairs[ragged_arange(rows.ptr[ids], count)])


def _curves_subset(curves: list[Curve], ids: np.ndarray) -> list[Curve]:
    """The curves ``ids`` as a list of their own: copies whose families hold only their
    exact rows (:meth:`tether.curves.Family.rows`, the same numbers), their polylines kept
    for the conchoids only (the projection's start, :func:`tether.curves.project_many`;
    lines and circles are projected exactly)."""
    out: list[Curve | None] = [None] * len(ids)
    kinds: dict[str, list[int]] = {}
    for k, c in enumerate(ids.tolist()):
        kinds.setdefault(curves[c].kind, []).append(k)
    for kind, ks in kinds.items():
        mine = [curves[c] for c in ids[ks].tolist()]
        fam = mine[0].family.rows(np.array([c.index for c in mine], dtype=np.int64))
        light = kind in "ABCD"
        for j, (k, c) in enumerate(zip(ks, mine, strict=True)):
            out[k] = replace(c, family=fam, index=j, polylines=() if light else c.polylines,
                             params=() if light else c.params)
    return out
