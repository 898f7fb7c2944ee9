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

import networkx as nx
import numpy as np

from tether.arcs import TWO_PI, feature_name, free_arcs_many
from tether.decomposition import FREE, Decomposition, cell_name
from tether.tolerances import ANGLE_TOL


@dataclass(frozen=True, eq=False)
class ConnectivityGraph:
    """G: a networkx ``MultiGraph`` whose nodes are cell ids and whose edges carry their piece.

    ``partners[(cell, piece)]`` lists the cells adjacent to ``cell`` across ``piece``;
    ``pieces_of[region]`` the pieces bounding a region.
    """

    dec: Decomposition = field(repr=False)
    graph: nx.MultiGraph = field(repr=False)
    partners: dict[tuple[str, int], tuple[str, ...]] = field(repr=False)
    pieces_of: dict[int, tuple[int, ...]] = field(repr=False)

    @property
    def edges(self) -> list[tuple[str, str, str]]:
        """``[cell, cell, piece]`` triples, sorted."""
        return sorted((min(a, b), max(a, b), f"P{k}") for a, b, k in self.graph.edges(keys=True))

    def __repr__(self) -> str:
        return (f"ConnectivityGraph(cells={self.graph.number_of_nodes()}, "
                f"edges={self.graph.number_of_edges()})")


def _overlap(s1: float, e1: float, s2: float, e2: float) -> float:
    """Length (radians) of the intersection of two CCW arcs (``s == e`` never occurs)."""
    l1 = (e1 - s1) % TWO_PI or TWO_PI
    l2 = (e2 - s2) % TWO_PI or TWO_PI
    total = 0.0
    for a, la, b, lb in ((s1, l1, s2, l2), (s2, l2, s1, l1)):
        # the part of arc b that starts inside arc a
        d = (b - a) % TWO_PI
        if d < la:
            total = max(total, min(la - d, lb))
    return total


def _side_arcs(dec: Decomposition, pts: np.ndarray) -> list[list[tuple[float, float, str, str]]]:
    """Arcs ``(start, end, start_feature, end_feature)`` at each point; FULL is one arc."""
    env = dec.env
    table = free_arcs_many(env, pts, dec.lss, check=False)
    out = []
    for i in range(len(pts)):
        if table.full[i]:
            out.append([(0.0, TWO_PI, FREE, FREE)])
            continue
        rows = table.rows_of(i)
        out.append([(float(s), float(e), feature_name(env, a), feature_name(env, b))
                    for s, e, a, b in zip(table.start[rows], table.end[rows],
                                          table.start_code[rows], table.end_code[rows],
                                          strict=True)])
    return out


def build_graph(dec: Decomposition) -> ConnectivityGraph:
    """Build G from a decomposition: one edge per (cell, cell, piece) whose arcs continue into
    each other across the piece.

    Returns
    -------
    ConnectivityGraph
    """
    g = nx.MultiGraph()
    for c in dec.cells:
        g.add_node(c.id, region=c.region)
    partners: dict[tuple[str, int], list[str]] = {}
    pieces_of: dict[int, list[int]] = {r.id: [] for r in dec.regions}
    if dec.pieces:
        q = np.array([p.sample for p in dec.pieces])
        n = np.array([p.normal for p in dec.pieces])
        e = np.array([p.eps for p in dec.pieces])[:, None]
        arcs = _side_arcs(dec, np.vstack((q + e * n, q - e * n)))
        m = len(dec.pieces)
        known = {c.id for c in dec.cells}
        for k, piece in enumerate(dec.pieces):
            ra, rb = piece.regions
            pieces_of[ra].append(k)
            pieces_of[rb].append(k)
            for c in dec.regions[ra].cells:
                partners.setdefault((c, k), [])
            for c in dec.regions[rb].cells:
                partners.setdefault((c, k), [])
            for sa, ea, fa1, fa2 in arcs[k]:
                ka = cell_name(ra, fa1, fa2)
                for sb, eb, fb1, fb2 in arcs[m + k]:
                    kb = cell_name(rb, fb1, fb2)
                    if ka in known and kb in known and _overlap(sa, ea, sb, eb) > ANGLE_TOL:
                        g.add_edge(ka, kb, key=k)
                        partners[(ka, k)].append(kb)
                        partners[(kb, k)].append(ka)
    return ConnectivityGraph(dec, g, {key: tuple(v) for key, v in partners.items()},
                             {r: tuple(v) for r, v in pieces_of.items()})
