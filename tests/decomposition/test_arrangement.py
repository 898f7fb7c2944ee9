"""The arrangement's segment arrays taken from coordinates already at hand (the input lines'
when building them, the parts' from their ends) against ``_ring_segments`` reading the
geometries again: the same arrays, bit for bit (signed zeros included)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from tether.curves import critical_curves
from tether.decomposition import arrangement as arrangement_mod
from tether.decomposition import faces
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def _same(got: tuple, want: tuple) -> bool:
    return all(g.dtype == w.dtype and np.array_equal(g, w)
               and np.array_equal(np.signbit(g), np.signbit(w))
               for g, w in zip(got, want, strict=True))


@pytest.fixture(scope="module")
def inputs():
    env = floor_plan(60, seed=3).internal
    lss = 0.1 * (env.bounds[2] - env.bounds[0])
    tol = REL_CURVE_TOL * env.diameter
    return env, critical_curves(env, lss, REL_CURVE_TOL), tol


def test_input_lines_segments_are_the_lines_segments(inputs):
    env, curves, _ = inputs
    lines, src, segs = arrangement_mod._input_lines(env, curves)
    assert len(lines) == len(src) and len(segs[0]) > 1000
    assert _same(segs, faces.ring_segments(lines))


def test_part_segments_are_the_parts_segments(inputs):
    env, curves, tol = inputs
    arr = arrangement_mod.arrangement(env, curves, tol)
    want = faces.ring_segments(arr.parts)
    assert _same(faces.part_segments(faces.part_ends(arr.parts)), want)
    assert _same(arr.segments()[:3], want)  # kept from the arrangement's own
    assert "part_segments" not in arr.memo  # handed over once


def test_part_segments_with_repeated_points():
    parts = np.array([shapely.linestrings([[0, 0], [0, 0], [1, -0.0], [2, 1]]),
                      shapely.linestrings([[5, 5], [6, 6]]),
                      shapely.linestrings([[-0.0, 1], [3, 3], [3, 3]])])
    assert _same(faces.part_segments(faces.part_ends(parts)), faces.ring_segments(parts))
