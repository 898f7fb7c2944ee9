"""Line of sight, geodesic distances and the reachable set, against independent checks: the
segment test against the visibility polygon, distances against networkx on a visibility graph
built with shapely, and random walks at speed vt that must never leave the set."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from conftest import GENERIC, SQUARE_HOLE, STAR_HOLE, interior_points
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString

from tether.follow import Follower
from tether.follow.reachable import Geodesics, ReachGrid, clear_segments, visible_from


@pytest.mark.parametrize("env", [GENERIC, STAR_HOLE, SQUARE_HOLE], ids=lambda e: e.name)
def test_visibility_polygon_agrees_with_the_segment_test(env):
    pts = interior_points(env, 400, seed=3)
    sources = np.vstack((pts[:10], env.vertices[env.reflex_indices]))
    for s in sources:
        assert np.array_equal(visible_from(env, s, pts), clear_segments(env, s, pts))


def test_segment_test_agrees_with_shapely():
    env = GENERIC
    pts = interior_points(env, 60, seed=5)
    poly = env.polygon.buffer(1e-9)
    i, j = np.triu_indices(len(pts), 1)
    mine = clear_segments(env, pts[i], pts[j])
    theirs = np.array([poly.covers(LineString([pts[a], pts[b]]))
                       for a, b in zip(i, j, strict=True)])
    assert np.array_equal(mine, theirs)


def _networkx_distance(env, p, q):
    """Shortest path p -> q on the visibility graph of p, q and every vertex (shapely's
    ``covers`` for the edges): the textbook construction, independent of tether.follow."""
    poly = env.polygon.buffer(1e-9)
    nodes = [tuple(p), tuple(q)] + [tuple(v) for v in env.vertices]
    g = nx.Graph()
    for a in range(len(nodes)):
        for b in range(a + 1, len(nodes)):
            if poly.covers(LineString([nodes[a], nodes[b]])):
                g.add_edge(a, b, weight=math.dist(nodes[a], nodes[b]))
    return nx.shortest_path_length(g, 0, 1, weight="weight")


@pytest.mark.parametrize("env", [GENERIC, STAR_HOLE], ids=lambda e: e.name)
def test_geodesic_distance_matches_networkx(env):
    geo = Geodesics(env, ReachGrid(env, env.diameter / 20))
    pts = interior_points(env, 7, seed=11)
    for s in pts[:2]:
        mine = geo.distance(s, pts[2:])
        theirs = [_networkx_distance(env, s, q) for q in pts[2:]]
        assert mine == pytest.approx(theirs, rel=1e-9, abs=1e-9)


def test_field_is_the_distance_at_the_cell_centres():
    geo = Geodesics(GENERIC, ReachGrid(GENERIC, 0.4))
    s = interior_points(GENERIC, 1, seed=2)[0]
    assert geo.field(s) == pytest.approx(geo.distance(s, geo.grid.centers), rel=1e-12)


def _random_walk(env, start, vt, dt, steps, rng):
    """A walker at speed <= vt that turns at random and never crosses a wall."""
    p = np.array(start, dtype=float)
    out = [p]
    heading = rng.uniform(0, 2 * math.pi)
    for _ in range(steps):
        for _try in range(20):
            heading += rng.normal(0, 0.8)
            q = p + vt * dt * rng.uniform(0.5, 1.0) * np.array([math.cos(heading),
                                                                 math.sin(heading)])
            if env.contains(q[0], q[1]) and clear_segments(env, p, q[None, :])[0]:
                p = q
                break
        out.append(p)
    return np.array(out)


@pytest.mark.slow
@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_random_walks_never_leave_the_reachable_set(seed):
    rng = np.random.default_rng(seed)
    env = GENERIC
    f = Follower(env, lss=0.8, vt=0.4, vo=1.0, cell=0.4)
    start = interior_points(env, 1, seed=seed)[0]
    f.update(0.0, start, observer=start)
    dt = 0.25
    walk = _random_walk(env, start, 0.4, dt, 40, rng)
    d = f.reach_distance(walk)
    assert np.all(d <= 0.4 * dt * np.arange(len(walk)) + 1e-9)


def test_reachable_cells_are_within_reach_and_grow(corridor):
    f = Follower(corridor, lss=1.0, vt=0.5, vo=1.0, cell=0.2)
    f.update(0.0, (1.0, 0.5), observer=(2.0, 0.5))
    few, more = f.reachable(1.0), f.reachable(4.0)
    assert 0 < len(few) < len(more)
    d = f.reach_distance(more)
    assert np.all(d <= 0.5 * 4.0 + f.r0 + 1e-9)
    # every free centre within reach is in (the set is not a subset of something smaller)
    inside = f.grid.centers[f.reach_distance(f.grid.centers) <= 0.5 * 4.0 + f.r0]
    assert len(inside) == len(more)


def test_no_sighting_no_set(corridor):
    f = Follower(corridor, lss=1.0, vt=0.5, vo=1.0, cell=0.5)
    assert f.reachable().shape == (0, 2) and f.possible_cells().shape == (0, 2)
