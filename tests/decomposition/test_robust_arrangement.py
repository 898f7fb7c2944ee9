"""Robust arrangement (issue 8): maps made to break noding, the snap-rounding fallback, GEOS
errors as one-line TetherErrors, and the self-check that ``analyze`` runs by default."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.errors import GEOSException

from tether import load_map
from tether.analysis import analyze
from tether.cli import main
from tether.cli.maps import format_verdict
from tether.decomposition import ArrangementError, check, decompose, self_check
from tether.environment import Environment
from tether.errors import TetherError
from tether.examples import path as example_path


def square(x: float, y: float, s: float) -> list[tuple[float, float]]:
    return [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]


def two_holes_on_a_line() -> Environment:
    """A 12-vertex box with two 0.1 m holes whose bottom edges lie on one line."""
    return Environment(square(0, 0, 3), (square(1.0, 1.0, 0.1), square(2.0, 1.0, 0.1)),
                       "two-holes")


def six_vertex() -> Environment:
    """A 6-vertex L-shaped room with one edge 0.5025 m long (just over lss 0.5)."""
    return Environment([(0, 0), (2, 0), (2, 1), (1.2, 1), (1.2, 1.5025), (0, 1.5025)], (),
                       "six")


def assert_sound(env: Environment, lss: float) -> None:
    """Decomposes without a GEOS error, and either checks clean or the self-check says so."""
    dec = decompose(env, lss)
    rep = check(dec, per_region=8)
    verdict = analyze(dec, near_critical=False)
    assert rep.ok or verdict.verified is False, rep.to_dict()


@pytest.mark.slow
@pytest.mark.parametrize("lss", [0.45, 0.5, 0.55])
def test_two_holes_with_bottoms_on_one_line(lss):
    assert_sound(two_holes_on_a_line(), lss)


def test_six_vertex_with_an_edge_just_over_lss():
    assert_sound(six_vertex(), 0.5)


@pytest.mark.slow
@pytest.mark.parametrize("lss", [0.5, 1.0])
def test_vertex_circles_through_vertices(lss):
    """Holes spaced exactly lss apart: every vertex circle passes through other vertices, and
    edge offsets of facing walls coincide."""
    holes = tuple(square(0.5 + lss * i, 0.5 + lss * j, 0.1 * lss) for i in range(3)
                  for j in range(2))
    assert_sound(Environment(square(0, 0, 4 * lss + 1.0), holes, "circles"), lss)


@pytest.mark.slow
def test_coincident_and_tangent_offsets():
    """Facing walls exactly 2 lss apart (their offsets coincide), a wall 1e-9 off that, and a
    hole whose corner circle is tangent to another hole's edge offset."""
    lss = 0.5
    holes = (square(1.0, 1.0, 0.5), [(1.0, 2.5), (1.5, 2.5), (1.5, 3.0), (1.0, 3.0)],
             [(2.5 + 1e-9, 1.0), (3.0, 1.0), (3.0, 1.5), (2.5 + 1e-9, 1.5)],
             square(1.5 + lss, 2.0 + 1e-12, 0.3))
    assert_sound(Environment(square(0, 0, 4.5), holes, "coincident"), lss)


@pytest.mark.slow
def test_nearly_collinear_walls():
    env = Environment([(0, 0), (2, 1e-10), (4, 0), (4, 3), (2, 3 - 1e-10), (0, 3)],
                      (square(1.0, 1.0, 0.4), square(2.6, 1.0, 0.4)), "collinear")
    assert_sound(env, 0.6)


@pytest.fixture
def failing_node(monkeypatch):
    """Make GEOS's floating-point noder fail as it does on real robot maps."""
    def fail(*args, **kwargs):
        raise GEOSException("TopologyException: Iterated noding failed to converge")

    monkeypatch.setattr(shapely, "node", fail)


@pytest.mark.slow
@pytest.mark.parametrize("name, lss", [("rectangle", 1.0), ("convex_corner", 1.0),
                                       ("nonconvex_corner", 1.0), ("gallery", 2.0)])
def test_snap_rounding_fallback_keeps_the_result(name, lss, failing_node):
    env = load_map(example_path(name))
    dec = decompose(env, lss)
    assert check(dec).ok
    verdict = analyze(dec, near_critical=False)
    assert verdict.verified
    assert len(dec.regions) > 1


@pytest.mark.slow
def test_snap_rounding_fallback_same_verdict(monkeypatch):
    env = two_holes_on_a_line()
    exact = analyze(decompose(env, 0.5), near_critical=False)

    def fail(*args, **kwargs):
        raise GEOSException("TopologyException: Iterated noding failed to converge")

    monkeypatch.setattr(shapely, "node", fail)
    snapped = analyze(decompose(env, 0.5), near_critical=False)
    assert snapped.verified
    assert snapped.strategy_exists == exact.strategy_exists


def test_geos_failure_is_one_line_tether_error(monkeypatch, capsys, tmp_path):
    def fail(*args, **kwargs):
        raise GEOSException("TopologyException: side location conflict at 1 2\nmore")

    monkeypatch.setattr(shapely, "point_on_surface", fail)  # every decomposition calls it
    env = load_map(example_path("rectangle"))
    with pytest.raises(ArrangementError) as info:
        decompose(env, 1.0)
    assert isinstance(info.value, TetherError)
    assert "\n" not in str(info.value)
    assert main(["decompose", str(example_path("rectangle")), "--lss", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tether: error: geometry engine failed")


@pytest.mark.slow
def test_analyze_self_check_passes_on_examples():
    verdict = analyze(decompose(load_map(example_path("gallery")), 2.0))
    assert verdict.verified is True
    assert verdict.self_check.samples > 0
    assert verdict.to_dict()["verified"] is True
    assert analyze(verdict.dec, self_check=False).verified is None


def test_self_check_failure_is_loud():
    dec = decompose(load_map(example_path("rectangle")), 1.0)
    # corrupt one region's structure: a region claiming another region's cells
    regions = list(dec.regions)
    a, b = next((r, s) for r in regions for s in regions if r.structure != s.structure)
    regions[a.id] = dataclasses.replace(a, _structure=b.structure)
    pieces = tuple(dataclasses.replace(p, verified=False) if k == 0 else p
                   for k, p in enumerate(dec.pieces))
    bad = dataclasses.replace(dec, regions=tuple(regions), pieces=pieces)
    rep = self_check(bad, regions=len(regions))
    assert not rep.ok and rep.piece_disagreements
    verdict = analyze(bad, near_critical=False)
    assert verdict.verified is False
    assert format_verdict(verdict).startswith("SELF-CHECK FAILED")


@st.composite
def random_maps(draw):
    """Boxes with up to 4 square holes on a coarse grid (so that edges align, curves
    coincide and circles pass through vertices), and an lss from a few round values."""
    cells = draw(st.lists(st.tuples(st.integers(1, 8), st.integers(1, 8)), min_size=1,
                          max_size=4, unique=True))
    size = draw(st.sampled_from([0.1, 0.2, 0.25]))
    holes = tuple(square(0.5 * i, 0.5 * j, size) for i, j in cells)
    lss = draw(st.sampled_from([0.25, 0.5, 0.75, 1.0]))
    return Environment(square(0, 0, 5), holes, "random"), lss


@pytest.mark.slow
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_maps())
def test_random_maps_never_raise_geos_errors(case):
    env, lss = case
    try:
        dec = decompose(env, lss)
    except ArrangementError:  # allowed: a one-line refusal
        return
    assert np.isfinite(sum(r.area for r in dec.regions))


def test_unverified_crossings_reach_the_users_verdict(monkeypatch):
    """Pieces whose crossings could not be verified while building (here: every one) make the
    self-check fail, through the conversion to the user's frame."""
    from tether.decomposition import pieces
    from tether.decomposition.structure import StructureRows

    real = pieces._arcs_across

    def garbage(env, lss, q, n, eps):  # the arcs as found, the structures unrecognizable
        table, sides = real(env, lss, q, n, eps)
        return table, StructureRows(np.full(2 * len(q), -1), np.zeros(2 * len(q) + 1, int),
                                       np.zeros(0, int))

    monkeypatch.setattr(pieces, "_arcs_across", garbage)
    verdict = analyze(decompose(load_map(example_path("rectangle")), 1.0))
    assert verdict.verified is False
    assert verdict.self_check.piece_disagreements


def test_memory_bound_refuses_in_one_line(monkeypatch, capsys):
    import tether.curves as C

    monkeypatch.setattr(C, "MAX_CURVE_VERTICES", 50)
    with pytest.raises(C.ResourceLimitError) as info:
        decompose(load_map(example_path("gallery")), 2.0)
    assert isinstance(info.value, TetherError) and "MAX_CURVE_VERTICES" in str(info.value)
    assert main(["analyze", str(example_path("gallery")), "--lss", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "polyline vertices" in err[0]


def test_batched_arc_and_rod_tests_equal_unbatched(monkeypatch):
    import tether.arcs as A

    env = load_map(example_path("gallery"))
    rng = np.random.default_rng(3)
    x0, y0, x1, y1 = env.bounds
    pts = rng.uniform([x0, y0], [x1, y1], (3000, 2))
    pts = pts[np.asarray(env.contains(pts[:, 0], pts[:, 1]), bool)
              & (np.asarray(env.boundary_distance(pts[:, 0], pts[:, 1])) > 0)]
    ang = rng.uniform(0, 2 * np.pi, len(pts))
    whole = A.free_arcs_many(env, pts, 2.0, check=False), A.rod_is_free_many(env, pts, ang, 2.0)
    monkeypatch.setattr(A.free, "POINT_BATCH", 97)
    batched = A.free_arcs_many(env, pts, 2.0, check=False), A.rod_is_free_many(env, pts, ang, 2.0)
    for f in ("point", "start", "end", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(whole[0], f), getattr(batched[0], f))
    assert np.array_equal(whole[1], batched[1])


def test_components_match_a_naive_union_find():
    from tether._util.arrays import components

    rng = np.random.default_rng(5)
    for _ in range(100):
        n = int(rng.integers(1, 40))
        u, v = rng.integers(0, n, (2, int(rng.integers(0, 50))))
        parent = list(range(n))

        def find(a, parent=parent):
            while parent[a] != a:
                a = parent[a]
            return a

        for a, b in zip(u.tolist(), v.tolist(), strict=True):
            parent[find(a)] = find(b)
        label = components(n, u, v)
        roots = [find(i) for i in range(n)]
        assert all((label[i] == label[j]) == (roots[i] == roots[j])
                   for i in range(n) for j in range(n))
