"""The connectivity graph G (``math.md`` §8): cells adjacent across boundary pieces.

Cells ``K`` over ``R`` and ``K'`` over ``R'`` are adjacent across a piece ``γ`` shared by ``R``
and ``R'`` when the arc of ``K`` continues into the arc of ``K'`` as the target crosses ``γ``:
their arcs at the two sides of ``γ`` (``q ± eps n``, close to the exact curve) overlap. A relabel
maps arcs 1:1, a split 1:2; an arc that closes or is born at ``γ`` (width ``O(sqrt(eps))``, inside
the other side's blocked set) has no partner. Every edge keeps its piece: the relation may differ
between pieces shared by the same two regions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from tether.arcs import TWO_PI, feature_name, free_arcs_many
from tether.decomposition import FREE, Decomposition, cell_name, crossing_points
from tether.tolerances import ANGLE_TOL

if TYPE_CHECKING:  # networkx costs ~0.2 s to import: only when G is asked for as a graph
    import networkx as nx


@dataclass(frozen=True, eq=False)
class ConnectivityGraph:
    """G: cells (nodes) and ``(cell, cell, piece)`` edges.

    ``partners[(cell, piece)]`` lists the cells adjacent to ``cell`` across ``piece``;
    ``pieces_of[region]`` the pieces bounding a region. :attr:`graph` gives G as a networkx
    ``MultiGraph`` (edge keys are piece indices), built on first use.
    """

    dec: Decomposition = field(repr=False)
    edge_list: tuple[tuple[str, str, int], ...] = field(repr=False)
    partners: dict[tuple[str, int], tuple[str, ...]] = field(repr=False)
    pieces_of: dict[int, tuple[int, ...]] = field(repr=False)

    @property
    def graph(self) -> nx.MultiGraph:
        """G as a networkx MultiGraph; nodes carry their ``region``."""
        g = self.__dict__.get("_nx")
        if g is None:
            import networkx as nx

            g = nx.MultiGraph()
            g.add_nodes_from((c.id, {"region": c.region}) for c in self.dec.cells)
            g.add_edges_from(self.edge_list)
            self.__dict__["_nx"] = g
        return g

    @property
    def edges(self) -> list[tuple[str, str, str]]:
        """``[cell, cell, piece]`` triples, sorted."""
        return sorted((min(a, b), max(a, b), f"P{k}") for a, b, k in self.edge_list)

    def __repr__(self) -> str:
        return f"ConnectivityGraph(cells={len(self.dec.cells)}, edges={len(self.edge_list)})"


def _overlap(s1: Any, e1: Any, s2: Any, e2: Any, full1: Any = False, full2: Any = False
             ) -> Any:
    """Length (radians) of the intersection of CCW arcs ``(s1, e1)`` and ``(s2, e2)``;
    vectorized. ``full1``/``full2`` flag full-circle arcs (a FULL point); an arc whose end is
    given as ``start + 2π`` is full too. Arcs are never recognized as full by comparing reduced
    ends: a free arc is always longer than ``ANGLE_TOL`` and shorter than ``2π - ANGLE_TOL``."""
    s1, e1, s2, e2 = (np.asarray(x, dtype=float) for x in (s1, e1, s2, e2))
    l1 = _arc_length(s1, e1, full1)
    l2 = _arc_length(s2, e2, full2)
    d21 = np.mod(s2 - s1, TWO_PI)  # arc 2 starting inside arc 1
    d12 = np.mod(s1 - s2, TWO_PI)  # arc 1 starting inside arc 2
    a = np.where(d21 < l1, np.minimum(l1 - d21, l2), 0.0)
    b = np.where(d12 < l2, np.minimum(l2 - d12, l1), 0.0)
    out = np.maximum(a, b)
    return float(out) if out.ndim == 0 else out


def _arc_length(s: np.ndarray, e: np.ndarray, full: Any) -> np.ndarray:
    """CCW length of arcs from ``s`` to ``e`` (radians, in (0, 2π]); ``full`` forces 2π."""
    raw = e - s
    length = np.where(raw > 0, np.minimum(raw, TWO_PI), np.mod(raw, TWO_PI))
    return np.where(np.asarray(full, dtype=bool), TWO_PI, length)


def _arc_rows(dec: Decomposition, pts: np.ndarray) -> dict[str, np.ndarray]:
    """All free arcs at the points as flat arrays sorted by point; a FULL point contributes
    one full-circle arc (``full`` flag set, from 0 to 2π) with feature codes -1."""
    table = free_arcs_many(dec.env, pts, dec.lss, check=False)
    full = np.flatnonzero(table.full)
    point = np.concatenate((table.point, full))
    order = np.argsort(point, kind="stable")
    return {
        "point": point[order],
        "start": np.concatenate((table.start, np.zeros(len(full))))[order],
        "end": np.concatenate((table.end, np.full(len(full), TWO_PI)))[order],
        "full": np.concatenate((np.zeros(len(table.point), bool),
                                np.ones(len(full), bool)))[order],
        "start_code": np.concatenate((table.start_code, np.full(len(full), -1)))[order],
        "end_code": np.concatenate((table.end_code, np.full(len(full), -1)))[order],
    }


def build_graph(dec: Decomposition) -> ConnectivityGraph:
    """Build G from a decomposition: one edge per (cell, cell, piece) whose arcs continue into
    each other across the piece (all arc pairs of all pieces compared at once).

    Returns
    -------
    ConnectivityGraph
    """
    edges: list[tuple[str, str, int]] = []
    partners: dict[tuple[str, int], list[str]] = {}
    pieces_of: dict[int, list[int]] = {r.id: [] for r in dec.regions}
    for k, piece in enumerate(dec.pieces):
        for r in piece.regions:
            pieces_of[r].append(k)
            for c in dec.regions[r].cells:
                partners[(c, k)] = []
    m = len(dec.pieces)
    if m:
        rows = _arc_rows(dec, crossing_points(*dec.piece_crossings()))
        counts = np.bincount(rows["point"], minlength=2 * m)
        first = np.cumsum(counts) - counts
        a_rows = np.flatnonzero(rows["point"] < m)  # side of regions[0], grouped by piece
        piece_of_a = rows["point"][a_rows]
        nb = counts[m + piece_of_a]
        pair_a = np.repeat(a_rows, nb)
        within = np.arange(len(pair_a)) - np.repeat(np.cumsum(nb) - nb, nb)
        pair_b = np.repeat(first[m + piece_of_a], nb) + within
        ov = _overlap(rows["start"][pair_a], rows["end"][pair_a], rows["start"][pair_b],
                      rows["end"][pair_b], rows["full"][pair_a], rows["full"][pair_b])
        keep = np.flatnonzero(ov > ANGLE_TOL)
        names = [feature_name(dec.env, code) for code in range(2 * dec.env.n)]
        known = {c.id for c in dec.cells}

        def cell_of(row: int, region: int) -> str:
            sc, ec = rows["start_code"][row], rows["end_code"][row]
            return cell_name(region, names[sc] if sc >= 0 else FREE,
                             names[ec] if ec >= 0 else FREE)

        for i in keep.tolist():
            k = int(rows["point"][pair_a[i]])
            ra, rb = dec.pieces[k].regions
            ka, kb = cell_of(pair_a[i], ra), cell_of(pair_b[i], rb)
            if ka in known and kb in known:
                edges.append((ka, kb, k))
                partners[(ka, k)].append(kb)
                partners[(kb, k)].append(ka)
    return ConnectivityGraph(dec, tuple(edges), {key: tuple(v) for key, v in partners.items()},
                             {r: tuple(v) for r, v in pieces_of.items()})
