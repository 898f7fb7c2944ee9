"""Boundary pieces: the chains of arrangement parts between two regions, their crossing
candidates (clear of every other part), the crossing chosen on each (the two sides showing the
two regions' structures, exact) and the pieces' columns."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from tether._util.arrays import components, first_nearest, ragged_arange, row_ids
from tether._util.memory import release_memory
from tether._util.threads import map_batches
from tether.arcs import ArcTable, free_arcs_many, join_tables
from tether.curves import Curve, project_many
from tether.decomposition.arrangement import Arrangement, Chains
from tether.decomposition.faces import part_ends, part_segments
from tether.decomposition.model import Region, region_rows
from tether.decomposition.structure import (
    StructureRows,
    crossing_points,
    join_rows,
    rows_equal,
    table_rows,
)
from tether.decomposition.views import PieceTable, Shapes, packed_geometries
from tether.environment import Environment
from tether.spatial import SegmentGrid, point_segment_distance_xy, segment_pairs, z_order

__all__ = ["ACROSS_BATCH", "CLEARANCE_BATCH", "CLEARANCE_STAGES", "CLEARANCE_Z_CELL",
           "PIECE_BATCH", "Candidates", "chain_crossings", "chain_descriptions",
           "crossing_candidates", "joined_crossings", "longest_unresolved", "make_chains",
           "make_pieces", "part_candidates"]


def make_chains(arr: Arrangement, face_region: np.ndarray) -> Chains:
    """Arrangement parts separating two regions, grouped into chains: parts that meet end to
    end and share a source curve. Vectorized: parts sharing (region pair, end point, source)
    are linked, chains are the connected components."""
    fr = np.append(face_region, -1)  # index -1 (no face) maps to the last slot, -1
    ra, rb = fr[arr.part_faces[:, 0]], fr[arr.part_faces[:, 1]]
    parts = np.flatnonzero((ra >= 0) & (rb >= 0) & (ra != rb))
    if len(parts) == 0:
        return Chains(np.zeros((0, 2), np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    first_id, last_id = arr.end_ids()
    end_id = np.concatenate((first_id[parts], last_id[parts]))
    sptr, sflat = arr.sources()
    nsrc = sptr[parts + 1] - sptr[parts]
    src = sflat[ragged_arange(sptr[parts], nsrc)]
    local = np.tile(np.repeat(np.arange(len(parts)), nsrc), 2)  # rows: (end, source)
    end_of_row = np.concatenate((np.repeat(end_id[: len(parts)], nsrc),
                                 np.repeat(end_id[len(parts):], nsrc)))
    src_row = np.tile(src, 2)
    # rows of one (region pair, end point, source) group are linked (any links connecting
    # the group: the components, labelled by their smallest part, do not depend on which)
    pair = np.unique(lo[parts] * (int(hi.max()) + 1) + hi[parts], return_inverse=True)[1]
    u, v = _equal_row_links((pair.ravel()[local], end_of_row, src_row + 1))
    comp = components(len(parts), local[u], local[v])
    # chains sorted by (region pair, first part): parts in increasing order within each
    order = np.lexsort((parts, comp))
    comp_o, parts_o = comp[order], parts[order]
    starts = np.flatnonzero(np.r_[True, comp_o[1:] != comp_o[:-1]])
    stops = np.r_[starts[1:], len(parts_o)]
    head = parts_o[starts]
    rank = np.lexsort((head, hi[head], lo[head]))
    h = head[rank]
    size = (stops - starts)[rank]
    return Chains(np.column_stack((lo[h], hi[h])), np.r_[0, np.cumsum(size)],
                  parts_o[ragged_arange(starts[rank], size)])


def _equal_row_links(cols: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Links ``(u[k], v[k])`` between rows (of the columns ``cols``, non-negative integers)
    connecting every group of equal rows: rows next to each other in sorted order. The
    columns are packed into one integer per row (one sort) when their ranges allow it, else
    each row is linked to its group's first (:func:`row_ids`, hashed rows)."""
    n = len(cols[0])
    key = np.zeros(n, np.int64)
    size = 1
    for c in cols:
        span = int(c.max(initial=0)) + 1
        size *= span
        if size >= 2**62:
            group, first = row_ids(np.column_stack(cols))
            return np.arange(n), first[group]
        key = key * span + c
    order = np.argsort(key)
    same = np.flatnonzero(key[order[1:]] == key[order[:-1]])
    return order[same], order[same + 1]


@dataclass
class Candidates:
    """Candidate crossing points of every chain (CSR): chain ``i``'s candidates, best first,
    are rows ``ptr[i]:ptr[i + 1]`` of ``q`` (points, map units) and ``eps`` (offsets)."""

    ptr: np.ndarray
    q: np.ndarray
    eps: np.ndarray

    @property
    def count(self) -> np.ndarray:
        """Number of candidates of each chain."""
        return np.diff(self.ptr)


def crossing_candidates(arr: Arrangement, chains: Chains, tol: float, lss: float
                        ) -> Candidates:
    """For every chain, candidate crossing points (midpoints of the 6 longest segments of
    each of its parts) with their offsets ``eps``, best clearance first (up to 8; among equals
    in part order); only points clear of every other part by ``4 tol``. All chains are
    handled in one vectorized pass."""
    need = np.zeros(len(arr.parts), bool)
    need[chains.parts] = True
    Q, mine, clear = part_candidates(arr, need, tol, lss)  # in (part, rank) order
    # the rows chain after chain (a chain's parts in increasing order), then by clearance
    first = np.searchsorted(mine, np.arange(len(arr.parts) + 1))
    per_part = first[chains.parts + 1] - first[chains.parts]
    rows = ragged_arange(first[chains.parts], per_part)
    chain = np.repeat(np.repeat(np.arange(len(chains)), chains.size), per_part)
    ok = np.flatnonzero(clear[rows] >= 4 * tol)
    rows, chain = rows[ok], chain[ok]
    count = np.bincount(chain, minlength=len(chains))
    start = np.cumsum(count) - count
    rows = rows[_descending_within_runs(clear[rows], start, count)]
    # the best 8 of each chain (rank within the chain's run)
    rank = np.arange(len(rows)) - np.repeat(start, count)
    rows = rows[rank < 8]
    cap = max(50 * tol, 1e-4 * lss)
    eps = np.minimum(0.25 * (clear[rows] - tol), cap)
    ptr = np.r_[0, np.cumsum(np.minimum(count, 8))]
    return Candidates(ptr, np.take(Q, rows, axis=0).reshape(-1, 2), eps)


def _descending_within_runs(value: np.ndarray, start: np.ndarray, count: np.ndarray,
                            width: int = 8) -> np.ndarray:
    """The order of rows sorting each run ``start[i]:start[i] + count[i]`` (runs one after
    the other, covering the rows) by ``value``, largest first, equals in row order: that of
    ``np.lexsort((-value, run))``. Runs of up to ``width`` rows are sorted as the rows of one
    padded matrix (no sort of all the rows), longer ones by a lexsort of their rows."""
    n = len(value)
    order = np.arange(n)
    if n == 0:
        return order
    if np.isnan(value).any():
        run = np.repeat(np.arange(len(count)), count)
        return np.lexsort((-value, run))
    short = np.flatnonzero((count > 1) & (count <= width))
    if len(short):
        idx = start[short][:, None] + np.arange(width)
        real = np.arange(width) < count[short][:, None]
        idx = np.where(real, idx, n - 1)
        neg = np.where(real, -value[idx], np.inf)  # padding after every value, -inf too
        srt = np.take_along_axis(idx, np.argsort(neg, axis=1, kind="stable"), axis=1)
        order[idx[real]] = srt[real]
    long = np.flatnonzero(count > width)
    if len(long):
        rows = ragged_arange(start[long], count[long])
        run = np.repeat(np.arange(len(long)), count[long])
        order[rows] = rows[np.lexsort((-value[rows], run))]
    return order


#: Candidate points handled per batch when measuring their clearance: each brings one row per
#: segment near it, so this bounds the working memory (not the speed; one batch per thread).
CLEARANCE_BATCH = 10_000


#: The clearance search's radii, as fractions of its reach: a point is searched again within
#: the next radius only if nothing of another part was found within the previous one (a
#: first radius of 1/3: the fastest of 1/6 to 1/2, measured with the points in Z order).
CLEARANCE_STAGES = (1 / 3, 1.0)


#: The cells of the clearance's Z order of the points, in reaches (4 to 16 alike, measured).
CLEARANCE_Z_CELL = 8.0


def _clearance(pts: np.ndarray, owner: np.ndarray, sa: np.ndarray, sb: np.ndarray,
               sowner: np.ndarray, tree: shapely.STRtree | SegmentGrid, reach: float
               ) -> np.ndarray:
    """Each point's distance to the nearest segment ``sa[k]-sb[k]`` of another part
    (``sowner[k] != owner[i]``), at most ``reach`` (map units). Searched within growing radii
    (``CLEARANCE_STAGES``): a distance found within a radius is the nearest (every segment
    that close is among the radius's candidates), and most points have a neighbour much
    closer than ``reach``, so far fewer (point, segment) pairs are measured than in one search
    within ``reach``; the same distances. The points are taken in Z order (batches of nearby
    points: 1.4 -> 0.9 s at 1,000 map vertices, the segments' data read from cache)."""
    order = z_order(pts, CLEARANCE_Z_CELL * reach)
    pts, owner = pts[order], owner[order]
    clear = np.full(len(pts), reach)
    cols = tuple(np.ascontiguousarray(c) for c in (sa[:, 0], sa[:, 1], sb[:, 0], sb[:, 1]))
    todo = np.arange(len(pts))
    for frac in CLEARANCE_STAGES:
        r = reach * frac

        def batch(lo: int, hi: int, r: float = r, todo: np.ndarray = todo) -> np.ndarray:
            rows = todo[lo:hi]  # bounded memory: (point, segment) pairs per batch
            qi, d = _other_distances(np.take(pts, rows, axis=0), owner[rows], cols, sowner, r,
                                     tree)
            nearest = np.full(len(rows), np.inf)
            np.minimum.at(nearest, qi, d)
            return nearest

        # in threads (numpy's big calls release the GIL)
        found = np.concatenate([np.zeros(0), *map_batches(batch, len(todo), CLEARANCE_BATCH)])
        hit = found <= r  # the nearest within r, if any (farther candidates do not lower it)
        clear[todo[hit]] = found[hit]
        todo = todo[~hit]
    out = np.empty_like(clear)
    out[order] = clear
    return out


def _other_distances(pts: np.ndarray, owner: np.ndarray, cols: tuple[np.ndarray, ...],
                     sowner: np.ndarray, r: float, tree: shapely.STRtree | SegmentGrid
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Distances from points (m, 2) to the segments of other parts (``sowner != owner``)
    whose envelopes meet the point's box of half-width ``r``: point indices and distances
    (map units; some beyond ``r``). ``cols``: the segments' ``ax, ay, bx, by`` columns,
    indexed by ``tree``. A point's own part, its nearest, is dropped before measuring."""
    qi, si = segment_pairs(pts, r, tree)  # envelopes only; exact distances below
    k = np.flatnonzero(sowner[si] != owner[qi])
    qi, si = qi[k], si[k]
    ax, ay, bx, by = cols
    return qi, point_segment_distance_xy(pts[:, 0][qi], pts[:, 1][qi], ax[si], ay[si],
                                         bx[si], by[si])


#: Segments per block of :func:`_blocked_clearance` (about): bounds the segment grid held
#: at once (~130 bytes a segment) while the candidates' clearances are measured.
CLEARANCE_BLOCK_SEGMENTS = 1_000_000


def _blocked_clearance(pts: np.ndarray, owner: np.ndarray, sa: np.ndarray, sb: np.ndarray,
                       sowner: np.ndarray, reach: float) -> np.ndarray:
    """:func:`_clearance` of the points (m, 2) over the segments ``sa[k]-sb[k]``, the
    points taken in blocks of a ``k x k`` grid over their bounds (about
    :data:`CLEARANCE_BLOCK_SEGMENTS` segments a block), each block's against a
    :class:`SegmentGrid` of only the segments whose bounding box meets the block's points'
    box widened by ``reach``: the same distances (every segment a point's search can meet,
    within ``reach`` of it, is among them: floating-point addition is monotone; the nearest
    is the same minimum), with one block's grid held at a time instead of the whole map's
    (at 2,000 floor-plan vertices 3 million segments, ~0.5 GB)."""
    m = len(pts)
    if m == 0:
        return np.zeros(0)
    k = max(1, int(np.ceil(np.sqrt(len(sa) / CLEARANCE_BLOCK_SEGMENTS))))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    cell = np.minimum((k * (pts - lo) / span).astype(np.int64), k - 1)
    block = cell[:, 0] * k + cell[:, 1]
    order = np.argsort(block, kind="stable")
    bounds = np.searchsorted(block[order], np.arange(k * k + 1)).tolist()
    out = np.empty(m)
    for b0, b1 in zip(bounds[:-1], bounds[1:], strict=True):
        if b1 == b0:
            continue
        rows = order[b0:b1]
        p = pts[rows]
        plo, phi = p.min(axis=0) - reach, p.max(axis=0) + reach
        near = np.minimum(sa[:, 0], sb[:, 0]) <= phi[0]
        near &= np.maximum(sa[:, 0], sb[:, 0]) >= plo[0]
        near &= np.minimum(sa[:, 1], sb[:, 1]) <= phi[1]
        near &= np.maximum(sa[:, 1], sb[:, 1]) >= plo[1]
        seg = np.flatnonzero(near)
        del near
        a, bb = sa[seg], sb[seg]
        out[rows] = _clearance(p, owner[rows], a, bb, sowner[seg], SegmentGrid(a, bb), reach)
        del a, bb, seg
    return out


def _part_segment_ends(arr: Arrangement) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts' segments ``(a, b, part)`` (:func:`part_segments`), as the arrangement
    made them (``arr.memo["part_segments"]``) or made now, kept there: no grid of them
    (:func:`_blocked_clearance` makes one a block at a time)."""
    got = arr.memo.get("part_segments")
    if got is None:
        got = arr.memo["part_segments"] = part_segments(part_ends(arr.parts))
    return got


def part_candidates(arr: Arrangement, need: np.ndarray, tol: float, lss: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate crossing points of the parts flagged in ``need``: the midpoints of each
    part's 6 longest segments (part by part, longest first), their part and their clearance
    (distance to the nearest segment of another part, at most ``max(1e3 tol, 1e-3 lss)``).
    A part's candidates depend on the arrangement only: they are computed once per part and
    cached on ``arr`` (region merges recompute the chains, not the parts)."""
    sa, sb, sowner = _part_segment_ends(arr)
    cache = arr.memo.get("part_candidates")
    if cache is None:
        cache = arr.memo["part_candidates"] = {
            "done": np.zeros(len(arr.parts), bool), "Q": np.zeros((0, 2)),
            "part": np.zeros(0, np.int64), "rank": np.zeros(0, np.int64), "clear": np.zeros(0)}
    todo = need & ~cache["done"]
    if todo.any():
        seg = np.flatnonzero(todo[sowner])
        if np.any(sowner[seg[1:]] < sowner[seg[:-1]]):  # not in part order (never so)
            seg = seg[np.argsort(sowner[seg], kind="stable")]
        a, b, part = sa[seg], sb[seg], sowner[seg]
        ln = np.hypot(*(b - a).T)
        head = np.flatnonzero(np.r_[True, part[1:] != part[:-1]]) if len(part) else \
            np.zeros(0, np.int64)  # segments are in part order
        count = np.diff(np.r_[head, len(part)])
        order = _descending_within_runs(ln, head, count)  # longest first, as a lexsort
        rank = np.arange(len(order)) - np.repeat(head, count)
        keep = (rank < 6) & (ln[order] > 0)
        take = order[keep]
        Q = 0.5 * (np.take(a, take, axis=0) + np.take(b, take, axis=0))
        mine = part[take]
        clear = _blocked_clearance(Q, mine, sa, sb, sowner, max(1e3 * tol, 1e-3 * lss))
        cache["Q"] = np.vstack((cache["Q"], Q))
        cache["part"] = np.concatenate((cache["part"], mine))
        cache["rank"] = np.concatenate((cache["rank"], rank[keep]))
        cache["clear"] = np.concatenate((cache["clear"], clear))
        cache["done"] |= todo
    rows = np.flatnonzero(need[cache["part"]])
    key = cache["part"][rows] * 6 + cache["rank"][rows]  # ranks are 0..5
    if np.any(key[1:] <= key[:-1]):  # rows of several batches: in (part, rank) order
        rows = rows[np.argsort(key, kind="stable")]
    return cache["Q"][rows], cache["part"][rows], cache["clear"][rows]


def make_pieces(env: Environment, arr: Arrangement, regions: list[Region], chains: Chains,
                cands: Candidates, curves: list[Curve], lss: float,
                crossings: Callable[..., tuple] | None = None
                ) -> tuple[PieceTable, int, ArcTable]:
    """One piece per chain with a crossing sample. Returns the pieces (as columns), the
    number of chains dropped as below resolution (no candidate point clear of other curves by
    ``4 tol``: artefacts of the polyline approximation at tangencies, where the exact regions
    touch at a point only) and the exact arcs at both sides of every piece's crossing (see
    :meth:`Decomposition.crossing_arcs`).

    The crossings are chosen :data:`PIECE_BATCH` chains at a time (:func:`_pick_crossings`),
    each batch's arcs at its chosen crossings gathered and its rounds' tables freed before
    the next: a chain's rounds, its candidates' arcs and its choice depend on that chain
    only (the same regions, curves, offsets, verdicts and arcs' features for any batch
    size; a sample or normal may move by about 1e-9, as with the chains' order before:
    :func:`tether.curves.project_many` stops its Gauss-Newton steps once every row of a
    call has converged), and the peak is the arcs kept (those of the result) and one batch's
    rounds, not every chain's rounds at once (at 2,000 map vertices, 0.9 M chains: their
    first round's arcs and structures alone are about 1.8 M points' tables). A map of at
    most :data:`PIECE_BATCH` chains is one batch: the computation of before, bit for bit.

    ``crossings`` (default :func:`chain_crossings`) computes the crossings, arcs and lines,
    called with :func:`chain_crossings`'s arguments; its ``kept`` (the chains of the pieces,
    in the pieces' order) may be in any order (the tiles' tasks,
    :func:`tether.decomposition.tiles.tiled_crossings`, give them tile by tile)."""
    sptr, ssrc = arr.chain_sources(chains)
    reg = region_rows(regions, 2 * env.n + 1)
    got, kept, arcs, lines = (crossings or chain_crossings)(env, lss, curves, chains, cands,
                                                            (sptr, ssrc), reg, arr)
    desc, descs = _describe_chains(sptr, ssrc, kept, curves)
    table = PieceTable(chains.pair[kept].astype(np.int64), got["q"], got["n"], got["eps"],
                       got["ok"], desc, descs, Shapes(None, wkb=lines))
    return table, len(chains) - len(kept), arcs


def chain_crossings(env: Environment, lss: float, curves: list[Curve], chains: Chains,
                    cands: Candidates, srcs: tuple[np.ndarray, np.ndarray],
                    reg: tuple[StructureRows, np.ndarray], arr: Any
                    ) -> tuple[dict[str, np.ndarray], np.ndarray, ArcTable,
                               tuple[np.ndarray, np.ndarray]]:
    """The crossings, their arcs and the lines of the pieces of ``chains`` (the work of
    :func:`make_pieces` but the descriptions; also a tile's task,
    :func:`tether.decomposition.tiles.pieces_tile`): the crossings chosen
    :data:`PIECE_BATCH` chains at a time (:func:`_pick_crossings`; ``srcs``: the chains'
    curves, CSR ``(ptr, src)`` into ``curves``; ``reg``: the structure rows and the row of
    each region of ``chains.pair``), each batch's arcs at its chosen crossings kept and its
    rounds' tables freed before the next; ``arr``: the arrangement, or any object whose
    ``parts`` the chains' part ids index (:func:`_chain_geometries`). Returns the crossings
    of the chains with a candidate (``q``, ``n``, ``eps``, ``ok``, in chain order), those
    chains (``kept``), the arcs at both sides of their crossings (points ``0..k-1`` on the
    ``+n`` side, ``k..2k-1`` on the other) and their lines as a WKB column ``(raw, ptr)``."""
    m = len(chains)
    got = {"q": np.zeros((m, 2)), "n": np.zeros((m, 2)), "eps": np.zeros(m),
           "ok": np.zeros(m, bool)}
    kept = np.flatnonzero(cands.count > 0)  # the chains with a crossing sample
    sides: tuple[list[ArcTable], list[ArcTable]] = ([], [])
    whole = None  # one batch: its table is the result as it is (no halves joined again)
    for lo in range(0, max(m, 1), PIECE_BATCH):
        which = np.arange(lo, min(lo + PIECE_BATCH, m))
        b, tables = _pick_crossings(env, chains, cands, None, curves, srcs, lss, which, reg)
        for f, col in got.items():
            col[which] = b[f]
        # the batch's arcs at its crossings kept, its rounds' tables freed (a lower peak)
        at = b["at"][cands.count[which] > 0]
        arcs = _crossing_table(tables, at)
        del tables, b
        if m <= PIECE_BATCH:
            whole = arcs
        elif len(at):
            for side, part in zip(sides, _halves(arcs, len(at)), strict=True):
                side.append(part)
        del arcs
        release_memory()
    # +n sides, then the others (as one batch would give them); the halves held by one list
    # only, which join_tables empties: each column's batches freed once joined
    halves = sides[0] + sides[1]
    del sides
    arcs = (whole if whole is not None else join_tables(halves, release_memory) if halves
            else _crossing_table([], np.zeros((0, 3), np.int64)))
    # the lines packed as WKB, made a batch at a time (no shapely object kept)
    lines = packed_geometries(lambda ids: _chain_geometries(arr, chains, ids), kept)
    return {f: col[kept] for f, col in got.items()}, kept, arcs, lines


def joined_crossings(results: list[tuple]) -> tuple[dict[str, np.ndarray], np.ndarray,
                                                    ArcTable, tuple[np.ndarray, np.ndarray]]:
    """The results of :func:`chain_crossings` on disjoint sets of chains (each one's ``kept``
    given as the chains' global ids), as the result of one call on all of them whose pieces
    are those of the first set, then those of the second, ...: the crossings concatenated,
    the arcs' ``+n`` halves joined before the other halves (points renumbered), the lines'
    WKB columns one after the other. Empties ``results``: each one's arrays are freed once
    joined (the peak is the results and one joined column)."""
    got = {f: np.concatenate([r[0][f] for r in results]) if results else
           np.zeros((0, 2) if f in "qn" else 0, bool if f == "ok" else float)
           for f in ("q", "n", "eps", "ok")}
    kept = (np.concatenate([r[1] for r in results]) if results else
            np.zeros(0, np.int64)).astype(np.int64)
    raw = (np.concatenate([r[3][0] for r in results]) if results else
           np.zeros(0, np.uint8))
    ptr = np.zeros(len(kept) + 1, np.int64)
    if results:
        np.cumsum(np.concatenate([np.diff(r[3][1]) for r in results]), out=ptr[1:])
    sides: tuple[list[ArcTable], list[ArcTable]] = ([], [])
    for r in results:
        if len(r[1]):
            for side, part in zip(sides, _halves(r[2], len(r[1])), strict=True):
                side.append(part)
    results.clear()  # the arcs held by the halves only, which join_tables empties
    halves = sides[0] + sides[1]
    del sides
    arcs = (join_tables(halves, release_memory) if halves
            else _crossing_table([], np.zeros((0, 3), np.int64)))
    return got, kept, arcs, (raw, ptr)


#: Chains whose crossings are chosen at a time (:func:`make_pieces`): their rounds' arcs
#: (two points a chain and round, ~10 arcs a point) and structures are the batch's peak.
PIECE_BATCH = 100_000


def _halves(table: ArcTable, m: int) -> tuple[ArcTable, ArcTable]:
    """The arcs of points ``0..m-1`` and of points ``m..2m-1`` of ``table`` (rows sorted by
    point), each numbered from 0: views of its columns (its ``point`` column renumbered in
    place)."""
    cut = int(np.searchsorted(table.point, m))
    table.point[cut:] -= m
    return (ArcTable(table.point[:cut], table.start[:cut], table.end[:cut],
                     table.start_code[:cut], table.end_code[:cut], table.full[:m]),
            ArcTable(table.point[cut:], table.start[cut:], table.end[cut:],
                     table.start_code[cut:], table.end_code[cut:], table.full[m:]))


def longest_unresolved(arr: Arrangement, chains: Chains, cands: Candidates
                       ) -> dict | None:
    """The longest chain without a crossing sample (internal units): its length, regions and
    middle point; None if every chain has one."""
    dropped = np.flatnonzero(cands.count == 0)
    if len(dropped) == 0:
        return None
    geoms = _chain_geometries(arr, chains, dropped)
    length = shapely.length(geoms)
    i = int(np.argmax(length))
    mid = shapely.line_interpolate_point(shapely.line_merge(geoms[i]), 0.5, normalized=True) \
        if shapely.get_type_id(geoms[i]) in (1, 5) else shapely.centroid(geoms[i])
    return {"length": float(length[i]),
            "regions": [f"R{r}" for r in chains.pair[dropped[i]].tolist()],
            "point": shapely.get_coordinates(mid)[0].tolist()}


def chain_descriptions(sptr: np.ndarray, ssrc: np.ndarray, cands: Candidates,
                       curves: list[Curve]) -> tuple[np.ndarray, list[tuple]]:
    """The description id of every chain (-1 for a chain without a crossing candidate, which
    makes no piece) and the distinct descriptions ``(curves, kinds, features)``, as
    :func:`make_pieces` describes its pieces (``sptr``, ``ssrc``: the chains' curves,
    :meth:`Arrangement.chain_sources`): for pieces written as they come, whatever their
    order."""
    kept = np.flatnonzero(cands.count > 0)
    desc, descs = _describe_chains(sptr, ssrc, kept, curves)
    of = np.full(len(cands.count), -1, np.int64)
    of[kept] = desc
    return of, descs


def _describe_chains(sptr: np.ndarray, ssrc: np.ndarray, which: np.ndarray,
                     curves: list[Curve]) -> tuple[np.ndarray, list[tuple]]:
    """The descriptions of the chains ``which``, whose curves are ``ssrc[sptr[i]:sptr[i +
    1]]`` (sorted, distinct): an id per chain into the returned list of distinct ``(curves,
    kinds, features)`` (the curves' tuple, their kind letters sorted, ``"?"`` for none, and
    their features in order, each once). Chains of equal curves share an id, found
    vectorized, size by size (:func:`row_ids`); each distinct one is described once."""
    start = sptr[which]
    size = sptr[which + 1] - start
    desc = np.zeros(len(which), np.int64)
    descs: list[tuple] = []
    for s in np.unique(size).tolist():
        rows = np.flatnonzero(size == s)
        keys = ssrc[start[rows, None] + np.arange(s)]  # (k, s): each chain's curves
        ids, first = row_ids(keys) if s else (np.zeros(len(rows), np.int64), [0])
        desc[rows] = ids + len(descs)
        for key in keys[first].tolist():
            kinds = "".join(sorted({curves[c].kind for c in key})) or "?"
            feats = tuple(dict.fromkeys(f for c in key for f in curves[c].features))
            descs.append((tuple(key), kinds, feats))
    return desc, descs


def _chain_geometries(arr: Any, chains: Chains, which: np.ndarray) -> np.ndarray:
    """The lines of the chains ``which`` (an object array): a chain's part, or its parts
    merged into as few lines as they form (all multi-part chains at once); ``arr``: the
    arrangement, or any object whose ``parts`` the chains' part ids index (linestrings, or
    :class:`tether.decomposition.faces.PartLines`)."""
    size = chains.size[which]
    out = arr.parts[chains.parts[chains.ptr[which]]]  # single parts as they are
    multi = np.flatnonzero(size > 1)
    if len(multi):
        rows = ragged_arange(chains.ptr[which[multi]], size[multi])
        lines = shapely.multilinestrings(arr.parts[chains.parts[rows]],
                                         indices=np.repeat(np.arange(len(multi)), size[multi]))
        out[multi] = shapely.line_merge(lines)
    return out


def _pick_crossings(env: Environment, chains: Chains, cands: Candidates,
                    regions: list[Region] | None, curves: list[Curve],
                    chain_srcs: tuple[np.ndarray, np.ndarray], lss: float,
                    which: np.ndarray | None = None,
                    reg: tuple[StructureRows, np.ndarray] | None = None
                    ) -> tuple[dict[str, np.ndarray], list[ArcTable]]:
    """For each chain ``which[k]`` (default: every chain), the first candidate whose two
    offsets (from the exact curve, along its exact normal) show the two regions' structures:
    ``(q, n into regions[0], eps)``. Candidates are tried in rounds, all these chains at once
    (vectorized: structures compared as integer rows, :func:`rows_equal`; ``reg``: the
    regions' structure rows and each region's row, :func:`region_rows`, made from
    ``regions`` if not given). A chain with no clean
    candidate keeps its first one (``check`` reports it); a chain without candidates gets
    nothing (zeros). Returns arrays over ``which``: ``q``, ``n``, ``eps``, ``ok`` (verified)
    and ``at``, saying where the arcs of the two sides are in the returned tables:
    ``(round, row of the +n side, row of the other)``; ``chain_srcs`` are the chains' curves
    (CSR, :meth:`Arrangement.chain_sources`). A chain's result depends on that chain
    alone."""
    which = np.arange(len(chains)) if which is None else which
    m = len(which)
    count = cands.count[which]
    reg_rows, reg_of = region_rows(regions, 2 * env.n + 1) if reg is None else reg
    sa, sb = reg_of[chains.pair[which, 0]], reg_of[chains.pair[which, 1]]
    out_q, out_n = np.zeros((m, 2)), np.zeros((m, 2))
    out_eps = np.zeros(m)
    out_ok = np.zeros(m, bool)
    out_at = np.full((m, 3), -1, dtype=np.int64)
    tables: list[ArcTable] = []
    pending = np.flatnonzero(count > 0)
    first = None
    rnd = 0
    while len(pending):
        row = cands.ptr[which[pending]] + rnd
        q, n = _project_on_sources(curves, chain_srcs, which[pending],
                                   np.take(cands.q, row, axis=0))
        release_memory()  # the projection's temporaries, before the arcs allocate theirs
        eps = cands.eps[row]
        k = len(pending)
        j = np.arange(k)
        if first is None:  # every chain with a candidate is tried in round 0
            first = (q, n, eps, np.column_stack((np.zeros(k, np.int64), j, j + k)))
        table, sides = _arcs_across(env, lss, q, n, eps)
        tables.append(table)
        fwd = (rows_equal(sides, j, reg_rows, sa[pending])
               & rows_equal(sides, j + k, reg_rows, sb[pending]))
        back = ~fwd
        back[back] = (rows_equal(sides, j[back], reg_rows, sb[pending[back]])
                      & rows_equal(sides, j[back] + k, reg_rows, sa[pending[back]]))
        done = fwd | back
        for sel, sign, at in ((fwd, 1.0, np.column_stack((j, j + k))),
                              (back, -1.0, np.column_stack((j + k, j)))):
            i = pending[sel]
            out_q[i], out_n[i], out_eps[i] = q[sel], sign * n[sel], eps[sel]
            out_ok[i] = True
            out_at[i, 0] = rnd
            out_at[i, 1:] = at[sel]
        last = ~done & (rnd + 1 >= count[pending])  # out of candidates: keep the first
        if last.any():
            i = pending[last]
            f = np.searchsorted(np.flatnonzero(count > 0), i)
            out_q[i], out_n[i], out_eps[i] = first[0][f], first[1][f], first[2][f]
            out_at[i] = first[3][f]
        pending = pending[~done & ~last]
        rnd += 1
    return {"q": out_q, "n": out_n, "eps": out_eps, "ok": out_ok, "at": out_at}, tables


def _arcs_across(env: Environment, lss: float, q: np.ndarray, n: np.ndarray, eps: np.ndarray
                 ) -> tuple[ArcTable, StructureRows]:
    """Exact free arcs at both sides of crossings (rows ``0..k-1``: ``q + eps n``, then
    ``q - eps n``) and the structures of those ``2k`` points. Computed in batches of
    :data:`ACROSS_BATCH` points, each batch's structures from its own table, the batches
    joined column by column with the freed memory returned to the system: the peak is the
    table, its structures and the temporaries of one batch per thread."""
    pts = crossing_points(q, n, eps)

    def batch(lo: int, hi: int) -> tuple[ArcTable, StructureRows]:
        if lo // ACROSS_BATCH % 8 == 7:  # the batches' freed temporaries, scattered among
            release_memory()             # the tables made
        t = free_arcs_many(env, pts[lo:hi], lss, check=False)
        return t, table_rows(env, t, len(t.full))

    done = map_batches(batch, max(len(pts), 1), ACROSS_BATCH)  # in threads: numpy's big
    tables, rows = [t for t, _ in done], [r for _, r in done]   # calls release the GIL
    del done
    release_memory()
    return join_tables(tables, release_memory), join_rows(rows)


#: Points per batch of :func:`_arcs_across` (half of :data:`tether.arcs.POINT_BATCH`: the
#: batch's temporaries come on top of the table made so far).
ACROSS_BATCH = 10_000


def _crossing_table(tables: list[ArcTable], at: np.ndarray) -> ArcTable:
    """The arcs at both sides of every piece's crossing, gathered from the tables of the
    rounds that chose them (the very points of :meth:`Decomposition.piece_crossings`):
    points ``0..m-1`` on the ``+normal`` side, ``m..2m-1`` on the other. ``at``: each
    piece's ``(round, row of the +n side, row of the other)``, shape (m, 3). Empties
    ``tables``: their columns are freed one by one as they are gathered."""
    m = len(at)
    at_arr = np.asarray(at, dtype=np.int64).reshape(-1, 3)
    rnd = np.concatenate((at_arr[:, 0], at_arr[:, 0]))  # per output point
    src = np.concatenate((at_arr[:, 1], at_arr[:, 2]))
    full = np.zeros(2 * m, bool)
    first = np.zeros(2 * m, np.int64)  # first row in the tables' rows one after the other
    count = np.zeros(2 * m, np.int64)
    offset = 0
    for r, table in enumerate(tables):
        k = np.flatnonzero(rnd == r)
        full[k] = table.full[src[k]]
        size = np.bincount(table.point, minlength=len(table.full))  # rows of each point
        first[k] = offset + (np.cumsum(size) - size)[src[k]]
        count[k] = size[src[k]]
        offset += len(table.point)
    table = None  # no reference left to a round's table but ``tables``
    rows = ragged_arange(first, count)  # output points in order, no sort
    if not tables:
        return ArcTable(np.repeat(np.arange(2 * m), count), np.zeros(0), np.zeros(0),
                        np.zeros(0, np.int64), np.zeros(0, np.int64), full)
    fields = ("start", "end", "start_code", "end_code")
    src = {f: [getattr(t, f) for t in tables] for f in fields}
    tables.clear()  # each column of the rounds' tables freed once gathered
    cols = []
    for f in fields:
        parts = src.pop(f)
        cols.append((parts[0] if len(parts) == 1 else np.concatenate(parts))[rows])
        del parts
        release_memory()
    return ArcTable(np.repeat(np.arange(2 * m), count), *cols, full)


def _project_on_sources(curves: list[Curve], srcs: tuple[np.ndarray, np.ndarray],
                        which: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each point ``q0[k]``, the nearest point and unit normal on the exact curves of
    chain ``which[k]`` (``srcs``: the chains' curves, CSR ``(ptr, src)``; all rows at once); a
    row without a source curve keeps its point, normal (0, 1)."""
    q, n = q0.copy(), np.tile([0.0, 1.0], (len(q0), 1))
    ptr, src = srcs
    count = ptr[which + 1] - ptr[which]
    if count.sum() == 0:
        return q, n
    row = np.repeat(np.arange(len(which)), count)
    cid = src[ragged_arange(ptr[which], count)]
    at = np.take(q0, row, axis=0)  # rows of a 2-d array: np.take (fancy indexing is slower)
    _, p, nrm = project_many(curves, cid, at)
    # each row's nearest projection, the first among equals (no sort)
    best = first_nearest(row, np.hypot(*(p - at).T))
    q[row[best]] = p[best]
    n[row[best]] = nrm[best]
    return q, n
