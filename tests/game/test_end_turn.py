"""The end-turn bound of check 3 (``tether.game.end_turn``) against brute force: the end
condition sampled at many target headings, ``end_slack`` (the certificate's own proven lower
bound), and an ODE integration of the fastest turn."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tether.game.certificate import end_slack
from tether.game.end_turn import end_rate, turn_length

TH = np.linspace(0, math.tau, 200_001)


def sampled_min(G: np.ndarray, a: float, lss: float, vt: float, vo: float, upper: bool) -> float:
    """The end condition's slack ``F`` (certificate.end_slack's docstring) at 200,001 target
    headings: an upper bound of its minimum (a negative value proves a violation)."""
    x = TH - a
    root = np.sqrt(vo * vo - vt * vt * np.cos(x) ** 2)
    gu = G[0] * np.cos(TH) + G[1] * np.sin(TH)
    if upper:
        return float((root + vt * np.sin(x) + lss * vt * gu).min())
    return float((root - vt * np.sin(x) - lss * vt * gu).min())


games = st.tuples(st.floats(0.1, 2.0), st.floats(0.05, 0.9), st.floats(-math.pi, math.pi),
                  st.floats(-math.pi, math.pi), st.booleans())


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(games)
def test_end_rate_is_the_largest_gradient_check_3_allows(game):
    """Along the direction at ``psi`` from the end's orientation ``a``, a gradient of
    0.999·end_rate passes the sampled condition, 1.001·end_rate fails it (at both ends), and
    ``end_slack`` proves 0.9·end_rate passing."""
    lss, ratio, a, psi, upper = game
    vt, vo = ratio, 1.0
    g = float(end_rate(psi, lss, vt, vo))
    d = np.array([math.cos(a + psi), math.sin(a + psi)])
    assert sampled_min(1.001 * g * d, a, lss, vt, vo, upper) < 0
    assert sampled_min(0.999 * g * d, a, lss, vt, vo, upper) > 0
    G = (0.9 * g * d)[None, :]
    assert end_slack(G, np.array([a]), np.array([a]), lss, vt, vo, upper)[0] > 0


def test_end_rate_pinned_along_and_across_the_rod():
    """Exact values: across the rod ``(1 ± vo/vt)/lss`` (the ray from ``u⊥`` meets the
    ellipse at the ends ``±vo/vt`` of its axis across the rod), along it
    ``A·sqrt(1 − 1/B²)/lss``."""
    lss, vt, vo = 0.8, 0.3, 1.0
    up, down, along = end_rate(np.array([math.pi / 2, -math.pi / 2, 0.0]), lss, vt, vo)
    assert up == pytest.approx((vo / vt - 1) / lss, rel=1e-12)
    assert down == pytest.approx((vo / vt + 1) / lss, rel=1e-12)
    a, b = math.sqrt(vo * vo - vt * vt) / vt, vo / vt
    assert along == pytest.approx(a * math.sqrt(1 - 1 / b**2) / lss, rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("delta", [math.pi, math.tau])
def test_turn_length_against_the_fastest_turn_integrated(delta):
    """The shortest length of a turn by ``delta``: the ODE ``da/ds = end_rate(−a)`` (the
    direction at angle 0) integrated from 72 starts, the least length to turn by ``delta``
    (an upper bound of the minimum over starts, within the start grid's spacing)."""
    lss, vt, vo = 0.8, 0.3, 1.0
    lengths = []
    for a0 in np.linspace(0, math.tau, 72, endpoint=False):
        def hit(s, a, a0=a0):
            return a[0] - a0 - delta
        hit.terminal = True
        sol = solve_ivp(lambda s, a: end_rate(-a, lss, vt, vo), (0, 10), [a0], events=hit,
                        rtol=1e-10, atol=1e-12)
        lengths.append(sol.t_events[0][0])
    best = turn_length(delta, lss, vt, vo)
    assert best <= min(lengths) * (1 + 1e-6)
    assert best == pytest.approx(min(lengths), rel=2e-3)


def test_turn_length_scales_with_the_rod_and_rejects_bad_turns():
    """``turn_length`` is ``lss`` times a function of ``vt/vo`` (a scaled game)."""
    assert turn_length(math.pi, 0.4, 0.3, 1.0) * 2 == pytest.approx(
        turn_length(math.pi, 0.8, 0.6, 2.0), rel=1e-12)
    with pytest.raises(ValueError):
        turn_length(0.0, 0.8, 0.3, 1.0)
