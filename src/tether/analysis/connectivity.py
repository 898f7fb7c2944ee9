"""The connectivity graph G: cells adjacent across boundary pieces (``docs/formulas.md``, "The
verdict").

Cells ``K`` over ``R`` and ``K'`` over ``R'`` are adjacent across a piece ``γ`` shared by ``R``
and ``R'`` when the arc of ``K`` continues into the arc of ``K'`` as the target crosses ``γ``:
their arcs at the two sides of ``γ`` (``q ± eps n``, close to the exact curve) overlap. A relabel
maps arcs 1:1, a split 1:2; an arc that closes or is born at ``γ`` (width ``O(sqrt(eps))``, inside
the other side's blocked set) has no partner. Every edge keeps its piece: the relation may differ
between pieces shared by the same two regions.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from tether._util.arrays import ragged_arange
from tether._util.memo import Memo, memo_field
from tether._util.memory import gc_paused, release_memory
from tether.arcs import ArcTable, free_arcs_many
from tether.decomposition import Decomposition
from tether.decomposition.views import Cells, Pieces
from tether.tolerances import ANGLE_TOL

if TYPE_CHECKING:  # networkx costs ~0.2 s to import: only when G is asked for as a graph
    import networkx as nx

__all__ = ["EDGE_CHUNK_ROWS", "PARTNER_CHUNK", "SLOT_CHUNK", "ConnectivityGraph", "build_graph",
           "index_dtype", "partner_entries", "size_runs"]


@dataclass(frozen=True, eq=False)
class ConnectivityGraph:
    """G: cells (nodes) and ``(cell, cell, piece)`` edges, on integer arrays (int32 where
    the counts allow, :func:`index_dtype`: about 50 bytes an edge).

    Cells are indices into ``dec.cells``. Each cell has one *slot* per piece bounding its
    region (in increasing piece order): slots ``slot_ptr[c]:slot_ptr[c + 1]``, their pieces
    ``slot_piece``. The partners of a slot (the cells adjacent to the cell across the piece)
    are ``partner_cell[partner_ptr[s]:partner_ptr[s + 1]]`` (CSR; made from the slots on the
    first read), and ``partner_slot`` the partner's own slot for the same piece. Edges are
    ``(edge_a[i], edge_b[i], edge_piece[i])``.

    The string views :attr:`edge_list`, :attr:`partners` (``partners[(cell, piece)]`` lists
    the cells adjacent to ``cell`` across ``piece``), :attr:`pieces_of` (``pieces_of[region]``
    the pieces bounding a region) and :attr:`graph` (a networkx ``MultiGraph``, edge keys are
    piece indices) are built on first use.
    """

    dec: Decomposition = field(repr=False)
    edge_a: np.ndarray = field(repr=False)
    edge_b: np.ndarray = field(repr=False)
    edge_piece: np.ndarray = field(repr=False)
    region_ptr: np.ndarray = field(repr=False)
    region_pieces: np.ndarray = field(repr=False)
    slot_ptr: np.ndarray = field(repr=False)
    slot_piece: np.ndarray = field(repr=False)
    partner_ptr: np.ndarray = field(repr=False)
    partner_slot: np.ndarray = field(repr=False)
    #: values derived on demand and kept (indexes, name tables): see :class:`Memo`
    memo: Memo = memo_field()

    @cached_property
    def partner_cell(self) -> np.ndarray:
        """The cell of every partner entry (the cell of its ``partner_slot``), made on the
        first read: the elimination reads only the slots (4 bytes an entry not held)."""
        cell = np.searchsorted(self.slot_ptr, self.partner_slot, side="right") - 1
        return cell.astype(index_dtype(len(self.slot_ptr) - 1))

    @property
    def n_edges(self) -> int:
        """Number of edges of G."""
        return len(self.edge_a)

    @cached_property
    def cell_ids(self) -> list[str]:
        """``dec.cells[i].id`` for every cell index ``i``."""
        return cell_ids(self.dec)

    @cached_property
    def edge_list(self) -> tuple[tuple[str, str, int], ...]:
        """``(cell, cell, piece index)`` per edge, cells by id (in build order)."""
        ids = self.cell_ids
        with gc_paused():
            return tuple((ids[a], ids[b], p) for a, b, p in zip(
                self.edge_a.tolist(), self.edge_b.tolist(), self.edge_piece.tolist(),
                strict=True))

    @cached_property
    def pieces_of(self) -> dict[int, tuple[int, ...]]:
        """The pieces bounding each region, increasing."""
        ptr, pcs = self.region_ptr.tolist(), self.region_pieces.tolist()
        return {r: tuple(pcs[ptr[r]:ptr[r + 1]]) for r in range(len(ptr) - 1)}

    @cached_property
    def partners(self) -> dict[tuple[str, int], tuple[str, ...]]:
        """``partners[(cell id, piece)]``: the ids of the cells adjacent across the piece, for
        every cell of both regions of every piece (piece by piece)."""
        with gc_paused():
            return self._partners()

    def _partners(self) -> dict[tuple[str, int], tuple[str, ...]]:
        ids = self.cell_ids
        dec = self.dec
        first = cell_first(dec).tolist()
        sptr, pptr = self.slot_ptr.tolist(), self.partner_ptr.tolist()
        pc = self.partner_cell.tolist()
        rptr, rpcs = self.region_ptr.tolist(), self.region_pieces.tolist()
        pos = {}  # (region, piece) -> position of the piece among the region's pieces
        for r in range(len(rptr) - 1):
            for j in range(rptr[r], rptr[r + 1]):
                pos[(r, rpcs[j])] = j - rptr[r]
        out: dict[tuple[str, int], tuple[str, ...]] = {}
        for k, regions in enumerate(piece_regions(dec).tolist()):
            for r in regions:
                j = pos[(r, k)]
                for c in range(first[r], first[r + 1]):
                    s = sptr[c] + j
                    out[(ids[c], k)] = tuple(ids[x] for x in pc[pptr[s]:pptr[s + 1]])
        return out

    @property
    def graph(self) -> nx.MultiGraph:
        """G as a networkx MultiGraph; nodes carry their ``region``."""
        g = self.memo.get("nx")
        if g is None:
            import networkx as nx

            g = nx.MultiGraph()
            g.add_nodes_from((c.id, {"region": c.region}) for c in self.dec.cells)
            g.add_edges_from(self.edge_list)
            self.memo["nx"] = g
        return g

    @property
    def edges(self) -> list[tuple[str, str, str]]:
        """``[cell, cell, piece]`` triples, sorted."""
        return sorted((min(a, b), max(a, b), f"P{k}") for a, b, k in self.edge_list)

    def __repr__(self) -> str:
        return f"ConnectivityGraph(cells={len(self.dec.cells)}, edges={self.n_edges})"


def cell_ids(dec: Decomposition) -> list[str]:
    """The ids of ``dec.cells`` as a list, cached on the decomposition."""
    got = dec.memo.get("cell_id_list")
    if got is None:
        cells = dec.cells
        got = cells._table.ids() if type(cells) is Cells else [c.id for c in cells]
        dec.memo["cell_id_list"] = got
    return got


def cell_ids_of(dec: Decomposition, which: Any) -> list[str]:
    """The ids of the cells of indices ``which`` (made from the cells' columns, not the list
    of every id unless it exists already)."""
    which = np.asarray(which, dtype=np.int64).reshape(-1)
    cells = dec.cells
    if "cell_id_list" in dec.memo or type(cells) is not Cells:
        ids = cell_ids(dec)
        return [ids[i] for i in which.tolist()]
    return cells._table.ids(which)


def cell_regions(dec: Decomposition) -> np.ndarray:
    """The region of every cell of ``dec.cells`` (int array), cached."""
    return dec.cell_codes()[0]


def cell_first(dec: Decomposition) -> np.ndarray:
    """``first[r]:first[r + 1]`` are the indices of region ``r``'s cells in ``dec.cells``
    (cells are listed region by region)."""
    counts = np.bincount(cell_regions(dec), minlength=len(dec.regions))
    return np.concatenate(([0], np.cumsum(counts))).astype(np.int64)


def _overlap(s1: Any, e1: Any, s2: Any, e2: Any, full1: Any = False, full2: Any = False
             ) -> Any:
    """Length (radians) of the intersection of CCW arcs ``(s1, e1)`` and ``(s2, e2)``;
    vectorized. ``full1``/``full2`` flag full-circle arcs (a FULL point); an arc whose end is
    given as ``start + 2π`` is full too. Arcs are never recognized as full by comparing reduced
    ends: a free arc is always longer than ``ANGLE_TOL`` and shorter than ``2π - ANGLE_TOL``."""
    s1, e1, s2, e2 = (np.asarray(x, dtype=float) for x in (s1, e1, s2, e2))
    out = _overlap_lengths(s1, _arc_length(s1, e1, full1), s2, _arc_length(s2, e2, full2))
    return float(out) if out.ndim == 0 else out


def _overlap_lengths(s1: np.ndarray, l1: np.ndarray, s2: np.ndarray, l2: np.ndarray
                     ) -> np.ndarray:
    """:func:`_overlap` of CCW arcs given by start and length (radians, :func:`_arc_length`)."""
    d21 = np.mod(s2 - s1, math.tau)  # arc 2 starting inside arc 1
    d12 = np.mod(s1 - s2, math.tau)  # arc 1 starting inside arc 2
    a = np.where(d21 < l1, np.minimum(l1 - d21, l2), 0.0)
    b = np.where(d12 < l2, np.minimum(l2 - d12, l1), 0.0)
    return np.maximum(a, b)


def _arc_length(s: np.ndarray, e: np.ndarray, full: Any) -> np.ndarray:
    """CCW length of arcs from ``s`` to ``e`` (radians, in (0, 2π]); ``full`` forces 2π."""
    raw = e - s
    length = np.where(raw > 0, np.minimum(raw, math.tau), np.mod(raw, math.tau))
    return np.where(np.asarray(full, dtype=bool), math.tau, length)


def _arc_rows(dec: Decomposition, pts: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """All free arcs at the points (default: both sides of every piece's crossing, as the
    decomposition found them) as flat arrays sorted by point; a FULL point contributes one
    full-circle arc (``full`` flag set, from 0 to 2π) with feature codes -1."""
    table = dec.crossing_arcs() if pts is None else free_arcs_many(dec.env, pts, dec.lss,
                                                                   check=False)
    return _table_arc_rows(table)


def _table_arc_rows(table: ArcTable) -> dict[str, np.ndarray]:
    """The rows of :func:`_arc_rows` from an arc table (its own arrays when they are sorted
    by point already and no point is FULL, else a sorted copy)."""
    full = np.flatnonzero(table.full)
    if len(full) == 0 and np.all(table.point[1:] >= table.point[:-1]):  # as is: no copies
        return {"point": table.point, "start": table.start, "end": table.end,
                "full": np.zeros(len(table.point), bool), "start_code": table.start_code,
                "end_code": table.end_code}
    point = np.concatenate((table.point, full))
    order = np.argsort(point, kind="stable")
    return {
        "point": point[order],
        "start": np.concatenate((table.start, np.zeros(len(full))))[order],
        "end": np.concatenate((table.end, np.full(len(full), math.tau)))[order],
        "full": np.concatenate((np.zeros(len(table.point), bool),
                                np.ones(len(full), bool)))[order],
        "start_code": np.concatenate((table.start_code, np.full(len(full), -1)))[order],
        "end_code": np.concatenate((table.end_code, np.full(len(full), -1)))[order],
    }


def _cell_index(dec: Decomposition, region: np.ndarray, start_code: np.ndarray,
                end_code: np.ndarray, keys: tuple[np.ndarray, np.ndarray] | None = None
                ) -> np.ndarray:
    """Index in ``dec.cells`` of the cell ``(region, start, end)`` given by feature codes
    (-1 for the free end of a FULL region), vectorized; -1 where no such cell exists.
    ``keys``: :func:`_cell_keys` of ``dec`` (made if not given)."""
    keys, order = _cell_keys(dec) if keys is None else keys
    base = 2 * dec.env.n + 1
    q = (np.asarray(region, np.int64) * base + (np.asarray(start_code, np.int64) + 1)) \
        * base + (np.asarray(end_code, np.int64) + 1)
    if len(keys) == 0:
        return np.full(len(q), -1)
    pos = np.clip(np.searchsorted(keys, q), 0, len(keys) - 1)
    return np.where(keys[pos] == q, order[pos], -1)


def _cell_keys(dec: Decomposition) -> tuple[np.ndarray, np.ndarray]:
    """Sorted integer keys ``(region * B + start + 1) * B + end + 1`` of the cells (codes in
    ``dec.env``'s numbering, ``B = 2 n + 1``) and the cell index of each key (not kept: 16
    bytes a cell, needed once per build of G)."""
    base = 2 * dec.env.n + 1
    region, start, end = dec.cell_codes()
    keys = (region.astype(np.int64) * base + start + 1) * base + end + 1
    order = np.argsort(keys, kind="stable")
    return keys[order], order.astype(index_dtype(len(keys)))


def index_dtype(n: int) -> type:
    """The integer type of indices into ``n`` items, and of counts up to ``n``: int32 below
    2**31 (half the bytes of G's columns), else int64."""
    return np.int32 if n < 2**31 else np.int64


def _edges(dec: Decomposition, progress: Any = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every edge ``(cell a over regions[0], cell b over regions[1], piece)`` as three int
    arrays (:func:`index_dtype` of the cells' and the pieces' counts): arc pairs of the two
    sides of each piece whose arcs overlap, found part by part of the crossings' arcs
    (:meth:`Decomposition.crossing_arc_parts`: one part in memory, or a store's parts read
    one at a time), for runs of consecutive pieces of about :data:`EDGE_CHUNK_ROWS` arc rows
    at a time (all at once within a run; the same edges in the same order as in one run:
    the rows of a run are those of its pieces, in order). ``progress(stage, fraction)`` is
    told of the cells' index and of the pieces done."""
    m = len(dec.pieces)
    empty = np.zeros(0, dtype=np.int32)
    if m == 0:
        return empty, empty, empty
    report = progress or (lambda stage, frac: None)
    report("cells index", 0.0)
    regs = piece_regions(dec)
    keys = _cell_keys(dec)
    cell_t, piece_t = index_dtype(len(dec.cells)), index_dtype(m)
    got = []
    report("G edges", 0.0)
    for first, table in dec.crossing_arc_parts():
        k = len(table.full) // 2
        got += _part_edges(dec, table, regs[first:first + k], first, keys, cell_t, piece_t)
        del table
        release_memory()  # the part's arcs and its runs' temporaries, before the next part
        report("G edges", (first + k) / m)
    if len(got) == 1:
        return got[0]
    cols = [list(c) for c in zip(*got, strict=True)]
    del got
    out = []
    for c in cols:  # a column joined, its runs' arrays freed before the next is joined
        out.append(np.concatenate(c) if c else np.zeros(0, np.int32))
        c.clear()
    return out[0], out[1], out[2]


def _part_edges(dec: Decomposition, table: ArcTable, regs: np.ndarray, first: int,
                keys: tuple[np.ndarray, np.ndarray], cell_t: type, piece_t: type
                ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The edges of the ``m = len(regs)`` pieces ``first .. first + m - 1`` from the arcs at
    their crossings (``table``, numbered as a decomposition of those pieces alone), run by
    run of about :data:`EDGE_CHUNK_ROWS` rows: per run, the cells of both sides (indices
    into ``dec.cells``, found by ``keys``, :func:`_cell_keys`) and the pieces (global)."""
    m = len(regs)
    if _sorted_by_point(table.point):  # each run's rows read from the table as it is
        at = np.searchsorted(table.point, np.arange(2 * m + 1))  # each point's first row
        full = np.asarray(table.full, bool)
        count = np.diff(at) + full  # rows of each point, a FULL point's full arc counted

        def run_rows(p0: int, p1: int) -> dict[str, np.ndarray]:
            return _table_run_rows(table, at, m, p0, p1)
    else:  # a sorted copy of every row (a table not made by decompose nor the store)
        rows = _table_arc_rows(table)
        at = np.searchsorted(rows["point"], np.arange(2 * m + 1))
        count = np.diff(at)

        def run_rows(p0: int, p1: int) -> dict[str, np.ndarray]:
            return _run_rows(rows, at, m, p0, p1)
    per_piece = count[:m] + count[m:]  # rows of both sides
    del count
    ends = size_runs(np.cumsum(per_piece), EDGE_CHUNK_ROWS)
    got = []
    for p0, p1 in zip([0, *ends[:-1]], ends, strict=True):
        sub = run_rows(p0, p1)
        k, ia, ib = _run_pairs(sub, p1 - p0)
        k += p0
        ca = _cell_index(dec, regs[k, 0], sub["start_code"][ia], sub["end_code"][ia], keys)
        cb = _cell_index(dec, regs[k, 1], sub["start_code"][ib], sub["end_code"][ib], keys)
        del sub, ia, ib
        ok = (ca >= 0) & (cb >= 0)
        got.append((ca[ok].astype(cell_t), cb[ok].astype(cell_t),
                    (k[ok] + first).astype(piece_t)))
    return got


#: Arc rows (of both sides of a run of consecutive pieces) whose overlapping pairs
#: :func:`_edges` finds at once: bounds its temporaries (~150 bytes a row) on large maps
EDGE_CHUNK_ROWS = 1 << 20


def size_runs(total: np.ndarray, limit: int) -> list[int]:
    """The ends of runs of consecutive items of cumulative sizes ``total``, each run at most
    ``limit`` in all (or one item); the last end is ``len(total)``."""
    ends, done, n = [], 0, len(total)
    while done < n:
        base = int(total[done - 1]) if done else 0
        end = max(int(np.searchsorted(total, base + limit, side="right")), done + 1)
        ends.append(min(end, n))
        done = ends[-1]
    return ends


def _run_rows(rows: dict[str, np.ndarray], first: np.ndarray, m: int, p0: int, p1: int
              ) -> dict[str, np.ndarray]:
    """The arc rows of pieces ``p0:p1`` (both sides), their points renumbered as a
    decomposition of those pieces alone: side 0 ``0 .. k - 1``, side 1 ``k .. 2k - 1``."""
    a0, a1, b0, b1 = (int(first[i]) for i in (p0, p1, m + p0, m + p1))
    if p0 == 0 and p1 == m:
        return rows
    out = {name: np.concatenate((col[a0:a1], col[b0:b1])) for name, col in rows.items()}
    shift = np.full(len(out["point"]), -p0, dtype=np.int64)
    shift[a1 - a0:] = -(m + p0) + (p1 - p0)
    out["point"] = out["point"] + shift
    return out


def _sorted_by_point(point: np.ndarray, chunk: int = 1 << 22) -> bool:
    """Whether ``point`` never decreases (checked ``chunk`` rows at a time: no temporary of
    every row)."""
    for lo in range(0, max(len(point) - 1, 0), chunk):
        hi = min(lo + chunk, len(point) - 1)
        if np.any(point[lo + 1:hi + 1] < point[lo:hi]):
            return False
    return True


def _table_run_rows(table: ArcTable, first: np.ndarray, m: int, p0: int, p1: int
                    ) -> dict[str, np.ndarray]:
    """:func:`_run_rows` of pieces ``p0:p1`` read from the arc table (sorted by point;
    ``first`` each point's first row) without the sorted copy of every row
    :func:`_table_arc_rows` makes: the run's rows of both sides and a full-circle row for
    each of its FULL points, after that point's rows (as the stable sort there puts them),
    the same rows as there."""
    a0, a1, b0, b1 = (int(first[i]) for i in (p0, p1, m + p0, m + p1))
    fa = np.flatnonzero(table.full[p0:p1]) + p0
    fb = np.flatnonzero(table.full[m + p0:m + p1]) + m + p0
    nf = len(fa) + len(fb)
    point = np.concatenate((table.point[a0:a1], table.point[b0:b1], fa, fb))
    out = {"point": point.astype(np.int64),
           "start": np.concatenate((table.start[a0:a1], table.start[b0:b1], np.zeros(nf))),
           "end": np.concatenate((table.end[a0:a1], table.end[b0:b1], np.full(nf, math.tau))),
           "full": np.r_[np.zeros(len(point) - nf, bool), np.ones(nf, bool)]}
    for name in ("start_code", "end_code"):
        col = getattr(table, name)
        out[name] = np.concatenate((col[a0:a1], col[b0:b1], np.full(nf, -1, col.dtype)))
    if nf:  # the full rows among the others, in point order (stable: after its rows)
        order = np.argsort(out["point"], kind="stable")
        out = {k: v[order] for k, v in out.items()}
    shift = np.where(out["point"] < m, -p0, -(m + p0) + (p1 - p0))
    out["point"] += shift
    return out


def _run_pairs(rows: dict[str, np.ndarray], m: int) -> tuple[np.ndarray, np.ndarray,
                                                              np.ndarray]:
    """The overlapping arc pairs of ``m`` pieces' rows: each pair's piece, its row on the
    side of ``regions[0]`` and its row on the other side."""
    length = _arc_length(rows["start"], rows["end"], rows["full"])  # each arc's, once
    pair_a, pair_b = _candidate_pairs(rows, m, length)
    keep = _overlapping(rows["start"], length, pair_a, pair_b)
    del length
    pair_a, pair_b = pair_a[keep], pair_b[keep]
    return rows["point"][pair_a].astype(np.int64), pair_a, pair_b


#: Arc pairs compared at once by :func:`_overlapping` (bounds its temporaries: ~10 arrays of
#: this length, 8 bytes each)
OVERLAP_CHUNK = 1 << 18


def _overlapping(start: np.ndarray, length: np.ndarray, pair_a: np.ndarray,
                 pair_b: np.ndarray) -> np.ndarray:
    """Indices ``i`` of the pairs whose arcs ``pair_a[i]`` and ``pair_b[i]`` (of starts
    ``start`` and lengths ``length``, radians) overlap by more than ``ANGLE_TOL``
    (:func:`_overlap`, chunk by chunk: the same numbers, a lower peak)."""
    out = []
    for lo in range(0, len(pair_a), OVERLAP_CHUNK):
        a, b = pair_a[lo:lo + OVERLAP_CHUNK], pair_b[lo:lo + OVERLAP_CHUNK]
        ov = _overlap_lengths(start[a], length[a], start[b], length[b])
        out.append(np.flatnonzero(ov > ANGLE_TOL) + lo)
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


#: Angular margin (radians) of the candidate search: a superset of the overlapping arc pairs,
#: each pair then tested exactly by :func:`_overlap`. Far above the rounding of the search keys.
_SEARCH_MARGIN = 1e-6


def _candidate_pairs(rows: dict[str, np.ndarray], m: int, length: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Arc pairs (row on the side of ``regions[0]``, row on the other side) of each piece that
    may overlap, sorted by (a, b): every pair whose arcs overlap is among them, and their number
    is linear in the number of arcs. The arcs at a point are disjoint and sorted by start, so
    an arc ``a`` can only overlap the arc containing its start (the last one starting before
    it, around the circle) and the arcs starting inside it. ``length``: the arcs' lengths
    (:func:`_arc_length`), computed if not given."""
    point, start = rows["point"], rows["start"]
    counts = np.bincount(point, minlength=2 * m)
    first = np.cumsum(counts) - counts
    key = point * 8.0 + start  # increasing: rows are sorted by point, then start (< 2π)
    a = np.flatnonzero(point < m)
    pb = point[a] + m  # the point across the piece
    has = counts[pb] > 0
    a, pb = a[has], pb[has]
    s1 = start[a]
    lo = s1 - _SEARCH_MARGIN
    hi = s1 + (_arc_length(s1, rows["end"][a], rows["full"][a]) if length is None
               else length[a]) + _SEARCH_MARGIN
    base = pb * 8.0
    del pb, s1
    # the arcs starting in [lo, hi] (wrapped around 2π: up to three ranges)
    got_a, got_b = [], []
    for got in (_starting_in(key, base, lo.clip(0.0, math.tau), np.minimum(hi, math.tau), a),
                _starting_in(key, base, None, hi - math.tau, a, hi > math.tau),
                _starting_in(key, base, lo + math.tau, None, a, lo < 0)):
        got_a.append(got[0])
        got_b.append(got[1])
    # the arc containing a's start: the last starting at or before it, else the point's last
    pb = point[a] + m
    j = np.searchsorted(key, base + lo, side="right") - 1
    j = np.where(j >= first[pb], j, first[pb] + counts[pb] - 1)
    del lo, hi, base, pb
    got_a.append(a)
    got_b.append(j)
    del j
    pair = np.concatenate(got_a)
    pair *= len(point)
    del got_a
    pair += np.concatenate(got_b)
    del got_b
    pair.sort()  # sorted by (a, b); a few pairs appear twice
    pair = pair[np.r_[True, pair[1:] != pair[:-1]]] if len(pair) else pair
    return pair // len(point), pair % len(point)


def _starting_in(key: np.ndarray, base: np.ndarray, r0: np.ndarray | None,
                 r1: np.ndarray | None, a: np.ndarray, use: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``(a[i], row)`` of the rows whose key lies in ``[base[i] + r0[i], base[i] +
    r1[i]]`` (``r0`` None: 0, ``r1`` None: 2π), for the ``i`` of mask ``use`` (None: all)."""
    if use is not None:
        w = np.flatnonzero(use)
        base, a = base[w], a[w]
        r0 = None if r0 is None else r0[w]
        r1 = None if r1 is None else r1[w]
    i0 = np.searchsorted(key, base + (0.0 if r0 is None else r0), side="left")
    i1 = np.searchsorted(key, base + (math.tau if r1 is None else r1), side="right")
    n = np.maximum(i1 - i0, 0)
    return np.repeat(a, n), ragged_arange(i0, n)


def piece_regions(dec: Decomposition) -> np.ndarray:
    """``(m, 2)`` int array of every piece's two regions: the pieces' column (never to be
    written), or read from the pieces and cached on the decomposition."""
    if type(dec.pieces) is Pieces:
        return dec.pieces._table.pair
    got = dec.memo.get("piece_regions")
    if got is None:
        m = len(dec.pieces)
        flat = np.fromiter(itertools.chain.from_iterable(p.regions for p in dec.pieces),
                           np.int64, 2 * m)
        got = dec.memo["piece_regions"] = flat.reshape(m, 2)
    return got


def build_graph(dec: Decomposition, progress: Any = None) -> ConnectivityGraph:
    """Build G from a decomposition: one edge per (cell, cell, piece) whose arcs continue into
    each other across the piece (all arc pairs of all pieces compared at once), stored as
    integer arrays (see :class:`ConnectivityGraph`). The crossings' arcs are read part by
    part (:meth:`Decomposition.crossing_arc_parts`: from a store, one part in memory at a
    time, ``docs/store.md``).

    Parameters
    ----------
    dec : Decomposition
    progress : callable, optional
        Called as ``progress(stage, fraction_done)``, stages ``"cells index"``, ``"G
        edges"`` (by pieces done) and ``"G slots"``.

    Returns
    -------
    ConnectivityGraph

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.analysis import build_graph
    >>> from tether.decomposition import decompose
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> build_graph(decompose(room, 1.0))
    ConnectivityGraph(cells=32, edges=54)
    """
    ea, eb, ep = _edges(dec, progress)
    if progress is not None:
        progress("G slots", 0.0)
    nreg, ncell = len(dec.regions), len(dec.cells)
    regs = piece_regions(dec)
    m = len(regs)
    piece_t = index_dtype(2 * m)
    # pieces of each region (CSR), increasing: entries (region, piece) per piece side
    ent_region = regs.T.ravel()  # side 0 of every piece, then side 1
    ent_piece = np.tile(np.arange(m, dtype=piece_t), 2)
    order = np.lexsort((ent_piece, ent_region))
    region_count = np.bincount(ent_region, minlength=nreg)
    region_ptr = np.zeros(nreg + 1, dtype=piece_t)
    np.cumsum(region_count, out=region_ptr[1:])
    region_pieces = ent_piece[order]
    # position of each piece side among its region's pieces
    pos = np.empty(2 * m, dtype=piece_t)
    pos[order] = np.arange(2 * m, dtype=piece_t) - region_ptr[ent_region[order]]
    del order, ent_piece, ent_region
    side_pos = pos.reshape(2, m)
    # slots: one per (cell, piece of the cell's region)
    creg = cell_regions(dec)
    nslot = region_count[creg] if ncell else np.zeros(0, np.int64)
    total = int(nslot.sum())
    slot_t = index_dtype(total + 1)
    slot_ptr = np.zeros(ncell + 1, dtype=slot_t)
    np.cumsum(nslot, out=slot_ptr[1:])
    del nslot
    slot_piece = _slot_pieces(slot_ptr, creg, region_ptr, region_pieces)
    del creg
    # partner entries: (slot of a, b) and (slot of b, a) per edge, in edge order
    # (made one after the other, each temporary freed when used: a lower peak)
    slot_a = _edge_slots(slot_ptr, ea, side_pos[0], ep)
    slot_b = _edge_slots(slot_ptr, eb, side_pos[1], ep)
    partner_ptr, partner_slot = partner_entries(slot_a, slot_b, len(slot_piece))
    del slot_a, slot_b
    release_memory()  # the temporaries' heap, before the elimination allocates its own
    return ConnectivityGraph(dec, ea, eb, ep, region_ptr, region_pieces,
                             slot_ptr, slot_piece, partner_ptr, partner_slot)


#: Slots (of a run of consecutive cells, :func:`_slot_pieces`) or edges
#: (:func:`_edge_slots`) made at once: bounds their temporaries (~30 bytes an item of the
#: run, ~30 MB) where one pass over every slot would take ~30 bytes a slot of G (~2 GB at
#: 4,000 floor-plan vertices)
SLOT_CHUNK = 1 << 20


def _slot_pieces(slot_ptr: np.ndarray, creg: np.ndarray, region_ptr: np.ndarray,
                 region_pieces: np.ndarray) -> np.ndarray:
    """The piece of every slot: cell ``c`` (of region ``creg[c]``) has slots
    ``slot_ptr[c]:slot_ptr[c + 1]``, one per piece of its region in order
    (``region_pieces[region_ptr[r]:region_ptr[r + 1]]``); made for runs of consecutive
    cells of about :data:`SLOT_CHUNK` slots at a time."""
    out = np.empty(int(slot_ptr[-1]), dtype=region_pieces.dtype)
    ends = size_runs(slot_ptr[1:], SLOT_CHUNK)
    for c0, c1 in zip([0, *ends][:len(ends)], ends, strict=True):
        reg = creg[c0:c1]
        out[slot_ptr[c0]:slot_ptr[c1]] = region_pieces[ragged_arange(
            region_ptr[reg], region_ptr[reg + 1] - region_ptr[reg])]
    return out


def _edge_slots(slot_ptr: np.ndarray, cell: np.ndarray, side_pos: np.ndarray,
                piece: np.ndarray) -> np.ndarray:
    """``slot_ptr[cell] + side_pos[piece]`` (each edge's slot of its cell on one side), in
    ``slot_ptr``'s type, :data:`SLOT_CHUNK` edges at a time."""
    out = np.empty(len(cell), dtype=np.result_type(slot_ptr.dtype, side_pos.dtype))
    for lo in range(0, len(cell), SLOT_CHUNK):
        hi = lo + SLOT_CHUNK
        np.add(slot_ptr[cell[lo:hi]], side_pos[piece[lo:hi]], out=out[lo:hi])
    return out


#: Edges whose partner entries :func:`partner_entries` places at once (bounds its
#: temporaries: ~100 bytes an edge of the run, ~25 MB)
PARTNER_CHUNK = 1 << 18


def partner_entries(slot_a: np.ndarray, slot_b: np.ndarray, nslot: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """G's partner CSR from its edges' slots (edge ``i`` joins slot ``slot_a[i]`` and slot
    ``slot_b[i]``): ``partner_ptr`` (``nslot + 1``) and ``partner_slot``, the entries
    ``(slot_a[i] -> slot_b[i])`` and ``(slot_b[i] -> slot_a[i])`` of every edge grouped by
    their slot, in edge order within a slot (the stable sort of the entries by slot). Made
    by a counting sort, :data:`PARTNER_CHUNK` edges at a time: no sort, index or count
    array of every entry or slot in 8 bytes, the peak is the result, one int per slot and
    one run's temporaries."""
    ne = len(slot_a)
    entry_t = index_dtype(2 * ne + 1)
    partner_ptr = np.zeros(nslot + 1, dtype=entry_t)
    count = partner_ptr[1:]  # each slot's entries, counted in place, then summed
    # a one in the counts' own type: ``ufunc.at`` casting a Python int into int32 is ~50x
    # slower (1 M entries: 56 ms against 1 ms; into int64 there is no cast)
    one = count.dtype.type(1)
    for lo in range(0, ne, PARTNER_CHUNK):
        np.add.at(count, slot_a[lo:lo + PARTNER_CHUNK], one)
        np.add.at(count, slot_b[lo:lo + PARTNER_CHUNK], one)
    np.cumsum(partner_ptr, out=partner_ptr)
    cursor = partner_ptr[:-1].copy()  # each slot's next free entry
    partner_slot = np.empty(2 * ne, dtype=np.result_type(slot_a.dtype, slot_b.dtype))
    for lo in range(0, ne, PARTNER_CHUNK):
        hi = min(lo + PARTNER_CHUNK, ne)
        key = np.column_stack((slot_a[lo:hi], slot_b[lo:hi])).ravel()
        order = np.argsort(key, kind="stable")
        key = key[order]
        head = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        size = np.diff(np.r_[head, len(key)])
        at = np.arange(len(key)) - np.repeat(head, size)  # position among equal keys
        at += cursor[key]
        partner_slot[at] = np.column_stack((slot_b[lo:hi], slot_a[lo:hi])).ravel()[order]
        cursor[key[head]] += size.astype(entry_t)
    return partner_ptr, partner_slot
