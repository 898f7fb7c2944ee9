"""The certified kernel end to end, against independent computations: the rod test on states
the kernel calls safe, the sampled-time step of the argument on random states and target
moves, the simulator's monitor on runs of the certified controller against every target kind,
and the checks on files read back and on fields made wider than certified."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether import Environment
from tether.arcs import rod_is_free_many
from tether.game.certificate import ArcField, certify
from tether.game.certified import CertifiedKernel, certified_kernel, load_certified
from tether.game.controller import CertifiedController, _landing
from tether.rates import step_rate_interval
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import TARGETS, make_target

ROOM = Environment([(0, 0), (10, 0), (10, 10), (0, 10)], name="room")
LSS, VT, VO = 1.0, 0.3, 1.0


@pytest.fixture(scope="module")
def room() -> CertifiedKernel:
    ck = certified_kernel(ROOM, LSS, VT, VO, h=0.5)
    assert ck.certified, ck.log
    return ck


def _field_states(ck: CertifiedKernel, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random states of the field (uniform point, uniform place in its arc)."""
    pts = rng.uniform(0, 10, size=(4 * n, 2))
    lo, hi, ok = ck.arcs(pts)
    pts, lo, hi = pts[ok][:n], lo[ok][:n], hi[ok][:n]
    return pts, lo + rng.uniform(0, 1, len(pts)) * (hi - lo)


@pytest.mark.slow
def test_safe_states_have_a_free_rod(room):
    """Every sampled state the certified kernel calls safe has a free rod by the independent
    rod test, points on walls and exactly lss from them included."""
    rng = np.random.default_rng(0)
    pts, a = _field_states(room, 20_000, rng)
    edge = np.array([[0.0, 5.0], [1.0, 5.0], [5.0, 9.0], [9.0, 9.0], [10.0, 10.0]])
    pts = np.vstack([pts, np.repeat(edge, 64, axis=0)])
    a = np.concatenate([a, np.tile(np.linspace(0, math.tau, 64, endpoint=False), len(edge))])
    safe = room.contains(pts, a)
    assert safe.sum() > 20_000 * 0.99
    assert rod_is_free_many(ROOM, pts[safe], a[safe], LSS).all()


@pytest.mark.slow
def test_every_sampled_step_can_stay_in_the_field(room):
    """The sampled-time step of the argument: from random states of the field and random
    target moves of one step (speed vt, every heading), some reachable orientation (the exact
    chord interval) lies in the arc at the target's next point, and the controller's landing
    finds one."""
    rng = np.random.default_rng(1)
    n = 4000
    pts, a = _field_states(room, n, rng)
    th = rng.uniform(0, math.tau, len(pts))
    v = VT * np.stack([np.cos(th), np.sin(th)], axis=1)
    for dt in (0.01, 0.05, 0.2):
        nxt = pts + v * dt
        inside = ROOM.contains(nxt[:, 0], nxt[:, 1])
        r_lo, r_hi = step_rate_interval(v, a, LSS, VO, dt)
        lo1, hi1, _ = room.arcs(nxt)
        for i in np.flatnonzero(inside):
            end = _landing(a[i], a[i] + r_lo[i] * dt, a[i] + r_hi[i] * dt, lo1[i],
                           hi1[i] - lo1[i], a[i])
            assert a[i] + r_lo[i] * dt - 1e-12 <= end <= a[i] + r_hi[i] * dt + 1e-12
            assert room.margin(nxt[i:i + 1], end)[0] >= -1e-9, (pts[i], a[i], th[i], dt)


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(set(TARGETS) - {"path", "track", "pedestrian"}))
def test_certified_controller_never_loses(room, kind):
    """From random certified starts, the certified controller holds against every target kind
    (the simulator's monitor checks every step), and every sampled state is in the field."""
    world = World(ROOM, lss=LSS, vt=VT, vo=VO)
    world.extra["certified"] = room
    rng = np.random.default_rng(hash(kind) % 2**32)
    pts, a = _field_states(room, 1 if kind == "search" else 3, rng)  # search: slow per step
    for i in range(len(pts)):
        res = simulate(world, CertifiedController(), make_target(kind, world),
                       (float(pts[i, 0]), float(pts[i, 1]), float(a[i])), duration=8.0,
                       dt=0.02, seed=i)
        assert res.held, (kind, pts[i], a[i], res.reason)
        assert (room.margin(res.trace.p, res.trace.a) >= -1e-9).all()


@pytest.mark.slow
def test_classify_three_answers(room):
    """safe in the certified kernel; unsafe outside the optimistic grid kernel (the rod pointing
    into a wall half a unit away); undecided between (a state the optimistic kernel holds
    that the certified one does not)."""
    from tether.game import surveillance_kernel
    from tether.game.certified import classify

    outer = surveillance_kernel(ROOM, LSS, VT, VO, h=0.5, scheme="outer")
    pts = np.array([[5.0, 5.0], [0.5, 5.0]])
    assert list(classify(room, outer, pts, [0.0, math.pi])) == ["safe", "unsafe"]
    rng = np.random.default_rng(4)
    q = rng.uniform(0, 10, size=(20_000, 2))
    a = rng.uniform(0, math.tau, len(q))
    got = classify(room, outer, q, a)
    assert {"safe", "unsafe", "undecided"} <= set(got.tolist())
    assert not (room.contains(q, a) & (got != "safe")).any()


@pytest.mark.slow
def test_a_field_wider_than_certified_fails_its_checks(room):
    """Widening every partial arc by 0.3 rad breaks the checks (the free check at the walls,
    the ends' rates): the checks are not vacuous."""
    f = room.field
    wide = ArcField(f.points, f.tri, f.lo - 0.15, np.minimum(f.w + 0.3, math.tau))
    env, lss, vt, vo = room.game  # the field's own (normalized) frame
    checks = certify(wide, env, lss, vt, vo)
    assert not checks.passed
    assert checks.counts()["free"] > 0
    # the same field at a faster target fails the end checks
    fast = certify(f, env, lss, 0.9, vo).counts()
    assert fast["lo"] + fast["hi"] > 0


@pytest.mark.slow
def test_saved_field_is_certified_again_on_reading(room, tmp_path):
    """A saved field reads back certified; a tampered one (arcs widened) reads back not
    certified, so nothing in it is claimed safe."""
    path = tmp_path / "room.npz"
    room.save(path)
    again = load_certified(path)
    assert again.certified and np.array_equal(again.field.w, room.field.w)
    with np.load(path) as d:
        data = dict(d)
    data["w"] = np.minimum(data["w"] + 0.3, math.tau)
    data["lo"] = data["lo"] - 0.15
    np.savez(path, **data)
    bad = load_certified(path)
    assert not bad.certified
    assert not bad.contains([[5.0, 5.0]], 0.0).any()


def test_margin_pins():
    """``margin`` on a hand-made field of one triangle: inside, outside, the whole circle."""
    env = Environment([(0, 0), (4, 0), (0, 4)])
    f = ArcField(np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]), np.array([[0, 1, 2]]),
                 np.array([0.5, 0.5, 0.5]), np.array([1.0, 1.0, 1.0]))
    ck = CertifiedKernel(env, 1.0, 0.3, 1.0, 1.0, f, certify(f, env, 1.0, 0.3, 1.0))
    ck_ok = CertifiedKernel(env, 1.0, 0.3, 1.0, 1.0, f, None)
    assert (ck_ok.margin([[1.0, 1.0]], 1.0) == -math.pi).all()  # not certified: never safe
    ck.checks.free[:] = ck.checks.open[:] = ck.checks.lo[:] = ck.checks.hi[:] = False
    m = ck.margin([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [9.0, 9.0]], [1.0, 0.6, 0.4, 1.0])
    assert m[0] == pytest.approx(0.5)  # ends at 0.5 and 1.5
    assert m[1] == pytest.approx(0.1)
    assert m[2] == pytest.approx(-0.1)
    assert m[3] == -math.pi  # off the mesh


def test_bad_parameters_are_one_line_errors():
    from tether.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError):
        certified_kernel(ROOM, LSS, 1.0, 0.5, h=0.5)
    with pytest.raises(InvalidParameterError, match="h must be"):
        certified_kernel(ROOM, LSS, VT, VO, h=float("nan"))


@pytest.mark.slow
def test_moved_and_scaled_map_gives_the_same_answer(room):
    """The room moved far from the origin (by (1e5, -3e4)) and scaled by 4 (lss, h and speeds
    with it), and mirrored: still certified, the same mesh size, and states answer as the
    original's images (away from the field's boundary, where the two may round apart)."""
    s, off = 4.0, np.array([1e5, -3e4])
    moved = Environment([tuple(off + s * np.array(q)) for q in [(0, 0), (10, 0), (10, 10),
                                                                (0, 10)]])
    ck = certified_kernel(moved, s * LSS, s * VT, s * VO, h=s * 0.5)
    assert ck.certified
    assert len(ck.field.points) == len(room.field.points)
    rng = np.random.default_rng(5)
    pts, a = _field_states(room, 2000, rng)
    deep = room.margin(pts, a) > 0.05
    assert ck.contains(off + s * pts[deep], a[deep]).mean() > 0.99
    mirror = Environment([(0, 0), (0, 10), (10, 10), (10, 0)])  # listed clockwise
    mk = certified_kernel(Environment([(-x, y) for x, y in mirror.polygon.exterior.coords[:-1]]),
                          LSS, VT, VO, h=0.5)
    assert mk.certified
    flip = np.column_stack([-pts[:, 0], pts[:, 1]])
    assert mk.contains(flip[deep], (math.pi - a[deep])).mean() > 0.99
