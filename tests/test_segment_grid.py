"""The segment grid (``tether.spatial.SegmentGrid``) against brute force and against the
STRtree it replaces in ``_segments_near``: the same (point, segment) pairs, the same
distances, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tether import spatial
from tether.decomposition import pieces
from tether.spatial import SegmentGrid, _Blocks


def _segments(rng, k, scale=1.0, offset=0.0):
    """Random segments, mostly short, some long, some of zero length, a few axis-aligned."""
    a = offset + scale * rng.random((k, 2))
    step = scale * rng.normal(0, 0.004, (k, 2)) * np.where(rng.random(k) < 0.05, 40, 1)[:, None]
    step[rng.random(k) < 0.03] = 0.0
    step[rng.random(k) < 0.05, 1] = 0.0
    return a, a + step


def _envelope_pairs(pts, a, b, r):
    """Brute force: every (point, segment) whose bounding box meets the point's box."""
    lo, hi = pts - r, pts + r
    x0, x1 = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    y0, y1 = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    meet = ((x0[None] <= hi[:, :1]) & (x1[None] >= lo[:, :1]) & (y0[None] <= hi[:, 1:])
            & (y1[None] >= lo[:, 1:]))
    return {(int(i), int(j)) for i, j in np.argwhere(meet)}


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 1e-6, 1e-3, 0.01, 0.05, 0.3, 3.0]),
       st.sampled_from([(1.0, 0.0), (1e-3, 0.0), (1.0, 1e6)]))
@pytest.mark.slow
def test_meeting_pairs_are_the_envelope_pairs(seed, r, frame):
    scale, offset = frame
    rng = np.random.default_rng(seed)
    a, b = _segments(rng, 400, scale, offset)
    # points near the segments, anywhere in and around their box, on segment ends
    pts = np.concatenate((0.5 * (a[:100] + b[:100]), a[100:130],
                          offset + scale * rng.uniform(-0.2, 1.2, (100, 2))))
    r = r * scale
    grid = SegmentGrid(a, b)
    qi, si = grid.meeting(pts - r, pts + r)
    got = list(zip(qi.tolist(), si.tolist(), strict=True))
    assert len(set(got)) == len(got)  # each pair once
    assert np.all(np.diff(qi) >= 0)  # grouped by box, increasing
    assert set(got) == _envelope_pairs(pts, a, b, r)
    assert grid.meeting(pts - r, pts + r)[1].tolist() == si.tolist()  # kept blocks alike


@pytest.mark.slow
def test_meeting_is_strtree_query_on_rectangles():
    """``SegmentGrid.meeting`` answers as an STRtree of the segments does, for boxes of
    several sizes (one block set per size)."""
    rng = np.random.default_rng(11)
    a, b = _segments(rng, 2000)
    grid, tree = SegmentGrid(a, b), spatial.segment_tree(a, b)
    for r in (0.001, 0.01, 0.01, 0.04):
        c = rng.uniform(-0.1, 1.1, (700, 2))
        w = r * rng.uniform(0.5, 1.0, (700, 2))
        boxes = shapely.box(c[:, 0] - w[:, 0], c[:, 1] - w[:, 1], c[:, 0] + w[:, 0],
                            c[:, 1] + w[:, 1])
        got, want = np.vstack(grid.meeting(c - w, c + w)), tree.query(boxes)
        assert got.shape[0] == 2 and want.shape[1] > 100
        assert sorted(map(tuple, got.T.tolist())) == sorted(map(tuple, want.T.tolist()))
    assert len(grid._blocks) == 3


@pytest.mark.slow
def test_blocks_hold_every_segment_of_their_cells():
    """Cell (i, j) holds exactly the segments whose bounding box, grown by the blocks' reach
    to the left and below, meets it (loops over the segments' cells, as a reference), for
    cells of the boxes' width and wider."""
    rng = np.random.default_rng(3)
    a, b = _segments(rng, 1500)
    grid = SegmentGrid(a, b)
    for r, cell in ((0.004, 0.0), (0.02, 0.0), (0.01, 0.05), (1e-6, 0.003)):
        blk = _Blocks.build(grid, r, cell)
        (ox, oy), c, e = blk.origin, blk.cell, blk.reach
        assert c >= max(cell, e) and e > 2 * r
        gx0, gx1 = ((grid.x0 - e - ox) / c).astype(int), ((grid.x1 - ox) / c).astype(int)
        gy0, gy1 = ((grid.y0 - e - oy) / c).astype(int), ((grid.y1 - oy) / c).astype(int)
        want = [[] for _ in range(blk.shape[0] * blk.shape[1])]
        for k in range(len(gx0)):
            for i in range(gx0[k], gx1[k] + 1):
                for j in range(gy0[k], gy1[k] + 1):
                    want[i * blk.shape[1] + j].append(k)
        assert blk.seg.tolist() == [k for w in want for k in w]
        assert blk.block.tolist() == [k for k, w in enumerate(want) if w]
        some = np.r_[blk.block, rng.integers(0, len(want), 500)].tolist()
        assert all(blk.contents(k).tolist() == want[k] for k in some)


@pytest.mark.parametrize("r", [1e-9, 1e-4, 0.01])
def test_meeting_with_cells_wider_than_the_boxes(r):
    """Cells of twice the segments' median extent, far wider than tiny boxes (the parts'
    sources): the envelope pairs still, each once, in order."""
    rng = np.random.default_rng(8)
    a, b = _segments(rng, 1500)
    grid = SegmentGrid(a, b)
    pts = np.concatenate((0.5 * (a + b), b[:300], rng.uniform(-0.1, 1.1, (300, 2))))
    qi, si = grid.meeting(pts - r, pts + r)
    (blk,) = grid._blocks.values()
    assert blk.cell >= grid._cell() > 4 * r or r == 0.01
    got = list(zip(qi.tolist(), si.tolist(), strict=True))
    assert got == sorted(set(got))
    assert set(got) == _envelope_pairs(pts, a, b, r)


def test_blocks_guard_many_long_segments():
    """Long diagonal segments and a tiny radius: the cells grow until the registrations fit."""
    rng = np.random.default_rng(4)
    a = rng.random((300, 2))
    b = a + 0.5
    grid = SegmentGrid(a, b)
    blk = _Blocks.build(grid, 1e-7)
    assert len(blk.seg) <= 16 * 300 + 1_000_000
    pts = 0.5 * (a + b)
    qi, si = grid.meeting(pts - 1e-7, pts + 1e-7)
    assert _envelope_pairs(pts, a, b, 1e-7) == set(zip(qi.tolist(), si.tolist(), strict=True))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("r", [1e-4, 0.003, 0.02])
def test_segments_near_grid_equals_strtree(seed, r):
    """``_segments_near`` on a grid gives the STRtree's pairs and distances, bit for bit."""
    rng = np.random.default_rng(seed)
    a, b = _segments(rng, 3000)
    take = rng.integers(0, 3000, 2000)
    pts = np.concatenate((0.5 * (a[take] + b[take]), rng.uniform(-0.1, 1.1, (500, 2))))
    want = spatial.segments_near(pts, a, b, r, spatial.segment_tree(a, b))
    got = spatial.segments_near(pts, a, b, r, SegmentGrid(a, b))
    assert len(want[0]) > 100
    assert sorted(zip(*(x.tolist() for x in got), strict=True)) == \
        sorted(zip(*(x.tolist() for x in want), strict=True))
    assert got[0].dtype == got[1].dtype == np.int64


def test_pair_distances_equal_the_column_formula():
    rng = np.random.default_rng(7)
    a, b = _segments(rng, 2000)
    grid = SegmentGrid(a, b)
    si = rng.integers(0, 2000, 50_000)
    p = rng.uniform(-0.1, 1.1, (50_000, 2))
    p[:1000] = a[si[:1000]]  # on a segment's end
    got = spatial.pair_distances(p[:, 0], p[:, 1], grid, si)
    want = spatial.point_segment_distance_xy(p[:, 0], p[:, 1], a[si, 0], a[si, 1], b[si, 0],
                                        b[si, 1])
    assert np.array_equal(got, want)


def test_clearance_on_grid_equals_strtree():
    """The parts' clearance (staged search) is the same on the grid as on the STRtree."""
    rng = np.random.default_rng(9)
    a, b = _segments(rng, 4000)
    sowner = rng.integers(0, 500, 4000)
    take = rng.integers(0, 4000, 3000)
    pts, owner = 0.5 * (a[take] + b[take]), sowner[take]
    want = pieces._clearance(pts, owner, a, b, sowner, spatial.segment_tree(a, b), 0.02)
    got = pieces._clearance(pts, owner, a, b, sowner, SegmentGrid(a, b), 0.02)
    assert np.array_equal(got, want)
    assert (got < 0.02).any() and (got == 0.02).any()


def test_empty_inputs():
    grid = SegmentGrid(np.zeros((0, 2)), np.zeros((0, 2)))
    assert [len(x) for x in grid.meeting(np.zeros((3, 2)), np.ones((3, 2)))] == [0, 0]
    a = np.array([[0.0, 0.0]])
    grid = SegmentGrid(a, a + 1.0)
    assert [len(x) for x in grid.meeting(np.zeros((0, 2)), np.zeros((0, 2)))] == [0, 0]
    qi, si, d = spatial.segments_near(np.array([[0.5, 0.6]]), a, a + 1.0, 0.1, grid)
    assert qi.tolist() == [0] and si.tolist() == [0] and d[0] == pytest.approx(0.1 / 2**0.5)


def test_segment_pairs_grid_equals_strtree():
    rng = np.random.default_rng(12)
    a, b = _segments(rng, 2500)
    pts = rng.uniform(-0.05, 1.05, (1500, 2))
    for r in (0.002, 0.03):
        got = spatial.segment_pairs(pts, r, SegmentGrid(a, b))
        want = spatial.segment_pairs(pts, r, spatial.segment_tree(a, b))
        assert len(want[0]) > 100
        assert sorted(zip(*(x.tolist() for x in got), strict=True)) == \
            sorted(zip(*(x.tolist() for x in want), strict=True))


@pytest.mark.parametrize(("r", "cell"), [(0.004, 0.0), (0.02, 0.0), (0.01, 0.03), (1e-6, 0.0)])
def test_block_table_lookup_equals_the_binary_search(r, cell):
    """Blocks found through the direct table (small grids) are those the binary search in
    the sorted block numbers finds (large sparse grids), for boxes in and around the grid."""
    import dataclasses

    rng = np.random.default_rng(6)
    a, b = _segments(rng, 1500)
    grid = SegmentGrid(a, b)
    blk = _Blocks.build(grid, r, cell)
    c = rng.uniform(-0.3, 1.3, (3000, 2))
    w = r * rng.uniform(0.0, 1.0, (3000, 2))
    sparse = dataclasses.replace(blk, slot=None)
    assert blk.slot is not None or r < 1e-5
    got, want = blk.query(c - w, c + w), sparse.query(c - w, c + w)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert len(got[1]) > 0


def test_z_order_interleaves_the_cells_bits():
    """The Z order: points sorted by their cells' x and y bits interleaved (built bit by bit
    in Python), ties in input order; a permutation."""
    from tether.spatial import z_order

    rng = np.random.default_rng(5)
    pts = rng.uniform(-3.0, 5.0, (3000, 2))
    pts[::7] = pts[3::7][: len(pts[::7])]  # shared cells
    cell = 0.01
    g = ((pts - pts.min(axis=0)) / cell).astype(int)

    def code(x, y):
        return sum((((x >> i) & 1) << (2 * i)) | (((y >> i) & 1) << (2 * i + 1))
                   for i in range(32))

    want = sorted(range(len(pts)), key=lambda k: (code(*g[k].tolist()), k))
    assert z_order(pts, cell).tolist() == want
    assert len(z_order(np.zeros((0, 2)), 1.0)) == 0
