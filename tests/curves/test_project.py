"""The projection of points onto conchoids with the block-pruned nearest-segment search against
the search over every segment, and the nearest pick per row it relies on."""

from __future__ import annotations

import numpy as np
import pytest

import tether.curves.project as P
from tether._util.arrays import first_nearest, ragged_arange
from tether.curves import critical_curves
from tether.examples.floorplan import floor_plan


@pytest.mark.slow
def test_pruned_conchoid_projection_equals_the_full_search(monkeypatch):
    """Projections on conchoids with the block-pruned nearest-segment search equal those with
    every segment of the curve (points on the polylines, at their vertices, and anywhere)."""
    env = floor_plan(100, seed=0)
    inner = env.internal
    curves = critical_curves(inner, (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale)
    conchoids = [c.id for c in curves if c.kind == "E"]
    rng = np.random.default_rng(0)
    cid = rng.choice(conchoids, 3000)
    pts = []
    for k in cid[:2000]:
        p = curves[k].polylines[0]
        i = rng.integers(0, len(p) - 1)
        w = rng.choice([0.0, 0.5, rng.random()])
        pts.append(p[i] + w * (p[i + 1] - p[i]))
    x0, y0, x1, y1 = inner.bounds
    q = np.vstack((pts, rng.uniform([x0, y0], [x1, y1], (1000, 2))))
    pruned = P._project_conchoids(curves, cid, q)

    def every_segment(a, b, sc, ncurves, inv, q):
        count = np.bincount(sc, minlength=ncurves)
        first = np.cumsum(count) - count
        return (np.repeat(np.arange(len(inv)), count[inv]),
                ragged_arange(first[inv], count[inv]))

    monkeypatch.setattr(P, "_near_segment_pairs", every_segment)
    full = P._project_conchoids(curves, cid, q)
    for x, y in zip(pruned, full, strict=True):
        assert np.array_equal(x, y)


def test_first_nearest_is_the_stable_sort_pick():
    """The nearest segment per row by a minimum per row picks what a stable sort by (row,
    distance) picks: the first of equal distances (ties are common: shared vertices)."""
    rng = np.random.default_rng(8)
    row = np.sort(rng.integers(0, 300, 3000))
    row = np.searchsorted(np.unique(row), row)  # every row present
    dist = rng.choice([0.0, 0.5, 1.0, 2.0], len(row)) + rng.choice([0.0, 1e-17], len(row))
    for d in (dist, np.where(rng.random(len(row)) < 0.01, np.nan, dist)):
        order = np.lexsort((d, row))
        want = order[np.r_[True, row[order][1:] != row[order][:-1]]]
        assert np.array_equal(first_nearest(row, d), want)
