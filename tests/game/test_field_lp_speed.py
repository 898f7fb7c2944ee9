"""The faster search of the certified field (issue #22, "Speed"): the bounds it uses against
dense sampling, the free windows from cached spans against the rod test, and the warm-started
LP against certify (the judge) and against a silent stdout."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from tether import Environment
from tether.arcs import rod_is_free_many
from tether.game.certificate import heading_window_min, window_min, window_min_at
from tether.game.field_lp import free_windows, triangle_spans, windows_of_spans


def _dense_min(x0: np.ndarray, x1: np.ndarray, vt: float, sgn: float) -> np.ndarray:
    """``min over x in [x0, x1]`` of ``sqrt(1 − vt²cos²x) + sgn·vt·sin x``, 1001 samples."""
    out = np.full(np.broadcast(x0, x1).shape, np.inf)
    for q in np.linspace(0, 1, 1001):
        x = x0 + q * (x1 - x0)
        out = np.minimum(out, np.sqrt(1 - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x))
    return out


@pytest.mark.parametrize("sgn", [-1.0, 1.0])
@pytest.mark.parametrize("vt", [0.3, 0.9])
def test_heading_window_min_is_a_lower_bound(sgn, vt):
    """The bound at the headings 2πj/H is never above the minimum over a densely sampled
    orientation range (short, long, over a full turn), and close to it."""
    rng = np.random.default_rng(11)
    amin = rng.uniform(-10, 10, 24)
    amax = amin + np.concatenate([rng.uniform(0, 0.05, 8), rng.uniform(0, 7, 16)])
    th = np.linspace(0, math.tau, 32, endpoint=False)
    bound = heading_window_min(amin, amax, 32, vt, 1.0, sgn)
    dense = _dense_min(th[None, :] - amax[:, None], th[None, :] - amin[:, None], vt, sgn)
    assert (bound <= dense + 1e-12).all()
    assert (dense - bound).max() < 0.01


def test_heading_window_min_needs_a_divisor():
    with pytest.raises(ValueError, match="does not divide"):
        heading_window_min(np.zeros(1), np.ones(1), 300, 0.3, 1.0, 1.0)


@pytest.mark.parametrize("sgn", [-1.0, 1.0])
def test_window_min_at_is_a_lower_bound_elementwise(sgn):
    """The element-wise bound (the LP's end rows, one per row) against dense sampling, and
    the same numbers as the table form at the same windows."""
    rng = np.random.default_rng(12)
    x0 = rng.uniform(-20, 20, 150)
    x1 = x0 + np.concatenate([rng.uniform(0, 1e-3, 50), rng.uniform(0, 8, 100)])
    bound = window_min_at(x0, x1, 0.6, 1.0, sgn)
    assert (bound <= _dense_min(x0, x1, 0.6, sgn) + 1e-12).all()
    th = np.array([0.7])
    assert np.array_equal(window_min(-x1 + 0.7, -x0 + 0.7, th, 0.6, 1.0, sgn)[:, 0],
                          window_min_at(th[0] - (0.7 - x0), th[0] - (0.7 - x1), 0.6, 1.0,
                                        sgn))


def test_windows_from_cached_spans_are_free_by_the_rod_test():
    """Windows of the spans computed once, for several references (as the search's rounds
    use them): every orientation inside is free by the rod test from sampled points of the
    triangle, and the same windows as free_windows."""
    env = Environment([(0, 0), (6, 0), (6, 6), (0, 6)], holes=[[(2, 2), (4, 2), (4, 4), (2, 4)]])
    rng = np.random.default_rng(3)
    base = rng.uniform(0.2, 1.6, size=(40, 1, 2)) + rng.uniform(0, 4.2, size=(40, 1, 2))
    tri = base + rng.uniform(-0.15, 0.15, size=(40, 3, 2))
    tri = tri[shapely.contains(env.polygon, shapely.polygons(tri))]
    spans = triangle_spans(env, tri, 1.0)
    for ref in (np.zeros(len(tri)), rng.uniform(-math.pi, math.pi, len(tri))):
        f_lo, f_hi = windows_of_spans(spans, ref, len(tri))
        g_lo, g_hi = free_windows(env, tri, ref, 1.0)
        assert np.array_equal(f_lo, g_lo) and np.array_equal(f_hi, g_hi)
        for t, lo, hi in zip(tri, f_lo, f_hi, strict=True):
            if not lo < hi:
                continue
            w = rng.dirichlet(np.ones(3), 30)
            p = w @ t
            a = np.linspace(max(lo, -10), min(hi, 10), 24)[1:-1]
            pp, aa = np.repeat(p, len(a), axis=0), np.tile(a, len(p))
            assert rod_is_free_many(env, pp, aa, 1.0).all()


def test_lp_rounds_are_silent(capfd):
    """Two rounds of the warm-started LP on a small room write nothing on stdout or stderr
    (highspy's ``Highs`` class prints a banner on stdout: the CLI's --json output must stay
    clean), and keep every field end inside its trust region."""
    from tether.game import surveillance_kernel
    from tether.game.certificate import first_field
    from tether.game.field_lp import lp_field

    room = Environment([(0, 0), (4, 0), (4, 4), (0, 4)], name="room")
    f = first_field(surveillance_kernel(room, 1.0, 0.3, 1.0, h=0.5, orientations=90))
    capfd.readouterr()
    r = lp_field(room, f.points, f.tri, f.lo, f.w, 1.0, 0.3, 1.0, rounds=2, rho=0.1)
    assert capfd.readouterr() == ("", "")
    assert r.rounds == 2 or r.slack == 0.0
    assert np.abs(r.lo - f.lo).max() <= 2 * 0.1 + 1e-6


@pytest.mark.slow
def test_search_prints_nothing_and_certifies(capfd):
    """The warm-started search on a small room: the field it returns passes certify, the
    record has the time split, and nothing is written on stdout or stderr."""
    from tether.game.certified import certified_kernel

    room = Environment([(0, 0), (6, 0), (6, 6), (0, 6)], name="room")
    ck = certified_kernel(room, 1.0, 0.3, 1.0, h=0.5)
    assert capfd.readouterr() == ("", "")
    assert ck.certified
    tries = [e for e in ck.log if "rounds" in e]
    assert tries and all(e["t_lp"] >= 0 and e["t_certify"] >= 0 for e in tries)
