"""The first field of :mod:`tether.game.directions`: its singularities obey Poincaré–Hopf
(the index sum is the Euler characteristic ``1 − holes`` of the free space, counted from the
map's geometry), the index of a triangle is that of known analytic fields, the harmonic solve
commutes with rotations and mirrors of the directions, and the clamp into a run agrees with
brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tether import Environment
from tether.game.certificate import FULL, lifted_ends
from tether.game.directions import (
    _clamp,
    direction_field,
    harmonic_directions,
    singularities,
)
from tether.game.kernel import surveillance_kernel


def _grid_mesh(n: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """A triangulated square [−1, 1]² of n × n points."""
    t = np.linspace(-1, 1, n)
    x, y = np.meshgrid(t, t)
    pts = np.column_stack([x.ravel(), y.ravel()])
    tri = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            tri += [(a, b, d), (a, d, c)]
    return pts, np.array(tri)


@pytest.mark.parametrize(("field", "index"), [(lambda p: p[:, 0] + 1j * p[:, 1], 1),
                                              (lambda p: p[:, 0] - 1j * p[:, 1], -1),
                                              (lambda p: (p[:, 0] + 1j * p[:, 1]) ** 2, 2),
                                              (lambda p: np.ones(len(p)) + 0j, 0)])
def test_the_index_of_analytic_fields(field, index):
    pts, tri = _grid_mesh()
    z = field(pts - [0.13, 0.07])  # the zero inside a triangle, off every edge
    idx = singularities(z, tri)
    assert idx.sum() == index
    assert (np.abs(idx) <= 1).all()  # a triangle holds one turn at most: a double zero
    hot = np.flatnonzero(idx)  # shows as two triangles next to it
    assert len(hot) == abs(index)
    cen = pts[tri[hot]].mean(axis=1)
    assert (np.hypot(*(cen - [0.13, 0.07]).T) < 0.25).all()  # one edge length


def _room(holes):
    return Environment([(0, 0), (8, 0), (8, 6), (0, 6)],
                       tuple(np.array(h, float) for h in holes), "room")


@pytest.mark.slow
@pytest.mark.parametrize("holes", [[], [[(3, 2), (5, 2), (5, 4), (3, 4)]],
                                   [[(2, 2), (3, 2), (3, 4), (2, 4)],
                                    [(5, 2), (6, 2), (6, 4), (5, 4)]]])
def test_the_index_sum_is_the_euler_characteristic(holes):
    env = _room(holes)
    kern = surveillance_kernel(env, 0.5, 0.3, 1.0, h=0.25, orientations=180)
    f, z = direction_field(kern)
    chi = 1 - len(env.polygon.interiors)  # from the geometry, not from the field
    assert singularities(z, f.tri).sum() == chi
    # the arcs' gap centres wind the same way (the lift of the certificate)
    c = f.lo - (math.tau - f.w) / 2
    a = c[f.tri]
    turn = sum(np.mod(a[:, (k + 1) % 3] - a[:, k] + math.pi, math.tau) - math.pi
               for k in range(3))
    assert round(turn.sum() / math.tau) == chi
    # every singularity of the gap lies where the arcs are whole circles
    _, _, winds = lifted_ends(f.lo, f.w, f.tri)
    assert (f.w[f.tri[winds]] >= FULL).all()


@settings(max_examples=8, deadline=None)
@given(phi=st.floats(-math.pi, math.pi), seed=st.integers(0, 10_000))
def test_the_harmonic_solve_turns_and_mirrors_with_its_data(phi, seed):
    pts, tri = _grid_mesh(6)
    rng = np.random.default_rng(seed)
    fixed = rng.random(len(pts)) < 0.4
    fixed[0] = True
    value = np.where(fixed, np.exp(1j * rng.uniform(0, math.tau, len(pts))), 0)
    clear = rng.uniform(0.1, 1.0, len(pts))
    z = harmonic_directions(pts, tri, clear, fixed, value)
    rot = harmonic_directions(pts, tri, clear, fixed, value * np.exp(1j * phi))
    mir = harmonic_directions(pts, tri, clear, fixed, np.conj(value))
    assert np.allclose(rot, z * np.exp(1j * phi), atol=1e-9)
    assert np.allclose(mir, np.conj(z), atol=1e-9)
    assert np.allclose(z[fixed], value[fixed])
    # a free vertex is the weighted mean of its neighbours: |z| <= 1 (maximum principle)
    assert (np.abs(z) <= 1 + 1e-9).all()


@settings(max_examples=60, deadline=None)
@given(a=st.floats(-10, 10), lo=st.floats(-10, 10), w=st.floats(0.01, 6.2))
def test_the_clamp_into_a_run_is_the_nearest_point_of_the_inner_arc(a, lo, w):
    got = float(_clamp(np.array([a]), np.array([lo]), np.array([w]))[0])
    m = min(math.radians(20), w / 4)
    grid = lo + m + np.linspace(0, w - 2 * m, 4001)  # the inner arc, densely
    dist = np.abs(np.mod(grid - a + math.pi, math.tau) - math.pi)
    d_got = abs((got - a + math.pi) % math.tau - math.pi)
    assert d_got <= dist.min() + 2e-3
    assert (got - lo - m) % math.tau <= w - 2 * m + 1e-9 or \
        abs((got - lo - m + math.pi) % math.tau - math.pi) < 1e-9


@pytest.mark.slow
def test_the_floor_plan_index_sum_is_its_euler_characteristic():
    """With passages (the runs along them only) the sum still counts the holes: the gap keeps
    to the walls on every wall the arcs are not along."""
    from tether.examples.floorplan import floor_plan

    env = floor_plan(20, seed=0)
    s = env.frame.scale
    kern = surveillance_kernel(env.internal, 0.3 * s, 0.3, 1.0, h=0.15 * s, orientations=180)
    f, z = direction_field(kern)
    assert singularities(z, f.tri).sum() == 1 - len(env.polygon.interiors) == -3
