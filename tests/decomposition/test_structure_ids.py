"""Structure ids found without the padded grid of every point's pairs (issue 25: its memory
was rows times the longest row): equal ids for equal sets of cells and only for them (against
sets made point by point), the very ids of the grid's sort, and the grid's sort when two
distinct rows share a hash."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tether.decomposition.structure as structure
from tether.decomposition.structure import structure_ids_of


def table(rng, npts, nvertices, max_arcs):
    """A random arc table's columns: each point some (start, end) code pairs (repeats
    allowed), drawn from few distinct sets so that many points share one; some points full."""
    sets = [rng.integers(0, 2 * nvertices, size=(rng.integers(1, max_arcs + 1), 2))
            for _ in range(max(1, npts // 4))]
    full = rng.random(npts) < 0.1
    point, start, end = [], [], []
    for p in np.flatnonzero(~full & (rng.random(npts) < 0.9)).tolist():
        s = sets[rng.integers(len(sets))]
        s = s[rng.permutation(len(s))]
        point += [p] * len(s)
        start += s[:, 0].tolist()
        end += s[:, 1].tolist()
    return (full, np.array(point, np.int64), np.array(start, np.int64),
            np.array(end, np.int64))


def reference_sets(npts, full, point, start, end):
    out = [("FULL",) if f else () for f in full.tolist()]
    cells: dict[int, set] = {}
    for p, a, b in zip(point.tolist(), start.tolist(), end.tolist(), strict=True):
        cells.setdefault(p, set()).add((a, b))
    for p, c in cells.items():
        out[p] = frozenset(c)
    return out


def check(seed, npts, nvertices, max_arcs, monkeypatch=None):
    rng = np.random.default_rng(seed)
    full, point, start, end = table(rng, npts, nvertices, max_arcs)
    ids, structs = structure_ids_of(nvertices, full, point, start, end, npts)
    want = reference_sets(npts, full, point, start, end)
    for p in range(npts):  # each id's structure is the point's set of cells
        s = structs.structure(int(ids[p]))
        assert (s == "FULL") if want[p] == ("FULL",) else (
            (s == "EMPTY") if want[p] == () else s == want[p])
    keys = {}
    for p in range(npts):  # equal ids exactly for equal sets
        assert keys.setdefault(want[p], ids[p]) == ids[p]
    assert len(set(keys.values())) == len(keys)
    return ids, structs


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), npts=st.integers(1, 60), nvertices=st.integers(1, 9),
       max_arcs=st.integers(1, 7))
def test_ids_are_the_sets(seed, npts, nvertices, max_arcs):
    check(seed, npts, nvertices, max_arcs)


@pytest.mark.parametrize("size", [pytest.param(3000, marks=pytest.mark.slow), 400])
def test_same_ids_as_the_grid(size, monkeypatch):
    got = check(size, size, 50, 12)
    monkeypatch.setattr(structure, "_ragged_row_ids", lambda *a: None)  # the grid's sort
    grid = check(size, size, 50, 12)
    assert np.array_equal(got[0], grid[0])
    assert np.array_equal(got[1].ptr, grid[1].ptr)
    assert np.array_equal(got[1].pairs, grid[1].pairs)


def test_a_hash_collision_falls_back_to_the_grid(monkeypatch):
    rng = np.random.default_rng(3)
    full, point, start, end = table(rng, 300, 20, 6)
    want = structure_ids_of(20, full, point, start, end, 300)
    # every row one hash: distinct rows of equal hash, so the grid's exact sort decides
    monkeypatch.setattr(structure, "_row_hashes", lambda p, s, n: np.zeros(len(s), np.uint64))
    assert structure._ragged_row_ids(np.arange(6), np.array([0, 3]), np.array([3, 3])) is None
    assert structure._ragged_row_ids(np.arange(6), np.array([0, 3]), np.array([3, 2])) is None
    ids, structs = structure_ids_of(20, full, point, start, end, 300)
    assert np.array_equal(ids, want[0]) and np.array_equal(structs.ptr, want[1].ptr)
    assert np.array_equal(structs.pairs, want[1].pairs)
