"""Thin walls and gaps: below tether's resolution (REL_FEATURE_TOL x diameter) a map is rejected
with a message naming the vertex, the wall and the limit; just above it, check agrees."""

from __future__ import annotations

import math

import pytest

from tether import Environment, InvalidMapError
from tether.decomposition import check, decompose
from tether.tolerances import REL_FEATURE_TOL

SQUARE = [[0, 0], [10, 0], [10, 10], [0, 10]]
DIAM = 10 * math.sqrt(2)


def thin_hole(w: float) -> Environment:
    """A needle-thin vertical wall (a hole w wide, 4 long) in the square."""
    return Environment(SQUARE, ([[5, 3], [5 + w, 3], [5 + w, 7], [5, 7]],), "thin_hole")


def thin_spike(w: float) -> Environment:
    """A needle-thin wall from the top of the square down to y = 4."""
    return Environment([[0, 0], [10, 0], [10, 10], [5 + w, 10], [5 + w, 4], [5, 4], [5, 10],
                        [0, 10]], (), "thin_spike")


def narrow_gap(w: float) -> Environment:
    """A hole whose right side is w away from the square's right wall."""
    return Environment(SQUARE, ([[6, 3], [10 - w, 3], [10 - w, 7], [6, 7]],), "gap")


@pytest.mark.parametrize("make", [thin_hole, thin_spike, narrow_gap])
def test_below_resolution_is_rejected_with_names(make):
    with pytest.raises(InvalidMapError, match=r"V\d+ is .* from wall E\d+: .*resolution"):
        make(0.8 * REL_FEATURE_TOL * DIAM)


@pytest.mark.slow
@pytest.mark.parametrize("make", [thin_hole, thin_spike, narrow_gap])
@pytest.mark.parametrize("rel", [1.2, 3.0])
@pytest.mark.parametrize("lss", [2.0, 3.3])
def test_just_above_resolution_checks(make, rel, lss):
    env = make(rel * REL_FEATURE_TOL * DIAM)
    assert check(decompose(env, lss), 6).ok


def test_collinear_chain_is_not_a_thin_wall():
    """Dense straight vertices are no features: their short edges are not thin walls."""
    bottom = [[10 * k / 2001, 0.0] for k in range(1, 2001)]
    env = Environment([[0, 0], *bottom, [10, 0], [10, 10], [0, 10]], ())
    assert int(env.straight.sum()) == 2000
