"""``lp_field(fixed=...)``, the search local to some vertices that refinement runs: held
vertices keep their reference ends exactly, the others move as the LP finds; an all-False
mask is the search over the whole mesh, and a bad mask is a one-line error."""

from __future__ import annotations

import numpy as np
import pytest

from tether import Environment
from tether.errors import InvalidParameterError
from tether.game.certificate import free_mesh
from tether.game.field_lp import lp_field

ROOM4 = Environment([(0, 0), (4, 0), (4, 4), (0, 4)], name="room4")
LSS, VT, VO = 1.0, 0.3, 1.0


@pytest.fixture(scope="module")
def mesh():
    lattice = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
    pts, tri, _ = free_mesh(ROOM4, 1.0, lattice)
    lo = np.full(len(pts), 1.0)  # rods from 1 to 3 rad: free at the bottom wall, not the top
    w = np.full(len(pts), 2.0)
    return pts, tri, lo, w


def _moved(r, lo, w) -> np.ndarray:
    return np.flatnonzero((r.lo != lo) | (r.hi != lo + w))


def test_only_the_free_vertex_moves(mesh):
    """Without ``fixed`` several vertices move; with every vertex but one fixed, for each of
    those that moved, only that one moves (its ends, exactly; the others bit for bit)."""
    pts, tri, lo, w = mesh
    whole = lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=2)
    moved = _moved(whole, lo, w)
    assert len(moved) >= 4
    alone = []
    for i in moved:
        fixed = np.ones(len(pts), bool)
        fixed[i] = False
        r = lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=2, fixed=fixed)
        assert set(_moved(r, lo, w).tolist()) <= {int(i)}
        alone += _moved(r, lo, w).tolist()
    assert len(alone) >= 2  # some vertex can widen with its whole star held


def test_all_false_is_the_whole_search(mesh):
    pts, tri, lo, w = mesh
    a = lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=3)
    b = lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=3,
                 fixed=np.zeros(len(pts), bool))
    assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi)


def test_half_fixed_keeps_that_half(mesh):
    """The left half held (x < 2): it keeps its ends, the right half is searched."""
    pts, tri, lo, w = mesh
    fixed = pts[:, 0] < 2.0
    r = lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=3, fixed=fixed)
    assert np.array_equal(r.lo[fixed], lo[fixed])
    assert np.array_equal(r.hi[fixed], (lo + w)[fixed])
    assert len(_moved(r, lo, w)) > 0


@pytest.mark.parametrize("bad", [np.ones(3, bool), np.ones(41, int)])
def test_bad_mask_is_a_one_line_error(mesh, bad):
    pts, tri, lo, w = mesh
    assert len(pts) == 41
    with pytest.raises(InvalidParameterError, match="fixed must be a bool mask"):
        lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=1, fixed=bad)
