"""The radial field (``tether.game.radial``): the ellipse form of the end check and the
outward-end bound against brute force, and the field certified by the checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether import Environment
from tether.game.certificate import end_slack
from tether.game.radial import radial_field, radial_profile


def _brute_slack(G: np.ndarray, a: float, lss: float, vt: float, vo: float) -> float:
    """min over 5,000 headings of lss·Ωmax(v, a) − lss·G·v, |v| = vt (the lower end)."""
    th = np.linspace(0, math.tau, 5_000, endpoint=False)
    x = th - a
    return float((np.sqrt(vo**2 - vt**2 * np.cos(x) ** 2) - vt * np.sin(x)
                  - lss * vt * (G[0] * np.cos(th) + G[1] * np.sin(th))).min())


def test_the_end_check_is_an_ellipse():
    """lss·G + u⊥(a) inside the ellipse (semi-axes sqrt(vo² − vt²)/vt along u, vo/vt along
    u⊥) iff the lower end follows every heading: 120 random gradients and orientations."""
    rng = np.random.default_rng(3)
    vt, vo, lss = 0.9, 1.0, 1.0
    agree = 0
    for _ in range(120):
        a = rng.uniform(0, math.tau)
        G = rng.normal(scale=0.6, size=2)
        u, up = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        g = lss * G + up
        q = (g @ u) ** 2 * vt**2 / (vo**2 - vt**2) + (g @ up) ** 2 * vt**2 / vo**2
        s = _brute_slack(G, a, lss, vt, vo)
        if abs(q - 1) > 1e-3:  # off the ellipse's border, the brute force must agree
            assert (q < 1) == (s > 0), (G, a, q, s)
            agree += 1
    assert agree > 100


@pytest.mark.parametrize("ratio", [0.3, 0.6, 0.9])
def test_an_end_pointing_away_from_the_centre_needs_a_wide_radius(ratio):
    """An end ``ψ + π`` rotated by π (pointing away from c), α constant: it follows the
    target iff ρ >= lss·vt/(vo − vt), by brute force over headings and by end_slack."""
    vt, vo, lss = ratio, 1.0, 1.0
    rho_min = lss * vt / (vo - vt)
    for rho, ok in ((0.97 * rho_min, False), (1.03 * rho_min, True)):
        # polar frame at ψ = 0: the end's direction is 0 (outward), its gradient e_ψ/ρ
        G = np.array([0.0, 1.0 / rho])
        assert (_brute_slack(G, 0.0, lss, vt, vo) > 0) == ok
        bound = end_slack(G[None], np.zeros(1), np.zeros(1), lss, vt, vo, False)[0]
        assert bound <= _brute_slack(G, 0.0, lss, vt, vo) + 1e-12
        if not ok:
            assert bound < 0


@pytest.mark.slow
def test_the_profile_opens_the_circle_far_out_at_fast_targets():
    """ρ1 (where the whole circle opens) lies beyond lss·vt/(vo − vt) at 0.9 and the profile
    narrows to the wall's half-width."""
    rho, alpha = radial_profile(0.9, 1.0, span=1.0)
    assert rho[0] >= 0.9 / 0.1
    assert alpha[0] == math.pi and alpha[-1] == pytest.approx(math.pi / 5)
    assert np.all(np.diff(alpha) <= 0)


@pytest.mark.slow
def test_radial_field_certified_at_0_9_in_a_wide_room_only():
    """The 10 x 10 room at vt/vo = 0.9: certified with lss = 0.15 (a room 67 lss wide), and
    no radial field with lss = 1 (the whole circle would open 12.5 lss out, beyond the
    walls); the certified field's states are checked again by random rods."""
    from tether.arcs import rod_is_free_many

    room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])
    ck = radial_field(room, 0.15, 0.9, 1.0, h=0.075)
    assert ck.certified
    frac, _ = ck.safe_fraction(4000)
    assert 0.3 < frac < 0.7
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 10, size=(4000, 2))
    lo, hi, ok = ck.arcs(pts)
    a = lo + rng.uniform(0, 1, len(pts)) * (hi - lo)
    assert rod_is_free_many(room, pts[ok], a[ok], 0.15).all()
    assert not radial_field(room, 1.0, 0.9, 1.0, h=0.5).certified
