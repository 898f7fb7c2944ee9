"""The breakpoint search near each curve against the search over every (curve, vertex) pair:
the critical intervals of every curve must be exactly equal."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, SQUARE_HOLE, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tether.curves.critical as critical
from tether import Environment
from tether.arcs import rod_is_free_many
from tether.curves import candidate_families
from tether.curves.critical import critical_intervals
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def all_pairs(env, fam):
    """Every curve against every vertex (the quadratic search)."""
    m = len(fam)
    return (np.repeat(np.arange(m), env.n).astype(np.int64),
            np.tile(np.arange(env.n), m).astype(np.int64))


def assert_same_intervals(env, lss, monkeypatch):
    inner = env.internal
    fams = list(candidate_families(inner, lss * env.frame.scale))
    near = [critical_intervals(inner, fam) for fam in fams]
    with monkeypatch.context() as mp:
        mp.setattr(critical, "_breakpoint_pairs", all_pairs)
        mp.setattr(critical, "_conchoid_vertex_pairs", all_pairs)
        every = [critical_intervals(inner, fam) for fam in fams]
    assert near == every
    assert_same_breakpoints(inner, fams, monkeypatch)


def sorted_breakpoints(env, fam):
    c, t = critical._breakpoints(env, fam)
    order = np.lexsort((t, c))
    return c[order], t[order]


def assert_same_breakpoints(inner, fams, monkeypatch):
    """The pair filters (edge boxes; the conchoids' vertex sectors) keep every breakpoint
    of the search over all pairs, each once: the same sets of (curve, parameter)."""
    near = [sorted_breakpoints(inner, fam) for fam in fams]
    with monkeypatch.context() as mp:
        mp.setattr(critical, "_breakpoint_pairs", all_pairs)
        mp.setattr(critical, "_conchoid_vertex_pairs", all_pairs)
        every = [sorted_breakpoints(inner, fam) for fam in fams]
    for fam, (c, t), (c2, t2) in zip(fams, near, every, strict=True):
        assert np.array_equal(c, c2) and np.array_equal(t, t2), fam.kind


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (GENERIC, 6.0), (STAR_HOLE, 0.4)])
def test_test_maps(env, lss, monkeypatch):
    assert_same_intervals(env, lss, monkeypatch)


def test_floor_plan(monkeypatch):
    env = floor_plan(60, seed=0)
    assert_same_intervals(env, (env.bounds[2] - env.bounds[0]) / 15, monkeypatch)


def test_sector_boxes_hold_the_sectors():
    """Every point of a conchoid's double sector (the directions from the pole to Q(t), t
    over the padded domain, radius 2 lss either way) lies in its box or the mirrored box."""
    env = floor_plan(120, seed=3)
    inner = env.internal
    fam = candidate_families(inner, (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale)[4]
    x0, y0, x1, y1 = critical._sector_boxes(fam, 1e-3)
    span = fam.hi - fam.lo
    frac = np.linspace(-1e-3, 1 + 1e-3, 101)
    t = fam.lo[:, None] + frac[None, :] * span[:, None]
    q = fam.w[:, None, :] + t[:, :, None] * fam.d[:, None, :] - fam.p[:, None, :]
    u = q / np.hypot(q[..., 0], q[..., 1])[..., None]
    for r in np.linspace(-2, 2, 21) * fam.lss:
        x, y = r * u[..., 0], r * u[..., 1]
        slack = 1e-12
        inside = ((x >= x0[:, None] - slack) & (x <= x1[:, None] + slack)
                  & (y >= y0[:, None] - slack) & (y <= y1[:, None] + slack))
        mirrored = ((-x >= x0[:, None] - slack) & (-x <= x1[:, None] + slack)
                    & (-y >= y0[:, None] - slack) & (-y <= y1[:, None] + slack))
        assert np.all(inside | mirrored)
    # and the boxes are tighter than the pole's box on most conchoids
    assert np.mean((x1 - x0) * (y1 - y0)) < 0.5 * (4 * fam.lss) ** 2


@pytest.mark.slow
@settings(max_examples=15, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(env=random_maps(), lss=st.floats(0.3, 8.0))
def test_random_maps(env, lss, monkeypatch):
    assert_same_intervals(env, lss, monkeypatch)


def merged(intervals, gap):
    """Intervals with the gaps narrower than ``gap`` closed."""
    out = []
    for a, b in intervals:
        if out and a - out[-1][1] < gap:
            out[-1] = (out[-1][0], b)
        else:
            out.append((a, b))
    return out


def assert_same_as_dense(env, lss):
    """Sampling at the exact breakpoints finds the critical intervals the former dense uniform
    sampling (96 samples per rod length of curve) finds. The ends are pinned by bisection
    from different brackets: they agree to ~1e-17 where freeness changes cleanly, and to the
    curve tolerance (REL_CURVE_TOL of the internal frame's unit diameter; every end is then
    overshot by 20 times that) where a rod lies along a wall at the end (a regular hexagon:
    the angular tolerances then leave slivers of 1e-13 rad that either search may hit)."""
    inner = env.internal
    tol = REL_CURVE_TOL
    for fam in candidate_families(inner, lss * env.frame.scale):
        sparse = critical_intervals(inner, fam)
        dense = critical_intervals(inner, fam, per_lss=96)
        for c, (a, b) in enumerate(zip(sparse, dense, strict=True)):
            a, b = merged(a, tol), merged(b, tol)
            assert len(a) == len(b), (fam.kind, fam.features[c], a, b)
            if a:
                assert np.allclose(a, b, rtol=0, atol=tol), (fam.kind, fam.features[c], a, b)


def test_breakpoint_sampling_regular_hexagon():
    """The hypothesis find: rods along the walls at the ends of the vertex circles."""
    t = np.pi / 3 * np.arange(1, 7)
    env = Environment(np.column_stack((3 * np.cos(t), 3 * np.sin(t))), (), "hexagon")
    for lss in (1.0, 2.5):
        assert_same_as_dense(env, lss)


@pytest.mark.slow
@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (GENERIC, 6.0), (STAR_HOLE, 0.4)])
def test_breakpoint_sampling_test_maps(env, lss):
    assert_same_as_dense(env, lss)


def test_breakpoint_sampling_floor_plan():
    env = floor_plan(60, seed=0)
    assert_same_as_dense(env, (env.bounds[2] - env.bounds[0]) / 15)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.3, 8.0))
def test_breakpoint_sampling_random_maps(env, lss):
    assert_same_as_dense(env, lss)


def no_boxes(fam, frac):
    """Boxes that hold every point: the pair filter of the conchoid crossings disabled."""
    big = np.full(len(fam), 1e150)  # an edge line always splits it (finite: no nan)
    return -big, -big, big, big


@pytest.mark.parametrize(("env", "lss"), [(GENERIC, 2.5), (STAR_HOLE, 1.5), (GENERIC, 6.0),
                                          (floor_plan(120, seed=3), 2.0)])
def test_conchoid_pair_filter_drops_no_crossing(env, lss, monkeypatch):
    """Dropping the (conchoid, edge) pairs whose edge line leaves the conchoid's grid box on one
    side finds the very same crossings as testing every pair on the grid."""
    inner = env.internal
    fam = candidate_families(inner, lss * env.frame.scale)[4]
    assert fam.kind == "E" and len(fam)
    cc, vk = critical._breakpoint_pairs(inner, fam)
    kept = critical._conchoid_edge_crossings(inner, fam, cc, vk)
    with monkeypatch.context() as mp:
        mp.setattr(critical, "_conchoid_grid_boxes", no_boxes)
        every = critical._conchoid_edge_crossings(inner, fam, cc, vk)
    assert len(every[0]) > 0
    assert np.array_equal(kept[0], every[0]) and np.array_equal(kept[1], every[1])


def test_insert_after_is_the_stable_sort():
    """Samples inserted after given sorted samples: the arrays the former stable sort of the
    concatenation gave (equal keys included: an inserted parameter may round to its
    neighbour's)."""
    rng = np.random.default_rng(2)
    c = np.sort(rng.integers(0, 40, 2000))
    t = np.round(rng.random(2000), 2)
    order = np.lexsort((t, c))
    c, t = c[order], t[order]
    at = np.flatnonzero((c[1:] == c[:-1]) & (rng.random(1999) < 0.5))
    frac = rng.choice([0.0, 0.3819660112501051, 1.0], len(at))
    t_new = t[at] + frac * (t[at + 1] - t[at])
    c2, t2 = critical.insert_after(c, t, at, t_new)
    cc, tt = np.concatenate((c, c[at])), np.concatenate((t, t_new))
    order = np.lexsort((tt, cc))
    assert np.array_equal(c2, cc[order]) and np.array_equal(t2, tt[order])


def test_equal_samples_tested_once():
    """The semi-free test of sorted samples with equal ones tested once answers as the test
    of every sample (the samples of a floor plan's curves: D has a fifth of them twice)."""
    env = floor_plan(120, seed=3)
    inner = env.internal
    fams = candidate_families(inner, (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale)
    rng = np.random.default_rng(4)
    repeated = 0
    for fam in fams:
        bc, bt = critical._breakpoints(inner, fam)
        c = np.concatenate((bc, rng.integers(0, len(fam), 50)))
        t = np.concatenate((bt, rng.uniform(fam.lo.min(), fam.hi.max(), 50)))
        keep = (t > fam.lo[c]) & (t < fam.hi[c])
        c, t = c[keep], t[keep]
        order = np.lexsort((t, c))
        c, t = c[order], t[order]
        repeated += int(np.sum((c[1:] == c[:-1]) & (t[1:] == t[:-1])))
        want = rod_is_free_many(inner, fam.points(c, t), fam.rod_angles(c, t),
                                           fam.lss)
        assert np.array_equal(critical._semi_free(inner, fam, c, t), want), fam.kind
    assert repeated > 0
