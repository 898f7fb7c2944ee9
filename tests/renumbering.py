"""The comparison of a tiled decomposition with the untiled one, up to the numbering of its
regions (shared by the tiled tests)."""

from __future__ import annotations

import collections

import numpy as np
import pytest

from tether.analysis import analyze, build_graph

__all__ = ["assert_equal_up_to_renumbering"]


def _key_maps(dec, ren):
    """Cells and pieces of ``dec`` as keys in the regions' numbering ``ren``."""
    cells = [(int(ren[c.region]), c.start_feature, c.end_feature) for c in dec.cells]
    pieces = [(tuple(sorted(int(ren[r]) for r in p.regions)), p.kind, p.features)
              for p in dec.pieces]
    return cells, pieces


def _graph_edges(dec, ren):
    """G's edges as a multiset of (cell key pair, piece key) in the numbering ``ren``."""
    g = build_graph(dec)
    cells, pieces = _key_maps(dec, ren)
    return collections.Counter(
        (tuple(sorted((cells[a], cells[b]))), pieces[p])
        for a, b, p in zip(g.edge_a.tolist(), g.edge_b.tolist(), g.edge_piece.tolist(),
                           strict=True))


def assert_equal_up_to_renumbering(a, b):
    """``b`` (tiled) equals ``a`` (untiled) up to renumbering: each region of ``a`` holds its
    representative point in a distinct region of ``b`` of the same area and structure; the
    cells, the pieces (regions, kind, features), G's edges and the eliminations (cell, round)
    are the same multisets in that numbering; the verdicts agree."""
    assert a.counts == b.counts
    j = b.region_at(np.array([r.point for r in a.regions]).reshape(-1, 2))
    assert sorted(j.tolist()) == list(range(len(b.regions))), "regions matched one to one"
    for r, k in zip(a.regions, j.tolist(), strict=True):
        assert b.regions[k].structure == r.structure
        assert b.regions[k].area == pytest.approx(r.area, rel=1e-9, abs=1e-12)
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))
    ident = np.arange(len(j))
    cells_a, pieces_a = _key_maps(a, ident)
    cells_b, pieces_b = _key_maps(b, inv)
    assert collections.Counter(cells_a) == collections.Counter(cells_b)
    assert collections.Counter(pieces_a) == collections.Counter(pieces_b)
    assert _graph_edges(a, ident) == _graph_edges(b, inv)
    va = analyze(a, self_check=False, near_critical=False)
    vb = analyze(b, self_check=False, near_critical=False)
    assert va.strategy_exists == vb.strategy_exists
    assert (sorted((cells_a[c], r) for c, r in zip(va.eliminated.cell.tolist(),
                                                   va.eliminated.round.tolist(), strict=True))
            == sorted((cells_b[c], r) for c, r in zip(vb.eliminated.cell.tolist(),
                                                      vb.eliminated.round.tolist(),
                                                      strict=True)))
