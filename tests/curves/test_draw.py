"""The vectorized overshoot and polylines of the critical curves (all curves of a family at
once) against the scalar one-interval-at-a-time functions they replace: the very same numbers;
and the vertex estimates likewise."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.curves import candidate_families
from tether.curves.critical import critical_intervals
from tether.curves.draw import (
    _norms,
    _overshoot,
    _polyline,
    _vertex_estimate,
    draw_all,
    overshoot_family,
    vertex_estimates,
)
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def assert_same_as_scalar(env, lss):
    inner = env.internal
    tol = REL_CURVE_TOL * inner.diameter
    margin = 20 * tol
    for fam in candidate_families(inner, lss * env.frame.scale):
        intervals = critical_intervals(inner, fam)
        found = overshoot_family(fam, intervals, margin)
        expect = [(c, [_overshoot(fam, c, iv, margin) for iv in ivs])
                  for c, ivs in enumerate(intervals) if ivs]
        assert [(c, ivs) for _, c, ivs in found] == expect
        for (_, c, ivs), drawn in zip(found, draw_all(found, tol), strict=True):
            for (lo, hi), (ts, pts) in zip(ivs, drawn, strict=True):
                ts0, pts0 = _polyline(fam, c, lo, hi, tol)
                assert np.array_equal(ts, ts0) and np.array_equal(pts, pts0), (fam.kind, c)


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (GENERIC, 6.0), (L_SHAPE, 3.0)])
def test_test_maps(env, lss):
    assert_same_as_scalar(env, lss)


def test_floor_plan():
    env = floor_plan(60, seed=0)
    assert_same_as_scalar(env, (env.bounds[2] - env.bounds[0]) / 15)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.3, 8.0))
def test_random_maps(env, lss):
    assert_same_as_scalar(env, lss)


def test_row_norms_are_the_scalar_norms_bit_for_bit():
    rng = np.random.default_rng(5)
    v = rng.normal(size=(20_000, 2)) * rng.uniform(1e-6, 1e6, size=(20_000, 1))
    assert np.array_equal(_norms(v), np.array([np.linalg.norm(x) for x in v]))


@pytest.mark.parametrize(("env", "lss"), [(GENERIC, 2.5), (STAR_HOLE, 1.5), (L_SHAPE, 3.0),
                                          (floor_plan(150, seed=2), 1.2)])
def test_vertex_estimates_equal_the_scalar_ones(env, lss):
    inner = env.internal
    tol = REL_CURVE_TOL * inner.diameter
    found = []
    for fam in candidate_families(inner, lss * env.frame.scale):
        found += overshoot_family(fam, critical_intervals(inner, fam), 20 * tol)
    assert vertex_estimates(found, tol) == [_vertex_estimate(f, c, ivs, tol)
                                             for f, c, ivs in found]
