"""The undecided band against brute force: the counts against the two kernels' own
``contains`` state by state, the reach against a scan of every lattice point of the slice."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import lattice_states

from tether import Environment
from tether.game import surveillance_kernel
from tether.game.band import lattice_classes, undecided_band

ROOM = Environment([(0, 0), (6, 0), (6, 6), (0, 6)], name="room6")


class _LeftOf:
    """A stand-in certified kernel: the states with ``x < cut`` (map units)."""

    def __init__(self, cut: float) -> None:
        self.cut = cut

    def contains(self, points, angles) -> np.ndarray:
        return np.asarray(points, dtype=float).reshape(-1, 2)[:, 0] < self.cut


@pytest.fixture(scope="module")
def outer():
    return surveillance_kernel(ROOM, 1.0, 0.3, 1.0, h=0.5, orientations=24, scheme="outer")


def _brute_reach(outer, undecided: np.ndarray) -> np.ndarray:
    """Distance of each undecided state to the nearest decided lattice point of its bin, by
    measuring it to every point of the lattice grown by one ring (points off the grid's free
    points are decided)."""
    g = outer.grid
    ny, nx, _ = g.shape
    iy, ix = np.mgrid[-1:ny + 1, -1:nx + 1]
    lattice = np.column_stack([ix.ravel(), iy.ravel()])
    out = []
    for k in range(undecided.shape[1]):
        und = g.ij[undecided[:, k]]
        if not len(und):
            continue
        is_und = (lattice[:, None, :] == und[None, :, :]).all(axis=2).any(axis=1)
        d = np.hypot(*(und[:, None, :] - lattice[None, ~is_und, :]).transpose(2, 0, 1))
        out.append(d.min(axis=1) * g.h)
    return np.concatenate(out)


@pytest.mark.parametrize("cut", [2.0, 3.3, 100.0, -1.0])
def test_band_counts_and_reach_against_brute_force(outer, cut):
    ck = _LeftOf(cut)
    band = undecided_band(ck, outer)
    g = outer.grid
    free, safe, maybe = lattice_states(ck, outer)
    assert band.free_states == int(free.sum())
    assert band.certified_states == int(safe.sum())
    assert band.undecided_states == int((maybe & ~safe).sum())
    assert band.unsafe_states == int((free & ~maybe & ~safe).sum())
    assert band.contradictions == int((safe & ~maybe).sum())
    assert band.volume == pytest.approx(band.undecided_states * g.h ** 2 * math.tau / g.n_a)
    _, undecided = lattice_classes(ck, outer)
    if band.undecided_states == 0:
        assert band.reach == band.reach_95 == band.share == 0.0
        return
    brute = _brute_reach(outer, undecided)
    assert band.reach == pytest.approx(brute.max())
    assert band.reach_95 == pytest.approx(np.percentile(brute, 95))




@pytest.mark.slow
def test_band_of_a_certified_room_brackets_and_is_thin():
    """The 10 x 10 room at vt/vo = 0.3, h = 0.5: no certified state outside the optimistic
    kernel, and every undecided state within two lattice steps of a decided one."""
    from tether.game.certified import certified_kernel

    room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)], name="room")
    ck = certified_kernel(room, 1.0, 0.3, 1.0, h=0.5)
    assert ck.certified
    outer10 = surveillance_kernel(room, 1.0, 0.3, 1.0, h=0.5, scheme="outer")
    band = undecided_band(ck, outer10)
    assert band.contradictions == 0
    assert 0 < band.undecided_states < band.certified_states
    assert band.reach <= 2 * band.h
