"""Tiles (tether/decomposition/tiles.py): the arrangement noded in a grid of tiles gives a
decomposition equal to the untiled one up to renumbering (regions matched by representative
point, their areas and structures, cells, pieces, G and the eliminations), whatever the
executor; and the clipping's exact rules at the cuts."""

from __future__ import annotations

import collections
from concurrent.futures import Executor, Future, ThreadPoolExecutor

import lattice_maps as lm
import numpy as np
import pytest
import shapely
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.analysis import analyze, build_graph
from tether.decomposition import check, decompose
from tether.decomposition.tiles import (
    MAX_TILES,
    TileGrid,
    auto_tiles,
    check_tiles,
    clip_to_tiles,
    cut_positions,
    tile_grid,
)
from tether.errors import InvalidParameterError
from tether.examples import load as load_example
from tether.examples.floorplan import floor_plan


class _Serial(Executor):
    """Runs each task at once, in this thread: the tiles' code without processes."""

    def submit(self, fn, /, *args, **kwargs):
        f = Future()
        f.set_result(fn(*args, **kwargs))
        return f


def _key_maps(dec, ren):
    """Cells and pieces of ``dec`` as keys in the regions' numbering ``ren``."""
    cells = [(int(ren[c.region]), c.start_feature, c.end_feature) for c in dec.cells]
    pieces = [(tuple(sorted(int(ren[r]) for r in p.regions)), p.kind, p.features)
              for p in dec.pieces]
    return cells, pieces


def _graph_edges(dec, ren):
    """G's edges as a multiset of (cell key pair, piece key) in the numbering ``ren``."""
    g = build_graph(dec)
    cells, pieces = _key_maps(dec, ren)
    return collections.Counter(
        (tuple(sorted((cells[a], cells[b]))), pieces[p])
        for a, b, p in zip(g.edge_a.tolist(), g.edge_b.tolist(), g.edge_piece.tolist(),
                           strict=True))


def assert_equal_up_to_renumbering(a, b):
    """``b`` (tiled) equals ``a`` (untiled) up to renumbering: each region of ``a`` holds its
    representative point in a distinct region of ``b`` of the same area and structure; the
    cells, the pieces (regions, kind, features), G's edges and the eliminations (cell, round)
    are the same multisets in that numbering; the verdicts agree."""
    assert a.counts == b.counts
    j = b.region_at(np.array([r.point for r in a.regions]).reshape(-1, 2))
    assert sorted(j.tolist()) == list(range(len(b.regions))), "regions matched one to one"
    for r, k in zip(a.regions, j.tolist(), strict=True):
        assert b.regions[k].structure == r.structure
        assert b.regions[k].area == pytest.approx(r.area, rel=1e-9, abs=1e-12)
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))
    ident = np.arange(len(j))
    cells_a, pieces_a = _key_maps(a, ident)
    cells_b, pieces_b = _key_maps(b, inv)
    assert collections.Counter(cells_a) == collections.Counter(cells_b)
    assert collections.Counter(pieces_a) == collections.Counter(pieces_b)
    assert _graph_edges(a, ident) == _graph_edges(b, inv)
    va = analyze(a, self_check=False, near_critical=False)
    vb = analyze(b, self_check=False, near_critical=False)
    assert va.strategy_exists == vb.strategy_exists
    assert (sorted((cells_a[c], r) for c, r in zip(va.eliminated.cell.tolist(),
                                                   va.eliminated.round.tolist(), strict=True))
            == sorted((cells_b[c], r) for c, r in zip(vb.eliminated.cell.tolist(),
                                                      vb.eliminated.round.tolist(),
                                                      strict=True)))


def _tiled(env, lss, tiles):
    return decompose(env, lss, tiles=tiles, executor=_Serial())


# ---------------------------------------------------------------- equality on the maps
_SLOW = pytest.mark.slow


@pytest.mark.parametrize("name,tiles", [
    ("rectangle", (3, 3)), pytest.param("rectangle", (5, 4), marks=_SLOW),
    pytest.param("convex_corner", (3, 3), marks=_SLOW),
    pytest.param("convex_corner", (5, 4), marks=_SLOW),
    pytest.param("nonconvex_corner", (3, 3), marks=_SLOW),
    pytest.param("nonconvex_corner", (5, 4), marks=_SLOW),
    pytest.param("gallery", (3, 3), marks=_SLOW), pytest.param("gallery", (5, 4), marks=_SLOW)])
def test_bundled_examples_equal(name, tiles):
    env = load_example(name)
    lss = 0.3 * env.diameter if name != "gallery" else 1.0
    a = decompose(env, lss)
    b = _tiled(env, lss, tiles)
    assert_equal_up_to_renumbering(a, b)


@pytest.mark.slow
@pytest.mark.parametrize("env", [L_SHAPE, SQUARE_HOLE, STAR_HOLE, GENERIC],
                         ids=lambda e: e.name)
def test_test_maps_equal_and_checked(env):
    lss = 0.25 * env.diameter
    a = decompose(env, lss)
    b = _tiled(env, lss, (4, 3))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 5, 0, 10).ok


@pytest.mark.slow
@pytest.mark.parametrize("n,seed", [(40, 0), (60, 1), (100, 2)])
def test_floor_plans_equal_and_checked(n, seed):
    env = floor_plan(n, seed)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    a = decompose(env, lss)
    b = _tiled(env, lss, (5, 4))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@pytest.mark.slow
@given(env=random_maps(), frac=st.floats(0.05, 0.5), nx=st.integers(1, 6),
       ny=st.integers(1, 6))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_maps_equal(env, frac, nx, ny):
    lss = frac * env.diameter
    assert_equal_up_to_renumbering(decompose(env, lss), _tiled(env, lss, (nx, ny)))


@pytest.mark.parametrize("family", [pytest.param("corridor", marks=_SLOW), "pillars_lss",
                                    pytest.param("pillars_half", marks=_SLOW),
                                    pytest.param("steps", marks=_SLOW)])
def test_lattice_maps_equal(family):
    """Never in general position: walls ``lss`` and ``2 lss`` apart (straight critical curves
    on lattice lines, coinciding offsets), vertices aligned on common lines. A naive grid
    (cuts at the middle of the box) would pass through vertices and along walls and curves:
    the chosen cuts avoid every input coordinate."""
    lss = 0.5
    env = lm.env_of(lm.families(lss)[family], family)
    a = decompose(env, lss)
    b = _tiled(env, lss, (3, 3))
    assert_equal_up_to_renumbering(a, b)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_rasterized_lattice_maps_equal_and_checked(seed):
    rings = lm.rasterized(seed)
    if rings is None:
        pytest.skip("unusable shape for this seed")
    env = lm.env_of(rings)
    lss = 0.25
    a = decompose(env, lss)
    b = _tiled(env, lss, (5, 4))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@pytest.mark.slow
def test_user_frame_and_threads_equal():
    """A map in its own frame (not normalized) on a thread pool: equal, in the user's units."""
    env = load_example("gallery")
    a = decompose(env, 1.5)
    with ThreadPoolExecutor(2) as ex:
        b = decompose(env, 1.5, tiles="4x2", executor=ex)
    assert_equal_up_to_renumbering(a, b)


@pytest.mark.slow
def test_local_processes_default_executor():
    """``executor=None``: local processes (spawned), the same result as in this thread."""
    env = SQUARE_HOLE
    a = _tiled(env, 3.0, (3, 3))
    b = decompose(env, 3.0, tiles=(3, 3))
    assert_equal_up_to_renumbering(a, b)


@pytest.mark.slow
def test_dask_local_cluster_same_as_processes():
    """Many tiles on a Dask LocalCluster (in-process workers): the same counts and verdict
    as local processes."""
    distributed = pytest.importorskip("distributed")
    env = STAR_HOLE
    lss = 0.3 * env.diameter
    with distributed.LocalCluster(n_workers=2, processes=False, dashboard_address=None) as lc, \
            distributed.Client(lc) as client:
        b = decompose(env, lss, tiles=(5, 4), executor=client.get_executor())
    a = decompose(env, lss, tiles=(5, 4))
    assert a.counts == b.counts
    va, vb = analyze(a), analyze(b)
    assert va.strategy_exists == vb.strategy_exists and vb.verified
    assert va.counts() == vb.counts()
    assert_equal_up_to_renumbering(a, b)


def test_curve_vertex_limit_applies_to_the_whole_map(monkeypatch):
    """Only the noding is tiled: the curves are made whole, so a vertex limit the whole map
    exceeds refuses the tiled decomposition too (one line, before any tile starts)."""
    import tether.curves
    from tether.errors import ResourceLimitError

    env = load_example("gallery")
    whole = decompose(env, 1.0)
    total = sum(len(p) for c in whole.curves for p in c.polylines)
    monkeypatch.setattr(tether.curves, "MAX_CURVE_VERTICES", total // 3)
    with pytest.raises(ResourceLimitError):
        decompose(env, 1.0)
    with pytest.raises(ResourceLimitError):
        _tiled(env, 1.0, (2, 2))
    assert tether.curves.MAX_CURVE_VERTICES == total // 3


# ---------------------------------------------------------------- the cuts' exact rules
@pytest.mark.slow
def test_cuts_avoid_every_coordinate_of_lattice_inputs():
    """On lattice maps the cuts fall strictly between input coordinates, never on one (the
    middle of a symmetric map's gap is avoided too: mirror-image curves cross there)."""
    lss = 0.5
    for rings in lm.families(lss).values():
        env = lm.env_of(rings)
        xy = np.vstack([np.vstack(env.rings)] + [np.vstack(c.polylines) for c in
                                                 decompose(env, lss).curves])
        for n in (2, 3, 5):
            grid = tile_grid(xy, (n, n))
            for cuts, v in ((grid.xcuts, xy[:, 0]), (grid.ycuts, xy[:, 1])):
                assert not np.isin(cuts, v).any()
                u = np.unique(v)
                i = np.searchsorted(u, cuts)
                assert np.all(cuts != 0.5 * (u[i - 1] + u[i]))


@given(st.lists(st.integers(-50, 50), min_size=2, max_size=40), st.integers(1, 8))
@settings(max_examples=30, deadline=None)
def test_cut_positions_strictly_between_values(values, n):
    v = np.asarray(values, float) * 0.05  # lattice values, as doubles
    cuts = cut_positions(v, n)
    assert len(cuts) <= n - 1
    assert np.all(np.diff(cuts) > 0)
    assert not np.isin(cuts, v).any()
    assert np.all((cuts > v.min()) & (cuts < v.max()))


def _pieces(pxy, ptr):
    return [pxy[ptr[i]:ptr[i + 1]] for i in range(len(ptr) - 1)]


_COORD = st.floats(-10, 10).filter(lambda v: v == 0 or abs(v) > 1e-6)


@given(st.lists(st.tuples(_COORD, _COORD), min_size=2, max_size=12), st.integers(1, 5),
       st.integers(1, 5))
@settings(max_examples=30, deadline=None)
def test_clip_pieces_cover_the_line_within_their_tiles(coords, nx, ny):
    """The pieces of a line, end to end, are the line (its vertices plus the cut vertices, no
    other point moved), each piece in its tile's closed box, consecutive pieces sharing their
    end vertex bit for bit."""
    xy = np.asarray(coords, float)
    grid = tile_grid(xy, (nx, ny))
    pxy, ptr, tile = clip_to_tiles(xy, np.zeros(len(xy), np.int64), grid)
    pieces = _pieces(pxy, ptr)
    line = shapely.linestrings(xy)
    for p, t in zip(pieces, tile.tolist(), strict=True):
        assert len(p) >= 2
        i, j = divmod(t, grid.shape[1])
        xs = np.r_[-np.inf, grid.xcuts, np.inf]
        ys = np.r_[-np.inf, grid.ycuts, np.inf]
        assert np.all((p[:, 0] >= xs[i]) & (p[:, 0] <= xs[i + 1]))
        assert np.all((p[:, 1] >= ys[j]) & (p[:, 1] <= ys[j + 1]))
        assert np.all(shapely.distance(shapely.points(p), line) <= 1e-12 * (1 + np.abs(p).max()))
    for p, q in zip(pieces[:-1], pieces[1:], strict=True):
        assert np.array_equal(p[-1], q[0])
    # every input vertex kept (zero-length steps dropped)
    kept = np.vstack(pieces) if pieces else np.zeros((0, 2))
    for v in xy:
        assert (kept == v).all(axis=1).any() or len(pieces) == 0


def test_clip_reverse_and_crossing_lines_share_cut_vertices():
    """A segment and its reverse get the same cut vertex; two segments crossing each other
    on the cut meet at one vertex there (rounded apart, then made one)."""
    grid = TileGrid(np.array([0.1]), np.zeros(0))
    a = np.array([[-0.3, 0.7], [0.9, -0.2]])
    pxy, ptr, _ = clip_to_tiles(np.vstack((a, a[::-1])), np.array([0, 0, 1, 1]), grid)
    cut = pxy[pxy[:, 0] == 0.1]
    assert len(cut) == 4 and np.all(cut == cut[0])
    # two lines through one point of the cut, from different directions
    p = np.array([0.1, 1 / 3])
    d1, d2 = np.array([0.7, 0.3]), np.array([0.3, -0.9])
    xy = np.vstack((p - d1 / 3, p + d1 * 0.7, p - d2 * 0.37, p + d2 / 7))
    pxy, ptr, _ = clip_to_tiles(xy, np.array([0, 0, 1, 1]), grid)
    cut = pxy[pxy[:, 0] == 0.1]
    assert len(cut) == 4 and np.all(cut == cut[0])
    assert abs(cut[0, 1] - 1 / 3) < 1e-15


def test_clip_vertex_exactly_on_a_cut():
    """A vertex exactly on a cut (possible only on a grid made by hand: :func:`tile_grid`
    never cuts through a vertex) is itself the shared vertex: no zero-length piece."""
    grid = TileGrid(np.array([1.0]), np.array([1.0]))
    xy = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 1.5]])
    pxy, ptr, tile = clip_to_tiles(xy, np.zeros(3, np.int64), grid)
    pieces = _pieces(pxy, ptr)
    assert [p.tolist() for p in pieces] == [[[0.0, 0.0], [1.0, 1.0]], [[1.0, 1.0], [2.0, 1.5]]]
    assert tile.tolist() == [0, 3]


# ---------------------------------------------------------------- parameters
def test_check_tiles():
    assert check_tiles("auto") == "auto"
    assert check_tiles("3x2") == (3, 2)
    assert check_tiles((5, 4)) == (5, 4)
    for bad in ("3", "0x2", "ax2", (0, 1), (1.5, 2), (MAX_TILES, 2), "3x2x1", None):
        with pytest.raises(InvalidParameterError):
            check_tiles(bad)
    with pytest.raises(InvalidParameterError, match="tiles"):
        decompose(load_example("rectangle"), 1.0, tiles="9x9")


def test_auto_tiles():
    assert auto_tiles(1000, 10.0, 10.0) == (1, 1)
    nx, ny = auto_tiles(3_600_000, 20.0, 10.0)
    assert nx * ny >= 3_600_000 / 250_000 and nx > ny
    assert 1 <= np.prod(auto_tiles(10**9, 1.0, 1.0)) <= MAX_TILES


# ---------------------------------------------------------------- the command line
def test_cli_refuses_bad_tiles_in_one_line(capsys):
    from tether.cli import main
    from tether.examples import path as example_path

    room = str(example_path("rectangle"))
    assert main(["decompose", room, "--lss", "1", "--tiles", "9x9"]) == 2
    assert main(["analyze", room, "--lss", "1", "--workers", "2", "--dask", "x:1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "tiles" in err[0] and "--workers or --dask" in err[1]


@pytest.mark.slow
def test_cli_analyze_in_tiles_on_processes_same_verdict(capsys):
    import json

    from tether.cli import main
    from tether.examples import path as example_path

    gallery = str(example_path("gallery"))
    assert main(["analyze", gallery, "--lss", "1", "--json"]) == 0
    whole = json.loads(capsys.readouterr().out)
    assert main(["analyze", gallery, "--lss", "1", "--json", "--tiles", "3x2",
                 "--workers", "2"]) == 0
    tiled = json.loads(capsys.readouterr().out)
    assert tiled["verdict"] == whole["verdict"] and tiled["verified"]
    assert tiled["counts"] == whole["counts"]


def test_a_tile_the_noder_fails_on_means_the_whole_noded(monkeypatch):
    """GEOS's floating-point noder failing in one tile: the whole input is noded as without
    tiles (never snap rounding on one tile), and the result is the untiled one."""
    from shapely.errors import GEOSException

    import tether.decomposition.tiles as tiles_mod

    real = tiles_mod.node_floating
    calls = []

    def flaky(lines):
        calls.append(len(lines))
        if len(calls) == 2:
            raise GEOSException("TopologyException: found non-noded intersection")
        return real(lines)

    monkeypatch.setattr(tiles_mod, "node_floating", flaky)
    env = load_example("gallery")
    log = {}
    noder = tiles_mod.tiled_noder((2, 2), _Serial(), 1e-6 * env.internal.diameter, log=log)
    from tether.curves import critical_curves
    from tether.decomposition.arrangement import arrangement

    inner = env.internal
    lss = 1.0 * env.frame.scale
    curves = critical_curves(inner, lss)
    tol = 1e-6 * inner.diameter
    tiled = arrangement(inner, curves, tol, noder)
    assert log["fallback"] and log["tiles"] == (2, 2) and len(calls) == 4
    whole = arrangement(inner, curves, tol)
    assert len(tiled.parts) == len(whole.parts) and len(tiled.faces) == len(whole.faces)
    assert shapely.equals_exact(tiled.parts, whole.parts, 0).all()


@pytest.mark.parametrize("tiles", [pytest.param((3, 3), marks=_SLOW), (5, 4)])
def test_cut_vertices_dissolved_parts_as_whole(tiles):
    """The cut vertices no other line passes through are taken out: the tiled arrangement
    has the whole noding's parts and faces (on the gallery, whose intersections are not
    rounded differently on a segment's halves, the very same coordinates)."""
    from tether.curves import critical_curves
    from tether.decomposition.arrangement import arrangement
    from tether.decomposition.tiles import tiled_noder

    env = load_example("gallery")
    inner, lss = env.internal, 1.0 * env.frame.scale
    curves = critical_curves(inner, lss)
    tol = 1e-6 * inner.diameter
    whole = arrangement(inner, curves, tol)
    log = {}
    tiled = arrangement(inner, curves, tol, tiled_noder(tiles, _Serial(), tol, log=log))
    assert log["tiles"] == tiles and not log["fallback"]
    assert len(tiled.parts) == len(whole.parts) and len(tiled.faces) == len(whole.faces)
    a = {tuple(p) for p in shapely.get_coordinates(whole.parts).tolist()}
    b = {tuple(p) for p in shapely.get_coordinates(tiled.parts).tolist()}
    assert a == b
    assert sorted(shapely.area(tiled.faces).round(12).tolist()) == \
        sorted(shapely.area(whole.faces).round(12).tolist())
