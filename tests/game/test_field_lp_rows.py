"""The search's end rows (issue #22, "Speed"): per triangle and end, evenly spaced base
headings plus the cutting planes of the headings that violate most (paired across the two
ends by default), and a core vertex whose boxes cannot meet held at its reference instead of
making the LP infeasible. Independent checks: the rows are counted from the model itself, and every
returned field is judged by ``certify``-free geometry (its ends stay within the trust
region and the free windows)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether import Environment
from tether.game import field_lp
from tether.game.certificate import free_mesh

LSS, VT, VO = 1.0, 0.3, 1.0
ROOM4 = Environment([(0, 0), (4, 0), (4, 4), (0, 4)], name="room4")


@pytest.fixture(scope="module")
def mesh():
    lattice = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
    pts, tri, _ = free_mesh(ROOM4, 1.0, lattice)
    return pts, tri


def _rows(monkeypatch, **kw):
    """The end rows (triangle, heading, end) each round's model holds, from the model."""
    seen = []
    orig = field_lp._RoundLP.solve

    def solve(self, *a):
        seen.append(self.have.copy())
        return orig(self, *a)

    monkeypatch.setattr(field_lp._RoundLP, "solve", solve)
    return seen


def test_unmovable_vertices_are_those_without_a_feasible_move():
    """A vertex is held when no ``(x, y)`` in its boxes exists (``x = y`` at a core vertex):
    checked against a brute-force search of a fine grid of each box (the office map's first
    LP was infeasible at one core vertex whose boxes were each nonempty but disjoint)."""
    rng = np.random.default_rng(0)
    n = 400
    x_lb, y_lb = rng.uniform(-0.25, 0.1, n), rng.uniform(-0.25, 0.1, n)
    x_ub, y_ub = x_lb + rng.uniform(-0.05, 0.3, n), y_lb + rng.uniform(-0.05, 0.3, n)
    core = rng.random(n) < 0.5
    bad = field_lp._unmovable(x_lb, x_ub, y_lb, y_ub, core)
    s = np.linspace(0, 1, 401)
    for i in range(n):
        xs = x_lb[i] + s * (x_ub[i] - x_lb[i])
        ys = y_lb[i] + s * (y_ub[i] - y_lb[i])
        if x_ub[i] < x_lb[i] or y_ub[i] < y_lb[i]:
            ok = False
        elif core[i]:
            ok = bool(((xs >= y_lb[i]) & (xs <= y_ub[i])).any()
                      or ((ys >= x_lb[i]) & (ys <= x_ub[i])).any())
        else:
            ok = True
        assert bad[i] == (not ok), i
    assert (core & bad & (x_lb <= x_ub) & (y_lb <= y_ub)).any()  # the office's case occurs


@pytest.mark.parametrize("base", [0, 2, 8])
def test_rows_are_base_headings_and_cuts_per_end(mesh, monkeypatch, base):
    """With ``base_steep`` 0 the first round's model holds exactly ``base`` evenly spaced
    headings per triangle and end (``tests/game/test_field_lp_steep.py``: the default, only
    the steep triangles')."""
    pts, tri = mesh
    lo = np.full(len(pts), 1.0)
    w = np.full(len(pts), 2.0)
    seen = _rows(monkeypatch)
    field_lp.lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=1, base_headings=base,
                      seed_cuts=False, base_steep=0.0)
    have = seen[0]
    headings = have.shape[1]
    per = have.sum(axis=1)  # (triangles, 2): rows per end
    assert (per == base).all()
    if base:
        assert have[:, ::headings // base].all()


def test_seeded_cuts_are_only_violated_headings(mesh, monkeypatch):
    """With no base headings, the seeded rows are at most one heading per triangle and
    end, and each is violated by the reference (its end bound below the margin's half)."""
    from tether.game.certificate import hat_gradients, heading_window_min, lifted_ends

    pts, tri = mesh
    rng = np.random.default_rng(3)
    lo = rng.uniform(0, 2 * math.pi, len(pts))
    w = np.full(len(pts), 1.5)
    seen = _rows(monkeypatch)
    field_lp.lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=1, base_headings=0,
                      seed_cuts=True, paired_ends=False)
    have = seen[0]
    assert (have.sum(axis=1) <= 1).all() and have.any()
    Lt, Ht, _ = lifted_ends(lo, w, tri)
    hat = hat_gradients(pts[tri])
    th = np.linspace(0, math.tau, have.shape[1], endpoint=False)
    U = np.stack([np.cos(th), np.sin(th)], 1)
    for end, (sgn, Z) in enumerate(((-1.0, Lt), (1.0, Ht))):
        t, hd = np.nonzero(have[:, :, end])
        S = heading_window_min(Z[t].min(1), Z[t].max(1), len(th), VT, VO, sgn)
        G = np.einsum("nvk,nv->nk", hat[t], Z[t])
        F = S[np.arange(len(t)), hd] + sgn * LSS * VT * (G * U[hd]).sum(1) - 0.03 / 2
        assert (F < 0).all()


def test_paired_ends_hold_the_same_headings(mesh, monkeypatch):
    """By default (``paired_ends``) every heading with a row for one end has one for the
    other, round after round; unpaired, the cutting planes of the two ends differ."""
    pts, tri = mesh
    rng = np.random.default_rng(3)
    lo = rng.uniform(0, 2 * math.pi, len(pts))
    w = np.full(len(pts), 1.5)
    seen = _rows(monkeypatch)
    field_lp.lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=3)
    assert len(seen) >= 2
    assert all((h[:, :, 0] == h[:, :, 1]).all() for h in seen)
    seen.clear()
    field_lp.lp_field(ROOM4, pts, tri, lo, w, LSS, VT, VO, rounds=3, paired_ends=False,
                      seed_cuts=True, base_headings=0)
    assert any((h[:, :, 0] != h[:, :, 1]).any() for h in seen)
