"""The curves' rod test (:func:`tether.curves.critical.rods_free`: candidate edges about
points along each rod) against the rod test over every (rod, edge) pair and against
:func:`tether.arcs.rod_is_free_many` (candidates about the rod's midpoint): the same booleans,
on rods made degenerate on purpose (through vertices, along walls, ending on edges, from
vertices) and random ones."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, SQUARE_HOLE, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tether.curves.critical as critical
from tether.arcs import rod_is_free_many, rod_is_free_rows
from tether.examples.floorplan import floor_plan


def degenerate_rods(env, lss, seed):
    """Targets and angles: from every vertex along and against its edges and toward other
    vertices; ending exactly on vertices and on edges' middles; along walls (on the edge's
    line); and random targets and angles over the map's box."""
    rng = np.random.default_rng(seed)
    V = env.vertices
    nxt = V[env.next_vertex]
    d = nxt - V
    along = np.arctan2(d[:, 1], d[:, 0])
    pts, ang = [V, V, V], [along, along + np.pi, along + np.pi / 2]
    # toward another vertex (the rod passes through it or ends beyond)
    j = rng.integers(0, len(V), len(V))
    to = V[j] - V
    pts.append(V)
    ang.append(np.arctan2(to[:, 1], to[:, 0]))
    # rods ending exactly on a vertex and on an edge's middle, from random directions
    for end in (V, 0.5 * (V + nxt)):
        a = rng.uniform(0, 2 * np.pi, len(V))
        pts.append(end - lss * np.column_stack((np.cos(a), np.sin(a))))
        ang.append(a)
    # on an edge's line, a little before its start, along it
    u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
    pts.append(V - 0.3 * lss * u)
    ang.append(along)
    lo, hi = V.min(axis=0), V.max(axis=0)
    pts.append(rng.uniform(lo, hi, (400, 2)))
    ang.append(rng.uniform(0, 2 * np.pi, 400))
    return np.vstack(pts), np.concatenate(ang)


def assert_same(env, lss, seed=0):
    inner = env.internal
    L = lss * env.frame.scale
    pts, ang = degenerate_rods(inner, L, seed)
    got = critical.rods_free(inner, pts, ang, L)
    edges = len(inner.oriented_edges[0])
    every = (np.repeat(np.arange(len(pts)), edges), np.tile(np.arange(edges), len(pts)))
    brute = rod_is_free_rows(inner, pts, ang, L, *every)
    assert np.array_equal(got, brute)
    assert np.array_equal(got, rod_is_free_many(inner, pts, ang, L))
    assert 0 < got.sum() < len(got)  # both answers occur


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (GENERIC, 6.0), (STAR_HOLE, 0.4)])
def test_test_maps(env, lss):
    assert_same(env, lss)


def test_floor_plan_and_splits(monkeypatch):
    env = floor_plan(60, seed=0)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    for splits in (1, 3, critical.ROD_SPLITS):
        monkeypatch.setattr(critical, "ROD_SPLITS", splits)
        assert_same(env, lss, seed=splits)


def test_batches_in_threads(monkeypatch):
    """Batches of a few rods (in threads): the booleans of one batch."""
    env = floor_plan(60, seed=1)
    inner = env.internal
    L = (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale
    pts, ang = degenerate_rods(inner, L, 3)
    whole = critical.rods_free(inner, pts, ang, L)
    monkeypatch.setattr(critical.arcs_free, "POINT_BATCH", 97)
    assert np.array_equal(critical.rods_free(inner, pts, ang, L), whole)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.3, 8.0), seed=st.integers(0, 10**6))
def test_random_maps(env, lss, seed):
    assert_same(env, lss, seed)
