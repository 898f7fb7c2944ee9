"""The critical curves with their intervals made by tasks on an executor (issue 25,
:mod:`tether.curves.tasks`) are the curves made in one process, bit for bit: the same kinds,
features, intervals, polylines and parameters in the same order, with chunks of a few curves
(many tasks per family), on threads and on worker processes."""

from __future__ import annotations

from concurrent.futures import Executor, ThreadPoolExecutor

import numpy as np
import pytest
from conftest import GENERIC, STAR_HOLE, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tether.curves.tasks as tasks
from tether.curves import critical_curves
from tether.decomposition import decompose
from tether.decomposition.tiles import process_executor
from tether.examples import load
from tether.examples.floorplan import floor_plan

PLAN = floor_plan(60, seed=0)
PLAN_LSS = (PLAN.bounds[2] - PLAN.bounds[0]) / 15


class Counting(Executor):
    """An executor's wrapper counting the tasks submitted to it."""

    def __init__(self, inner: Executor):
        self.inner, self.count, self.fns = inner, 0, []

    def submit(self, fn, /, *args, **kwargs):
        self.count += 1
        self.fns.append(fn)
        return self.inner.submit(fn, *args, **kwargs)


def assert_same_curves(got, want):
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        assert (a.id, a.kind, a.features, a.domain, a.intervals, a.index) == \
            (b.id, b.kind, b.features, b.domain, b.intervals, b.index)
        assert len(a.polylines) == len(b.polylines)
        for p, q in zip(a.polylines + a.params, b.polylines + b.params, strict=True):
            assert p.dtype == q.dtype and np.array_equal(p, q)


def assert_same_by_tasks(env, lss, executor, monkeypatch, chunk=3):
    want = critical_curves(env, lss)
    monkeypatch.setattr(tasks, "CHUNK_CURVES", chunk)
    counting = Counting(executor)
    got = critical_curves(env, lss, executor=counting)
    assert_same_curves(got, want)
    assert counting.count >= len(want) / chunk  # a task per chunk, the curves' chunks among them
    return counting.count


@pytest.mark.parametrize("name", [pytest.param("convex_corner", marks=pytest.mark.slow),
                                  pytest.param("gallery", marks=pytest.mark.slow),
                                  "nonconvex_corner", "rectangle"])
def test_bundled_examples_on_threads(name, monkeypatch):
    env = load(name)
    lss = 0.2 * min(env.bounds[2] - env.bounds[0], env.bounds[3] - env.bounds[1])
    with ThreadPoolExecutor(2) as pool:
        assert assert_same_by_tasks(env, lss, pool, monkeypatch, chunk=1) >= 4


@pytest.mark.slow
def test_user_frame_and_internal_map_on_threads(monkeypatch):
    with ThreadPoolExecutor(2) as pool:
        assert assert_same_by_tasks(GENERIC, 2.5, pool, monkeypatch) > 10
        assert_same_by_tasks(STAR_HOLE.internal, 1.5 * STAR_HOLE.frame.scale, pool,
                             monkeypatch, chunk=1)


def test_no_curve_and_one_task_per_family(monkeypatch):
    env = load("rectangle")
    with ThreadPoolExecutor(1) as pool:  # a rod longer than the map: no critical part
        assert assert_same_by_tasks(env, 10 * env.diameter, pool, monkeypatch,
                                    chunk=10**6) <= 5


@pytest.mark.slow
def test_floor_plan_on_worker_processes(monkeypatch):
    pool = process_executor(2)
    try:
        count = assert_same_by_tasks(PLAN, PLAN_LSS, pool, monkeypatch, chunk=8)
    finally:
        pool.shutdown()
    assert count > 10


@pytest.mark.slow
@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(env=random_maps(), frac=st.floats(0.1, 0.6), chunk=st.integers(1, 7))
def test_random_maps_on_threads(env, frac, chunk, monkeypatch):
    x0, y0, x1, y1 = env.bounds
    with ThreadPoolExecutor(2) as pool:
        assert_same_by_tasks(env, frac * min(x1 - x0, y1 - y0), pool, monkeypatch, chunk)


def test_tiled_decompose_makes_the_intervals_on_its_executor():
    """The pipeline passes the tiles' executor to the curves (tether/decomposition/pipeline.py)."""
    env = load("rectangle")
    with ThreadPoolExecutor(2) as pool:
        counting = Counting(pool)
        decompose(env, 0.3 * env.diameter, tiles=(2, 2), executor=counting)
    assert counting.fns.count(tasks._chunk_intervals) == 2  # the offsets (A), the circles (B)
