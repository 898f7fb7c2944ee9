"""The decomposition against exact arcs at sampled points, completeness along random segments,
random polygons, and the hand-derived curve examples of math.md §7."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from conftest import (
    GENERIC,
    L_SHAPE,
    SQUARE_HOLE,
    STAR_HOLE,
    interior_points,
    random_maps,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether import Environment, free_arcs, free_arcs_many, load_map
from tether.arcs import TWO_PI
from tether.decomposition import check, decompose, sample_in_regions, structures
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan

CASES = [(SQUARE_HOLE, 2.0), (L_SHAPE, 3.0), (STAR_HOLE, 1.5), (GENERIC, 2.5),
         (floor_plan(50, seed=3), 0.8)]


class _LazyDecompositions(dict):
    """The cases' decompositions by (map name, lss), each built when a selected test first asks
    for it (collecting the tests builds none)."""

    def __init__(self, cases):
        super().__init__()
        self.cases = {(e.name, lss): (e, lss) for e, lss in cases}

    def __iter__(self):
        return iter(self.cases)

    def __missing__(self, key):
        got = self[key] = decompose(*self.cases[key])
        return got


DECS = _LazyDecompositions(CASES)


@pytest.fixture(params=list(DECS), ids=lambda k: f"{k[0]}-{k[1]}")
def dec(request):
    return DECS[request.param]


@pytest.mark.slow
def test_sampled_points_have_their_regions_structure(dec):
    pts, owner = sample_in_regions(dec, 25, seed=1)
    assert len(pts) > 10 * len(dec.regions)
    found = structures(dec.env, free_arcs_many(dec.env, pts, dec.lss, check=False), len(pts))
    bad = [i for i, s in enumerate(found) if s != dec.regions[owner[i]].structure]
    assert not bad
    assert check(dec, 10).ok


def test_regions_tile_the_free_space(dec):
    areas = np.array([r.area for r in dec.regions])
    assert areas.sum() == pytest.approx(dec.env.area, rel=1e-9)
    union = shapely.union_all([r.polygon for r in dec.regions])
    assert union.area == pytest.approx(dec.env.area, rel=1e-9)  # no overlaps, no gaps
    assert union.symmetric_difference(dec.env.polygon).area < 1e-9 * dec.env.area


@pytest.mark.slow
def test_region_names_and_cells_are_consistent(dec):
    assert [r.name for r in dec.regions] == [f"R{k}" for k in range(len(dec.regions))]
    assert len(dec.cells) == sum(len(r.cells) for r in dec.regions)
    for r in dec.regions:
        n = len(free_arcs(dec.env, r.point, dec.lss).arcs) or (1 if r.structure == "FULL" else 0)
        assert len(r.cells) == n
    assert dec.region_at([dec.regions[3].point])[0] == 3


@pytest.mark.slow
def test_cell_at_agrees_with_the_arcs(dec):
    rng = np.random.default_rng(4)
    pts = interior_points(dec.env, 400, seed=9)
    ang = rng.uniform(0, TWO_PI, len(pts))
    got = dec.cell_at(pts, ang)
    table = free_arcs_many(dec.env, pts, dec.lss)
    located = 0
    for i, cid in enumerate(got):
        fa_rows = table.rows_of(i)
        free = bool(table.full[i]) or any(
            (ang[i] - s) % TWO_PI <= (e - s) % TWO_PI
            for s, e in zip(table.start[fa_rows], table.end[fa_rows], strict=True))
        if cid is None:
            assert not free or dec.region_at([pts[i]])[0] < 0
            continue
        located += 1
        cell = dec.cell(cid)
        assert dec.regions[cell.region].polygon.contains(shapely.Point(pts[i]))
        fa = free_arcs(dec.env, pts[i], dec.lss)
        arc = [a for a in fa.arcs if a.contains(ang[i])]
        assert fa.full or (arc[0].start_feature, arc[0].end_feature) == (
            cell.start_feature, cell.end_feature)
    assert located > 100


def change_points(env, lss, a, b, n=400):
    """Where the exact structure changes along segment a-b (bisection to 1e-12)."""
    t = np.linspace(0, 1, n)
    pts = a + t[:, None] * (b - a)
    st_ = structures(env, free_arcs_many(env, pts, lss, check=False), n)
    out = []
    for k in np.flatnonzero([st_[i] != st_[i + 1] for i in range(n - 1)]):
        lo, hi, s_lo = t[k], t[k + 1], st_[k]
        for _ in range(45):
            mid = 0.5 * (lo + hi)
            s = structures(env, free_arcs_many(env, [a + mid * (b - a)], lss, check=False), 1)[0]
            lo, hi = (mid, hi) if s == s_lo else (lo, mid)
        out.append(a + 0.5 * (lo + hi) * (b - a))
    return out


#: The larger maps' completeness runs take 1.5-2.5 s each: slow tier.
_SLOW_MAPS = {"generic", "plan-50-3"}


@pytest.mark.slow
@pytest.mark.parametrize("key", [k for k in DECS if k[0] not in _SLOW_MAPS],
                         ids=lambda k: f"{k[0]}-{k[1]}")
def test_every_structure_change_lies_on_a_critical_curve(key):
    _structure_changes_on_curves(DECS[key])


@pytest.mark.slow
@pytest.mark.parametrize("key", [k for k in DECS if k[0] in _SLOW_MAPS],
                         ids=lambda k: f"{k[0]}-{k[1]}")
def test_every_structure_change_lies_on_a_critical_curve_larger_maps(key):
    _structure_changes_on_curves(DECS[key])


def _structure_changes_on_curves(dec):
    """Completeness: along random segments, every change of the exact structure happens on
    the curves' linework, and on a region boundary."""
    env = dec.env
    rng = np.random.default_rng(5)
    lines = shapely.union_all([shapely.LineString(p) for c in dec.curves for p in c.polylines])
    bounds = shapely.union_all([r.polygon.boundary for r in dec.regions])
    found = 0
    pts = interior_points(env, 40, seed=6)
    for i in range(0, len(pts) - 1, 2):
        a, b = pts[i], pts[i + 1]
        if not env.polygon.covers(shapely.LineString([a, b])):
            continue
        for x in change_points(env, dec.lss, a, b):
            found += 1
            assert lines.distance(shapely.Point(x)) < 3 * dec.curve_tol
            assert bounds.distance(shapely.Point(x)) < 3 * dec.curve_tol
    assert found > 5
    del rng


@pytest.mark.slow
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.5, 6.0))
def test_random_polygons_decompose_consistently(env, lss):
    d = decompose(env, lss)
    assert sum(r.area for r in d.regions) == pytest.approx(env.area, rel=1e-8)
    assert shapely.union_all([r.polygon for r in d.regions]).area == pytest.approx(env.area,
                                                                                 rel=1e-8)
    rep = check(d, 8)
    if not rep.ok:
        import json
        import os
        if os.environ.get("TETHER_DUMP"):
            with open(os.environ["TETHER_DUMP"], "a") as f:
                f.write(json.dumps({"map": env.to_dict(), "lss": lss}) + "\n")
    assert rep.ok, (lss, rep.point_disagreements[:2], rep.piece_disagreements[:2])


# ---------------------------------------------------------------------- hand-derived cases
ROOM = [[0, 0], [12, 0], [12, 12], [0, 12]]


def sides(d, p, normal, eps=1e-4):
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    p = np.asarray(p, float)
    r = d.region_at([p + eps * n, p - eps * n])
    assert (r >= 0).all()
    return [d.regions[k].cells for k in r]


def piece_at(d, p):
    return min(d.pieces, key=lambda pc: pc.geometry.distance(shapely.Point(p)))


def test_type_a_offset():
    d = DECS[("square_hole", 2.0)]
    above, below = sides(d, (9, 2), (0, 1))
    assert [c.split(",", 1)[1] for c in above] == ["*,*)"]
    assert [c.split(",", 1)[1] for c in below] == ["E0,E0)"]
    piece = piece_at(d, (9, 2))
    # the floor's offset coincides with the offset of the hole's bottom edge E7 (y = 2)
    assert piece.kind == "A" and set(piece.features) == {"E0", "E7"}


def test_type_b_and_c():
    d = DECS[("square_hole", 2.0)]
    r = np.array([math.cos(math.radians(100)), math.sin(math.radians(100))])
    out, inside = sides(d, np.array([6, 6]) + 2 * r, r)
    assert out[0].endswith(",E5,E5)") and inside[0].endswith(",V6,E5)")
    assert piece_at(d, np.array([6, 6]) + 2 * r).kind == "B"
    up, down = sides(d, (7, 6), (0, 1))
    assert up[0].endswith(",E6,E5)") and down[0].endswith(",E6,V6)")
    assert piece_at(d, (7, 6)).kind == "C"


@pytest.mark.slow
def test_type_d_same_and_opposite_sides():
    env = Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],
                             [[4, 2], [4, 2.8], [5, 2.8], [5, 2]]))
    d = decompose(env, 3.0)
    v6, v10 = np.array([3, 3.0]), np.array([5, 2.8])
    u = (v6 - v10) / np.linalg.norm(v6 - v10)
    a, b = sides(d, v6 + 0.5 * u, (-u[1], u[0]))
    assert {a[0].split(",", 1)[1], b[0].split(",", 1)[1]} == {"V6,E3)", "V10,E3)"}
    assert "D" in piece_at(d, v6 + 0.5 * u).kind
    env = Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],
                             [[4.5, 2.5], [4.5, 3.5], [5.5, 3.5], [5.5, 2.5]]))
    d = decompose(env, 3.0)
    v8 = np.array([4.5, 2.5])
    u = (v6 - v8) / np.linalg.norm(v6 - v8)
    a, b = sides(d, v6 + 0.5 * u, (-u[1], u[0]))
    assert sorted([len(a), len(b)]) == [1, 2]
    assert any(c.endswith(",V6,V8)") for c in a + b)


def test_type_e_conchoid():
    p = np.array([2.226499, 4.160251])
    u = np.array([3, 3.0]) - p
    d = decompose(Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],)), 5.0)
    a, b = sides(d, p, (-u[1], u[0]))
    assert {a[0].split(",", 1)[1], b[0].split(",", 1)[1]} == {"E0,E3)", "V6,E3)"}
    assert piece_at(d, p).kind == "E"


# ---------------------------------------------------------------------- the paper's examples
def near(d, corner, radius=1.5):
    win = shapely.Point(*corner).buffer(radius)
    regs = [r for r in d.regions if r.polygon.intersects(win)]
    return len(regs), sum(len(r.cells) for r in regs)


def test_paper_convex_corner_has_6_regions_and_6_cells_at_the_corner():
    d = decompose(load_map(example_path("convex_corner")), 1.0)
    assert near(d, (0, 0)) == (6, 6)


def test_paper_nonconvex_corner_has_5_regions_and_6_cells_at_the_corner():
    d = decompose(load_map(example_path("nonconvex_corner")), 1.0)
    assert near(d, (0, 0)) == (5, 6)


@pytest.mark.slow
def test_rectangle_is_symmetric_under_swapping_sides():
    for w, h in [(1.0, 1.5), (0.6, 0.8), (2.0, 1.2)]:  # includes exact coincidences
        a = decompose(Environment([[0, 0], [w, 0], [w, h], [0, h]]), 1.0)
        b = decompose(Environment([[0, 0], [h, 0], [h, w], [0, w]]), 1.0)
        assert (len(a.regions), len(a.cells)) == (len(b.regions), len(b.cells))
        assert check(a, 10).ok and check(b, 10).ok
