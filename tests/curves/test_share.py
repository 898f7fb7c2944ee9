"""The vectorized sharing of vertices among straight curves on one line (``share_lines``,
``_line_groups``) against the former group-by-group, polyline-by-polyline loops, kept here as
the reference: the very same polylines and parameters, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, SQUARE_HOLE, STAR_HOLE

import tether.curves as C
import tether.curves.share as S
from tether.curves import Curve
from tether.examples.floorplan import floor_plan
from tether.tolerances import ANGLE_TOL, REL_CURVE_TOL


def reference_line_groups(theta, offset, tol):
    th = np.where(theta > np.pi / 2 - 1e-9, theta - np.pi, theta)
    off = np.where(theta > np.pi / 2 - 1e-9, -offset, offset)
    order = np.argsort(th, kind="stable")
    groups = []
    start = 0
    for j in range(1, len(order) + 1):
        if j == len(order) or th[order[j]] - th[order[j - 1]] > ANGLE_TOL:
            run = order[start:j]
            run = run[np.argsort(off[run], kind="stable")]
            cut = np.flatnonzero(np.diff(off[run]) > tol) + 1
            groups += [g.tolist() for g in np.split(run, cut)]
            start = j
    return groups


def reference_share_lines(curves, tol):
    straight = [k for k, c in enumerate(curves) if c.kind in "ACD"]
    if len(straight) < 2:
        return curves
    fam_d = np.array([curves[k].family.d[curves[k].index] for k in straight])
    fam_p = np.array([curves[k].family.p[curves[k].index] for k in straight])
    u = fam_d / np.linalg.norm(fam_d, axis=1)[:, None]
    flip = (u[:, 0] < 0) | ((u[:, 0] == 0) & (u[:, 1] < 0))
    u[flip] *= -1
    theta = np.arctan2(u[:, 1], u[:, 0])
    offset = u[:, 0] * fam_p[:, 1] - u[:, 1] * fam_p[:, 0]
    out = list(curves)
    for group in reference_line_groups(theta, offset, tol):
        if len(group) < 2:
            continue
        base = fam_p[group[0]]
        uu = u[group[0]]
        pts = np.vstack([p for g in group for p in curves[straight[g]].polylines])
        along = (pts - base) @ uu
        order = np.argsort(along, kind="stable")
        pts, along = pts[order], along[order]
        distinct = np.r_[True, np.diff(along) > tol]
        pts, along = pts[distinct], along[distinct]
        for g in group:
            k = straight[g]
            c = curves[k]
            fam, i = c.family, c.index
            dd = fam.d[i]
            polys, params = [], []
            for poly in c.polylines:
                a = (poly - base) @ uu
                lo, hi = a.min(), a.max()
                i0 = np.searchsorted(along, lo + tol, side="right")
                i1 = max(i0, np.searchsorted(along, hi - tol, side="left"))
                merged = np.vstack((poly[[int(np.argmin(a))]], pts[i0:i1],
                                    poly[[int(np.argmax(a))]]))
                if a[0] > a[-1]:
                    merged = merged[::-1]
                polys.append(merged)
                params.append((merged - fam.p[i]) @ dd / (dd @ dd))
            out[k] = Curve(c.id, c.kind, c.features, c.domain, c.intervals, tuple(polys),
                           tuple(params), fam, i, c.frame)
    return out


def unshared_curves(env, lss, monkeypatch):
    """The internal curves before ``_share_lines`` and its tolerance."""
    got = {}

    def grab(curves, tol):
        got["args"] = (curves, tol)
        return curves

    with monkeypatch.context() as mp:
        mp.setattr(C, "share_lines", grab)
        C.critical_curves(env.internal, lss * env.frame.scale, REL_CURVE_TOL)
    return got["args"]


def assert_same(a, b):
    assert len(a) == len(b)
    shared = 0
    for x, y in zip(a, b, strict=True):
        assert x.id == y.id and len(x.polylines) == len(y.polylines)
        for p, q in zip(x.polylines + x.params, y.polylines + y.params, strict=True):
            assert p.shape == q.shape and np.array_equal(p, q)
        shared += sum(len(p) > 2 for p in x.polylines) if x.kind in "ACD" else 0
    return shared


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5),
                                          (floor_plan(150, seed=1), 1.0),
                                          (floor_plan(200, seed=4), 1.5)])
@pytest.mark.slow
def test_share_lines_equals_reference(env, lss, monkeypatch):
    curves, tol = unshared_curves(env, lss, monkeypatch)
    assert assert_same(S.share_lines(curves, tol), reference_share_lines(curves, tol)) >= 0


@pytest.mark.slow
def test_share_lines_shares_on_floor_plans(monkeypatch):
    """On a floor plan many lines carry several curves: vertices are shared, the same ones."""
    env = floor_plan(200, seed=4)
    curves, tol = unshared_curves(env, (env.bounds[2] - env.bounds[0]) / 15, monkeypatch)
    assert assert_same(S.share_lines(curves, tol), reference_share_lines(curves, tol)) > 20


def test_line_groups_equals_reference():
    rng = np.random.default_rng(5)
    # clusters of nearly equal angles and offsets, some across +-pi/2
    theta = np.concatenate((rng.choice([-np.pi / 2 + 1e-12, 0.3, np.pi / 2, 1.0], 400)
                            + rng.normal(0, 1e-10, 400), rng.uniform(-1.5, 1.5, 100)))
    theta = np.clip(theta, -np.pi / 2 + 1e-15, np.pi / 2)
    offset = rng.choice([0.0, 1.0, 1.0 + 1e-10, -2.0], 500) + rng.normal(0, 1e-11, 500)
    for tol in (1e-12, 1e-9, 1e-3):
        assert S._line_groups(theta, offset, tol) == reference_line_groups(theta, offset, tol)
