"""The candidates' clearance measured block by block (#25: no grid of the whole map's
segments held) equals the distance to the nearest segment of another part, capped at the
reach, computed by brute force over every (point, segment) pair, and the one-grid
measurement, to the bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tether.decomposition.pieces as P
from tether.spatial import SegmentGrid, point_segment_distance_xy


def _brute(pts, owner, sa, sb, sowner, reach):
    out = np.full(len(pts), reach)
    for i, (p, o) in enumerate(zip(pts, owner, strict=True)):
        other = sowner != o
        if other.any():
            d = point_segment_distance_xy(np.full(other.sum(), p[0]), np.full(other.sum(), p[1]),
                                          sa[other, 0], sa[other, 1], sb[other, 0], sb[other, 1])
            out[i] = min(reach, d.min())
    return out


def _case(seed, m=150, k=300, span=10.0):
    rng = np.random.default_rng(seed)
    sa = rng.uniform(0, span, (k, 2))
    sb = sa + rng.normal(0, 0.4, (k, 2))
    sb[::17] = sa[::17]  # degenerate segments (points)
    sb[1::23, 1] = sa[1::23, 1]  # horizontal ones
    sowner = rng.integers(0, 40, k)
    pts = rng.uniform(-0.5, span + 0.5, (m, 2))
    pts[:20] = 0.5 * (sa[:20] + sb[:20])  # midpoints: their own part's segment at 0
    owner = sowner[:m].copy()
    owner[:20] = sowner[:20]
    return pts, owner, sa, sb, sowner


@pytest.mark.parametrize("block", [pytest.param(1, marks=pytest.mark.slow), 7, 50, 10**6])
def test_blocks_equal_brute_force_and_one_grid(monkeypatch, block):
    pts, owner, sa, sb, sowner = _case(3)
    reach = 0.6
    monkeypatch.setattr(P, "CLEARANCE_BLOCK_SEGMENTS", block)
    got = P._blocked_clearance(pts, owner, sa, sb, sowner, reach)
    one = P._clearance(pts, owner, sa, sb, sowner, SegmentGrid(sa, sb), reach)
    assert np.array_equal(got, one)
    assert np.array_equal(got, _brute(pts, owner, sa, sb, sowner, reach))


def test_degenerate_point_sets(monkeypatch):
    monkeypatch.setattr(P, "CLEARANCE_BLOCK_SEGMENTS", 5)
    _, _, sa, sb, sowner = _case(1)
    assert len(P._blocked_clearance(np.zeros((0, 2)), np.zeros(0, np.int64), sa, sb, sowner,
                                    1.0)) == 0
    same = np.full((9, 2), 4.0)  # every point at one place: one block, zero spans
    owner = np.arange(9)
    got = P._blocked_clearance(same, owner, sa, sb, sowner, 1.0)
    assert np.array_equal(got, _brute(same, owner, sa, sb, sowner, 1.0))
    line = np.column_stack((np.linspace(0, 10, 30), np.full(30, 5.0)))  # a zero-height box
    owner = np.zeros(30, np.int64)
    got = P._blocked_clearance(line, owner, sa, sb, sowner, 0.3)
    assert np.array_equal(got, _brute(line, owner, sa, sb, sowner, 0.3))


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10**6), block=st.integers(1, 400),
       reach=st.floats(0.01, 3.0, allow_nan=False))
def test_random_blocks_equal_brute_force(seed, block, reach):
    pts, owner, sa, sb, sowner = _case(seed, m=60, k=120)
    old = P.CLEARANCE_BLOCK_SEGMENTS
    P.CLEARANCE_BLOCK_SEGMENTS = block
    try:
        got = P._blocked_clearance(pts, owner, sa, sb, sowner, reach)
    finally:
        P.CLEARANCE_BLOCK_SEGMENTS = old
    assert np.array_equal(got, _brute(pts, owner, sa, sb, sowner, reach))
