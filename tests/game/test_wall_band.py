"""The wall-band field (``tether.game.wall_band``): its pieces against independent computations
(the saddle's index by a winding count on loops, the walls' normals from the map's geometry,
the profile's end condition by brute force over headings, the rounded core and the direction
to it by plane geometry), and the room certified at 0.9."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from scipy.spatial import cKDTree

from tether import Environment
from tether.examples import load
from tether.game.certificate import free_mesh
from tether.game.wall_band import (
    core_direction,
    rounded_core,
    saddle_direction,
    wall_band_field,
    wall_profile,
)

ROOM = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])


def _mesh(env, h):
    x0, y0, x1, y1 = env.bounds
    xs, ys = np.arange(x0, x1 + h / 2, h), np.arange(y0, y1 + h / 2, h)
    return free_mesh(env, h, np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2))


def _winding(pts: np.ndarray, theta: np.ndarray, loop: np.ndarray) -> int:
    """Turns of θ along the closed polyline ``loop``, θ read at the nearest mesh vertex of
    each of its points (dense: consecutive readings differ by much less than π)."""
    near = cKDTree(pts).query(loop)[1]
    t = theta[near]
    step = np.mod(np.diff(np.append(t, t[0])) + math.pi, math.tau) - math.pi
    assert np.abs(step).max() < 1.0
    return round(step.sum() / math.tau)


def _rectangle(x0, y0, x1, y1, n=400) -> np.ndarray:
    s = np.linspace(0, 4, n, endpoint=False)[:, None]
    a, b = np.array([x0, y0]), np.array([x1, y1])
    corners = np.array([[a[0], a[1]], [b[0], a[1]], [b[0], b[1]], [a[0], b[1]], [a[0], a[1]]])
    k = np.floor(s).astype(int).ravel()
    f = s - np.floor(s)
    return corners[k] + f * (corners[k + 1] - corners[k])


def test_saddle_direction_winds_as_prescribed():
    """On the gallery: θ turns −1 around the saddle, +1 around each block, +1 along a loop
    near the outer wall (1 − 2 = −1 in all: Poincaré–Hopf), and equals the walls' inward
    normals (from the map's edges, rotated, the sign by a point-in-polygon test)."""
    env = load("gallery")
    h = 0.25
    pts, tri, _ = _mesh(env, h)
    z0 = (2.71, 2.66)
    theta = saddle_direction(env, pts, tri, h, z0)
    ang = np.linspace(0, math.tau, 600, endpoint=False)
    circle = np.array(z0) + 1.5 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    assert _winding(pts, theta, circle) == -1
    assert _winding(pts, theta, _rectangle(4.4, 3.4, 7.6, 6.6)) == 1
    assert _winding(pts, theta, _rectangle(10.4, 2.4, 12.6, 7.6)) == 1
    assert _winding(pts, theta, _rectangle(0.4, 0.4, 15.6, 8.6, 1600)) == 1
    # mid-edge wall points: θ is the inward normal
    for ring in env.rings:
        for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
            m = (a + b) / 2
            t = (b - a) / np.hypot(*(b - a))
            n = np.array([-t[1], t[0]])
            if not shapely.contains_xy(env.polygon, *(m + 1e-3 * n)):
                n = -n
            i = np.argmin(np.hypot(*(pts - m).T))
            if np.hypot(*(pts[i] - m)) < 1e-9:
                d = np.mod(theta[i] - math.atan2(n[1], n[0]) + math.pi, math.tau) - math.pi
                assert abs(d) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("ratio", [0.6, 0.9])
def test_wall_profile_passes_the_end_condition_by_brute_force(ratio):
    """Each step of the profile: both ends (``∓α``, gradients ``∓r·n`` with ``r`` the step's
    rate, n = +x) follow every heading, by brute force over 4,000 headings, at both of the
    step's half-widths; α rises from alpha_wall to π."""
    vt, vo = ratio, 1.0
    d, alpha = wall_profile(vt, vo, math.pi / 6, pace=1.0, steps=16)
    assert alpha[0] == pytest.approx(math.pi / 6) and alpha[-1] == pytest.approx(math.pi)
    assert np.all(np.diff(d) > 0)
    th = np.linspace(0, math.tau, 2000, endpoint=False)
    v = vt * np.stack([np.cos(th), np.sin(th)], axis=1)
    for i in range(len(d) - 1):
        r = (alpha[i + 1] - alpha[i]) / (d[i + 1] - d[i])
        for a in (alpha[i], alpha[i + 1]):
            for end, sgn in ((-a, -1.0), (a, 1.0)):  # lower end −α, upper end +α
                u = np.array([math.cos(end), math.sin(end)])
                up = np.array([-math.sin(end), math.cos(end)])
                g = sgn * r * np.array([1.0, 0.0])  # lss·G = ∓r·n, lss = 1
                # |ȯ| <= vo for the observer that keeps the end: ȯ = v + (g·v)·u⊥
                speed = np.hypot(*(v + (v @ g)[:, None] * up[None, :]).T)
                assert speed.max() < vo, (i, a, end)
                assert u @ u == pytest.approx(1.0)


def test_rounded_core_by_plane_geometry():
    """The 10 x 10 room, depth 1, rounding 2: the core's nearest point to a room corner is at
    |(3, 3)| − 2 from it (the circle of radius 2 centred 3 from both walls), to a side's
    middle at 1; every point of the core is at least 1 from the walls."""
    core = rounded_core(ROOM, 1.0, 2.0)
    assert shapely.distance(core, shapely.Point(0, 0)) == pytest.approx(math.hypot(3, 3) - 2,
                                                                        abs=1e-4)
    assert shapely.distance(core, shapely.Point(5, 0)) == pytest.approx(1.0, abs=1e-9)
    xy = shapely.get_coordinates(core)
    assert ROOM.boundary_distance(xy[:, 0], xy[:, 1]).min() >= 1.0 - 1e-9
    sharp = rounded_core(ROOM, 1.0, 0.0)
    assert shapely.distance(sharp, shapely.Point(0, 0)) == pytest.approx(math.sqrt(2))


def test_core_direction_points_at_the_core():
    """Beside a wall's middle the direction is the inward normal; in a corner's sector it
    points at the rounding circle's centre (3, 3); inside the shrunk core it is 0."""
    core = rounded_core(ROOM, 1.0, 2.0)
    pts = np.array([[0.5, 5.0], [5.0, 9.5], [1.0, 0.6], [0.3, 0.9], [5.0, 5.0]])
    th = core_direction(core, pts, 0.1)
    expect = [0.0, -math.pi / 2, math.atan2(3 - 0.6, 3 - 1.0), math.atan2(3 - 0.9, 3 - 0.3),
              0.0]
    assert np.allclose(th, expect, atol=2e-3)


@pytest.mark.slow
def test_wall_band_field_certifies_the_room_at_0_9():
    """The 10 x 10 room at vt/vo = 0.9, lss 0.15, the corner profile: certified, no saddle
    (every singular point of the direction lies in the whole-circle core); its states'
    rods free by the independent rod test at 4,000 random points."""
    from tether.arcs import rod_is_free_many

    ck = wall_band_field(ROOM, 0.15, 0.9, 1.0, h=0.075, profile="corner",
                         alpha_wall=math.pi / 5)
    assert ck.certified
    rng = np.random.default_rng(1)
    pts = rng.uniform(0, 10, size=(4000, 2))
    lo, hi, ok = ck.arcs(pts)
    a = lo + rng.uniform(0, 1, len(pts)) * (hi - lo)
    assert ok.mean() > 0.9
    assert rod_is_free_many(ROOM, pts[ok], a[ok], 0.15).all()
