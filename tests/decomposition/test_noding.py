"""Noding in two strips (issue 8): the cut, the pieces, and that the union of the two strips'
nodings is a noding of the whole, checked by brute force on every pair of segments and against
GEOS's noding of the whole; and the decomposition it gives against the unsplit one."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tether.decomposition.noding as noding
from tether import load_map
from tether.analysis import analyze
from tether.decomposition import check, decompose
from tether.decomposition.noding import STRIP_MIN_SEGMENTS, cut_position, node_lines, strip_cut
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan

coord = st.floats(-10, 10, allow_nan=False).map(lambda v: round(v, 2))


@st.composite
def random_lines(draw, max_lines: int = 12) -> np.ndarray:
    """Polylines (some closed) with coordinates on a 0.01 grid: many shared x coordinates,
    collinear and overlapping segments, lines through each other's vertices."""
    out = []
    for _ in range(draw(st.integers(1, max_lines))):
        pts = draw(st.lists(st.tuples(coord, coord), min_size=2, max_size=7))
        if draw(st.booleans()) and len(pts) >= 3:
            pts = [*pts, pts[0]]
        line = shapely.linestrings(pts)
        if shapely.length(line) > 0:
            out.append(line)
    if not out:
        out.append(shapely.linestrings([(0.0, 0.0), (1.0, 1.0)]))
    return np.asarray(out, dtype=object)


@pytest.mark.slow
@given(st.lists(coord, min_size=1, max_size=40))
def test_cut_lies_strictly_between_vertex_coordinates(xs):
    x = np.asarray(xs)
    x0 = cut_position(x)
    if len(np.unique(x)) < 2:
        assert x0 is None
        return
    assert x0 is not None
    assert not np.any(x == x0)
    assert x.min() < x0 < x.max()


def test_cut_is_central_and_in_the_widest_gap():
    x = np.r_[np.arange(45.0), 60.0, np.arange(61.0, 101.0)]  # one wide gap: 44 .. 60
    assert cut_position(x) == 52.0


@pytest.mark.slow
@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(random_lines())
def test_strip_pieces_are_the_lines_cut_at_one_x(lines):
    got = strip_cut(lines)
    xy = shapely.get_coordinates(lines)
    x0 = cut_position(xy[:, 0])
    if got is None:
        assert x0 is None
        return
    left, right = got
    lx, rx = shapely.get_coordinates(left)[:, 0], shapely.get_coordinates(right)[:, 0]
    assert np.all(lx <= x0) and np.all(rx >= x0)
    # the pieces cover the lines exactly: same total length, same vertices plus cut vertices
    total = shapely.length(lines).sum()
    assert abs(shapely.length(left).sum() + shapely.length(right).sum() - total) <= 1e-12 * (
        1 + total)
    pieces = np.concatenate([left, right])
    pxy = shapely.get_coordinates(pieces)
    off = pxy[pxy[:, 0] != x0]
    assert sorted(map(tuple, off)) == sorted(map(tuple, xy))
    # a piece's ends on the cut are shared by exactly two pieces of one line (or more lines)
    ends = shapely.get_coordinates(shapely.boundary(pieces))
    on_cut = ends[ends[:, 0] == x0]
    _, count = np.unique(on_cut, axis=0, return_counts=True)
    assert np.all(count % 2 == 0)


def _segments(parts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xy, idx = shapely.get_coordinates(parts, return_index=True)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    return xy[k], xy[k + 1]


def _part_ends(parts: np.ndarray) -> np.ndarray:
    """The first and last vertex of every part (a closed part's twice)."""
    xy, idx = shapely.get_coordinates(parts, return_index=True)
    first = np.searchsorted(idx, np.arange(len(parts)))
    last = np.searchsorted(idx, np.arange(len(parts)), side="right") - 1
    return np.concatenate([xy[first], xy[last]])


def _orient(u, v, w) -> int:
    """The exact sign of the orientation of ``u, v, w`` (float coordinates, in rationals)."""
    ux, uy, vx, vy, wx, wy = (Fraction(float(c)) for c in (*u, *v, *w))
    d = (vx - ux) * (wy - uy) - (vy - uy) * (wx - ux)
    return (d > 0) - (d < 0)


def _on_interior(w, u, v) -> bool:
    """Whether ``w`` lies on segment ``u-v`` other than at its ends (exactly)."""
    if _orient(u, v, w) != 0 or tuple(w) in (tuple(u), tuple(v)):
        return False
    return (min(u[0], v[0]) <= w[0] <= max(u[0], v[0])
            and min(u[1], v[1]) <= w[1] <= max(u[1], v[1]))


def _interior_contacts(parts: np.ndarray) -> int:
    """Pairs of segments of the parts that meet other than at part ends (brute force, all
    pairs, exact orientation tests in rationals on the float coordinates): 0 for a noding."""
    a, b = _segments(parts)
    ends = {tuple(p) for p in _part_ends(parts)}
    bad = 0
    for i in range(len(a)):
        for j in range(i + 1, len(a)):
            p, q, r, s = a[i], b[i], a[j], b[j]
            if (max(p[0], q[0]) < min(r[0], s[0]) or max(r[0], s[0]) < min(p[0], q[0])
                    or max(p[1], q[1]) < min(r[1], s[1]) or max(r[1], s[1]) < min(p[1], q[1])):
                continue
            if (_orient(p, q, r) * _orient(p, q, s) < 0
                    and _orient(r, s, p) * _orient(r, s, q) < 0):
                bad += 1  # crossing in both interiors
                continue
            for w, (u, v) in ((r, (p, q)), (s, (p, q)), (p, (r, s)), (q, (r, s))):
                if _on_interior(w, u, v) and tuple(w) not in ends:
                    bad += 1  # touching at a point that is no node
    return bad


def _nodes(parts: np.ndarray) -> dict[tuple, int]:
    """The part ends and their degrees."""
    pts, count = np.unique(np.round(_part_ends(parts), 9), axis=0, return_counts=True)
    return {tuple(p): int(c) for p, c in zip(pts, count, strict=True)}


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_lines(max_lines=8))
def test_strips_give_a_noding_of_the_whole(lines):
    split, grid = node_lines(lines, 1e-6, segments=STRIP_MIN_SEGMENTS)
    whole = shapely.get_parts(shapely.node(shapely.multilinestrings(lines)))
    assert grid == 0.0
    assert _interior_contacts(split) == 0
    # the same point set as GEOS's noding of the whole
    assert abs(shapely.length(split).sum() - shapely.length(whole).sum()) <= 1e-9 * (
        1 + shapely.length(whole).sum())
    u_split, u_whole = shapely.union_all(split), shapely.union_all(whole)
    assert shapely.hausdorff_distance(u_split, u_whole) <= 1e-9
    # the same nodes; the split adds only degree-2 nodes on the cut
    # the same nodes; the split adds only degree-2 nodes: on the cut, and where a closed line
    # that GEOS left whole (no boundary) was cut open
    n_split, n_whole = _nodes(split), _nodes(whole)
    x0 = cut_position(shapely.get_coordinates(lines)[:, 0])
    closings = {tuple(np.round(shapely.get_coordinates(g)[0], 9))
                for g in lines if shapely.is_closed(g)}
    for p, d in n_whole.items():
        assert n_split.get(p) == d, (p, d, n_split.get(p))
    for p, d in n_split.items():
        if p not in n_whole:
            assert d == 2 and (abs(p[0] - x0) <= 1e-9 or p in closings), (p, d)


def test_small_inputs_are_noded_whole():
    lines = np.asarray([shapely.linestrings([(0, 0), (4, 2)]),
                        shapely.linestrings([(0, 2), (1, 0)])], dtype=object)  # cross at x 0.8
    x0 = cut_position(shapely.get_coordinates(lines)[:, 0])
    assert x0 == 0.5
    parts, _ = node_lines(lines, 1e-6, segments=STRIP_MIN_SEGMENTS - 1)
    assert len(parts) == 4 and not np.any(shapely.get_coordinates(parts)[:, 0] == x0)
    parts, _ = node_lines(lines, 1e-6, segments=STRIP_MIN_SEGMENTS)
    assert len(parts) == 6 and np.sum(shapely.get_coordinates(parts)[:, 0] == x0) == 4


def _same_decomposition(a, b) -> None:
    """Two decompositions of one map equal up to the regions' numbering: each region's
    representative point lies in a region of the other with the same structure and area."""
    assert a.counts == b.counts
    pts = np.array([r.point for r in a.regions])
    j = b.region_at(pts)
    assert np.all(j >= 0) and len(set(j.tolist())) == len(j)
    for r, k in zip(a.regions, j.tolist(), strict=True):
        assert r.structure == b.regions[k].structure
        assert abs(r.area - b.regions[k].area) <= 1e-9 * max(r.area, 1e-12)
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))

    def pieces(dec, ren):
        return sorted((tuple(sorted(int(ren[r]) for r in p.regions)), p.kind, p.features)
                      for p in dec.pieces)

    assert pieces(a, np.arange(len(j))) == pieces(b, inv)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["gallery@2.0", "nonconvex_corner@1.0", "plan100"])
def test_decomposition_with_strips_is_the_same(case, monkeypatch):
    if case == "plan100":
        env = floor_plan(100, seed=0)
        lss = (env.bounds[2] - env.bounds[0]) / 15
    else:
        name, lss = case.split("@")
        env, lss = load_map(example_path(name)), float(lss)
    whole = decompose(env, lss)
    monkeypatch.setattr(noding, "STRIP_MIN_SEGMENTS", 0)
    split = decompose(env, lss)
    assert check(split).ok
    _same_decomposition(whole, split)
    v_whole, v_split = analyze(whole), analyze(split)
    assert v_split.verified
    assert v_whole.strategy_exists == v_split.strategy_exists
    assert len(v_whole.surviving) == len(v_split.surviving)
    assert len(v_whole.eliminated) == len(v_split.eliminated)


def test_a_failing_strip_falls_back_to_the_whole(monkeypatch):
    env = load_map(example_path("gallery"))
    expected = decompose(env, 2.0)
    calls = []
    real = noding._node_floating

    def fail_once(lines):
        calls.append(len(lines))
        if len(calls) == 1:
            raise shapely.errors.GEOSException("TopologyException: found non-noded intersection")
        return real(lines)

    monkeypatch.setattr(noding, "STRIP_MIN_SEGMENTS", 0)
    monkeypatch.setattr(noding, "_node_floating", fail_once)
    got = decompose(env, 2.0)
    assert len(calls) >= 2
    assert got.counts == expected.counts
    assert [r.structure for r in got.regions] == [r.structure for r in expected.regions]


def test_strips_do_not_depend_on_the_thread_count(monkeypatch):
    rng = np.random.default_rng(3)
    lines = np.asarray([shapely.linestrings(rng.uniform(0, 10, (5, 2))) for _ in range(30)],
                       dtype=object)
    got = {}
    for threads in ("1", "3"):
        monkeypatch.setenv("TETHER_THREADS", threads)
        parts, _ = node_lines(lines, 1e-6, segments=STRIP_MIN_SEGMENTS)
        got[threads] = shapely.to_wkb(parts)
    assert len(got["1"]) > 30 and list(got["1"]) == list(got["3"])
