"""The pieces in tiles (tether/decomposition/tiles.py, ``tiled_crossings``, issue 25): each
tile's task computes the crossings, the arcs at them and the lines of the chains it owns,
and the pieces are those of the untiled run up to renumbering. Checked independently of the
pieces' code: every untiled piece matched to the tiled piece nearest its sample (brute force),
the same regions (through the regions' renumbering, the normal's side first), curves' kind
and features, line, offset and verification, the sample within 1e-9 of the map's diameter,
the normal within 1e-7, and the free arcs at both sides of the crossing the same features at
angles within 1e-7 (the projection's last Gauss-Newton step depends on the rows it runs
with); on top of the common comparison (``renumbering.py``: cells, G, eliminations,
verdict)"""

from __future__ import annotations

from concurrent.futures import Executor, Future

import numpy as np
import pytest
import shapely
from renumbering import assert_equal_up_to_renumbering

import tether.decomposition.tiles as tiles_mod
from tether.curves import critical_curves, project_many
from tether.decomposition import decompose, pipeline
from tether.decomposition import pieces as pieces_mod
from tether.decomposition.structure import StructureRows
from tether.examples import load as load_example
from tether.examples.floorplan import floor_plan


class _Counting(Executor):
    """Runs each task at once in this thread, counting the pieces' tasks."""

    def __init__(self):
        self.pieces = 0

    def submit(self, fn, /, *args, **kwargs):
        self.pieces += args[0] is tiles_mod.pieces_tile
        f = Future()
        f.set_result(fn(*args, **kwargs))
        return f


def _arcs_of(table, k):
    """The arcs of point ``k``: their (start code, end code) and (start, end) angles."""
    rows = table.rows_of(k)
    codes = list(zip(table.start_code[rows].tolist(), table.end_code[rows].tolist(),
                     strict=True))
    return codes, np.column_stack((table.start[rows], table.end[rows])), bool(table.full[k])


def assert_same_pieces(a, b):
    """``b``'s pieces are ``a``'s (see the module's docstring)."""
    ren = b.region_at(np.array([r.point for r in a.regions]).reshape(-1, 2))
    qa, na, ea = a.piece_crossings()
    qb, nb, eb = b.piece_crossings()
    assert len(qa) == len(qb)
    if len(qa) == 0:
        return
    tol = 1e-9 * a.env.diameter
    d = np.hypot(*(qa[:, None, :] - qb[None, :, :]).transpose(2, 0, 1))
    match = d.argmin(axis=1)
    assert sorted(match.tolist()) == list(range(len(qb))), "pieces matched one to one"
    assert d[np.arange(len(qa)), match].max() <= tol
    assert np.abs(na - nb[match]).max() <= 1e-7
    assert np.array_equal(ea, eb[match])
    arcs_a, arcs_b = a.crossing_arcs(), b.crossing_arcs()
    m = len(qa)
    for i, j in enumerate(match.tolist()):
        pa, pb = a.pieces[i], b.pieces[j]
        assert tuple(ren[list(pa.regions)].tolist()) == pb.regions  # the +n side first
        assert (pa.kind, pa.features, pa.verified) == (pb.kind, pb.features, pb.verified)
        assert shapely.equals(pa.geometry, pb.geometry)
        assert pa.geometry.length == pytest.approx(pb.geometry.length, rel=1e-12)
        for side in (0, m):
            ca, xa, fa = _arcs_of(arcs_a, i + side)
            cb, xb, fb = _arcs_of(arcs_b, j + side)
            assert (ca, fa) == (cb, fb)
            assert np.abs(xa - xb).max(initial=0) <= 1e-7


def _pair(env, lss, tiles):
    whole = decompose(env, lss)
    ex = _Counting()
    return whole, decompose(env, lss, tiles=tiles, executor=ex), ex.pieces


def test_tiled_crossings_on_the_same_chains(monkeypatch):
    """The pieces of one arrangement's chains made in 4 x 4 tiles (an untiled decomposition's
    arrangement: the same chains and regions, no renumbering) are its untiled pieces, tile
    by tile: the same regions, curves and lines (bit for bit), offsets, verification and
    arcs' features; samples, normals and angles within 1e-9 / 1e-7."""
    args = []
    made = pieces_mod.make_pieces
    monkeypatch.setattr(pipeline, "make_pieces", lambda *a: args.append(a) or made(*a))
    env = load_example("rectangle")
    decompose(env, 0.3 * env.diameter)
    env_i = args[0][0]
    whole, _, wa = made(*args[0])
    ex, log = _Counting(), {}
    tiled, _, ta = made(*args[0], crossings=tiles_mod.tiled_crossings((4, 4), ex, log=log))
    assert ex.pieces == log["piece_tasks"] > 4 and log["piece_tiles"] == (4, 4)
    # each table's pieces ordered by (regions, line's bytes): a piece is its chain's
    lines = [shapely.to_wkb(t.shapes.all()).tolist() for t in (whole, tiled)]
    w, k = (np.array(sorted(range(len(t)), key=lambda i, t=t, b=b: (*t.pair[i].tolist(), b[i])))
            for t, b in zip((whole, tiled), lines, strict=True))
    assert len(k) == len(whole) and np.array_equal(tiled.pair[k], whole.pair[w])
    assert [lines[1][i] for i in k] == [lines[0][i] for i in w]
    wd, td = ([t.descs[i] for i in t.desc] for t in (whole, tiled))
    assert [td[i] for i in k.tolist()] == [wd[i] for i in w.tolist()]
    assert np.array_equal(tiled.eps[k], whole.eps[w])
    assert np.array_equal(tiled.ok[k], whole.ok[w])
    assert np.abs(tiled.q[k] - whole.q[w]).max() <= 1e-9 * env_i.diameter
    assert np.abs(tiled.n[k] - whole.n[w]).max() <= 1e-7
    m = len(k)
    for i, j in zip(w.tolist(), k.tolist(), strict=True):
        for side in (0, m):
            ca, xa, fa = _arcs_of(wa, i + side)
            cb, xb, fb = _arcs_of(ta, j + side)
            assert (ca, fa) == (cb, fb)
            assert np.abs(xa - xb).max(initial=0) <= 1e-7


def test_curves_subset_projects_bit_for_bit():
    """A task's curves (their own families' rows, polylines for conchoids only) project a
    point exactly as the whole list does."""
    env = load_example("gallery")
    curves = critical_curves(env.internal, 1.0 * env.frame.scale)
    rng = np.random.default_rng(3)
    ids = np.sort(rng.choice(len(curves), size=min(25, len(curves)), replace=False))
    lo, hi = np.array(env.internal.bounds[:2]), np.array(env.internal.bounds[2:])
    q = lo + rng.random((len(ids), 2)) * (hi - lo)
    sub = tiles_mod._curves_subset(curves, ids)
    assert [c.kind for c in sub] == [curves[c].kind for c in ids.tolist()]
    for got, want in zip(project_many(sub, np.arange(len(ids)), q),
                         project_many(curves, ids, q), strict=True):
        assert np.array_equal(got, want)


def test_rows_subset():
    rows = StructureRows(np.array([0, 1, 2, 2]), np.array([0, 0, 0, 2, 3]),
                         np.array([5, 7, 9]))
    sub = tiles_mod._rows_subset(rows, np.array([3, 2]))
    assert sub.kind.tolist() == [2, 2] and sub.ptr.tolist() == [0, 1, 3]
    assert sub.pairs.tolist() == [9, 5, 7]


@pytest.mark.slow
@pytest.mark.parametrize("name,tiles", [("rectangle", (3, 3)), ("convex_corner", (8, 8)),
                                        ("nonconvex_corner", (5, 4)), ("gallery", (8, 8))])
def test_bundled_examples(name, tiles):
    env = load_example(name)
    lss = 0.3 * env.diameter if name != "gallery" else 1.0
    whole, tiled, tasks = _pair(env, lss, tiles)
    assert tasks > 1
    assert_same_pieces(whole, tiled)
    assert_equal_up_to_renumbering(whole, tiled)


@pytest.mark.slow
def test_floor_plan():
    env = floor_plan(100, 1)
    whole, tiled, tasks = _pair(env, (env.bounds[2] - env.bounds[0]) / 15, (4, 4))
    assert tasks > 8
    assert_same_pieces(whole, tiled)
    assert_equal_up_to_renumbering(whole, tiled)


@pytest.mark.slow
def test_worker_processes():
    """The tasks' inputs and results cross process boundaries (pickled)."""
    env = load_example("convex_corner")
    lss = 0.3 * env.diameter
    with tiles_mod.process_executor(2) as ex:
        tiled = decompose(env, lss, tiles=(3, 3), executor=ex)
    whole = decompose(env, lss)
    assert_same_pieces(whole, tiled)
    assert_equal_up_to_renumbering(whole, tiled)
