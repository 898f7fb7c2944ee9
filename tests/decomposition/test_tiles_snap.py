"""Snap rounding in tiles (tether/decomposition/tiles.py, issue 25): where GEOS's
floating-point noder fails in a tile, every tile snap rounds the input on the grid the untiled
noder would use, and the parts are the untiled snap-rounded noding's bit for bit (coordinates,
direction, sources; in another order), so the decomposition (regions, cells, pieces, G,
verdict) is the untiled one up to renumbering. The floating-point noder is made to fail by
replacing ``shapely.node`` (both noders call it; the snap-rounding union does not), on the
bundled examples, floor plans, lattice maps with exactly coincident curves and random maps,
with forced small tiles; and a real input GEOS's floating-point noder fails on, pinned."""

from __future__ import annotations

import lattice_maps as lm
import numpy as np
import pytest
import shapely
from conftest import GENERIC, STAR_HOLE, SerialExecutor, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from renumbering import assert_equal_up_to_renumbering
from shapely.errors import GEOSException

from tether.curves import REL_CURVE_TOL, critical_curves
from tether.decomposition import check, decompose
from tether.decomposition.arrangement import arrangement
from tether.decomposition.noding import SNAP_GRIDS, node_lines, node_snapped
from tether.decomposition.tiles import tiled_noder
from tether.examples import load as load_example
from tether.examples.floorplan import floor_plan

_SLOW = pytest.mark.slow


def _fail(*args, **kwargs):
    raise GEOSException("TopologyException: Iterated noding failed to converge")


@pytest.fixture
def float_fails(monkeypatch):
    """GEOS's floating-point noder failing everywhere, as on some large robot maps."""
    monkeypatch.setattr(shapely, "node", _fail)


def _internal(env, lss):
    """The internal map and rod length of ``env`` at ``lss`` (user units)."""
    if env.is_internal:
        return env, lss
    return env.internal, lss * env.frame.scale


def _arrangements(env, lss, tiles):
    """The untiled and the tiled arrangements of ``env`` at ``lss`` (user units), and the
    tiled noder's log."""
    inner, ilss = _internal(env, lss)
    tol = REL_CURVE_TOL * inner.diameter
    curves = critical_curves(inner, ilss)
    log = {}
    tiled = arrangement(inner, curves, tol,
                        tiled_noder(tiles, SerialExecutor(), tol, log=log, arcs=(inner, ilss)))
    return arrangement(inner, curves, tol), tiled, log


def _wkb(parts):
    """The parts (linestrings) as sorted WKB: equal lists are the same parts bit for bit,
    direction included."""
    return sorted(shapely.to_wkb(np.asarray(parts, dtype=object)))


def assert_same_parts(whole, tiled):
    """The tiled arrangement's parts are the whole's, bit for bit, each with the same
    sources."""
    lines = tiled.parts.lines()
    assert _wkb(lines) == _wkb(whole.parts)
    src_w = dict(zip(shapely.to_wkb(whole.parts), whole.part_sources, strict=True))
    src_t = dict(zip(shapely.to_wkb(lines), tiled.part_sources, strict=True))
    assert src_w == src_t


def _both(env, lss, tiles):
    """The untiled and the tiled decompositions (floating-point noder failing: both snap
    rounded)."""
    return decompose(env, lss), decompose(env, lss, tiles=tiles, executor=SerialExecutor())


# ------------------------------------------------------------- what the union returns
def _coords(parts):
    return sorted(shapely.get_coordinates(p).round(9).tolist() for p in parts)


def test_snapped_parts_keep_line_ends_and_first_direction():
    """GEOS's snap-rounding union gives one part per edge: a ring's start and two lines
    meeting end to end stay nodes (as shapely.node), a duplicate keeps the first line's
    direction, and a vertex within a pixel of another line nodes both there."""
    ln = shapely.LineString
    ring = [ln([(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)])]
    assert _coords(node_snapped(np.array(ring), 0.01)) == _coords(ring)
    chain = [ln([(0, 0), (1, 0)]), ln([(1, 0), (2, 0.5)])]
    assert _coords(node_snapped(np.array(chain), 0.01)) == _coords(chain)
    dup = node_snapped(np.array([ln([(2, 0), (0, 0)]), ln([(0, 0), (2, 0)])]), 0.01)
    assert len(dup) == 1 and shapely.get_coordinates(dup[0]).tolist() == [[2, 0], [0, 0]]
    near = node_snapped(np.array([ln([(0, 0), (2, 0)]), ln([(1, 0.003), (1, 1)])]), 0.01)
    assert _coords(near) == [[[0, 0], [1, 0]], [[1, 0], [1, 1]], [[1, 0], [2, 0]]]


# ------------------------------------------------------------- the parts, bit for bit
def test_forced_failure_parts_bit_for_bit(float_fails):
    env = load_example("rectangle")
    whole, tiled, log = _arrangements(env, 0.3 * env.diameter, (3, 3))
    assert log["float_failed"] and not log["fallback"] and log["snap_grids_failed"] == 0
    assert whole.grid == tiled.grid == log["grid"] > 0 and log["retries"] > 0
    assert log["margin"] >= 8 * log["grid"]
    assert_same_parts(whole, tiled)
    assert len(tiled.faces) == len(whole.faces)


@_SLOW
@pytest.mark.parametrize("name,tiles", [("convex_corner", (5, 4)), ("nonconvex_corner", (4, 4)),
                                        ("gallery", (5, 4))])
def test_forced_failure_parts_on_examples(name, tiles, float_fails):
    env = load_example(name)
    whole, tiled, _ = _arrangements(env, 0.3 * env.diameter if name != "gallery" else 1.0,
                                    tiles)
    assert_same_parts(whole, tiled)


@_SLOW
@given(env=random_maps(), frac=st.floats(0.05, 0.5), nx=st.integers(1, 6),
       ny=st.integers(1, 6))
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_forced_failure_parts_on_random_maps(env, frac, nx, ny):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shapely, "node", _fail)
        whole, tiled, _ = _arrangements(env, frac * env.diameter, (nx, ny))
    assert_same_parts(whole, tiled)


def test_coarser_grid_for_all_tiles_when_one_fails(float_fails, monkeypatch):
    """Snap rounding failing in one task on the finest grid: every tile is rounded again on
    the next grid (never two grids in one result), as the whole is rounded when its finest
    grid fails."""
    import tether.decomposition.tiles as tiles_mod

    calls = []

    def flaky(lines, grid):
        calls.append(grid)
        if len(calls) == 2:
            raise GEOSException("TopologyException: side location conflict")
        return node_snapped(lines, grid)

    monkeypatch.setattr(tiles_mod, "node_snapped", flaky)
    env = load_example("rectangle")
    whole, tiled, log = _arrangements(env, 0.3 * env.diameter, (2, 2))
    tol = REL_CURVE_TOL * env.internal.diameter
    assert log["snap_grids_failed"] == 1 and tiled.grid == pytest.approx(SNAP_GRIDS[1] * tol)
    # the four tasks of the first round (this executor runs each as it is submitted), then
    # all on the next grid
    assert set(calls[:4]) == {SNAP_GRIDS[0] * tol} and set(calls[4:]) == {tiled.grid}
    assert whole.grid == pytest.approx(SNAP_GRIDS[0] * tol)  # the whole's finest did not fail


def test_every_grid_failing_is_one_arrangement_error(float_fails, monkeypatch):
    import tether.decomposition.tiles as tiles_mod
    from tether.errors import ArrangementError

    monkeypatch.setattr(tiles_mod, "node_snapped", lambda lines, grid: _fail())
    env = load_example("rectangle")
    with pytest.raises(ArrangementError, match="could not be noded in tiles") as info:
        _arrangements(env, 0.3 * env.diameter, (2, 2))
    assert "\n" not in str(info.value)


# ------------------------------------------------------------- the decomposition
@_SLOW
@pytest.mark.parametrize("name,tiles", [("rectangle", (3, 3)), ("convex_corner", (5, 4)),
                                        ("nonconvex_corner", (3, 3)), ("gallery", (5, 4))])
def test_bundled_examples_equal(name, tiles, float_fails):
    env = load_example(name)
    a, b = _both(env, 0.3 * env.diameter if name != "gallery" else 1.0, tiles)
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@_SLOW
@pytest.mark.parametrize("env", [STAR_HOLE, GENERIC], ids=lambda e: e.name)
def test_test_maps_equal_and_checked(env, float_fails):
    a, b = _both(env, 0.25 * env.diameter, (4, 3))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@_SLOW
@pytest.mark.parametrize("n,seed", [(40, 0), (100, 2)])
def test_floor_plans_equal_and_checked(n, seed, float_fails):
    env = floor_plan(n, seed)
    a, b = _both(env, (env.bounds[2] - env.bounds[0]) / 15, (5, 4))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@_SLOW
@pytest.mark.parametrize("family", ["corridor", "pillars_lss", "pillars_half", "steps"])
def test_lattice_maps_equal(family, float_fails):
    """Walls exactly ``lss`` and ``2 lss`` apart: exactly coincident curves, snapped alike."""
    lss = 0.5
    env = lm.env_of(lm.families(lss)[family], family)
    a, b = _both(env, lss, (3, 3))
    assert_equal_up_to_renumbering(a, b)
    assert check(b, 3, 0, 10).ok


@_SLOW
@given(env=random_maps(), frac=st.floats(0.05, 0.5), nx=st.integers(1, 5),
       ny=st.integers(1, 5))
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_maps_equal(env, frac, nx, ny):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shapely, "node", _fail)
        a, b = _both(env, frac * env.diameter, (nx, ny))
    assert_equal_up_to_renumbering(a, b)


# ------------------------------------------------------------- a real failure, pinned
_OFF = 3.2e6  # map units: far from the origin, a unit in the last place is ~5e-10


def near_coincident_lines(seed: int, centers: list[tuple[float, float]], n: int = 21,
                          spread: float = 6e-10) -> np.ndarray:
    """Bundles of ``n`` nearly coincident polylines (directions and positions within
    ``spread``, about a unit in the last place here) around ``centers`` (offsets from
    ``(_OFF, 1.3 _OFF)``), crossed by a lattice of straight lines: GEOS's floating-point
    noder fails on them ("Iterated noding failed to converge")."""
    rng = np.random.default_rng(seed)
    pts = []
    for cx, cy in centers:
        for _ in range(n):
            t = 0.37 + rng.normal(0, spread)
            c = np.array([_OFF + cx, 1.3 * _OFF + cy]) + rng.normal(0, spread, 2)
            s = np.sort(rng.uniform(-1, 1, int(rng.integers(2, 8))))
            pts.append(c + s[:, None] * np.array([np.cos(t), np.sin(t)])
                       + rng.normal(0, 0.1 * spread, (len(s), 2)))
    for k in np.linspace(-1.3, 4.3, 4):
        pts.append(np.array([[_OFF + k, 1.3 * _OFF - 1.5], [_OFF + k, 1.3 * _OFF + 4.5]]))
        pts.append(np.array([[_OFF - 1.5, 1.3 * _OFF + k], [_OFF + 4.5, 1.3 * _OFF + k]]))
    return np.asarray([shapely.LineString(p) for p in pts], dtype=object)


@_SLOW
@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_real_float_failure_snap_rounded_in_tiles(executor):
    """No replaced noder: GEOS's floating-point noder really fails on the whole and in
    tiles; the tiles snap round on the whole's grid and deliver its parts bit for bit, on
    this thread or on spawned worker processes."""
    from tether.decomposition.tiles import process_executor

    lines = near_coincident_lines(0, [(0, 0), (3, 3)], 12)
    with pytest.raises(GEOSException, match="noding"):
        shapely.node(shapely.multilinestrings(lines))
    tol = 1e-6
    whole, grid = node_lines(lines, tol)
    assert grid == SNAP_GRIDS[0] * tol
    xy, idx = shapely.get_coordinates(lines, return_index=True)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    ex = SerialExecutor() if executor == "serial" else process_executor(2)
    try:
        log = {}
        got = tiled_noder((3, 3), ex, tol, log=log)(lines, np.arange(len(lines)),
                                                    (xy[k], xy[k + 1], idx[k]))
    finally:
        ex.shutdown()
    assert log["float_failed"] and got[4] == grid and log["retries"] > 0
    assert _wkb(got[0].lines()) == _wkb(whole)


#: Five pieces of curves of the 4,000-vertex floor plan (``floor_plan(4000, 0)``, lss = width /
#: 15, internal frame) within 1e-6 of (-0.280469, -0.105263), where GEOS's floating-point noder
#: failed in noding tiles ("Iterated noding failed to converge"): polylines nearly tangent
#: at one point (their middle vertices share a y exactly and differ in x by about 1e-11),
#: clipped to a 2e-6 box and reduced to a set that still fails (as hexadecimal floats).
_PLAN_4000_KNOT = [
    [("-0x1.1f3300de4c512p-2", "-0x1.af281399b48fdp-4"),
     ("-0x1.1f333332d9dd8p-2", "-0x1.af281397e0af7p-4"),
     ("-0x1.1f3387160956cp-2", "-0x1.af28139aec7c7p-4")],
    [("-0x1.1f3300de4c512p-2", "-0x1.af28139aa84aap-4"),
     ("-0x1.1f333332e3b84p-2", "-0x1.af281397e0af7p-4"),
     ("-0x1.1f3387160956cp-2", "-0x1.af28139c82b60p-4")],
    [("-0x1.1f3300de4c512p-2", "-0x1.af28139c5adf3p-4"),
     ("-0x1.1f333332f855fp-2", "-0x1.af281397e0af7p-4"),
     ("-0x1.1f3387160956cp-2", "-0x1.af28139f57027p-4")],
    [("-0x1.1f3300de4c512p-2", "-0x1.af2813a17764fp-4"),
     ("-0x1.1f3333330ada5p-2", "-0x1.af281397e0af7p-4"),
     ("-0x1.1f3387160956cp-2", "-0x1.af2813a7dbe31p-4")],
    [("-0x1.1f3300de4c512p-2", "-0x1.af2813d4629c9p-4"),
     ("-0x1.1f3333331f780p-2", "-0x1.af281397e0af7p-4"),
     ("-0x1.1f3387160956cp-2", "-0x1.af2813fcb95a8p-4")],
]


def test_real_floor_plan_knot_snap_rounded_in_tiles():
    """The noding failure found in the 4,000-vertex plan, pinned: GEOS's floating-point
    noder fails on it; tiles cutting through the knot snap round it on the whole's grid and
    deliver the whole's parts bit for bit."""
    lines = np.asarray([shapely.LineString([(float.fromhex(x), float.fromhex(y))
                                            for x, y in pts]) for pts in _PLAN_4000_KNOT],
                       dtype=object)
    with pytest.raises(GEOSException, match="noding"):
        shapely.node(shapely.multilinestrings(lines))
    tol = 8.643675998417859e-07  # the plan's curve tolerance (internal units)
    whole, grid = node_lines(lines, tol)
    assert grid == SNAP_GRIDS[0] * tol
    xy, idx = shapely.get_coordinates(lines, return_index=True)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    for tiles in [(2, 2), (3, 1)]:
        log = {}
        got = tiled_noder(tiles, SerialExecutor(), tol, log=log)(lines, np.arange(len(lines)),
                                                          (xy[k], xy[k + 1], idx[k]))
        assert log["float_failed"] and got[4] == grid
        assert _wkb(got[0].lines()) == _wkb(whole)


# ------------------------------------------------------------- auto tiles when snap rounding
def test_auto_snap_tiles_aim_at_snap_tile_segments(monkeypatch):
    """With ``noding="snap"`` and ``"auto"``, the grid aims at ``SNAP_TILE_SEGMENTS`` input
    segments a tile (smaller than ``TILE_SEGMENTS``: GEOS's hot-pixel index costs less a
    segment in a smaller tile), and the parts are still the untiled snap rounding's, bit for
    bit, with the same sources."""
    import tether.decomposition.tiles as tiles_mod
    monkeypatch.setattr(tiles_mod, "SNAP_TILE_SEGMENTS", 400)
    env = load_example("rectangle")
    inner, ilss = _internal(env, 0.3 * env.diameter)
    tol = REL_CURVE_TOL * inner.diameter
    curves = critical_curves(inner, ilss)
    log = {}
    tiled = arrangement(inner, curves, tol,
                        tiled_noder("auto", SerialExecutor(), tol, log=log, arcs=(inner, ilss),
                                    noding="snap"), "snap")
    whole = arrangement(inner, curves, tol, noding="snap")
    nx, ny = log["tiles"]
    assert nx * ny > 1 and not log["float_failed"] and log["grid"] == whole.grid > 0
    assert_same_parts(whole, tiled)
