"""The uniform-grid edge index against brute force: every edge within the reach of a point is
among the point's candidates, and each candidate appears once."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.examples.floorplan import floor_plan
from tether.spatial import EdgeIndex


def distances(p, a, b):
    """Brute-force point-segment distances, (m points) x (n segments)."""
    d = b - a
    rel = p[:, None, :] - a[None, :, :]
    t = np.clip((rel * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-300), 0.0, 1.0)
    return np.hypot(*np.moveaxis(rel - t[..., None] * d, -1, 0))


def assert_complete(env, reach, seed):
    a, b, _, _ = env.oriented_edges
    x0, y0, x1, y1 = env.bounds
    rng = np.random.default_rng(seed)
    pts = rng.uniform((x0 - reach, y0 - reach), (x1 + reach, y1 + reach), size=(400, 2))
    pi, ei = EdgeIndex.build(a, b, reach).query(pts)
    got = set(zip(pi.tolist(), ei.tolist(), strict=True))
    assert len(got) == len(pi)  # no pair twice
    want = np.argwhere(distances(pts, a, b) <= reach)
    assert {(int(i), int(j)) for i, j in want} <= got
    assert np.all(np.diff(pi) >= 0)  # grouped by point, increasing


@pytest.mark.parametrize("reach", [0.3, 2.0, 9.0])
def test_floor_plan(reach):
    assert_complete(floor_plan(150, seed=4), reach, 0)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), reach=st.floats(0.05, 6.0), seed=st.integers(0, 99))
def test_random_maps(env, reach, seed):
    assert_complete(env, reach, seed)
