"""``certify``'s end check skips :func:`end_slack` where a cheap bound already passes
(``end_fails``): the verdict must be ``end_slack < MARGIN`` exactly, on every triangle.
Checked against ``end_slack`` itself over random gradients straddling the line where the
bound stops deciding, random orientation windows and speed ratios, and on whole fields."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import corner_room_first_field

from tether.game import certificate
from tether.game.certificate import MARGIN, end_fails, end_slack, window_floor


@pytest.mark.parametrize("vt", [0.3, 0.6, 0.9])
@pytest.mark.parametrize("upper", [False, True])
def test_end_fails_is_end_slack_below_the_margin(vt, upper):
    rng = np.random.default_rng(int(vt * 10) + upper)
    lss, vo, n = 1.7, 1.0, 2500
    line = window_floor(vt, vo, 1.0 if upper else -1.0) / (lss * vt)  # |G| of no skip
    mag = line * rng.uniform(0.0, 1.3, n)
    mag[:20] = 0.0  # a flat end
    ang = rng.uniform(0, math.tau, n)
    G = np.stack([mag * np.cos(ang), mag * np.sin(ang)], 1)
    a_lo = rng.uniform(-10, 10, n)
    a_hi = a_lo + rng.exponential(0.3, n) * rng.integers(0, 2, n)
    slack = end_slack(G, a_lo, a_hi, lss, vt, vo, upper)
    fails = end_fails(G, a_lo, a_hi, lss, vt, vo, upper)
    assert np.array_equal(fails, slack < MARGIN)
    assert fails.any() and (~fails).any()
    # the cheap bound is a lower bound of end_slack, and both sides of it occur
    k, r = lss * vt, vt * vt / (2 * math.sqrt(vo * vo - vt * vt))
    g = k * mag
    cheap = window_floor(vt, vo, 1.0 if upper else -1.0) - g \
        - (r + vt + g) * (math.tau / certificate.THETA_SAMPLES) / 2
    assert (cheap <= slack + 1e-12).all()
    assert (cheap >= MARGIN).any() and (cheap < MARGIN).any()


@pytest.mark.parametrize("vt", [0.3, 0.6])
def test_certify_gives_the_verdicts_of_end_slack(monkeypatch, vt):
    """The checks of a whole field (the room's first field, moved at random so that some
    ends fail) are those of ``certify`` with ``end_slack`` run on every triangle."""
    space, lss, f = corner_room_first_field(vt)
    rng = np.random.default_rng(5)
    g = certificate.ArcField(f.points, f.tri, f.lo + rng.normal(0, 0.2, len(f.lo)),
                             np.clip(f.w - rng.uniform(0, 0.3, len(f.w)), 0.01, None))
    fast = certificate.certify(g, space, lss, vt, 1.0)
    monkeypatch.setattr(certificate, "end_fails",
                        lambda G, lo, hi, lss, vt, vo, up:
                        end_slack(G, lo, hi, lss, vt, vo, up) < MARGIN)
    slow = certificate.certify(g, space, lss, vt, 1.0)
    for name in ("free", "open", "lo", "hi", "meets"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name))
    assert fast.lo.any() and fast.hi.any() and not (fast.lo | fast.hi).all()


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_a_non_finite_gradient_fails():
    """A NaN or infinite gradient (a degenerate triangle's) is not proven to pass: it fails,
    where a comparison ``end_slack < MARGIN`` would have let NaN through."""
    G = np.array([[np.nan, 0.0], [np.inf, 0.0], [0.0, 0.0]])
    a = np.zeros(3)
    for upper in (False, True):
        assert end_fails(G, a, a, 1.0, 0.3, 1.0, upper).tolist() == [True, True, False]
