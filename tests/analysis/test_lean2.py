"""G built without a copy of the whole arc table nor a sort of every partner entry (#25): the
edges of each run of pieces read from the crossings' arc table as it is held, the partner
CSR placed by a counting sort a run of edges at a time. Compared with a direct computation:
all arc pairs of all pieces in one pass over a sorted copy of the rows, and a stable argsort
of every partner entry."""

import numpy as np
import pytest

import tether.analysis.connectivity as C
from tether import Environment
from tether.analysis import analyze, build_graph
from tether.decomposition import decompose

QUICK = {"self_check": False, "near_critical": False}


@pytest.fixture(scope="module")
def room():
    """An L-shaped room at a short rod: many FULL regions (crossings with no arc row)."""
    dec = decompose(Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)]), 0.5)
    assert dec.crossing_arcs().full.any()
    return dec


def _reference_edges(dec):
    """Every edge in one pass over a sorted copy of every arc row (the pieces all at once)."""
    rows = C._table_arc_rows(dec.crossing_arcs())
    m = len(dec.pieces)
    k, ia, ib = C._run_pairs(rows, m)
    regs = C.piece_regions(dec)
    ca = C._cell_index(dec, regs[k, 0], rows["start_code"][ia], rows["end_code"][ia])
    cb = C._cell_index(dec, regs[k, 1], rows["start_code"][ib], rows["end_code"][ib])
    ok = (ca >= 0) & (cb >= 0)
    return ca[ok], cb[ok], k[ok]


@pytest.mark.parametrize("limit", [1, 23, 1 << 20])
def test_edges_read_run_by_run_from_the_table_equal_one_pass(room, monkeypatch, limit):
    monkeypatch.setattr(C, "EDGE_CHUNK_ROWS", limit)
    got = C._edges(room)
    for a, b in zip(got, _reference_edges(room), strict=True):
        assert np.array_equal(a, b)


def _reference_partners(slot_a, slot_b, nslot):
    key = np.column_stack((slot_a, slot_b)).ravel()
    order = np.argsort(key, kind="stable")
    ptr = np.r_[0, np.cumsum(np.bincount(key, minlength=nslot))]
    return ptr, np.column_stack((slot_b, slot_a)).ravel()[order]


@pytest.mark.parametrize("chunk", [1, 3, 1000])
def test_partner_entries_by_counting_sort_equal_a_stable_sort(monkeypatch, chunk):
    rng = np.random.default_rng(chunk)
    monkeypatch.setattr(C, "PARTNER_CHUNK", chunk)
    for nslot, ne in ((1, 0), (5, 40), (50, 400), (400, 50)):
        a = rng.integers(0, nslot, ne).astype(np.int32)
        b = rng.integers(0, nslot, ne).astype(np.int32)
        ptr, slot = C.partner_entries(a, b, nslot)
        want_ptr, want_slot = _reference_partners(a, b, nslot)
        assert ptr.tolist() == want_ptr.tolist() and slot.tolist() == want_slot.tolist()
        assert slot.dtype == np.int32 and ptr.dtype == np.int32


def test_graph_from_small_runs_gives_the_same_verdict(room, monkeypatch):
    whole = build_graph(room)
    monkeypatch.setattr(C, "PARTNER_CHUNK", 7)
    monkeypatch.setattr(C, "EDGE_CHUNK_ROWS", 11)
    monkeypatch.setattr(C, "SLOT_CHUNK", 5)
    runs = build_graph(room)
    for name in ("edge_a", "edge_b", "edge_piece", "partner_ptr", "partner_slot", "slot_ptr",
                 "slot_piece"):
        assert np.array_equal(getattr(whole, name), getattr(runs, name)), name
    assert analyze(room, runs, **QUICK).to_dict() == analyze(room, whole, **QUICK).to_dict()


@pytest.mark.slow
def test_sides_of_a_critical_length_decomposed_in_the_tiles_given(monkeypatch):
    """A 4 x 4 room at lss 2 (opposite walls 2 lss apart): analyze decomposes the map just
    below and above; with ``tiles`` those decompositions are tiled too (on the executor
    given), with the same verdicts and counts as untiled."""
    from concurrent.futures import ThreadPoolExecutor

    import tether.analysis.elimination as E

    env = Environment([(0, 0), (4, 0), (4, 4), (0, 4)])
    dec = decompose(env, 2.0)
    seen = []
    real = E.decompose

    def spy(*args, **kw):
        seen.append(kw.get("tiles"))
        return real(*args, **kw)

    monkeypatch.setattr(E, "decompose", spy)
    plain = analyze(dec, self_check=False)
    with ThreadPoolExecutor(2) as ex:
        tiled = analyze(dec, self_check=False, tiles=(2, 2), executor=ex)
    assert seen == [None, None, (2, 2), (2, 2)]
    assert tiled.critical.to_dict() == plain.critical.to_dict()
