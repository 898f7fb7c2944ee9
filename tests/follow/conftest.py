"""Fixtures of the follower tests: an L-shaped corridor (1 wide) and a person walking round its
corner (``track``), so that an observer left behind in the first arm loses sight of them."""

from __future__ import annotations

import numpy as np
import pytest

from tether import Environment
from tether.io.tracks import Track

#: Horizontal arm y in [0, 1], x in [0, 6]; vertical arm x in [5, 6], y up to 6. V4 = (5, 1).
CORRIDOR = Environment([(0, 0), (6, 0), (6, 6), (5, 6), (5, 1), (0, 1)], (), "corridor")


def corner_track(x0: float = 4.0, speed: float = 0.5, duration: float = 16.0) -> Track:
    """Along y = 0.5 from x0 to the corner at x = 5.5, then up x = 5.5 (to y = 5.5)."""
    t = np.arange(0.0, duration + 1e-9, 0.25)
    d = x0 + speed * t
    xy = np.where((d <= 5.5)[:, None], np.column_stack((d, np.full_like(d, 0.5))),
                  np.column_stack((np.full_like(d, 5.5), np.minimum(0.5 + d - 5.5, 5.5))))
    return Track(t, xy, "corner")


@pytest.fixture
def corridor() -> Environment:
    """The L-shaped corridor."""
    return CORRIDOR


@pytest.fixture
def track() -> Track:
    """The person walking round the corridor's corner at 0.5 map units/s."""
    return corner_track()
