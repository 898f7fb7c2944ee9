"""Rotation time and distance bounds: closed form against quadrature and simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from tether import InvalidParameterError
from tether.bounds import (
    best_rotation,
    distance_bound,
    rotation_time,
    thetas,
    worst_case_distance,
    worst_case_time,
    worst_straight_time,
)
from tether.motion import rotate, trace

PI = math.pi


def quad_time(th0, thf, vt, vo, lss):
    """The defining integral dt = lss dθ / |ω(θ)| with the saturated rate of the sense taken."""
    if thf >= th0:
        f = lambda th: lss / (math.sqrt(vo**2 - (vt * math.sin(th)) ** 2) - vt * math.cos(th))  # noqa: E731
        lo, hi = th0, thf
    else:
        f = lambda th: lss / (math.sqrt(vo**2 - (vt * math.sin(th)) ** 2) + vt * math.cos(th))  # noqa: E731
        lo, hi = thf, th0
    n = max(1, math.ceil((hi - lo) / (PI / 2)))  # pieces of a quarter turn each
    edges = np.linspace(lo, hi, n + 1)
    return sum(quad(f, a, b, epsabs=0, epsrel=1e-13, limit=200)[0]
               for a, b in zip(edges[:-1], edges[1:], strict=True))


def test_closed_form_matches_quadrature():
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(600):
        vo = rng.uniform(0.5, 5)
        vt = vo * rng.uniform(0, 0.98)
        lss = rng.uniform(0.1, 5)
        th0 = rng.uniform(-2 * PI, 2 * PI)
        thf = th0 + rng.uniform(-6 * PI, 6 * PI)  # both senses, up to 3 turns
        closed = rotation_time(th0, thf, vt, vo, lss)
        ref = quad_time(th0, thf, vt, vo, lss)
        worst = max(worst, abs(closed - ref) / ref)
    assert worst < 1e-10


@pytest.mark.parametrize(("lss", "vo", "vt", "th0", "thf", "T", "L"), [
    (1, 2, 1, 0, PI / 2, 1.31164147289295, 1.31164147289295),
    (2.5, 3, 1.2, -PI / 3, 2 * PI / 3, 3.67530113863852, 4.41036136636623),
    (1, 1.5, 1.4, -PI / 2, PI / 2, 21.3200250742136, 29.8480351038990),
    (3, 2, 0.5, 1, -2, 4.02572083336687, 2.01286041668344),
    (0.7, 5, 4, 0.3, 0.3 + 4 * PI, 3.97086648986193, 15.8834659594477),
])
def test_reference_values(lss, vo, vt, th0, thf, T, L):
    assert rotation_time(th0, thf, vt, vo, lss) == pytest.approx(T, abs=1e-10)
    assert distance_bound(th0, thf, vt, vo, lss) == pytest.approx(L, abs=1e-10)


def test_additivity_symmetry_full_turn_and_limits():
    rng = np.random.default_rng(1)
    from scipy.special import ellipe

    for _ in range(200):
        vo, lss = rng.uniform(1, 3), rng.uniform(0.5, 2)
        vt = vo * rng.uniform(0.05, 0.95)
        a = rng.uniform(-5, 5)
        b, c = sorted(a + rng.uniform(0, 9, 2))
        def T(x, y, vt=vt, vo=vo, lss=lss):
            return rotation_time(x, y, vt, vo, lss)

        assert T(a, b) + T(b, c) == pytest.approx(T(a, c), rel=1e-12)
        assert T(c, b) + T(b, a) == pytest.approx(T(c, a), rel=1e-12)
        # mirror: CW from a to a-d equals CCW from pi-a to pi-a+d
        assert T(a, a - 1.3) == pytest.approx(T(PI - a, PI - a + 1.3), rel=1e-12)
        full = 4 * lss * vo * ellipe((vt / vo) ** 2) / (vo**2 - vt**2)
        assert T(a, a + 2 * PI) == pytest.approx(full, rel=1e-12)
    # vt -> 0: T -> lss |dθ| / vo
    assert rotation_time(0.2, 3.0, 1e-9, 2.0, 1.5) == pytest.approx(1.5 * 2.8 / 2.0, rel=1e-8)
    # vt -> vo: a sweep through cos θ > 0 takes ever longer
    times = [rotation_time(-0.5, 0.5, vo_ratio, 1.0, 1.0) for vo_ratio in (0.9, 0.99, 0.999)]
    assert times[0] < times[1] < times[2] and times[2] > 100 * times[0] / 10


@pytest.mark.parametrize("m", [0.0, 0.01, 0.5, 0.9, 0.97, 0.99])
def test_fast_elliptic_integral_equals_scipy(m):
    from scipy.special import ellipeinc

    from tether.bounds import ellipe_inc

    phi = np.random.default_rng(2).uniform(-60, 60, 50_000)
    phi[:5] = [0.0, PI / 2, -PI / 2, PI, 1e-300]
    assert np.max(np.abs(ellipe_inc(phi, m) - ellipeinc(phi, m))) < 1e-13


def test_vectorized():
    th0 = np.linspace(-3, 3, 7)
    out = rotation_time(th0, th0 + 1, 1, 2, 1)
    assert out.shape == (7,)
    assert np.allclose(out, [rotation_time(t, t + 1, 1, 2, 1) for t in th0])


@pytest.mark.parametrize(("args", "message"), [
    ((0, 1, 2.0, 2.0, 1.0), "vo must exceed vt"),
    ((0, 1, 3.0, 2.0, 1.0), "vo must exceed vt"),
    ((0, 1, 1.0, 2.0, 0.0), "lss must be"),
    ((0, 1, 1.0, 2.0, -1.0), "lss must be"),
    ((0, 1, float("nan"), 2.0, 1.0), "vt must be finite"),
    ((0, 1, -1.0, 2.0, 1.0), "vt must be >= 0"),
    ((float("nan"), 1, 1.0, 2.0, 1.0), "theta0 must be finite"),
    ((0, float("inf"), 1.0, 2.0, 1.0), "thetaf must be finite"),
])
def test_bad_parameters(args, message):
    with pytest.raises(InvalidParameterError, match=message):
        rotation_time(*args)


def test_thetas_and_best_sense():
    # rod at a0 = psi - pi/2 is theta = 0 (observer right of the path)
    th0, thf = thetas(-PI / 2, 0.0, 0.0, 1)
    assert (th0, thf) == pytest.approx((0.0, PI / 2))
    th0, thf = thetas(-PI / 2, 0.0, 0.0, -1)
    assert (th0, thf) == pytest.approx((0.0, -3 * PI / 2))
    r = best_rotation(-PI / 2, 0.0, 0.0, 1.0, 2.0, 1.0)
    assert r.sense == 1 and r.time == pytest.approx(1.31164147289295)


def test_worst_case_is_tight_against_the_tangential_target():
    """A target running along u⊥ in the sense of rotation forces exactly lss Δ/(vo - vt)."""
    vt, vo, lss, delta = 0.8, 1.5, 2.0, 1.7
    tg = worst_case_time(delta, vt, vo, lss)

    def steer(t, T, O):  # tangential, in the rotation's (CCW) direction
        ux, uy = (O[0] - T[0]) / lss, (O[1] - T[1]) / lss
        return (-vt * uy, vt * ux)

    sol = trace(lambda T, O, V: rotate(T, O, V, vo, 1), steer, (0, 0), (lss, 0), 3 * tg,
                stop=lambda t, y: y[4] - delta)
    assert sol.t_events[0][0] == pytest.approx(tg, rel=1e-8)
    # and it beats every straight heading: L_straight <= L_g
    assert worst_straight_time(delta, vt, vo, lss) < tg
    assert worst_case_distance(delta, vt, vo, lss) == pytest.approx(vt * tg)


@pytest.mark.parametrize(("ratio", "delta", "expected"), [
    (0.25, PI / 4, 1.006), (0.5, PI / 2, 1.051), (0.75, PI, 1.329), (0.9, PI, 1.441),
])
def test_ratio_table_of_math_md(ratio, delta, expected):
    lg = worst_case_distance(delta, ratio, 1.0, 1.0)
    ls = ratio * worst_straight_time(delta, ratio, 1.0, 1.0)
    assert lg / ls == pytest.approx(expected, abs=6e-4)
