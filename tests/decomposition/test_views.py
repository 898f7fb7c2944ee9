"""Cells held as integer columns, against the per-region objects they replaced.

The reference is the former ``_make_regions``: each region's structure named with
:func:`structure_names` (sorted by name) and one :class:`Cell` made per name pair. The lazy
sequence ``dec.cells``, ``Region.cells``, ``dec.cell(id)``, the cell codes, the lazily made
multi-face polygons and the eliminations' ids must equal what the objects gave.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import shapely
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE, STAR_HOLE

from tether.analysis import analyze
from tether.analysis.connectivity import cell_ids
from tether.arcs import feature_name
from tether.decomposition import (
    FREE,
    Cell,
    cell_name,
    decompose,
    structure_codes,
    structure_names,
)
from tether.decomposition.regions import _structure_cells
from tether.decomposition.structure import Structures
from tether.decomposition.views import RegionShapes
from tether.examples.floorplan import floor_plan


def _cases():
    plan = floor_plan(40, seed=1)
    return [(GENERIC, 2.5), (SQUARE_HOLE, 1.0), (STAR_HOLE, 2.5), (L_SHAPE, 4.0),
            (plan.internal, (plan.bounds[2] - plan.bounds[0]) / 6 * plan.frame.scale)]


def _reference_cells(dec) -> tuple[Cell, ...]:
    """The cells as the per-region loop made them (the decomposition's own map numbering)."""
    out = []
    for r in dec.regions:
        out += [Cell(cell_name(r.id, s, e), r.id, s, e)
                for s, e in structure_names(dec.env, r.structure)]
    return tuple(out)


@pytest.mark.slow
@pytest.mark.parametrize("case", range(5))
def test_cells_equal_the_per_region_objects(case):
    env, lss = _cases()[case]
    dec = decompose(env, lss)
    ref = _reference_cells(dec)
    cells = dec.cells
    assert len(cells) == len(ref) > 5
    assert cells == ref and ref == cells and tuple(cells) == ref and list(cells) == list(ref)
    assert hash(cells) == hash(ref)
    assert cells != ref[:-1] and cells != list(ref)  # a tuple is never equal to a list
    assert cells[0] == ref[0] and cells[-1] == ref[-1] and cells[len(ref) - 2] == ref[-2]
    assert cells[2:7] == ref[2:7] and cells[::3] == ref[::3] and cells[5:2] == ()
    with pytest.raises(IndexError):
        cells[len(ref)]
    assert ref[3] in cells and Cell("(R0,E9,E9)", 0, "E9", "E9") not in cells
    for r in dec.regions:
        assert r.cells == tuple(c.id for c in ref if c.region == r.id)
        assert r.cells is r.cells  # made once
    # codes: per region the rows of structure_codes, in cell order
    region, start, end = dec.cell_codes()
    want = [(r.id, a, b) for r in dec.regions for a, b in structure_codes(dec.env, r.structure)
            .tolist()]
    assert list(zip(region.tolist(), start.tolist(), end.tolist(), strict=True)) == want
    assert cell_ids(dec) == [c.id for c in ref]


def test_cell_lookup_by_id():
    dec = decompose(GENERIC, 2.5)
    ref = _reference_cells(dec)
    for c in ref:
        assert dec.cell(c.id) == c
    first = ref[0]
    r, s, e = first.id[1:-1].split(",")
    bad = [f"(R0{r[1:]},{s},{e})", f"({r},{s},{e}", f"({r},{s})", f"(R{len(dec.regions)},{s},{e})",
           f"({r},{e}9,{s})", "R1", "", f"(r{r[1:]},{s},{e})", f"(R-1,{s},{e})", f" {first.id}"]
    for cid in bad:
        with pytest.raises(KeyError):
            dec.cell(cid)
        with pytest.raises(KeyError):
            dec.cell_named(cid)
        with pytest.raises(KeyError):
            dec.cell_index(cid)
    with pytest.raises(KeyError):
        dec.cell_named(5)
    for i in (0, 5, len(dec.cells) - 1):  # identity is the index; the name is for output
        assert dec.cell(i) == dec.cells[i] == dec.cell_named(dec.cells[i].id)
        assert dec.cell_index(dec.cells[i].id) == i
    with pytest.raises(IndexError):
        dec.cell(len(dec.cells))


def test_cell_at_names_existing_cells():
    dec = decompose(GENERIC, 2.5)
    pts = np.array([r.point for r in dec.regions])
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 2 * np.pi, len(pts))
    known = {c.id for c in _reference_cells(dec)}
    got = dec.cell_at(pts, ang)
    assert sum(c is not None for c in got) > len(pts) // 3
    assert all(c is None or c in known for c in got)


def test_structure_cells_sorts_like_structure_codes():
    """Random structures (shared objects, FULL and EMPTY among them): the columns are each
    structure's structure_codes rows, region after region."""
    env = GENERIC
    rng = np.random.default_rng(3)
    pool = ["FULL", "EMPTY"]
    for _ in range(40):
        k = int(rng.integers(1, 9))
        pool.append(frozenset(zip(rng.integers(0, 2 * env.n, k).tolist(),
                                  rng.integers(0, 2 * env.n, k).tolist(), strict=True)))
    structs = [pool[i] for i in rng.integers(0, len(pool), 300).tolist()]
    structs += [frozenset(s) if not isinstance(s, str) else s for s in structs[:20]]  # copies
    table, sid = _as_structures(env, structs)
    region, start, end = _structure_cells(env, table, sid)
    want = [(i, a, b) for i, s in enumerate(structs) for a, b in structure_codes(env, s).tolist()]
    assert list(zip(region.tolist(), start.tolist(), end.tolist(), strict=True)) == want
    names = [FREE] + [feature_name(env, c) for c in range(2 * env.n)]
    got = [(names[a + 1], names[b + 1]) for a, b in zip(start.tolist(), end.tolist(),
                                                          strict=True)]
    assert got == [p for s in structs for p in structure_names(env, s)]
    assert all(len(x) == 0 for x in _structure_cells(env, table, np.zeros(0, np.int64)))


def _as_structures(env, structs):
    """Structures (frozensets, FULL, EMPTY) as a ``Structures`` table (one id per distinct
    value, in order of first appearance) and the id of each."""
    base = 2 * env.n + 1
    ids = {"EMPTY": 0, "FULL": 1}
    rows = []
    for s in structs:
        if s not in ids:
            ids[s] = len(ids)
            rows.append(sorted(a * base + b for a, b in s))
    ptr = np.cumsum([0, 0, 0] + [len(r) for r in rows])
    pairs = np.array([c for r in rows for c in r], dtype=np.int64)
    return Structures(base, ptr, pairs), np.array([ids[s] for s in structs], dtype=np.int64)


@pytest.mark.slow
def test_multi_face_polygons_made_on_first_read():
    """Unions of several faces are made on the first read; a few read through ``some`` are
    the same geometries as all made at once, and every polygon's area is the region's."""
    env, lss = _cases()[4]
    dec = decompose(env, lss)
    shapes = dec.regions[0]._polygon
    assert type(shapes) is RegionShapes and not shapes.converted
    multi = sorted(shapes._unions)
    assert len(multi) > 3
    few = shapes.some(multi[:3] + [0])
    assert not shapes.converted
    dec2 = decompose(env, lss)
    full = [r.polygon for r in dec2.regions]
    assert dec2.regions[0]._polygon.converted
    assert all(shapely.is_prepared(p) for p in full)
    assert shapely.to_wkb(few).tolist() == shapely.to_wkb(
        [full[i] for i in multi[:3] + [0]]).tolist()
    for r, p in zip(dec2.regions, full, strict=True):
        assert p.area == pytest.approx(r.area, rel=1e-9)
    assert all(p.geom_type in ("Polygon", "MultiPolygon") for p in full)


def test_pickled_decomposition_keeps_cells_and_lazy_polygons():
    dec = decompose(GENERIC, 2.5)
    copy = pickle.loads(pickle.dumps(dec))
    assert copy.cells == dec.cells
    assert [r.cells for r in copy.regions] == [r.cells for r in dec.regions]
    assert [shapely.to_wkb(r.polygon) for r in copy.regions] == [
        shapely.to_wkb(r.polygon) for r in dec.regions]


@pytest.mark.slow
@pytest.mark.parametrize("case", [0, 2, 4])
def test_eliminations_and_survivors_by_id(case):
    """The eliminations made in one pass equal those made one by one from the list of every
    cell id, and the survivors are the ids of the alive cells."""
    env, lss = _cases()[case]
    v = analyze(decompose(env, lss), self_check=False)
    el = v.eliminated
    ids = cell_ids(v.dec)
    regions = [c.region for c in v.dec.cells]
    for i, e in enumerate(el):
        c = int(el.cell[i])
        assert e == el._one(i) == el[i]
        assert e.cell == c and e.cell_name == ids[c] and e.piece == el.piece[i]
        assert (e.because is None) == (e.because_name is None) == (el.because[i] < 0)
        assert e.because is None or (e.because, e.because_name) == (
            el.because[i], ids[el.because[i]])
        a, b = v.dec.pieces[int(el.piece[i])].regions
        assert e.escapes_to == (b if a == regions[c] else a)
        assert e.to_dict() == {"cell": ids[c], "escapes_to": f"R{e.escapes_to}",
                               "piece": f"P{e.piece}", "round": e.round,
                               "because": e.because_name}
    fell = set(el.cell.tolist())
    assert v.surviving == frozenset(ids[i] for i in range(len(ids)) if i not in fell)


def test_decrement_and_increasing_against_plain_loops():
    from tether.analysis.elimination import _decrement, _increasing

    rng = np.random.default_rng(5)
    for n, k in ((50, 3), (50, 400), (1000, 10), (7, 0)):
        count = rng.integers(0, 100, n)
        idx = rng.integers(0, n, k)
        want = count.copy()
        for i in idx.tolist():
            want[i] -= 1
        _decrement(count, idx)
        assert count.tolist() == want.tolist()
    for _ in range(200):
        m = int(rng.integers(0, 6))
        a, b, c = (rng.integers(0, 3, m) for _ in range(3))
        rows = list(zip(a.tolist(), b.tolist(), c.tolist(), strict=True))
        assert _increasing(a, b, c) == all(x < y for x, y in zip(rows, rows[1:], strict=False))


def test_to_dict_cells_and_regions_as_the_objects_give():
    dec = decompose(STAR_HOLE, 2.5)
    ref = _reference_cells(dec)
    assert dec.regions[1].cells  # one region read already, the others filled in one pass
    d = dec.to_dict()
    assert d["cells"] == [c.to_dict() for c in ref]
    assert [r["cells"] for r in d["regions"]] == [
        [c.id for c in ref if c.region == r.id] for r in dec.regions]
    # the regions are made when read (decompose's Regions): each read gives the same cells
    assert [r["cells"] for r in d["regions"]] == [list(r.cells) for r in dec.regions]


def _old_arc_rows(table):
    """The former ``_arc_rows`` (always a sorted copy)."""
    from tether.arcs import TWO_PI

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


def _old_candidate_pairs(rows, m):
    """The former ``_candidate_pairs`` (every range's queries at once)."""
    from tether._util.arrays import ragged_arange
    from tether.analysis.connectivity import _SEARCH_MARGIN, _arc_length
    from tether.arcs import TWO_PI

    point, start = rows["point"], rows["start"]
    counts = np.bincount(point, minlength=2 * m)
    first = np.cumsum(counts) - counts
    key = point * 8.0 + start
    a = np.flatnonzero(point < m)
    pb = point[a] + m
    has = counts[pb] > 0
    a, pb = a[has], pb[has]
    s1 = start[a]
    lo = s1 - _SEARCH_MARGIN
    hi = s1 + _arc_length(s1, rows["end"][a], rows["full"][a]) + _SEARCH_MARGIN
    base = pb * 8.0
    ranges = [(lo.clip(0.0, TWO_PI), np.minimum(hi, TWO_PI), np.ones(len(a), bool)),
              (np.zeros(len(a)), hi - TWO_PI, hi > TWO_PI),
              (lo + TWO_PI, np.full(len(a), TWO_PI), lo < 0)]
    got_a, got_b = [], []
    for r0, r1, use in ranges:
        i0 = np.searchsorted(key, base[use] + r0[use], side="left")
        i1 = np.searchsorted(key, base[use] + r1[use], side="right")
        n = np.maximum(i1 - i0, 0)
        got_a.append(np.repeat(a[use], n))
        got_b.append(ragged_arange(i0, n))
    j = np.searchsorted(key, base + lo, side="right") - 1
    j = np.where(j >= first[pb], j, first[pb] + counts[pb] - 1)
    got_a.append(a)
    got_b.append(j)
    ga, gb = np.concatenate(got_a), np.concatenate(got_b)
    pair = np.sort(ga * len(point) + gb)
    pair = pair[np.r_[True, pair[1:] != pair[:-1]]] if len(pair) else pair
    return pair // len(point), pair % len(point)


@pytest.mark.slow
@pytest.mark.parametrize("case", range(5))
def test_arc_rows_and_candidate_pairs_as_before(case):
    """The arc rows (as they are when sorted without FULL points, else a sorted copy) and
    the candidate pairs (range by range) equal the former all-at-once versions, with FULL
    points and unsorted tables made up as well."""
    from tether.analysis.connectivity import _candidate_pairs, _table_arc_rows
    from tether.arcs import ArcTable

    env, lss = _cases()[case]
    dec = decompose(env, lss)
    m = len(dec.pieces)
    t = dec.crossing_arcs()
    rng = np.random.default_rng(case)
    full = np.asarray(t.full, dtype=bool).copy()
    free_pts = np.setdiff1d(np.arange(len(full)), t.point)
    full[free_pts] = True  # points without arcs: made FULL
    flip = rng.permutation(len(t.point))
    for table in (t, ArcTable(t.point, t.start, t.end, t.start_code, t.end_code, full),
                  ArcTable(t.point[flip], t.start[flip], t.end[flip], t.start_code[flip],
                           t.end_code[flip], t.full)):
        got, want = _table_arc_rows(table), _old_arc_rows(table)
        assert set(got) == set(want)
        for k in want:
            assert np.array_equal(got[k], want[k]), k
        for a, b in zip(_candidate_pairs(got, m), _old_candidate_pairs(want, m), strict=True):
            assert np.array_equal(a, b)


@pytest.mark.slow
def test_escape_story_chain_on_arrays_as_on_objects():
    """The story's chain found on the elimination arrays equals the one found by scanning
    the Elimination objects (a verdict holding them as a plain tuple)."""
    import dataclasses

    from tether import load_map
    from tether.examples import path as example_path

    seen = 0
    cases = _cases() + [(load_map(example_path("rectangle")), 1.0)]
    for env, lss in cases:
        v = analyze(decompose(env, lss), self_check=False)
        if v.strategy_exists or not v.dec.regions[v.witness_region].cells:
            continue
        seen += 1
        plain = dataclasses.replace(v, eliminated=tuple(v.eliminated))
        assert v.story() == plain.story()
        assert len(v.story()) >= 2
    assert seen >= 1
