"""The search's LP splits each move into ``x = x⁺ − x⁻`` (``_RoundLP``) instead of bounding a
proximal column by ``p >= ±x`` rows: its optimum must be that of the LP of the module
docstring written out with those rows. Checked against that LP built here from the model's
own end rows and solved by ``scipy.optimize.linprog``, with random bounds, widths and
right-hand sides, core vertices and held (non-live) vertices, on the 10 x 10 room's coarse
mesh; the returned moves and slacks must be feasible for it and reach its optimum."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field
from scipy import sparse
from scipy.optimize import linprog

from tether.game.certificate import W_MIN, hat_gradients
from tether.game.field_lp import PENALTY, PROXIMAL, _RoundLP

HEADINGS = 32


def _row_lp(model, area_v, core, live, xb, yb, width, rhs):
    """The docstring's LP with proximal rows: variables x, y (nv), s (2 nt), p, q (nv);
    minimise area·x − area·y + PENALTY·s + PROXIMAL·area·(p + q) over live p, q."""
    nv, nt = model.nv, len(model.tri)
    n = 4 * nv + 2 * nt
    X, Y, S, P, Q = 0, nv, 2 * nv, 2 * nv + 2 * nt, 3 * nv + 2 * nt
    cost = np.zeros(n)
    cost[X:X + nv], cost[Y:Y + nv] = area_v, -area_v
    cost[S:S + 2 * nt] = PENALTY
    cost[P + live], cost[Q + live] = PROXIMAL * area_v[live], PROXIMAL * area_v[live]
    rows, ub = [], []
    a = sparse.lil_matrix((0, n))
    for i in live:  # widths and proximal rows
        for coef, b in (({X + i: 1, Y + i: -1}, width[i] - W_MIN),
                        ({X + i: -1, Y + i: 1}, 2 * np.pi - width[i]),
                        ({X + i: 1, P + i: -1}, 0.0), ({X + i: -1, P + i: -1}, 0.0),
                        ({Y + i: 1, Q + i: -1}, 0.0), ({Y + i: -1, Q + i: -1}, 0.0)):
            rows.append(coef)
            ub.append(b)
    u = np.stack([np.cos(np.linspace(0, 2 * np.pi, HEADINGS, endpoint=False)),
                  np.sin(np.linspace(0, 2 * np.pi, HEADINGS, endpoint=False))], 1)
    for r, (t, h, sg) in enumerate(zip(model.row_t, model.row_h, model.row_s, strict=True)):
        coef = model.hat[t] @ u[h]
        base = X if sg < 0 else Y
        row = {base + int(j): -sg * model.k * c for j, c in zip(model.tri[t], coef, strict=True)}
        row[S + 2 * int(t) + (sg > 0)] = -1.0
        rows.append(row)
        ub.append(rhs[r])
    a = sparse.lil_matrix((len(rows), n))
    for r, row in enumerate(rows):
        for j, c in row.items():
            a[r, j] += c
    ci = np.intersect1d(np.flatnonzero(core), live)
    eq = sparse.lil_matrix((len(ci), n))
    for r, i in enumerate(ci):
        eq[r, X + i], eq[r, Y + i] = 1.0, -1.0
    bounds = [(lo, hi) for lo, hi in zip(xb[0], xb[1], strict=True)]
    bounds += [(lo, hi) for lo, hi in zip(yb[0], yb[1], strict=True)]
    bounds += [(0, None)] * (2 * nt + 2 * nv)
    res = linprog(cost, A_ub=a.tocsr(), b_ub=np.array(ub), A_eq=eq.tocsr() if len(ci) else None,
                  b_eq=np.zeros(len(ci)) if len(ci) else None, bounds=bounds, method="highs")
    assert res.status == 0
    return res.fun, a.tocsr(), np.array(ub)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_split_lp_has_the_optimum_of_the_row_lp(seed):
    space, lss, f = corner_room_first_field(0.6)
    rng = np.random.default_rng(seed)
    nv, xy = len(f.points), f.points[f.tri]
    e1, e2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    area_v = np.zeros(nv)
    np.add.at(area_v, f.tri.ravel(), np.repeat(np.abs(e1[:, 0] * e2[:, 1]
                                                      - e1[:, 1] * e2[:, 0]) / 6, 3))
    area_v /= area_v.mean()
    core = (f.w >= 2 * np.pi - 1e-9) & (rng.random(nv) < 0.5)
    live = np.flatnonzero(rng.random(nv) < 0.85)
    model = _RoundLP(f.tri, hat_gradients(xy), core, area_v, lss * 0.6, HEADINGS, live)
    cut = rng.random((len(f.tri), HEADINGS, 2)) < 0.1
    et = np.flatnonzero(~core[f.tri].all(axis=1))
    model.add_cuts(cut, np.stack([np.cos(np.linspace(0, 2 * np.pi, HEADINGS, endpoint=False)),
                                  np.sin(np.linspace(0, 2 * np.pi, HEADINGS,
                                                     endpoint=False))], 1), et)
    # boxes of every sign, some wholly above or below 0; y's box holds x's (x = y is
    # feasible: the widths' rows hold at the reference)
    c = rng.uniform(-0.2, 0.2, nv)
    r = rng.uniform(0.0, 0.15, (2, nv))
    held = np.setdiff1d(np.arange(nv), live)
    xb, yb = [c - r[0], c + r[0]], [c - r[0] - r[1], c + r[0] + r[1]]
    for b in (xb, yb):
        b[0][held], b[1][held] = 0.0, 0.0
    core_live = core.copy()
    core_live[held] = False
    for b in (xb, yb):  # core vertices: boxes that meet (x = y)
        b[0][core_live], b[1][core_live] = -0.1, 0.1
    width = np.minimum(f.w, 2 * np.pi)
    rhs = rng.uniform(-0.3, 0.5, len(model.row_t))
    status, z = model.solve((xb[0], xb[1]), (yb[0], yb[1]), width, rhs)
    assert status is None
    want, a, ub = _row_lp(model, area_v, core, live, xb, yb, width, rhs)
    got = float(model.h.getInfo().objective_function_value)
    assert got == pytest.approx(want, rel=1e-7, abs=1e-6)
    # the returned x, y, s with p = |x|, q = |y| are feasible for the row LP and optimal
    nt = len(f.tri)
    x, y, s = z[:nv], z[nv:2 * nv], z[2 * nv:2 * nv + 2 * nt]
    p, q = np.zeros(nv), np.zeros(nv)
    p[live], q[live] = np.abs(x[live]), np.abs(y[live])
    v = np.concatenate([x, y, s, p, q])
    assert (a @ v <= ub + 1e-6).all()
    assert (x >= xb[0] - 1e-7).all() and (x <= xb[1] + 1e-7).all()
    assert np.allclose(x[core_live], y[core_live], atol=1e-7)
    cost = np.concatenate([area_v, -area_v, np.full(2 * nt, PENALTY),
                           PROXIMAL * np.where(np.isin(np.arange(nv), live), area_v, 0.0),
                           PROXIMAL * np.where(np.isin(np.arange(nv), live), area_v, 0.0)])
    assert float(cost @ v) == pytest.approx(want, rel=1e-7, abs=1e-6)
    assert (s > 1e-9).any() and (np.abs(x) > 1e-9).any()  # slacks and moves both occur
