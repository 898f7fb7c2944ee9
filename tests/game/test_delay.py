"""The certified kernel with a sensing delay (issue #22), against independent computations:
the line of sight from the observer to every true target within ``vt·d`` of the seen one,
tested densely against the walls; the grown triangle against sampled points within ``r`` of
the triangle; the bad delays; and the checks run again on a field read back."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tether import Environment
from tether.arcs import rod_is_free_many
from tether.cli import main
from tether.errors import InvalidParameterError
from tether.examples import path as example_path
from tether.game.cells import grow_triangles, triangle_blocked_any
from tether.game.certificate import certify, sight_widening
from tether.game.certified import CertifiedKernel, certified_kernel
from tether.game.controller import CertifiedController
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import TARGETS, make_target

ROOM = Environment([(0, 0), (10, 0), (10, 10), (0, 10)], name="room")
LSS, VT, VO = 1.0, 0.3, 1.0
DELAY = 1.0  # r = vt·d = 0.3


@pytest.fixture(scope="module")
def delayed() -> CertifiedKernel:
    ck = certified_kernel(ROOM, LSS, VT, VO, h=0.5, delay=DELAY)
    assert ck.certified, ck.log
    return ck


def _segments_free(env: Environment, a: np.ndarray, b: np.ndarray, n: int = 100) -> np.ndarray:
    """Whether each segment ``a[i] → b[i]`` lies in the free space, by ``n + 1`` points along
    it (each inside or on the boundary)."""
    s = np.linspace(0.0, 1.0, n + 1)
    pts = a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]
    inside = shapely.intersects_xy(env.polygon, pts[..., 0].ravel(), pts[..., 1].ravel())
    return inside.reshape(len(a), n + 1).all(axis=1)


@pytest.mark.slow
def test_line_of_sight_to_every_true_target_is_free(delayed):
    """From random seen states ``(q, a)`` of the field certified at delay d, the segment from
    the observer ``q + lss·u(a)`` to random true targets ``p`` within ``vt·d`` of ``q`` (in the
    free space, on the disc's rim among them) is free: densely sampled, and by the exact rod
    test from ``p`` toward the observer."""
    rng = np.random.default_rng(7)
    r = VT * DELAY
    q = rng.uniform(0, 10, size=(30_000, 2))
    lo, hi, ok = delayed.arcs(q)
    q, lo, hi = q[ok], lo[ok], hi[ok]
    a = lo + rng.uniform(0, 1, len(q)) * (hi - lo)
    assert delayed.contains(q, a).all()
    rho = r * np.sqrt(rng.uniform(0, 1, len(q)))
    rho[::4] = r  # the rim
    phi = rng.uniform(0, math.tau, len(q))
    p = q + rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    inside = ROOM.contains(p[:, 0], p[:, 1])
    q, a, p = q[inside], a[inside], p[inside]
    assert len(q) > 20_000
    o = q + LSS * np.stack([np.cos(a), np.sin(a)], axis=1)
    assert _segments_free(ROOM, o, p).all()
    d = o - p
    assert rod_is_free_many(ROOM, p, np.arctan2(d[:, 1], d[:, 0]), LSS + r).all()
    dist = np.hypot(d[:, 0], d[:, 1])
    assert (np.abs(dist - LSS) <= r + 1e-12).all()


@pytest.mark.slow
def test_delayed_field_is_certified_without_delay_and_read_back(delayed, tmp_path, capsys):
    """A field certified at delay d passes the checks without delay (the grown check contains
    the plain one); a file read back (``simulate --kernel``) is checked again at its own
    delay, holds a run at that delay and is refused for a longer one."""
    env, lss, vt, vo = delayed.game
    assert certify(delayed.field, env, lss, vt, vo).passed
    path = tmp_path / "k.npz"
    delayed.save(path)
    assert delayed.to_dict()["delay"] == DELAY
    sim = ["simulate", str(example_path("nonconvex_corner")), "--lss", "1", "--vt", "0.3",
           "--vo", "1", "--controller", "certified", "--kernel", str(path), "--target",
           "wall", "--start", "5", "5", "0", "--duration", "2", "--json", "--delay", "1"]
    assert main(sim) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["outcome"] == "held" and out["delay"] == 1 and out["delay_steps"] == 50
    sim[-1] = "1.01"  # rounded up to 51 steps: longer than the field is certified for
    assert main(sim) == 2
    assert "certified for a delay of 1 s" in capsys.readouterr().err


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=6, max_size=6), st.floats(0.01, 0.5))
def test_grown_triangle_holds_every_point_within_r(c, r):
    """The grown triangle holds every sampled point within ``r`` of the triangle (on the
    rounded rim included), the exact distance by shapely."""
    t = np.array(c).reshape(3, 2)
    det = (t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1]) - (t[1, 1] - t[0, 1]) * (t[2, 0] - t[0, 0])
    if abs(det) < 1e-2:
        return
    if det < 0:
        t = t[[0, 2, 1]]
    g = shapely.Polygon(grow_triangles(t[None], r)[0])
    tri = shapely.Polygon(t)
    rng = np.random.default_rng(0)
    rim = shapely.get_coordinates(tri.buffer(r, quad_segs=64).exterior)
    pts = rng.uniform(t.min(0) - r, t.max(0) + r, size=(500, 2))
    near = shapely.distance(tri, shapely.points(pts)) <= r
    pts = np.vstack([pts[near], rim])
    assert shapely.covers(g.buffer(1e-9), shapely.points(pts)).all()


def test_wall_within_r_of_the_triangle_blocks_what_a_true_target_would_see_blocked():
    """Degenerate case pinned: a thin obstacle ends ``r`` from a mesh vertex ``q``, beside a
    rod from ``q`` along +x. Without delay the rod is free; the true target a little less
    than ``r`` below ``q`` sees the observer across the obstacle, and the check with delay
    ``r`` blocks that orientation; moved clearly farther than ``r`` (by the grown triangle's
    reach), the obstacle no longer blocks it."""
    r, lss = 0.3, 1.0
    q = np.array([0.0, 0.0])
    tri = np.array([[q, q + [0.01, 0.0], q + [0.0, 0.01]]])
    for gap, blocked in ((r, True), (0.9 * r, True), (2.5 * r, False)):
        hole = [(0.05, -gap), (0.06, -gap), (0.06, -5.0), (0.05, -5.0)]
        env = Environment([(-5, -6), (5, -6), (5, 5), (-5, 5)], holes=[hole])
        plain, _ = triangle_blocked_any(env, tri, np.zeros(1), np.zeros(1), lss)
        assert not plain[0]
        beta = sight_widening(r, lss)
        grown, _ = triangle_blocked_any(env, grow_triangles(tri, r), np.array([-beta]),
                                        np.array([beta]), lss + r)
        assert bool(grown[0]) is blocked, gap
    # the true target just inside r below q, and the observer at q + lss·u(0): the line of
    # sight crosses the obstacle when the obstacle ends 0.9·r below q
    env = Environment([(-5, -6), (5, -6), (5, 5), (-5, 5)],
                      holes=[[(0.05, -0.9 * r), (0.06, -0.9 * r), (0.06, -5.0), (0.05, -5.0)]])
    p = q + [0.0, -0.99 * r]
    assert not _segments_free(env, (q + [lss, 0.0])[None], p[None])[0]


@pytest.mark.parametrize("delay", [-0.1, float("nan"), float("inf"), 4.0])
def test_bad_delays_are_refused(delay):
    """A negative, NaN or infinite delay, or one with ``vt·delay >= lss``: one clear error."""
    with pytest.raises(InvalidParameterError, match="delay"):
        certified_kernel(ROOM, LSS, VT, VO, h=0.5, delay=delay)


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(set(TARGETS) - {"path", "track", "pedestrian"}))
def test_certified_controller_with_delay_never_loses(delayed, kind):
    """From a random seen state of the field certified at delay d, the certified controller
    fed the target's position d late holds against every target kind: the monitor checks the
    true line of sight, the observer's chord and the distance within ``lss ± vt·d``."""
    rng = np.random.default_rng(sum(map(ord, kind)))
    while True:
        q = rng.uniform(0.5, 9.5, size=(1, 2))
        lo, hi, ok = delayed.arcs(q)
        a = float(lo[0] + rng.uniform(0.1, 0.9) * (hi[0] - lo[0]))
        if ok[0] and delayed.contains(q, a)[0]:
            break
    world = World(ROOM, lss=LSS, vt=VT, vo=VO)
    world.extra["certified"] = delayed
    res = simulate(world, CertifiedController(), make_target(kind, world),
                   (float(q[0, 0]), float(q[0, 1]), a), duration=6.0, dt=0.05, seed=3,
                   delay=DELAY)
    assert res.held, (kind, res.reason)
    assert res.delay_steps == 20 and res.trace.seen is not None
    assert res.monitor.max_speed_ratio <= 1 + 1e-6
    dist = np.hypot(*(res.trace.observer - res.trace.p).T)
    assert (np.abs(dist - LSS) <= VT * DELAY + 1e-9).all()
    assert delayed.contains(res.trace.seen, res.trace.a).all()
