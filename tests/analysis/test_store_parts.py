"""G and the elimination on a store read part by part (issue 25): the crossings' arcs of
a store are read one part at a time (``Decomposition.crossing_arc_parts``), never as one
table, and the verdict, the counts and the surviving cells are those of the untiled
decomposition made in memory, up to the store's renumbering of the regions."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SerialExecutor, random_maps
from hypothesis import HealthCheck, given, settings

import tether.decomposition.store as S
from tether.analysis import analyze, build_graph
from tether.decomposition import decompose
from tether.decomposition.store import read_decomposition, write_decomposition
from tether.environment import Environment
from tether.examples import load as load_example
from tether.examples.floorplan import floor_plan

QUICK = {"self_check": False, "near_critical": False}


@pytest.fixture
def parts_only(monkeypatch):
    """A store's whole arc table made unreadable: what reads it fails the test."""
    def whole(self):
        raise AssertionError("the store's arcs were read as one table")
    monkeypatch.setattr(S.StoredArcs, "__call__", whole)


def _surviving_keys(dec, verdict, ren):
    """The surviving cells as ``(region in the numbering ren, start, end)`` features."""
    cells = dec.cells
    return sorted((int(ren[cells[i].region]), cells[i].start_feature, cells[i].end_feature)
                  for i in np.flatnonzero(verdict.surviving.alive).tolist())


def assert_same_verdict(mem, stored):
    """``stored`` (read from a store, part by part) analyzes as ``mem`` (untiled, in
    memory): counts, edges, eliminations and rounds, the verdict, and the surviving cells
    matched by the regions' representative points (the store's regions renumbered)."""
    va, vb = analyze(mem, **QUICK), analyze(stored, **QUICK)
    assert mem.counts == stored.counts
    assert va.counts() == vb.counts()
    assert (len(va.eliminated), va.rounds) == (len(vb.eliminated), vb.rounds)
    assert va.strategy_exists == vb.strategy_exists
    assert (va.witness_region is None) == (vb.witness_region is None)
    j = stored.region_at(np.array([r.point for r in mem.regions]).reshape(-1, 2))
    assert sorted(j.tolist()) == list(range(len(stored.regions)))
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))
    assert _surviving_keys(mem, va, np.arange(len(j))) == _surviving_keys(stored, vb, inv)


def test_parts_read_one_at_a_time_give_the_same_graph(tmp_path, parts_only):
    """A decomposition written in 3 parts: G built from the parts' arcs (the whole table
    never read) has the in-memory G's arrays, in the same order."""
    dec = decompose(Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)]), 1.5)
    back = read_decomposition(write_decomposition(dec, tmp_path / "s", parts=3))
    m = len(dec.pieces)
    assert [(f, len(t.full) // 2) for f, t in back.crossing_arc_parts()] == \
        [(m * k // 3, m * (k + 1) // 3 - m * k // 3) for k in range(3)]
    ga, gb = build_graph(dec), build_graph(back)
    for name in ("edge_a", "edge_b", "edge_piece", "slot_ptr", "slot_piece", "partner_ptr",
                 "partner_slot"):
        assert np.array_equal(getattr(ga, name), getattr(gb, name)), name
    assert analyze(back, **QUICK).surviving == analyze(dec, **QUICK).surviving
    # each cell's slots: the pieces bounding its region, increasing (counted from the pieces)
    bounding = {}
    for k, piece in enumerate(dec.pieces):
        for r in piece.regions:
            bounding.setdefault(r, []).append(k)
    for c, cell in enumerate(dec.cells):
        got = gb.slot_piece[gb.slot_ptr[c]:gb.slot_ptr[c + 1]].tolist()
        assert got == sorted(bounding.get(cell.region, []))


def test_progress_names_the_steps():
    room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    seen = []
    analyze(decompose(room, 1.0), progress=lambda stage, frac: seen.append(stage), **QUICK)
    assert list(dict.fromkeys(seen)) == ["cells index", "G edges", "G slots", "elimination",
                                         "verdict", "done"]


@pytest.mark.slow
@pytest.mark.parametrize("name,lss,tiles", [("rectangle", None, (4, 4)),
                                            ("gallery", 1.0, (5, 5)),
                                            ("nonconvex_corner", None, (3, 3))])
def test_tiled_store_analyzes_as_the_untiled_map(tmp_path, parts_only, name, lss, tiles):
    """Bundled maps in forced small tiles written to a store, analyzed part by part: the
    untiled in-memory verdict, counts and surviving cells."""
    env = load_example(name)
    lss = 0.3 * env.diameter if lss is None else lss
    stored = decompose(env, lss, tiles=tiles, executor=SerialExecutor(), out=tmp_path / "s")
    assert assert_same_verdict(decompose(env, lss), stored) is None


@pytest.mark.slow
def test_floor_plan_store_analyzes_as_the_untiled_map(tmp_path, parts_only):
    env = floor_plan(80, seed=3)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    stored = decompose(env, lss, tiles=(3, 2), executor=SerialExecutor(), out=tmp_path / "s")
    assert_same_verdict(decompose(env, lss), stored)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, suppress_health_check=list(HealthCheck))
@given(env=random_maps())
def test_random_maps_store_analyzes_as_the_untiled_map(tmp_path_factory, env):
    lss = 0.3 * env.diameter
    out = tmp_path_factory.mktemp("s") / "s"
    S.StoredArcs.__call__ = _forbidden  # as parts_only (hypothesis: no function fixture)
    try:
        stored = decompose(env, lss, tiles=(3, 3), executor=SerialExecutor(), out=out)
        assert_same_verdict(decompose(env, lss), stored)
    finally:
        S.StoredArcs.__call__ = _WHOLE


_WHOLE = S.StoredArcs.__call__


def _forbidden(self):
    raise AssertionError("the store's arcs were read as one table")


class _Terminal:
    """A stderr that says it is a terminal (the progress bar draws only on one)."""

    def __init__(self):
        self.text = []

    def isatty(self):
        return True

    def write(self, s):
        self.text.append(s)

    def flush(self):
        pass


def test_cli_analyze_from_shows_its_steps_on_a_terminal(tmp_path, monkeypatch, capsys):
    from tether.cli import main

    room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    store = write_decomposition(decompose(room, 1.0), tmp_path / "s", parts=2)
    term = _Terminal()
    monkeypatch.setattr("sys.stderr", term)
    assert main(["analyze", "--from", str(store)]) == 0
    bar = "".join(term.text)
    assert "G edges" in bar and "elimination" in bar and bar.rstrip().endswith("s")
    assert "100%" in bar
    assert "NO surveillance strategy exists" in capsys.readouterr().out
