"""The cutting-plane search skips an end whose gradient is too gentle for any heading to
violate it: that needs a lower bound of every end bound the search computes
(``window_floor``), checked here against the bounds themselves over random windows, and the
skip itself checked against the search without it (the same rows, round by round)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field

import tether.game.field_lp as field_lp
from tether.game.certificate import heading_window_min, window_floor, window_min_at


@pytest.mark.parametrize(("vt", "sgn"), [(0.3, -1.0), (0.3, 1.0), (0.6, -1.0), (0.9, 1.0)])
def test_the_floor_bounds_every_window_and_is_reached(vt, sgn):
    rng = np.random.default_rng(0)
    x0 = rng.uniform(-10, 10, 20_000)
    x1 = x0 + rng.exponential(0.5, x0.size) * rng.integers(0, 2, x0.size)
    floor = window_floor(vt, 1.0, sgn)
    assert (window_min_at(x0, x1, vt, 1.0, sgn) >= floor).all()
    assert (heading_window_min(x0[:500], x1[:500], 256, vt, 1.0, sgn) >= floor).all()
    # a whole turn holds the table's minimum: the floor is the bound of such a window
    assert window_min_at(np.zeros(1), np.full(1, 7.0), vt, 1.0, sgn)[0] == floor
    # and f itself never goes below it (sampled densely)
    x = np.linspace(0, 2 * np.pi, 200_001)
    f = np.sqrt(1 - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x)
    assert f.min() >= floor


def test_the_skip_changes_no_row(monkeypatch):
    """The search with the skip and with a floor so low that nothing is skipped add the same
    end rows in the same rounds (10 x 10 room, h 1, vt 0.6: steep and gentle ends both)."""
    space, lss, f = corner_room_first_field(0.6)
    orig_solve, orig_floor = field_lp._RoundLP.solve, field_lp.window_floor
    orig_min = field_lp.heading_window_min

    def rows(floor_shift: float) -> tuple[list, int]:
        seen, searched = [], [0]

        def solve(self, *a):
            seen.append(self.have.copy())
            return orig_solve(self, *a)

        def counted(amin, *a):
            searched[0] += len(amin)
            return orig_min(amin, *a)

        with monkeypatch.context() as m:
            m.setattr(field_lp._RoundLP, "solve", solve)
            m.setattr(field_lp, "window_floor", lambda *a: orig_floor(*a) - floor_shift)
            m.setattr(field_lp, "heading_window_min", counted)
            field_lp.lp_field(space, f.points, f.tri, f.lo, f.w, lss, 0.6, 1.0, rounds=4,
                              base_steep=0.0)  # every base row: the skip alone
        return seen, searched[0]

    (with_skip, n_skip), (without, n_all) = rows(0.0), rows(1e3)
    assert len(with_skip) == len(without) == 4
    for a, b in zip(with_skip, without, strict=True):
        assert np.array_equal(a, b)
    assert n_skip < n_all  # the skip skips something
