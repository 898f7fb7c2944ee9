"""The lean result (#25): regions, cells, G and the elimination held as small int columns, with
records made when read. Each check compares the lean form with what the per-object reading
gives (records iterated one by one, sets of ids built from the cells), or with the same
computation on int64 columns: the compact types change no value."""

import pickle

import numpy as np
import pytest

import tether.analysis.connectivity as C
from tether import Environment
from tether.analysis import analyze, build_graph
from tether.analysis.elimination import CellSet, eliminate
from tether.decomposition import decompose
from tether.decomposition.model import Region, Regions, compact_arcs, shared_holder
from tether.decomposition.views import CellTable

ELL = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # a strategy exists
QUICK = {"self_check": False, "near_critical": False}


@pytest.fixture(scope="module")
def star():
    return decompose(ELL, 0.5)


def test_regions_are_records_made_when_read(star):
    regs = star.regions
    assert type(regs) is Regions and len(regs) > 10
    a, b = regs[5], regs[5]
    assert a is not b and a == b and hash(a) == hash(b)
    assert regs[-1] == regs[len(regs) - 1] and regs[2:4] == (regs[2], regs[3])
    assert tuple(regs) == regs and regs == tuple(regs) and list(regs) == list(tuple(regs))
    with pytest.raises(IndexError):
        regs[len(regs)]
    other = decompose(ELL, 0.5).regions[5]  # another decomposition's: not the same
    assert other != a and (other.id, other.area, other.point) == (a.id, a.area, a.point)


def test_region_records_read_as_the_cells_and_map_say(star):
    by_region = {}
    for c in star.cells:  # the cells one by one, a path apart from the regions' columns
        by_region.setdefault(c.region, []).append(c.id)
    for r in star.regions:
        assert type(r) is Region and r.name == f"R{r.id}"
        assert list(r.cells) == by_region.get(r.id, [])
        assert star.region_at([r.point])[0] == r.id  # its point lies in it
        assert r.area == pytest.approx(r.polygon.area, rel=1e-9)
    assert sum(r.area for r in star.regions) == pytest.approx(ELL.area, rel=1e-8)
    assert star.to_dict()["regions"] == [r.to_dict() for r in star.regions]


def test_shared_holder_of_records_and_of_the_view(star):
    t = star.regions._table
    recs = tuple(star.regions)
    for attr, held in (("_polygon", t.shapes), ("_structure", t.structures), ("_cells", t.cells)):
        assert shared_holder(star.regions, attr) is held
        assert shared_holder(recs, attr) is held
    assert shared_holder((), "_polygon") is None


def test_cell_and_graph_columns_are_small_ints(star):
    t = star.cells._table
    assert (t.region.dtype, t.start.dtype, t.end.dtype) == (np.int32, np.int16, np.int16)
    assert all(a is b for a, b in zip(star.cell_codes(), (t.region, t.start, t.end),
                                      strict=True))  # held once
    arcs = star.crossing_arcs()
    assert (arcs.point.dtype, arcs.start_code.dtype) == (np.int32, np.int16)
    g = build_graph(star)
    for name in ("edge_a", "edge_b", "edge_piece", "region_ptr", "region_pieces", "slot_ptr",
                 "slot_piece", "partner_ptr", "partner_cell", "partner_slot"):
        assert getattr(g, name).dtype == np.int32, name
    assert C.index_dtype(2**31 - 1) is np.int32 and C.index_dtype(2**31) is np.int64


def test_small_ints_change_no_value(monkeypatch):
    """G and the elimination on int32 columns equal those on int64 columns (the index type
    forced to int64 everywhere it is chosen)."""
    v_lean = analyze(decompose(ELL, 0.5), **QUICK)
    monkeypatch.setattr(C, "index_dtype", lambda n: np.int64)
    import tether.analysis.elimination as E

    monkeypatch.setattr(E, "index_dtype", lambda n: np.int64)
    wide = decompose(ELL, 0.5)
    v_wide = analyze(wide, **QUICK)
    assert build_graph(wide).edge_a.dtype == np.int64
    assert v_wide.to_dict() == v_lean.to_dict()
    for a, b in ((v_wide.graph.partner_slot, v_lean.graph.partner_slot),
                 (v_wide.eliminated.cell, v_lean.eliminated.cell),
                 (v_wide.eliminated.because, v_lean.eliminated.because)):
        assert np.array_equal(a, b)


def test_compact_types_widen_past_their_ranges():
    from tether.arcs import ArcTable

    t = ArcTable(np.array([0, 0, 1]), np.zeros(3), np.ones(3), np.array([-1, 4, 7]),
                 np.array([3, -1, 9]), np.zeros(2, bool))
    small = compact_arcs(t, 2**15 - 1)
    assert (small.point.dtype, small.start_code.dtype) == (np.int32, np.int16)
    assert compact_arcs(t, 2**15).start_code.dtype == np.int32
    for f in ("point", "start_code", "end_code"):
        assert np.array_equal(getattr(small, f), getattr(t, f))
    names = ["*"] + [f"E{i}" for i in range(2**15)]  # 2**15 + 1 names: int32 codes
    table = CellTable(np.array([0, 1]), np.array([-1, 2**15 - 1]), np.array([-1, 5]),
                      names, 2)
    assert table.start.dtype == np.int32 and table.cell(1).start_feature == f"E{2**15 - 1}"


def test_surviving_cells_read_as_the_set_of_their_ids(star):
    dec = star
    v = analyze(dec, **QUICK)
    s = v.surviving
    assert type(s) is CellSet and len(s) == 20
    fell = set(v.eliminated.cell.tolist())
    ref = frozenset(c.id for i, c in enumerate(dec.cells) if i not in fell)
    assert s == ref and ref == s and hash(s) == hash(ref) and set(s) == set(ref)
    assert all((c.id in s) == (c.id in ref) for c in dec.cells)
    assert "(R99999,E1,E2)" not in s and 5 not in s and "x" not in s
    some = next(iter(ref))
    assert type(s & {some}) is frozenset and s & {some} == {some}
    assert s | {"y"} == ref | {"y"} and s - ref == frozenset()
    back = pickle.loads(pickle.dumps(s))
    assert type(back) is frozenset and back == ref
    none = eliminate(build_graph(decompose(Environment([(0, 0), (1.5, 0), (1.5, 3),
                                                        (0, 3)]), 1.0)))[0]
    assert len(none) == 0 and not none and none == frozenset()


@pytest.mark.parametrize("limit", [1, 37, 100])
def test_edges_found_run_by_run_equal_all_at_once(star, monkeypatch, limit):
    """G found for runs of a few pieces at a time (limit: arc rows a run) has the same
    edges in the same order, and the same verdict."""
    whole = build_graph(star)
    monkeypatch.setattr(C, "EDGE_CHUNK_ROWS", limit)
    ends = C.size_runs(np.cumsum(np.ones(len(star.pieces), np.int64) * 8), limit)
    assert len(ends) > 1 and ends[-1] == len(star.pieces)
    runs = build_graph(star)
    for name in ("edge_a", "edge_b", "edge_piece", "partner_ptr", "partner_cell"):
        assert np.array_equal(getattr(whole, name), getattr(runs, name)), name
    assert analyze(star, runs, **QUICK).to_dict() == analyze(star, whole, **QUICK).to_dict()


def test_runs_cover_every_item_once():
    total = np.cumsum([5, 1, 1, 9, 2, 2, 2])
    assert C.size_runs(total, 6) == [2, 3, 4, 7]  # 5 1 | 1 | 9 (alone: over the limit) | 2 2 2
    assert C.size_runs(total, 100) == [7] and C.size_runs(np.zeros(0, np.int64), 4) == []


@pytest.mark.parametrize("limit", [1, 5])
def test_rounds_read_run_by_run_equal_all_at_once(star, monkeypatch, limit):
    """The elimination reading each round's partner entries a few at a time gives the same
    removals (cell, piece, round, because) in the same order and the same survivors."""
    import tether.analysis.elimination as E

    room = decompose(Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)]), 1.0)  # all fall
    for dec in (star, room):
        g = build_graph(dec)
        whole = eliminate(g)
        monkeypatch.setattr(E, "ELIM_CHUNK", limit)
        runs = eliminate(g)
        monkeypatch.undo()
        assert runs[0] == whole[0] and len(whole[1]) > 4
        for name in ("cell", "piece", "round", "because"):
            assert np.array_equal(getattr(runs[1], name), getattr(whole[1], name)), name
