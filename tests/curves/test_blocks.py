"""The curves computed in blocks (bounded memory, issue 25) are those computed all at once:
every curve's critical intervals computed alone, every polyline drawn alone, the D lines'
pole pairs found one row of the distance matrix at a time."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, STAR_HOLE

import tether.curves.critical as critical
import tether.curves.draw as draw
import tether.curves.families as families
from tether.curves import candidate_families, critical_curves
from tether.curves.critical import critical_intervals
from tether.curves.draw import draw_all, overshoot_family
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL

PLAN = floor_plan(60, seed=0)
PLAN_LSS = (PLAN.bounds[2] - PLAN.bounds[0]) / 15


def inner_families(env, lss):
    inner = env.internal
    return inner, candidate_families(inner, lss * env.frame.scale)


def assert_same_in_blocks(env, lss, block, monkeypatch):
    inner, fams = inner_families(env, lss)
    whole = [critical_intervals(inner, fam) for fam in fams]
    monkeypatch.setattr(critical, "SAMPLE_BLOCK", block)
    monkeypatch.setattr(critical, "_FIRST_BLOCK", 1)
    assert [critical_intervals(inner, fam) for fam in fams] == whole
    assert sum(len(fam) for fam in fams) > 50  # many blocks were made


@pytest.mark.slow
@pytest.mark.parametrize(("env", "lss"), [(PLAN, PLAN_LSS), (STAR_HOLE, 1.5)])
def test_intervals_of_each_curve_alone(env, lss, monkeypatch):
    assert_same_in_blocks(env, lss, 1, monkeypatch)


def test_conchoid_intervals_in_blocks(monkeypatch):
    inner, fams = inner_families(GENERIC, 2.5)
    fam = fams[-1]
    assert fam.kind == "E" and len(fam) > 10
    whole = critical_intervals(inner, fam)
    monkeypatch.setattr(critical, "SAMPLE_BLOCK", 150)  # a few curves a block
    monkeypatch.setattr(critical, "_FIRST_BLOCK", 1)
    assert critical_intervals(inner, fam) == whole
    assert any(whole)


def test_polylines_of_each_curve_alone(monkeypatch):
    inner, fams = inner_families(GENERIC, 2.5)
    tol = REL_CURVE_TOL * inner.diameter
    found = []
    for fam in fams:
        found += overshoot_family(fam, critical_intervals(inner, fam), 20 * tol)
    whole = draw_all(found, tol)
    monkeypatch.setattr(draw, "DRAW_BLOCK", 1)  # one curve a block
    alone = draw_all(found, tol)
    assert {f.kind for f, _, _ in found} >= set("ABCE")
    assert len(alone) == len(whole) == len(found)
    for a, b in zip(alone, whole, strict=True):
        assert len(a) == len(b)
        for (ta, pa), (tb, pb) in zip(a, b, strict=True):
            assert np.array_equal(ta, tb) and np.array_equal(pa, pb)


def dense_reflex_pairs(env, R, L):
    """The former computation: the whole distance matrix of the poles at once."""
    V = env.vertices
    diff = V[R][:, None, :] - V[R][None, :, :]
    dist = np.linalg.norm(diff, axis=2)
    a, b = np.nonzero((dist < L - env.length_tol) & (dist > 0))
    first, nxt, n = env.coincident, env.next_vertex, env.n
    edges = np.concatenate((first * n + first[nxt], first[nxt] * n + first))
    keep = ~np.isin(first[R[a]] * n + first[R[b]], edges)
    a, b = a[keep], b[keep]
    return a, b, diff[a, b] / dist[a, b][:, None], dist[a, b]


@pytest.mark.parametrize(("env", "lss", "block"), [(PLAN, PLAN_LSS, 1), (PLAN, PLAN_LSS, 97),
                                                   (GENERIC, 6.0, 5)])
def test_reflex_pairs_in_row_blocks(env, lss, block, monkeypatch):
    inner = env.internal
    L = lss * env.frame.scale
    R = families._poles(inner)
    want = dense_reflex_pairs(inner, R, L)
    monkeypatch.setattr(families, "_PAIR_BLOCK", block)
    got = families._reflex_pairs(inner, R, L)
    assert len(want[0]) > 0
    for x, y in zip(got, want, strict=True):
        assert x.dtype == y.dtype and np.array_equal(x, y)


@pytest.mark.slow
def test_critical_curves_in_small_blocks(monkeypatch):
    whole = critical_curves(GENERIC, 2.5)
    monkeypatch.setattr(critical, "SAMPLE_BLOCK", 300)
    monkeypatch.setattr(critical, "_FIRST_BLOCK", 4)
    monkeypatch.setattr(draw, "DRAW_BLOCK", 10)
    monkeypatch.setattr(families, "_PAIR_BLOCK", 3)
    small = critical_curves(GENERIC, 2.5)
    assert [(c.name, c.intervals) for c in small] == [(c.name, c.intervals) for c in whole]
    for c, d in zip(small, whole, strict=True):
        assert all(np.array_equal(p, q) for p, q in zip(c.polylines, d.polylines, strict=True))
