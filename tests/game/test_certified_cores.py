"""The radius a whole-circle core needs (``docs/certified.md``, "Where no field is
certified"): a core whose small gap points at its own centre passes the end check on a circle
of radius ``lss·vt/(vo + vt)`` around it, well inside the search's ``vortex_radius``; the
bound of :func:`~tether.game.certificate.end_slack` (itself tested against brute force in
``test_certificate.py``) says so, and fails just inside that radius."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether.game.certificate import MARGIN, end_slack
from tether.game.field_lp import aligned_radius, vortex_radius

LSS, VO = 1.0, 1.0


def _slacks(rho: float, vt: float) -> np.ndarray:
    """The lower and upper ends' slack bounds at 8 points of the circle of radius ``rho``:
    both ends at ``ψ + π`` (the gap points at the centre), turning at ``1/rho`` along it."""
    psi = np.linspace(0.0, math.tau, 8, endpoint=False)
    g = np.stack([-np.sin(psi), np.cos(psi)], axis=1) / rho
    a = psi + math.pi
    return np.concatenate([end_slack(g, a, a, LSS, vt, VO, upper) for upper in (False, True)])


@pytest.mark.parametrize("vt", [0.3, 0.6, 0.9])
def test_an_aligned_core_needs_only_lss_vt_over_vo_plus_vt(vt):
    rho = aligned_radius(LSS, vt, VO)
    assert rho == pytest.approx(LSS * vt / (VO + vt))
    assert (_slacks(1.05 * rho, vt) >= MARGIN).all()
    assert (_slacks(0.95 * rho, vt) < 0).any()
    r_v = vortex_radius(LSS, vt, VO)
    assert r_v < 0 or r_v > 1.05 * rho  # the search's model asks for more (or has none)


@pytest.mark.slow
def test_above_one_over_root_two_every_core_size_is_one_search():
    """``vortex_radius`` is negative above ``vt/vo = 1/√2``: every core size of ``CORE_TRIES``
    then starts from the same core (all whole-circle vertices) and protects nothing, so the
    searches are the same (checked on the 10 x 10 room, h 1, 3 rounds) and ``solve_field``
    runs one."""
    from tether.examples import path as example_path
    from tether.game import surveillance_kernel
    from tether.game.certificate import first_field
    from tether.game.field_lp import CORE_TRIES, lp_field, solve_field
    from tether.io import load_map

    env = load_map(example_path("nonconvex_corner"))
    space, s, vt = env.internal, env.frame.scale, 0.9
    kern = surveillance_kernel(space, s, vt, VO, h=1.0 * s, orientations=90)
    f = first_field(kern)
    r_v = vortex_radius(s, vt, VO)
    assert r_v < 0
    ends = [lp_field(space, f.points, f.tri, f.lo, f.w, s, vt, VO, rounds=3,
                     core_radius=q * r_v) for q in CORE_TRIES[:2]]
    assert np.array_equal(ends[0].lo, ends[1].lo) and np.array_equal(ends[0].hi, ends[1].hi)
    _, _, log = solve_field(space, kern, s, vt, VO, rounds=3)
    assert [e["core"] for e in log] == [CORE_TRIES[0]]
