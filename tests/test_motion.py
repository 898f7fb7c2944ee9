"""The observer motions, integrated with solve_ivp and checked against their invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether.bounds import rotation_time, thetas
from tether.motion import (
    contact_vertex,
    follow,
    rotate,
    slide_on_wall,
    trace,
    tractrix,
    translate,
    wall_contact_needed,
)

PI = math.pi


def wavy(vt):
    """A curved target path at constant speed vt: heading oscillates."""
    def v(t, T, O):
        h = 0.3 + 0.8 * math.sin(1.3 * t)
        return (vt * math.cos(h), vt * math.sin(h))
    return v


def check_invariants(sol, lss, vo, law, target_velocity):
    T = sol.y[:2].T
    O = sol.y[2:4].T
    dist = np.linalg.norm(O - T, axis=1)
    assert np.max(np.abs(dist - lss)) / lss < 1e-6
    for t, y in zip(sol.t, sol.y.T, strict=True):
        v = law(y[:2], y[2:4], target_velocity(t, y[:2], y[2:4]))
        assert v.feasible and v.speed <= vo * (1 + 1e-9)


@pytest.mark.parametrize("name", ["translate", "follow", "rotate+", "rotate-"])
def test_free_laws_keep_distance_and_speed(name):
    vt, vo, lss = 1.0, 1.6, 2.0
    law = {
        "translate": lambda T, O, V: translate(T, O, V, vo),
        "follow": lambda T, O, V: follow(T, O, V, vo),
        "rotate+": lambda T, O, V: rotate(T, O, V, vo, 1),
        "rotate-": lambda T, O, V: rotate(T, O, V, vo, -1),
    }[name]
    sol = trace(law, wavy(vt), (0, 0), (0.3 * lss, -math.sqrt(0.91) * lss), 12.0)
    assert sol.success and not sol.infeasible
    check_invariants(sol, lss, vo, law, wavy(vt))


def test_follow_reproduces_the_tractrix():
    lss, vt, s0 = 1.5, 0.7, -2.0
    T0 = (lss * s0, 0.0)
    x0, y0 = tractrix(s0, lss)
    sol = trace(lambda T, O, V: follow(T, O, V), lambda t, T, O: (vt, 0.0), T0,
                (float(x0), float(y0)), 10.0)
    t = np.linspace(0, 10, 50)
    O = sol.sol(t)[2:4]
    x, y = tractrix(s0 + vt * t / lss, lss)
    assert np.max(np.hypot(O[0] - x, O[1] - y)) < 1e-8
    # the observer is at rest at the cusp s = 0 and never faster than the target
    assert follow((0, 0), (0, lss), (vt, 0)).speed == pytest.approx(0, abs=1e-15)


def test_follow_is_the_minimum_norm_admissible_velocity():
    rng = np.random.default_rng(3)
    for _ in range(100):
        a = rng.uniform(0, 2 * PI)
        O = (math.cos(a), math.sin(a))
        V = tuple(rng.normal(size=2))
        f = follow((0, 0), O, V)
        for rate in rng.normal(size=5):  # every admissible velocity: Vt + rate * u_perp
            vx, vy = V[0] - rate * O[1], V[1] + rate * O[0]
            assert math.hypot(vx, vy) >= f.speed - 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_rotation_time_matches_integration(seed):
    rng = np.random.default_rng(seed)
    vo, lss = rng.uniform(1, 3), rng.uniform(0.5, 3)
    vt = vo * rng.uniform(0.1, 0.9)
    psi, a0 = rng.uniform(-PI, PI, 2)  # a0 as atan2 gives it: trace's lifted start
    sense = 1 if seed % 2 == 0 else -1
    sweep = rng.uniform(0.3, 7.0)  # up to more than a turn
    th0 = a0 - psi + PI / 2  # the paper's angle, lifted (math.md §2)
    thf = th0 + sense * sweep
    if sweep < 2 * PI:
        assert thetas(a0, a0 + sense * sweep, psi, sense) == pytest.approx((th0, thf))
    expected = rotation_time(th0, thf, vt, vo, lss)
    sol = trace(lambda T, O, V: rotate(T, O, V, vo, sense),
                lambda t, T, O: (vt * math.cos(psi), vt * math.sin(psi)),
                (0, 0), (lss * math.cos(a0), lss * math.sin(a0)), 2 * expected + 1,
                stop=lambda t, y: y[4] - (a0 + sense * sweep))
    assert sol.t_events[0][0] == pytest.approx(expected, rel=1e-8)


def test_wall_slide_keeps_contact_and_distance():
    vt, vo, lss = 1.0, 2.0, 2.0
    # wall y = 0 along +x (free side above); target above it at h = 1.2 < lss sqrt(1-1/4)
    h = 1.2
    T0 = (0.0, h)
    O0 = (math.sqrt(lss**2 - h**2), 0.0)

    def target(t, T, O):  # wanders but stays between h = 0.4 and 1.6
        return (vt * math.cos(0.5 * math.sin(t)), vt * 0.6 * math.sin(2 * t))

    def law(T, O, V):
        return slide_on_wall(T, O, V, (1.0, 0.0), vo)

    sol = trace(law, target, T0, O0, 8.0)
    assert not sol.infeasible
    assert np.max(np.abs(sol.y[3])) < 1e-9  # the observer stays on the wall line
    check_invariants(sol, lss, vo, law, target)


def test_wall_slide_feasibility_formula():
    rng = np.random.default_rng(4)
    vo, lss = 1.5, 1.0
    for _ in range(2000):
        vt = rng.uniform(0.1, 1.4)
        alpha = -rng.uniform(0.01, PI - 0.01)  # sin α < 0
        tw = rng.uniform(0, 2 * PI)
        T = (0.0, -lss * math.sin(alpha))
        O = (lss * math.cos(alpha), 0.0)
        V = (vt * math.cos(tw), vt * math.sin(tw))
        v = slide_on_wall(T, O, V, (1.0, 0.0), vo)
        required = vt * abs(math.cos(tw - alpha)) / abs(math.cos(alpha))
        assert v.speed == pytest.approx(required, rel=1e-9)
        assert v.feasible == (required <= vo * (1 + 1e-12))
        if not v.feasible:
            assert math.isnan(v.vx)
    assert wall_contact_needed((0.3, -0.1), (1.0, 0.0))
    assert not wall_contact_needed((0.3, 0.1), (1.0, 0.0))


def test_vertex_contact_keeps_the_vertex_on_the_rod():
    vt, vo, lss = 1.0, 2.5, 2.0
    V = np.array([0.0, 0.0])
    T0 = (-1.0, -0.2)
    u = -np.array(T0) / np.linalg.norm(T0)
    O0 = tuple(np.array(T0) + lss * u)

    def target(t, T, O):
        return (0.2 * vt, vt * math.sqrt(1 - 0.04) * math.cos(t))

    def law(T, O, Vt):
        return contact_vertex(T, O, Vt, V, vo)

    sol = trace(law, target, T0, O0, 1.0)
    assert not sol.infeasible
    T, O = sol.y[:2].T, sol.y[2:4].T
    d = O - T
    cross = d[:, 0] * (V[1] - T[:, 1]) - d[:, 1] * (V[0] - T[:, 0])
    assert np.max(np.abs(cross)) < 1e-8  # V stays on the rod line
    check_invariants(sol, lss, vo, law, target)


def test_vertex_contact_speed_formula_and_blow_up():
    rng = np.random.default_rng(5)
    lss, vo = 2.0, 3.0
    for _ in range(500):
        lt = rng.uniform(0.05, 1.95)
        a = rng.uniform(0, 2 * PI)
        u = np.array([math.cos(a), math.sin(a)])
        T = np.zeros(2)
        vt = rng.uniform(0.1, 2.9)
        psi = rng.uniform(0, 2 * PI)
        V = (vt * math.cos(psi), vt * math.sin(psi))
        v = contact_vertex(T, T + lss * u, V, T + lt * u, vo)
        th_v = psi - a
        lo = lss - lt
        expected = vt * math.sqrt(1 + (lo**2 / lt**2 - 1) * math.sin(th_v) ** 2)
        assert v.speed == pytest.approx(expected, rel=1e-9)
        assert v.feasible == (expected <= vo * (1 + 1e-12))
    # feasible for every heading iff lt >= lss vt / (vo + vt)
    vt = 1.0
    lt_min = lss * vt / (vo + vt)
    headings = np.linspace(0, 2 * PI, 721)
    for lt, ok in ((lt_min * 1.01, True), (lt_min * 0.99, False)):
        feas = [contact_vertex((0, 0), (lss, 0), (math.cos(h), math.sin(h)), (lt, 0), vo).feasible
                for h in headings]
        assert all(feas) is ok
