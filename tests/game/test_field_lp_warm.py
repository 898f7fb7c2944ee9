"""The search's LP is one HiGHS model re-solved from its last basis after its bounds move,
cutting planes add rows and core vertices are released (``tether.game.field_lp._RoundLP``):
the warm re-solve must reach the same optimum as a model built afresh with the same rows,
core and bounds and solved cold. Checked on the 10 x 10 room's coarse mesh (h 1), with bounds
and right-hand sides drawn at random."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field

from tether.game.certificate import hat_gradients
from tether.game.field_lp import _RoundLP

HEADINGS = 32


def _objective(model: _RoundLP) -> float:
    return float(model.h.getInfo().objective_function_value)


@pytest.fixture(scope="module")
def room():
    space, lss, f = corner_room_first_field(0.6)
    nv = len(f.points)
    xy = f.points[f.tri]
    e1, e2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    det = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    area_v = np.zeros(nv)
    np.add.at(area_v, f.tri.ravel(), np.repeat(det / 6, 3))
    core = f.w >= 2 * np.pi - 1e-9
    et = np.flatnonzero(~core[f.tri].all(axis=1))
    return f, hat_gradients(xy), core, area_v / area_v.mean(), et, lss * 0.6


def _columns(model: _RoundLP) -> np.ndarray:
    """The model's own columns at its last solution (``solve`` returns ``x``, ``y`` and the
    slacks, not the split columns the costs are given for)."""
    return np.asarray(model.h.getSolution().col_value)


def _rhs(model: _RoundLP, per_row: np.ndarray) -> np.ndarray:
    """The end rows' right-hand sides in ``model``'s row order, from one per (triangle,
    heading, end)."""
    return per_row[model.row_t, model.row_h, (model.row_s > 0).astype(int)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_warm_and_cold_reach_the_same_optimum(room, seed):
    f, hat, core, area_v, et, k = room
    rng = np.random.default_rng(seed)
    th = np.linspace(0, 2 * np.pi, HEADINGS, endpoint=False)
    u = np.stack([np.cos(th), np.sin(th)], 1)
    cut = np.zeros((len(f.tri), HEADINGS, 2), bool)
    cut[:, ::8] = True  # 4 base headings
    warm = _RoundLP(f.tri, hat, core, area_v, k, HEADINGS)
    for _ in range(3):  # rounds: new cutting planes, new bounds, warm re-solves
        warm.add_cuts(cut, u, et)
        # random moves (within 0.1 to 0.3 rad) and end right-hand sides
        rho, nv = rng.uniform(0.1, 0.3), len(f.points)
        b = (np.full(nv, -rho), np.full(nv, rho))
        per_row = rng.uniform(-0.5, 0.5, cut.shape)
        status, z_warm = warm.solve(b, b, f.w, _rhs(warm, per_row))
        assert status is None
        cold = _RoundLP(f.tri, hat, core, area_v, k, HEADINGS)
        cold.add_cuts(warm.have, u)  # the same rows, added at once (in another order)
        assert len(cold.row_t) == len(warm.row_t)
        status, z_cold = cold.solve(b, b, f.w, _rhs(cold, per_row))
        assert status is None
        assert _objective(warm) == pytest.approx(_objective(cold), rel=1e-7, abs=1e-6)
        # the optimum's value, recomputed from the columns and the costs
        cost = np.asarray(cold.h.getLp().col_cost_)
        assert float(cost @ _columns(warm)) == pytest.approx(_objective(cold), rel=1e-7, abs=1e-6)
        cut |= rng.random(cut.shape) < 0.03  # the next round's cutting planes


@pytest.mark.parametrize("seed", [0, 1])
def test_a_release_in_the_warm_model_reaches_the_cold_optimum(room, seed):
    """A release of core vertices keeps the model (``_RoundLP.release``: their ``x = y`` rows
    become free; the end rows of the triangles it makes end-checked are added): the warm
    re-solve must reach the optimum of a model built with the smaller core from the start."""
    f, hat, core, area_v, _, k = room
    rng = np.random.default_rng(10 + seed)
    th = np.linspace(0, 2 * np.pi, HEADINGS, endpoint=False)
    u = np.stack([np.cos(th), np.sin(th)], 1)
    cut = np.zeros((len(f.tri), HEADINGS, 2), bool)
    cut[:, ::8] = True
    cut |= rng.random(cut.shape) < 0.02
    nv = len(f.points)
    b = (np.full(nv, -0.2), np.full(nv, 0.2))
    per_row = rng.uniform(-0.5, 0.5, cut.shape)
    warm = _RoundLP(f.tri, hat, core, area_v, k, HEADINGS)
    et = np.flatnonzero(~core[f.tri].all(axis=1))
    warm.add_cuts(cut, u, et)
    assert warm.solve(b, b, f.w, _rhs(warm, per_row))[0] is None
    freed = np.flatnonzero(core)[rng.random(int(core.sum())) < 0.3]
    assert len(freed)
    small = core.copy()
    small[freed] = False
    et2 = np.flatnonzero(~small[f.tri].all(axis=1))
    assert len(et2) > len(et)  # the release makes triangles end-checked
    warm.release(freed)
    warm.add_cuts(cut, u, np.setdiff1d(et2, et))
    status, z_warm = warm.solve(b, b, f.w, _rhs(warm, per_row))
    assert status is None
    cold = _RoundLP(f.tri, hat, small, area_v, k, HEADINGS)
    cold.add_cuts(cut, u, et2)
    assert len(cold.row_t) == len(warm.row_t)
    status, z_cold = cold.solve(b, b, f.w, _rhs(cold, per_row))
    assert status is None
    assert _objective(warm) == pytest.approx(_objective(cold), rel=1e-7, abs=1e-6)
    # the released vertices may open: the optimum uses it somewhere (x != y)
    assert np.abs(z_warm[freed] - z_warm[nv + freed]).max() > 1e-6
    cost = np.asarray(cold.h.getLp().col_cost_)
    assert float(cost @ _columns(warm)) == pytest.approx(_objective(cold), rel=1e-7, abs=1e-6)
