"""Coincident straight lines made one exactly (tether.decomposition.coincidence): copies of
one line that differ by rounding must node into one part, walls never move, and lines in
general position are left alone."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tether.decomposition.coincidence import COLLINEAR_TOL, merge_collinear


def _lines(xy, line):
    return shapely.linestrings(xy, indices=line)


def _noded_length_and_parts(xy, line):
    parts = shapely.get_parts(shapely.node(shapely.multilinestrings(_lines(xy, line))))
    return shapely.length(parts).sum(), len(parts)


@settings(max_examples=30, deadline=None)
@given(angle=st.floats(0, np.pi), offset=st.floats(-1, 1), s=st.lists(
    st.integers(-500, 500), min_size=4, max_size=4, unique=True),
    noise=st.floats(1e-18, 1e-15), wall=st.booleans())
def test_overlapping_copies_node_into_shared_parts(angle, offset, s, noise, wall):
    """Two overlapping copies of one line (ends on a 1e-3 grid), the second moved by
    rounding-sized noise: after merging, their overlap is one part (the noded length is the
    union's, not the sum)."""
    u = np.array([np.cos(angle), np.sin(angle)])
    nrm = np.array([-u[1], u[0]])
    s = [v / 1000 for v in sorted(s)]
    a = [offset * nrm + s[0] * u, offset * nrm + s[2] * u]  # [s0, s2]
    b = [offset * nrm + s[1] * u + noise * nrm, offset * nrm + s[3] * u - noise * nrm]  # [s1, s3]
    xy = np.array(a + b)
    line = np.array([0, 0, 1, 1])
    fixed = np.array([wall, wall, False, False])
    out, oline = merge_collinear(xy, line, fixed)
    if wall:  # a wall never moves
        assert np.array_equal(out[oline == 0][[0, -1]], xy[:2])
    moved = np.hypot(*(out[oline == 1][[0, -1]] - xy[2:]).T)
    assert moved.max() <= 2 * COLLINEAR_TOL
    total, parts = _noded_length_and_parts(out, oline)
    union = s[3] - s[0]
    assert abs(total - union) <= 1e-9
    assert parts == 3  # [s0,s1], [s1,s2] shared, [s2,s3]


def test_lines_in_general_position_are_untouched():
    rng = np.random.default_rng(3)
    xy = rng.uniform(-1, 1, size=(40, 2))
    line = np.repeat(np.arange(20), 2)
    out, oline = merge_collinear(xy, line, np.zeros(40, bool))
    assert np.array_equal(out, xy) and np.array_equal(oline, line)


def test_disjoint_pieces_of_one_line_are_untouched():
    """Two walls on one line with a door between them: nothing overlaps, nothing moves."""
    xy = np.array([[0, 0], [1, 0], [2, 1e-17], [3, 0]], float)
    line = np.array([0, 0, 1, 1])
    out, oline = merge_collinear(xy, line, np.zeros(4, bool))
    assert np.array_equal(out, xy) and np.array_equal(oline, line)


def test_three_copies_and_a_wall():
    """An offset along a wall, twice, both rounded apart: all on the wall's line, sharing its
    vertices; the wall's coordinates are kept exactly."""
    wall = [[0.0, 0.25], [2.0, 0.25]]
    c1 = [[0.5, 0.25 + 3e-17], [1.5, 0.25 - 2e-17]]
    c2 = [[1.0, 0.25 - 1e-17], [3.0, 0.25 + 1e-17]]
    xy = np.array(wall + c1 + c2)
    line = np.array([0, 0, 1, 1, 2, 2])
    out, oline = merge_collinear(xy, line, np.array([True, True, False, False, False, False]))
    assert np.all(out[:, 1] == 0.25)
    assert np.array_equal(out[oline == 0][[0, -1]], np.array(wall))
    total, _ = _noded_length_and_parts(out, oline)
    assert abs(total - 3.0) < 1e-12
