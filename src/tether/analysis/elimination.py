"""Escapable cells, their elimination and the existence verdict (Prop. 1; ``docs/formulas.md``,
"The verdict").

Cell ``K`` over ``R`` is escapable with respect to the surviving cells ``S`` iff some piece
``γ`` bounding ``R`` (toward ``R'``) has no cell of ``S`` over ``R'`` adjacent to ``K`` across
``γ``: the target crosses ``γ`` and no observer position continues the rod. Elimination is the
greatest fixed point of removing escapable cells, computed with a worklist in rounds (round
``k`` removes the cells escapable once rounds ``< k`` are removed). Since the free space is
connected the outcome is all-or-nothing: a surveillance strategy can exist iff some cell
survives (with unbounded observer speed, any start in a surviving cell can be held).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Sequence, Set
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from tether._util.arrays import ragged_arange
from tether._util.memo import Memo, memo_field
from tether._util.memory import gc_paused
from tether.analysis.connectivity import (
    ConnectivityGraph,
    build_graph,
    cell_first,
    cell_ids_of,
    cell_regions,
    index_dtype,
    piece_regions,
    size_runs,
)
from tether.analysis.critical import ON_CRITICAL_TOLS, CriticalLss, side_summary
from tether.analysis.critical import near_critical as critical_events
from tether.arcs import feature_name
from tether.decomposition import Decomposition, decompose, feature_name_rank
from tether.decomposition.structure import FREE
from tether.decomposition.views import parse_cell_name, small_ints
from tether.tolerances import REL_LENGTH_TOL

__all__ = ["JSON_LIST_MAX", "CellSet", "Elimination", "Eliminations", "Verdict", "analyze",
           "eliminate", "escape_story"]

#: Items a list of :meth:`Verdict.to_dict` holds at most (edges of G, surviving cells,
#: eliminations): a longer one is given as its count (and the file of its arrays) instead,
#: which bounds ``tether analyze --json`` on large maps (an edge costs ~300 bytes of Python
#: objects and ~60 of JSON text: 200,000 of them ~12 MB of text).
JSON_LIST_MAX = 200_000


@dataclass(frozen=True)
class Elimination:
    """Why a cell fell: crossing piece ``piece`` into region ``escapes_to`` loses it, in
    ``round``; ``because`` is the last partner across that piece whose removal made it
    escapable (None in round 1, or when the other side never had a partner).

    Identities are integers: ``cell`` and ``because`` index ``dec.cells``, ``escapes_to`` is a
    region id and ``piece`` a piece id; ``cell_name`` and ``because_name`` are the cells'
    names (``"(R3,E1,V2)"``), and :meth:`to_dict` prints names (``"R4"``, ``"P7"``)."""

    cell: int
    escapes_to: int
    piece: int
    round: int
    because: int | None
    cell_name: str = field(repr=False, compare=False)
    because_name: str | None = field(repr=False, compare=False)

    def to_dict(self) -> dict:
        """The elimination as JSON-ready values."""
        return {"cell": self.cell_name, "escapes_to": f"R{self.escapes_to}",
                "piece": f"P{self.piece}", "round": self.round, "because": self.because_name}


@dataclass(frozen=True, eq=False)
class Verdict:
    """The result of :func:`analyze`: surviving cells, eliminations, verdict and witness.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.analysis import analyze
    >>> from tether.decomposition import decompose
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> verdict = analyze(decompose(ell, 0.5))
    >>> verdict.strategy_exists, verdict.verified, len(verdict.surviving)
    (True, True, 20)
    """

    dec: Decomposition = field(repr=False)
    graph: ConnectivityGraph = field(repr=False)
    #: the surviving cells' ids (a frozenset, or from :func:`analyze` an equal
    #: :class:`CellSet` over a bool column, ids made when read)
    surviving: Set[str]
    #: the eliminations in order (a tuple-like :class:`Eliminations` from :func:`analyze`)
    eliminated: Sequence[Elimination]
    witness_region: int | None
    #: the cheap self-check run by :func:`analyze` (a
    #: :class:`tether.decomposition.CheckReport`), or None if it was skipped
    self_check: Any = None
    #: a :class:`tether.analysis.critical.CriticalLss` when ``lss`` is within tether's
    #: resolution of a critical length of the map (the verdicts just below and above), else None
    critical: Any = None
    #: values derived on demand and kept (indexes, name tables): see :class:`Memo`
    memo: Memo = memo_field()

    @property
    def verified(self) -> bool | None:
        """Whether the self-check passed (None: not run). A verdict with ``verified`` False
        rests on a decomposition that disagrees with exact evaluation somewhere."""
        return None if self.self_check is None else bool(self.self_check.ok)

    @property
    def strategy_exists(self) -> bool:
        """Whether some cell survives the elimination (necessary condition, Prop. 1)."""
        return bool(self.surviving)

    @property
    def rounds(self) -> int:
        """Number of elimination rounds (0 when nothing was eliminated)."""
        el = self.eliminated
        if isinstance(el, Eliminations):
            return int(el.round.max()) if len(el) else 0
        return max((e.round for e in el), default=0)

    def is_safe(self, points: Any, angles: Any) -> list[bool]:
        """Whether each rod configuration ``(x, y, a)`` lies in a surviving cell."""
        return [c is not None and c in self.surviving for c in self.dec.cell_at(points, angles)]

    def story(self) -> list[str]:
        """The escape in plain sentences: from the first escapable cell to the witness."""
        return escape_story(self)

    def counts(self) -> dict:
        """Counts of regions, cells, pieces, edges of G and surviving cells."""
        return {"regions": len(self.dec.regions), "cells": len(self.dec.cells),
                "pieces": len(self.dec.pieces), "edges": self.graph.n_edges,
                "surviving_cells": len(self.surviving)}

    def to_dict(self, max_items: float | None = None, arrays: str | None = None) -> dict:
        """The verdict as JSON-ready values (the ``tether analyze --json`` fields).

        A list longer than ``max_items`` (the edges of G, the surviving cells, the
        eliminations; None: :data:`JSON_LIST_MAX`, ``math.inf``: no bound) is given as
        ``{"count": n, "arrays": arrays}`` instead of one JSON value an item (~300 bytes of
        Python objects each, tens of GB at 4,000 map vertices): ``arrays`` names the file
        :meth:`save_arrays` wrote them to (None: not written)."""
        most = JSON_LIST_MAX if max_items is None else max_items

        def bounded(n: int, make: Any) -> Any:
            return {"count": n, "arrays": arrays} if n > most else make()

        return {
            "map": self.dec.env.name,
            "lss": self.dec.lss,
            "counts": self.counts(),
            "edges": bounded(self.graph.n_edges, lambda: [list(e) for e in self.graph.edges]),
            "verdict": {
                "strategy_exists": self.strategy_exists,
                "witness_region": None if self.witness_region is None
                else f"R{self.witness_region}",
                "rounds": self.rounds,
                "surviving": bounded(len(self.surviving), lambda: sorted(self.surviving)),
                "eliminated": bounded(len(self.eliminated),
                                      lambda: [e.to_dict() for e in self.eliminated]),
                "story": self.story(),
            },
            "self_check": None if self.self_check is None else self.self_check.to_dict(),
            "verified": self.verified,
            "critical_lss": None if self.critical is None else self.critical.to_dict(),
        }

    def arrays(self) -> dict[str, np.ndarray]:
        """The verdict's lists as integer columns (what :meth:`save_arrays` writes): G's
        edges ``edge_a``, ``edge_b`` (cell indices into ``dec.cells``), ``edge_piece``; the
        ``surviving`` cells' indices (increasing); the eliminations in order,
        ``eliminated_cell``, ``eliminated_piece``, ``eliminated_round``,
        ``eliminated_because`` (-1: none); and the cells' names as ``cell_region``,
        ``cell_start``, ``cell_end`` feature codes into ``feature_names`` (cell ``i`` is
        ``(R<cell_region[i]>,<feature_names[cell_start[i] + 1]>,<feature_names[cell_end[i]
        + 1]>)``, code -1 the free end of a FULL region's cell)."""
        g, el, dec = self.graph, self.eliminated, self.dec
        if not isinstance(el, Eliminations):  # a verdict made otherwise: from its records
            el = _records_as_columns(el)
        alive = (self.surviving.indices() if isinstance(self.surviving, CellSet) else
                 np.sort([dec.cell_index(c) for c in self.surviving]).astype(np.int64))
        region, start, end = dec.cell_codes()
        names = [feature_name(dec.env, c) for c in range(2 * dec.env.n)]
        return {"edge_a": g.edge_a, "edge_b": g.edge_b, "edge_piece": g.edge_piece,
                "surviving": alive, "eliminated_cell": el.cell,
                "eliminated_piece": el.piece, "eliminated_round": el.round,
                "eliminated_because": el.because, "cell_region": region,
                "cell_start": start, "cell_end": end,
                "feature_names": np.array([FREE, *names], dtype=str)}

    def save_arrays(self, path: str | os.PathLike) -> Path:
        """Write :meth:`arrays` to the ``.npz`` file ``path`` (numpy's format, no pickled
        object), whole or not at all; returns its path.

        Raises
        ------
        OutputPathError
            If the file cannot be written.
        """
        from tether._util.files import atomic_output

        with atomic_output(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, **self.arrays())
        return Path(path)

    def __repr__(self) -> str:
        return (f"Verdict(strategy_exists={self.strategy_exists}, "
                f"surviving={len(self.surviving)}/{len(self.dec.cells)}, "
                f"witness={self.witness_region})")

    def plot(self, fig: Any = None) -> Any:
        """The paper-style figure (see :func:`tether.plot.plot_verdict`)."""
        from tether.plot.verdict import plot_verdict

        return plot_verdict(self, fig)


class Eliminations(Sequence):
    """The eliminations of :func:`eliminate` in the order they happened, held as integer
    arrays; each :class:`Elimination` (string ids) is built when asked for."""

    def __init__(self, graph: ConnectivityGraph, cell: np.ndarray, piece: np.ndarray,
                 rnd: np.ndarray, because: np.ndarray) -> None:
        self.graph = graph
        #: cell index, piece index, round (from 1) and ``because`` cell index (-1: None)
        self.cell, self.piece, self.round, self.because = cell, piece, rnd, because

    def __len__(self) -> int:
        return len(self.cell)

    def _one(self, i: int) -> Elimination:
        dec = self.graph.dec
        c, k, b = int(self.cell[i]), int(self.piece[i]), int(self.because[i])
        ra, rb = piece_regions(dec)[k].tolist()
        other = rb if ra == cell_regions(dec)[c] else ra
        ids = cell_ids_of(dec, [c] if b < 0 else [c, b])
        return Elimination(c, int(other), k, int(self.round[i]), None if b < 0 else b,
                           ids[0], None if b < 0 else ids[1])

    @cached_property
    def _all(self) -> tuple[Elimination, ...]:
        with gc_paused():
            return self._make_all()

    def _make_all(self) -> tuple[Elimination, ...]:
        """Every :class:`Elimination`, in order (ids made in one pass)."""
        dec = self.graph.dec
        n = len(self)
        ids = cell_ids_of(dec, np.concatenate((self.cell, np.maximum(self.because, 0))))
        ends = piece_regions(dec)[self.piece]
        other = np.where(ends[:, 0] == cell_regions(dec)[self.cell], ends[:, 1], ends[:, 0])
        return tuple(Elimination(c, o, k, r, None if b < 0 else b, ic, None if b < 0 else ib)
                     for c, o, k, r, b, ic, ib in zip(
                         self.cell.tolist(), other.tolist(), self.piece.tolist(),
                         self.round.tolist(), self.because.tolist(), ids[:n], ids[n:],
                         strict=True))

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return self._all[i]
        if "_all" in self.__dict__:  # made already
            return self._all[i]
        n = len(self)
        j = int(i) + n if int(i) < 0 else int(i)
        if not 0 <= j < n:
            raise IndexError(i)
        return self._one(j)

    def __iter__(self) -> Iterator[Elimination]:
        return iter(self._all)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Sequence):
            return tuple(self) == tuple(other)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self._all)

    def __repr__(self) -> str:
        return f"Eliminations({len(self)})"


class CellSet(Set):
    """A set of cells of a decomposition, held as one bool per cell (``alive``, in the order
    of ``dec.cells``) and read as the set of their ids (``"(R3,E1,V2)"``): membership by id
    through the cells' columns (:meth:`Decomposition.cell_index`), iteration in cell order
    making the ids then. Equal to the frozenset of the same ids (and hashed as it; pickled
    as it): a million surviving cells cost a megabyte, not ~100 MB of strings and hash
    table."""

    __slots__ = ("_dec", "alive", "_n")

    def __init__(self, dec: Decomposition, alive: np.ndarray) -> None:
        self._dec = dec
        self.alive = np.asarray(alive, dtype=bool)
        self._n = int(np.count_nonzero(self.alive))

    @classmethod
    def _from_iterable(cls, it: Iterable[str]) -> frozenset[str]:
        return frozenset(it)  # the results of &, |, - ...: plain frozensets

    def __len__(self) -> int:
        return self._n

    def __contains__(self, cell_id: object) -> bool:
        if not isinstance(cell_id, str):
            return False
        try:
            i = self._dec.cell_index(cell_id)
        except KeyError:
            return False
        return bool(self.alive[i])

    def __iter__(self) -> Iterator[str]:
        return iter(self.indices_ids())

    def indices(self) -> np.ndarray:
        """The cells' indices into ``dec.cells``, increasing."""
        return np.flatnonzero(self.alive)

    def indices_ids(self) -> list[str]:
        """The cells' ids, in cell order."""
        return cell_ids_of(self._dec, self.indices())

    def __hash__(self) -> int:
        return hash(frozenset(self))

    def __reduce__(self) -> tuple:
        return (frozenset, (self.indices_ids(),))

    def __repr__(self) -> str:
        return f"CellSet({len(self)} of {len(self.alive)} cells)"


def eliminate(graph: ConnectivityGraph) -> tuple[CellSet, Eliminations]:
    """Greatest fixed point of removing escapable cells, by rounds (linear in the graph).

    Returns the surviving cells (a :class:`CellSet`, equal to the frozenset of their ids)
    and the eliminations in the order they happened.
    """
    dec = graph.dec
    alive, cell, slot, rnd, because = fixed_point_arrays(
        _rank_unless_listed(dec), graph.slot_ptr, graph.partner_ptr, graph.partner_slot)
    t = index_dtype(len(alive))  # held in 16 bytes an elimination instead of 32
    piece = graph.slot_piece[slot]  # the pieces: in G's type
    del slot
    return CellSet(dec, alive), Eliminations(
        graph, small_ints(cell, t), piece, small_ints(rnd, t), small_ints(because, t))


def _records_as_columns(records: Iterable[Elimination]) -> Any:
    """Elimination records as the columns of :class:`Eliminations` (``because`` -1: none)."""
    rows = [(e.cell, e.piece, e.round, -1 if e.because is None else e.because)
            for e in records]
    cell, piece, rnd, because = np.array(rows, dtype=np.int64).reshape(-1, 4).T
    return SimpleNamespace(cell=cell, piece=piece, round=rnd, because=because)


def cell_rank(dec: Decomposition) -> np.ndarray:
    """The rank of every cell in the elimination's processing order: by region, then start
    feature name, then end feature name (as strings; the order of :func:`_cell_key`)."""
    rank = _rank_unless_listed(dec)
    return np.arange(len(dec.cells), dtype=np.int64) if rank is None else rank


def _rank_unless_listed(dec: Decomposition) -> np.ndarray | None:
    """:func:`cell_rank`, or None where the cells are listed in that order already (as
    :func:`decompose` and the store list them, mostly): no column of every cell's rank."""
    region, start, end = dec.cell_codes()
    name_rank = feature_name_rank(dec.env)
    rs, re = name_rank[start + 1], name_rank[end + 1]
    n = len(region)
    if _increasing(region, rs, re):  # listed in that order already (decompose's, mostly)
        return None
    order = np.lexsort((re, rs, region))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    return rank


def _increasing(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
    """Whether the rows ``(a[i], b[i], c[i])`` are strictly increasing (lexicographically)."""
    if len(a) < 2:
        return True
    da, db, dc = np.diff(a), np.diff(b), np.diff(c)
    return bool(np.all((da > 0) | ((da == 0) & ((db > 0) | ((db == 0) & (dc > 0))))))


def fixed_point_arrays(rank: np.ndarray | None, slot_ptr: np.ndarray,
                       partner_ptr: np.ndarray, partner_slot: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The elimination on integer arrays, round by round (each round vectorized).

    Cell ``c`` has slots ``slot_ptr[c]:slot_ptr[c + 1]`` (one per piece bounding its region,
    in order); slot ``s`` has partner entries ``partner_ptr[s]:partner_ptr[s + 1]`` whose
    ``partner_slot`` is the partner's slot for the same piece. ``rank`` orders the cells (all
    distinct; None: the cells' own order). A cell falls when one of its slots has no
    surviving partner left; the order of the removals, the slot through which each falls and
    the partner whose removal made it fall (``because``) are those of a worklist processing
    each round's cells by rank, their slots in order and each slot's partners in order (the
    cell falls through its first slot to empty).

    Returns ``alive`` (bool per cell) and, per removal in order, the cell, its slot, its round
    (from 1) and the ``because`` cell (-1 in round 1), in :func:`index_dtype` of the cells'
    and the slots' counts.
    """
    ncell = len(slot_ptr) - 1
    count = np.subtract(partner_ptr[1:], partner_ptr[:-1], dtype=np.int32)  # partners left
    own_t = np.int32 if ncell < 2**31 else np.int64

    def slot_cell(slots: np.ndarray) -> np.ndarray:
        """The cell of each of ``slots`` (found in ``slot_ptr``: no column of every slot's
        cell held, 4 bytes a slot)."""
        return (np.searchsorted(slot_ptr, slots, side="right") - 1).astype(own_t)

    entry_ptr = partner_ptr[slot_ptr]  # a cell's slots' partner entries, one run per cell
    lvl_cell, lvl_slot = _first_empty_slots(count, slot_ptr, slot_cell)
    lvl_because = np.full(len(lvl_cell), -1, dtype=np.int64)
    queued = np.zeros(ncell, dtype=bool)
    queued[lvl_cell] = True
    cell_end = np.empty(ncell, np.int64 if len(partner_slot) >= 2**31 else np.int32)
    # (a scratch column, set where used)
    out_cell, out_slot, out_round, out_because = [], [], [], []
    cell_t, slot_t = index_dtype(ncell), index_dtype(len(count))
    rnd = 0
    while len(lvl_cell):
        rnd += 1
        order = np.argsort(lvl_cell if rank is None else rank[lvl_cell], kind="stable")
        lvl_cell, lvl_slot, lvl_because = lvl_cell[order], lvl_slot[order], lvl_because[order]
        out_cell.append(lvl_cell.astype(cell_t))  # kept in the smallest int types
        out_slot.append(lvl_slot.astype(slot_t))
        out_round.append(np.full(len(lvl_cell), rnd, dtype=cell_t))
        out_because.append(lvl_because.astype(cell_t))
        # every partner entry of every slot of the level's cells, in processing order
        first = entry_ptr[lvl_cell]
        nentry = entry_ptr[lvl_cell + 1] - first
        done = np.cumsum(nentry)  # entries up to each of the level's cells
        hit, slot, cell = _emptied(count, partner_slot, slot_cell, queued, first, nentry,
                                   done)  # cell: int32 mostly, made int64 once filtered
        # the entry position where each emptied slot reached 0 (its last), and each cell
        # falls through its slot that emptied first
        end = _group_max(slot, hit).astype(cell_end.dtype, copy=False)
        cell_end[cell] = int(done[-1]) if len(done) else 0
        # (in the scratch column's own dtype: ``ufunc.at`` with a cast is ~10x slower)
        np.minimum.at(cell_end, cell, end)
        keep = (hit == end) & (cell_end[cell] == end)
        pos, cell = hit[keep], cell[keep].astype(np.int64)
        queued[cell] = True
        # the level's cell whose run of entries holds each position
        src = lvl_cell[np.searchsorted(done, pos, side="right")]
        lvl_cell, lvl_slot, lvl_because = cell, slot[keep], src
    alive = ~queued
    del queued, count, entry_ptr, cell_end
    if out_cell:  # a column joined, its rounds' arrays freed before the next is joined
        cols = []
        for parts in (out_cell, out_slot, out_round, out_because):
            cols.append(np.concatenate(parts))
            parts.clear()
        return alive, cols[0], cols[1], cols[2], cols[3]
    empty = np.zeros(0, dtype=np.int64)
    return alive, empty, empty, empty, empty


def _first_empty_slots(count: np.ndarray, slot_ptr: np.ndarray, slot_cell: Any
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The cells with a slot without partners (``count`` 0), increasing, and the first such
    slot of each (int64), found for runs of consecutive cells of about :data:`ELIM_CHUNK`
    slots at a time (no index of every empty slot at once: at 4,000 floor-plan vertices
    tens of millions)."""
    cells, slots = [], []
    ends = size_runs(slot_ptr[1:], ELIM_CHUNK)
    for c0, c1 in zip([0, *ends][:len(ends)], ends, strict=True):
        s0, s1 = int(slot_ptr[c0]), int(slot_ptr[c1])
        zs = np.flatnonzero(count[s0:s1] == 0) + s0
        zc = slot_cell(zs)
        head = np.r_[True, zc[1:] != zc[:-1]] if len(zc) else np.zeros(0, bool)
        cells.append(zc[head])
        slots.append(zs[head])
    if not cells:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return (np.concatenate(cells).astype(np.int64, copy=False),
            np.concatenate(slots).astype(np.int64, copy=False))


#: Partner entries a round of the elimination reads at once (bounds its temporaries, ~30
#: bytes an entry, on large graphs): the round's cells taken in runs of about this many
ELIM_CHUNK = 1 << 22


def _group_max(key: np.ndarray, value: np.ndarray) -> np.ndarray:
    """For each item, the largest ``value`` among the items of its ``key`` (one sort of the
    items: no scratch column over every possible key)."""
    if len(key) == 0:
        return value.copy()
    order = np.argsort(key, kind="stable")
    k = key[order]
    head = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    top = np.maximum.reduceat(value[order], head)
    out = np.empty_like(value)
    out[order] = np.repeat(top, np.diff(np.r_[head, len(k)]))
    return out


def _emptied(count: np.ndarray, partner_slot: np.ndarray, slot_cell: Any,
             queued: np.ndarray, first: np.ndarray, nentry: np.ndarray, done: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One round's decrements: every partner entry of the level's cells (``first``,
    ``nentry``, cumulative ``done``), in processing order, run by run of about
    :data:`ELIM_CHUNK` entries. Returns the positions (in the round's entries) at which a
    slot of a cell not queued yet is left without partners, those slots and their cells
    (``slot_cell``: the cells of slots): a slot's count never rises, so it reaches 0 within
    the run holding its last entry of the round, and every entry of it in that run sees 0
    (its last among them: the one kept by the caller)."""
    hits, slots, cells = [], [], []
    ends = size_runs(done, ELIM_CHUNK)
    for c0, c1 in zip([0, *ends[:-1]], ends, strict=True):
        base = int(done[c0 - 1]) if c0 else 0
        tgt = partner_slot[ragged_arange(first[c0:c1], nentry[c0:c1])]
        _decrement(count, tgt)
        hit = np.flatnonzero(count[tgt] == 0)
        slot = tgt[hit]
        cell = slot_cell(slot)
        fresh = ~queued[cell]
        hits.append(hit[fresh] + base)
        slots.append(slot[fresh])
        cells.append(cell[fresh])
    if not hits:
        return (np.zeros(0, np.int64), np.zeros(0, partner_slot.dtype),
                slot_cell(np.zeros(0, np.int64)))
    return np.concatenate(hits), np.concatenate(slots), np.concatenate(cells)


def _decrement(count: np.ndarray, idx: np.ndarray) -> None:
    """``count[i] -= 1`` once per occurrence of ``i`` in ``idx``: ``np.subtract.at`` with a
    one in ``count``'s own type (numpy's fast path, ~0.01 µs an entry; with a cast, as
    with a Python int, it costs ~0.2 µs an entry), no sort and no column of every count."""
    np.subtract.at(count, idx, count.dtype.type(1))


def fixed_point(region_of: dict[str, int], pieces_of: dict[int, tuple[int, ...]],
                partners: dict[tuple[str, int], tuple[str, ...]]
                ) -> tuple[frozenset[str], list[tuple[str, int, int, str | None]]]:
    """The elimination on abstract data: cells with their regions, the pieces bounding each
    region, and each (cell, piece)'s partners (a missing key: no partner). Cells are processed
    in the order of :func:`_cell_key`. Returns the survivors and ``(cell, piece, round,
    because)`` per removal, in order (see :func:`fixed_point_arrays`)."""
    cells = sorted(region_of, key=_cell_key)
    nslot = [len(pieces_of[region_of[c]]) for c in cells]
    slot_ptr = np.concatenate(([0], np.cumsum(nslot, dtype=np.int64))).astype(np.int64)
    slot_of = {}
    slot_piece = []
    for i, c in enumerate(cells):
        for j, k in enumerate(pieces_of[region_of[c]]):
            slot_of[(c, k)] = int(slot_ptr[i]) + j
            slot_piece.append(k)
    counts, flat = [], []
    for c in cells:
        for k in pieces_of[region_of[c]]:
            ps = partners.get((c, k), ())
            counts.append(len(ps))
            flat.extend(slot_of[(p, k)] for p in ps)
    partner_ptr = np.concatenate(([0], np.cumsum(counts, dtype=np.int64))).astype(np.int64)
    alive, cell, slot, rnd, because = fixed_point_arrays(
        np.arange(len(cells), dtype=np.int64), slot_ptr, partner_ptr,
        np.asarray(flat, dtype=np.int64))
    removed = [(cells[c], slot_piece[s], r, None if b < 0 else cells[b]) for c, s, r, b in
               zip(cell.tolist(), slot.tolist(), rnd.tolist(), because.tolist(), strict=True)]
    return frozenset(c for c, a in zip(cells, alive.tolist(), strict=True) if a), removed


def _cell_key(cid: str) -> tuple:
    """Sort key of a cell id ``(R3,E1,V2)``; other ids sort as plain strings after them."""
    parsed = parse_cell_name(cid)
    return (1, cid, "", "") if parsed is None else (0, *parsed)


def analyze(dec: Decomposition, graph: ConnectivityGraph | None = None,
            self_check: bool = True, near_critical: bool = True, tiles: Any = None,
            executor: Any = None, progress: Any = None) -> Verdict:
    """Build G (unless given), eliminate escapable cells, and decide.

    The witness is a region without any cell (lowest id), else the first region emptied.
    With ``self_check`` (the default) the decomposition is verified cheaply first (see
    :func:`tether.decomposition.self_check`); :attr:`Verdict.verified` says whether it passed.
    With ``near_critical`` (the default), when ``dec.lss`` lies within tether's resolution of
    a critical length of the map (:func:`tether.analysis.critical.near_critical`), the map is also
    decomposed and analyzed at ``lss - delta`` and ``lss + delta``: :attr:`Verdict.critical`;
    ``tiles`` and ``executor`` are given to those decompositions (as :func:`decompose` takes
    them: a map decomposed in tiles for its size is so beside the critical length too).
    ``progress(stage, fraction_done)``, if given, is told of the stages: ``"self-check"``,
    those of :func:`build_graph`, ``"elimination"``, ``"verdict"`` (the witness) and
    ``"near critical"``.

    Examples
    --------
    In a 1.5 × 3 room a rod of length 1 cannot be kept free (Prop. 1 fails; the target wins from
    the witness region); in an L-shaped room 4 across a rod of length 0.5 can:

    >>> from tether import Environment
    >>> from tether.analysis import analyze
    >>> from tether.decomposition import decompose
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> analyze(decompose(room, 1.0))
    Verdict(strategy_exists=False, surviving=0/32, witness=9)
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> analyze(decompose(ell, 0.5))
    Verdict(strategy_exists=True, surviving=20/25, witness=None)
    """
    tell = progress or (lambda stage, frac: None)
    report = None
    if self_check:
        from tether.decomposition import self_check as run_self_check

        tell("self-check", 0.0)
        report = run_self_check(dec)
    with gc_paused():
        graph = build_graph(dec, progress) if graph is None else graph
        tell("elimination", 0.0)
        surviving, elim = eliminate(graph)
    tell("verdict", 0.0)
    witness = None
    if not surviving:
        empty = np.flatnonzero(np.diff(cell_first(dec)) == 0)
        if len(empty):
            witness = int(empty[0])
        else:
            witness = _first_emptied(dec, elim)
    if near_critical:
        tell("near critical", 0.0)
    critical = _beside_critical(dec, self_check, tiles, executor) if near_critical else None
    tell("done", 1.0)
    return Verdict(dec, graph, surviving, elim, witness, report, critical)


def _beside_critical(dec: Decomposition, self_check: bool, tiles: Any = None,
                     executor: Any = None) -> CriticalLss | None:
    """The verdicts just below and above ``dec.lss`` if it is near a critical length (the
    decompositions in ``tiles`` on ``executor`` when given)."""
    rel_tol = dec.curve_tol / dec.env.diameter
    events, value, delta = critical_events(dec.env, dec.lss, rel_tol)
    if not events:
        return None
    sides = []
    for lss in (value - delta, value + delta):
        side = decompose(dec.env, lss, rel_tol, tiles=tiles, executor=executor)
        sides.append(side_summary(analyze(side, self_check=self_check, near_critical=False)))
    on = ON_CRITICAL_TOLS * REL_LENGTH_TOL * dec.env.diameter
    return CriticalLss(dec.lss, value, delta, on, events, sides[0], sides[1])


def _first_emptied(dec: Decomposition, elim: Eliminations) -> int | None:
    """The first region whose last cell is eliminated (all its cells fell)."""
    reg = cell_regions(dec)[elim.cell]
    # the position of each region's last removal; the region emptied first has the smallest
    last = np.full(len(dec.regions), -1, dtype=np.int64)
    np.maximum.at(last, reg, np.arange(len(reg)))
    left = np.bincount(reg, minlength=len(dec.regions))
    full = np.diff(cell_first(dec)) == left
    cand = np.flatnonzero(full & (last >= 0))
    return int(cand[np.argmin(last[cand])]) if len(cand) else None


def escape_story(v: Verdict) -> list[str]:
    """Plain sentences following the chain of eliminations that empties the witness region."""
    dec = v.dec
    if v.strategy_exists:
        lines = [f"{len(v.surviving)} of {len(dec.cells)} cells survive the elimination "
                 f"({len(v.eliminated)} eliminated in {v.rounds} "
                 f"round{'' if v.rounds == 1 else 's'}): a surveillance "
                 "strategy can exist if the rod starts in a surviving cell."]
        if v.eliminated:
            e = v.eliminated[0]
            lines.append(f"For example, from {e.cell_name} the target escapes by crossing "
                         f"{_piece_text(dec, e.piece)} into R{e.escapes_to}.")
        return lines
    w = v.witness_region
    if w is not None and not dec.regions[w].cells:
        return [f"In region R{w} no rod orientation is free at all: a target that reaches it "
                "cannot be watched from distance lss. No surveillance strategy exists."]
    chain = _witness_chain(v, w)
    lines = []
    for e in reversed(chain):
        if e.because is None:
            lines.append(f"Round {e.round}: cell {e.cell_name} is escapable. The target "
                         f"crosses {_piece_text(dec, e.piece)} into R{e.escapes_to}, where no "
                         "free arc continues the rod's arc.")
        else:
            lines.append(f"Round {e.round}: {e.cell_name} falls. Across "
                         f"{_piece_text(dec, e.piece)} into R{e.escapes_to} its last "
                         f"continuation, {e.because_name}, was eliminated.")
    lines.append(f"Every cell over R{w} is eliminated: wherever the observer is, a target in "
                 f"R{w} can escape. No surveillance strategy exists (Proposition 1).")
    return lines


def _witness_chain(v: Verdict, w: int) -> list[Elimination]:
    """The last elimination of a cell over region ``w``, then the elimination of its
    ``because`` cell, and so on back to round 1 (on the arrays: no other elimination made)."""
    el = v.eliminated
    if not isinstance(el, Eliminations):
        by_cell = {e.cell: e for e in el}
        chain = [[e for e in el if v.dec.cell(e.cell).region == w][-1]]
        while chain[-1].because is not None:
            chain.append(by_cell[chain[-1].because])
        return chain
    at = np.full(len(v.dec.cells), -1, dtype=np.int64)  # each cell's elimination
    at[el.cell] = np.arange(len(el))
    i = int(np.flatnonzero(cell_regions(v.dec)[el.cell] == w)[-1])
    chain = [i]
    while el.because[chain[-1]] >= 0:
        chain.append(int(at[el.because[chain[-1]]]))
    return [el[j] for j in chain]


def _piece_text(dec: Decomposition, piece: int) -> str:
    from tether.curves import KIND_NAMES

    p = dec.pieces[piece]
    kinds = "/".join(KIND_NAMES.get(k, k) for k in p.kind)
    return f"{p.name} ({kinds} of {', '.join(p.features)})"
