"""Free arcs at tangencies: target points exactly at distance lss of a vertex or an edge, and one
ulp either side. A zero-width blocked interval must never turn into an almost-full free arc,
``FreeArcs.contains`` must agree with the independent rod test, and G must not depend on the last
bit of a crossing sample."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import SQUARE_HOLE, followed_pairs

from tether.analysis.connectivity import _overlap, build_graph
from tether.arcs import TWO_PI, free_arcs, rod_is_free_many
from tether.decomposition import decompose
from tether.tolerances import ANGLE_TOL

LSS = 2.0


def ulp_neighbours(p: np.ndarray) -> list[np.ndarray]:
    """``p`` and the points one ulp away in each coordinate direction."""
    out = [p]
    for k in range(2):
        for toward in (-math.inf, math.inf):
            q = p.copy()
            q[k] = np.nextafter(q[k], toward)
            out.append(q)
    return out


def tangent_points() -> list[np.ndarray]:
    """Points of SQUARE_HOLE at distance exactly LSS (as computed) from a vertex or an edge."""
    pts = []
    for vx, vy in SQUARE_HOLE.vertices:
        for phi in np.linspace(0, TWO_PI, 16, endpoint=False):
            pts.append(np.array([vx + LSS * math.cos(phi), vy + LSS * math.sin(phi)]))
    pts += [np.array([x, LSS]) for x in (1.0, 3.0, 7.5, 9.0)]  # above the outer bottom edge
    pts += [np.array([x, 6.0 + LSS]) for x in (4.5, 5.0, 5.5)]  # above the hole's top edge
    pts += [np.array([4.0 - LSS, y]) for y in (4.2, 5.0, 5.9)]  # left of the hole's left edge
    out = []
    for p in pts:
        for q in ulp_neighbours(p):
            inside = SQUARE_HOLE.contains(q[0], q[1])
            if inside and SQUARE_HOLE.boundary_distance(q[0], q[1]) > 1e-6:
                out.append(q)
    return out


POINTS = tangent_points()


def blocked_gaps(fa) -> list[float]:
    """Widths of the blocked gaps between consecutive free arcs (radians)."""
    arcs = sorted(fa.arcs, key=lambda a: a.start)
    return [(arcs[(i + 1) % len(arcs)].start - a.end) % TWO_PI for i, a in enumerate(arcs)]


def test_tangent_points_exist():
    assert len(POINTS) > 200


@pytest.mark.parametrize("k", range(0, len(POINTS), 7))
def test_no_sliver_arcs_or_gaps(k):
    fa = free_arcs(SQUARE_HOLE, POINTS[k], LSS)
    for arc in fa.arcs:
        assert ANGLE_TOL < arc.length < TWO_PI - ANGLE_TOL
    for gap in blocked_gaps(fa):
        assert gap > ANGLE_TOL


@pytest.mark.slow
def test_contains_agrees_with_rod_test():
    """Away from arc ends (within 1e-6 rad the two tests may differ by tolerance), on a fine
    grid plus the exact directions to every vertex. An orientation free for the rod test but
    blocked on both sides (the tip exactly on a convex corner: an isolated semi-free
    orientation, dropped by design) is not a free arc."""
    bad = []
    delta = 1e-6
    for p in POINTS:
        fa = free_arcs(SQUARE_HOLE, p, LSS)
        rel = SQUARE_HOLE.vertices - p
        angles = np.concatenate((np.linspace(0, TWO_PI, 360, endpoint=False),
                                 np.mod(np.arctan2(rel[:, 1], rel[:, 0]), TWO_PI)))
        ends = np.array([x for a in fa.arcs for x in (a.start, a.end)])
        if len(ends):
            d = np.abs((angles[:, None] - ends[None, :] + math.pi) % TWO_PI - math.pi)
            angles = angles[d.min(axis=1) > delta]
        m = len(angles)
        rod = rod_is_free_many(SQUARE_HOLE, np.tile(p, (3 * m, 1)),
                               np.concatenate((angles, angles - delta, angles + delta)), LSS)
        arcs = np.array([fa.contains(a) for a in angles])
        blocked_rod = ~rod[:m]
        free_rod = rod[:m] & rod[m:2 * m] & rod[2 * m:]
        wrong = (blocked_rod & arcs) | (free_rod & ~arcs)
        bad += [(tuple(p), float(a)) for a in angles[wrong]]
    assert not bad, bad[:5]


def test_full_circle_is_a_flag():
    assert _overlap(0.0, TWO_PI, 1.0, 2.0) == pytest.approx(1.0)
    assert _overlap(1.0, 1.0, 1.0, 2.0, full1=True) == pytest.approx(1.0)
    # an arc whose ends nearly coincide is nearly full (reduced ends) or nearly empty: it is
    # only ever full by the flag
    assert _overlap(1.0, 1.0, 1.0, 2.0) == 0.0
    assert _overlap(1.0 + 4.4e-16, 1.0, 3.0, 4.0) == pytest.approx(1.0)


@pytest.mark.slow
def test_square_hole_graph_whatever_the_last_bit():
    """The square_hole case of test_escape, with every B-piece's crossing sample moved by one
    ulp in each direction: arcs followed across the piece still match G's edges."""
    dec = decompose(SQUARE_HOLE, LSS)
    for k, piece in enumerate(dec.pieces):
        if "B" not in piece.kind:
            continue
        for q in ulp_neighbours(np.array(piece.sample)):
            moved = dataclasses.replace(piece, sample=(float(q[0]), float(q[1])))
            pieces = list(dec.pieces)
            pieces[k] = moved
            d2 = dataclasses.replace(dec, pieces=tuple(pieces))
            g = build_graph(d2)
            edges = set()
            for a, b, kk in g.graph.edges(keys=True):
                if kk != k:
                    continue
                first = a if d2.cell(a).region == moved.regions[0] else b
                edges.add((first, b if first == a else a))
            assert followed_pairs(d2, moved) == edges, (piece, q)
