"""Adaptive refinement against independent checks: the refined mesh's conformity (every edge
in two triangles or on a wall, the boundary as long as the walls, the area the free area), the
field carried over as the same set-valued map (arcs compared at random points), certified
where the parent is (the exact checks run again), and the whole loop on a room: the band
counted state by state, the file read back, runs of the certified controller with the
simulator's monitor, and a map moved by a power of two giving the same refined mesh."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from conftest import L_SHAPE, SQUARE_HOLE, lattice_states

from tether import Environment
from tether.errors import InvalidParameterError
from tether.game import surveillance_kernel
from tether.game.band import undecided_band
from tether.game.certificate import ArcField, certify, free_mesh
from tether.game.certified import CertifiedKernel, certified_kernel, load_certified
from tether.game.refine import (
    bisect,
    free_near_split,
    longest_edge_first,
    mark_triangles,
    refine_certified,
    refine_field,
)

ROOM = Environment([(0, 0), (10, 0), (10, 10), (0, 10)], name="room")
LSS, VT, VO = 1.0, 0.3, 1.0


def _lattice(env: Environment, h: float) -> np.ndarray:
    x0, y0, x1, y1 = env.bounds
    gx, gy = np.meshgrid(np.arange(x0, x1 + h / 2, h), np.arange(y0, y1 + h / 2, h))
    return np.column_stack([gx.ravel(), gy.ravel()])


def _conforms(env: Environment, points: np.ndarray, tri: np.ndarray) -> None:
    """Every edge lies in two triangles or on a wall (a hanging node would leave an interior
    edge in one triangle), the one-triangle edges add up to the walls' length, the triangles
    are counter-clockwise and cover the free area."""
    xy = points[tri]
    det = ((xy[:, 1, 0] - xy[:, 0, 0]) * (xy[:, 2, 1] - xy[:, 0, 1])
           - (xy[:, 1, 1] - xy[:, 0, 1]) * (xy[:, 2, 0] - xy[:, 0, 0]))
    assert (det > 0).all()
    assert 0.5 * det.sum() == pytest.approx(env.polygon.area, rel=1e-9)
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edges, count = np.unique(e, axis=0, return_counts=True)
    assert count.max() <= 2
    one = edges[count == 1]
    a, b = points[one[:, 0]], points[one[:, 1]]
    tol = 1e-9 * max(1.0, float(np.abs(points).max()))
    for q in (a, b, (a + b) / 2):
        assert env.boundary_distance(q[:, 0], q[:, 1]).max() <= tol
    assert np.hypot(*(b - a).T).sum() == pytest.approx(env.polygon.boundary.length, rel=1e-9)


def test_bisect_pins_the_closure():
    """Two triangles sharing their refinement edge: marking one cuts both at the middle of the
    shared edge. The children's refinement edges are the square's sides: marking one cuts
    that side alone; marking all four cuts the four sides."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    tri = np.array([[0, 1, 2], [3, 2, 1]])
    p, t, e = bisect(pts, tri, [0])
    assert p[4].tolist() == [0.5, 0.5] and e.tolist() == [[1, 2]] and len(t) == 4
    square = Environment([(0, 0), (1, 0), (1, 1), (0, 1)])
    _conforms(square, p, t)
    assert (t[:, 0] == 4).all()  # the new vertex is every child's newest
    p2, t2, e2 = bisect(p, t, [0])
    _conforms(square, p2, t2)
    assert len(e2) == 1 and len(t2) == 5
    p3, t3, _ = bisect(p, t, np.ones(len(t), bool))
    _conforms(square, p3, t3)
    assert len(t3) == 8


@pytest.mark.parametrize("env,h", [(L_SHAPE, 1.0), (SQUARE_HOLE, 1.0)])
def test_random_refinement_conforms_and_keeps_the_walls(env, h):
    """Five rounds of random marks (a third of the triangles each) on the free mesh: the mesh
    stays conforming, on the walls, of the free area; the wall's vertices stay vertices."""
    pts, tri, _ = free_mesh(env, h, _lattice(env, h))
    tri = longest_edge_first(pts, tri)
    _conforms(env, pts, tri)
    rng = np.random.default_rng(1)
    for _ in range(5):
        pts, tri, _ = bisect(pts, tri, rng.random(len(tri)) < 1 / 3)
        _conforms(env, pts, tri)
    corners = np.concatenate([np.asarray(r.coords)[:-1] for r in
                              [env.polygon.exterior, *env.polygon.interiors]])
    assert (np.hypot(*(pts[None, :, :] - corners[:, None, :]).transpose(2, 0, 1)).min(axis=1)
            == 0).all()


def test_triangle_at_a_reflex_wall_vertex_pinned():
    """The triangles at the L's reflex corner (4, 4), split three times: the corner stays a
    vertex, the new wall vertices lie on the two walls that meet there, and the mesh still
    follows the walls (every wall piece an edge or a chain of edges)."""
    pts, tri, _ = free_mesh(L_SHAPE, 1.0, _lattice(L_SHAPE, 1.0))
    tri = longest_edge_first(pts, tri)
    corner = np.array([4.0, 4.0])
    for _ in range(3):
        at = np.flatnonzero(np.hypot(*(pts - corner).T) == 0)
        assert len(at) == 1
        n0 = len(pts)
        pts, tri, edges = bisect(pts, tri, (tri == at[0]).any(axis=1))
        _conforms(L_SHAPE, pts, tri)
        on_wall = L_SHAPE.boundary_distance(pts[n0:, 0], pts[n0:, 1]) <= 1e-12
        both_on_wall = (L_SHAPE.boundary_distance(pts[edges, 0].ravel(), pts[edges, 1].ravel())
                        .reshape(-1, 2) <= 1e-12).all(axis=1)
        assert (on_wall >= both_on_wall).all()  # an edge along a wall halves on the wall
    star = np.flatnonzero((tri == np.flatnonzero((pts == corner).all(axis=1))[0]).any(axis=1))
    assert np.hypot(*(pts[tri[star]] - corner).reshape(-1, 2).T).max() <= 0.5 + 1e-12


def _interior_field(wrap: bool, full: bool) -> ArcField:
    """A field on a mesh of the room's middle, [3, 7]², where every rod of length 1 is free:
    ends varying slowly (gradients at most 0.4), ``lo`` wrapped across ±π where ``wrap``, a
    few whole-circle vertices where ``full``."""
    g = np.arange(3.0, 7.01, 0.5)
    pts = np.array([(x, y) for y in g for x in g])
    from scipy.spatial import Delaunay

    tri = Delaunay(pts).simplices
    xy = pts[tri]
    det = ((xy[:, 1, 0] - xy[:, 0, 0]) * (xy[:, 2, 1] - xy[:, 0, 1])
           - (xy[:, 1, 1] - xy[:, 0, 1]) * (xy[:, 2, 0] - xy[:, 0, 0]))
    tri = np.where((det < 0)[:, None], tri[:, [0, 2, 1]], tri)
    lo = 0.3 * np.sin(pts[:, 0]) + 0.2 * pts[:, 1] + (2.3 if wrap else 0.0)
    lo = np.mod(lo + math.pi, math.tau) - math.pi
    w = 1.5 + 0.3 * np.cos(pts[:, 0] + pts[:, 1])
    if full:
        w[np.hypot(pts[:, 0] - 5, pts[:, 1] - 5) < 0.8] = math.tau
    return ArcField(pts, longest_edge_first(pts, tri), lo, w)


def _arcs(f: ArcField, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The arc of ``f`` at each point: ``(lo mod 2π, width)``."""
    from tether.game.certificate import Checks

    ok = np.ones(len(f.tri), bool)
    z = ~ok
    ck = CertifiedKernel(ROOM, LSS, VT, VO, 0.5, f, Checks(z, z, z, z, ok))
    lo, hi, inside = ck.arcs(q)
    assert inside.all()
    return np.mod(lo, math.tau), hi - lo


@pytest.mark.parametrize("wrap,full", [(False, False), (True, False), (True, True)])
def test_carried_field_is_the_same_map(wrap, full):
    """Refined twice (random marks) without the LP, the field's arc at 2,000 random points of
    the mesh is the parent's (ends to 1e-9 rad, widths too), ends lifted across ±π and
    whole-circle vertices included."""
    f = _interior_field(wrap, full)
    rng = np.random.default_rng(3)
    g = refine_field(f, rng.random(len(f.tri)) < 0.5)
    g = refine_field(g, rng.random(len(g.tri)) < 0.5)
    q = rng.uniform(3.0, 7.0, size=(2000, 2))
    lo_f, w_f = _arcs(f, q)
    lo_g, w_g = _arcs(g, q)
    assert np.abs(np.mod(lo_g - lo_f + math.pi, math.tau) - math.pi).max() < 1e-9
    assert np.abs(w_g - w_f).max() < 1e-9


def test_certified_interior_field_stays_certified():
    """A field the exact checks pass (on the room's middle) passes them after three rounds of
    refinement without the LP, and a field that fails some triangle fails only inside it."""
    f = _interior_field(True, False)
    assert certify(f, ROOM, LSS, VT, VO).passed
    rng = np.random.default_rng(4)
    g = f
    for _ in range(3):
        g = refine_field(g, rng.random(len(g.tri)) < 0.4)
        assert certify(g, ROOM, LSS, VT, VO).passed
    bad = ArcField(f.points, f.tri, f.lo.copy(), f.w.copy())
    k = 40  # one vertex's lower end pulled far down: its star's lower end is too steep
    bad.lo[k] -= 1.2
    bad.w[k] += 1.2
    c = certify(bad, ROOM, LSS, VT, VO)
    assert c.bad.any()
    star = shapely.union_all(shapely.polygons(f.points[f.tri[c.bad]])).buffer(1e-9)
    h = refine_field(bad, np.ones(len(bad.tri), bool))
    ch = certify(h, ROOM, LSS, VT, VO)
    cen = h.points[h.tri[ch.bad]].mean(axis=1)
    assert shapely.contains_xy(star, cen[:, 0], cen[:, 1]).all()


def test_bad_budgets_are_one_line_errors():
    with pytest.raises(InvalidParameterError, match="max_rounds"):
        refine_certified(None, None, max_rounds=-1)
    with pytest.raises(InvalidParameterError, match="band width"):
        refine_certified(None, None, width=float("nan"))
    with pytest.raises(InvalidParameterError, match="ring"):
        refine_certified(None, None, ring=-1)
    with pytest.raises(InvalidParameterError, match="ring"):
        refine_certified(None, None, search_ring=1.5)


# --- the loop on a room (slow) -------------------------------------------------------------

SMALL = Environment([(0, 0), (6, 0), (6, 6), (0, 6)], name="room6")


@pytest.fixture(scope="module")
def refined():
    ck = certified_kernel(SMALL, LSS, VT, VO, h=0.5)
    assert ck.certified
    outer = surveillance_kernel(SMALL, LSS, VT, VO, h=0.5, scheme="outer")
    rk = refine_certified(ck, outer, max_rounds=1)
    return ck, outer, rk


@pytest.mark.slow
def test_refined_room_is_certified_and_its_band_counts_match_contains(refined):
    """One round on the 6 x 6 room: certified, the band narrower than the uniform mesh's, the
    counts against the two kernels' own ``contains`` state by state, the mesh conforming, and
    the uniform field carried over without the LP certified with the same answers."""
    ck, outer, rk = refined
    assert rk.certified and rk.refined == 1
    assert len(rk.refine_log) == 2 and rk.refine_log[1]["kept"] == "lp"
    _conforms(rk.space, rk.field.points, rk.field.tri)
    band, band0 = undecided_band(rk, outer), undecided_band(ck, outer)
    assert band.undecided_states < band0.undecided_states
    _, safe, maybe = lattice_states(rk, outer)
    assert band.certified_states == int(safe.sum())
    assert band.undecided_states == int((maybe & ~safe).sum())
    assert band.contradictions == int((safe & ~maybe).sum()) == 0
    # the uniform field carried over without the LP: certified, the same answers
    carried = refine_field(ck.field, mark_triangles(ck, outer))
    assert certify(carried, *ck.game).passed
    rng = np.random.default_rng(6)
    q = rng.uniform(0, 6, size=(3000, 2))
    a = rng.uniform(0, math.tau, 3000)
    ok = np.abs(ck.margin(q, a)) > 1e-9
    twin = CertifiedKernel(ck.env, LSS, VT, VO, 0.5, carried, certify(carried, *ck.game),
                           frame=ck.frame, space=ck.space)
    assert (twin.contains(q[ok], a[ok]) == ck.contains(q[ok], a[ok])).all()


@pytest.mark.slow
def test_widening_moves_only_near_the_split(refined):
    """The round's LP moved only the vertices of the split triangles and one ring around them:
    every other vertex (all of them old ones) keeps the uniform field's arc bit for bit, some
    free vertex widened, and the field is certified (``test_refined_room_...`` checks it
    state by state)."""
    ck, _, rk = refined
    n_old = len(ck.field.points)
    free = free_near_split(rk.field.tri, n_old)
    assert (free[n_old:]).all() and not free.all()
    held = np.flatnonzero(~free)
    assert np.array_equal(rk.field.lo[held], ck.field.lo[held])
    # w comes back as hi − lo: a whole circle's (lo + 2π) − lo may lose one ulp
    np.testing.assert_allclose(rk.field.w[held], ck.field.w[held], rtol=0, atol=1e-12)
    old_free = np.flatnonzero(free[:n_old])
    assert (rk.field.w[old_free] > ck.field.w[old_free] + 1e-6).any()
    assert rk.certified and rk.refine_log[1]["kept"] == "lp"


@pytest.mark.slow
def test_search_ring_repairs_a_failing_field_locally(refined):
    """A certified field spoilt at three vertices next to a wall (their arcs turned by 0.6
    rad): with ``search_ring=1`` the search moves only the split triangles' vertices and one
    ring around them (every other vertex keeps its arc, ``lo`` bit for bit). It does not
    repair this field in one round (what it keeps fails elsewhere): the local search is
    cheaper, not a cure by itself."""
    ck, outer, _ = refined
    f = ck.field
    d = SMALL.boundary_distance(*ck.frame.to_user(f.points).T)
    spoil = np.argsort(np.where(d > 0.2, d, np.inf))[:3]
    lo = f.lo.copy()
    lo[spoil] += 0.6
    bad = ArcField(f.points, f.tri, lo, f.w.copy())
    checks = certify(bad, *ck.game)
    assert not checks.passed
    spoilt = CertifiedKernel(ck.env, LSS, VT, VO, 0.5, bad, checks, frame=ck.frame,
                             space=ck.space)
    rk = refine_certified(spoilt, outer, max_rounds=1, search_ring=1)
    n_old = len(f.points)
    free = free_near_split(rk.field.tri, n_old, 1)
    held = np.flatnonzero(~free)
    assert len(held) > n_old // 2
    assert np.array_equal(rk.field.lo[held], bad.lo[held])
    assert np.allclose(rk.field.w[held], bad.w[held], rtol=0, atol=1e-12)  # w = hi − lo
    assert rk.refine_log[1]["kept"] == "search" and not rk.certified


def test_free_near_split_against_adjacency():
    """On a randomly bisected mesh: ring 0 is the vertices of the triangles holding a new
    vertex; each ring adds exactly the vertices sharing a triangle with a free one (brute
    force over the vertices)."""
    pts, tri, _ = free_mesh(L_SHAPE, 1.0, _lattice(L_SHAPE, 1.0))
    tri = longest_edge_first(pts, tri)
    rng = np.random.default_rng(3)
    p, t, _ = bisect(pts, tri, rng.random(len(tri)) < 0.2)
    n_old = len(pts)
    want = np.zeros(len(p), bool)
    for row in t:
        if (row >= n_old).any():
            want[row] = True
    near = [set() for _ in range(len(p))]  # the vertices sharing a triangle with each
    for row in t.tolist():
        for v in row:
            near[v].update(row)
    for ring in range(3):
        assert np.array_equal(free_near_split(t, n_old, ring), want)
        want = np.array([any(want[u] for u in near[v]) for v in range(len(p))])


@pytest.mark.slow
def test_refined_field_reads_back_and_holds_against_every_target(refined, tmp_path):
    """The refined kernel saved and read back (checked again) answers as before; the certified
    controller from certified starts of it, against every target kind, never loses with the
    simulator's monitor on."""
    from tether.game.controller import CertifiedController
    from tether.sim.protocols import World
    from tether.sim.simulate import simulate
    from tether.strategies import TARGETS, make_target

    _, _, rk = refined
    rk.save(tmp_path / "r.npz")
    back = load_certified(tmp_path / "r.npz")
    assert back.certified and back.refined == 1 and back.refine_log == rk.refine_log
    assert np.array_equal(back.field.tri, rk.field.tri)
    rng = np.random.default_rng(7)
    q = rng.uniform(0, 6, size=(2000, 2))
    a = rng.uniform(0, math.tau, 2000)
    assert (back.contains(q, a) == rk.contains(q, a)).all()
    lo, hi, ok = rk.arcs(q)
    # starts near the walls, where the refined mesh is, and the band was
    near = ok & (SMALL.boundary_distance(q[:, 0], q[:, 1]) < 1.0)
    kinds = sorted(set(TARGETS) - {"path", "track", "pedestrian"})
    for i, kind in zip(np.flatnonzero(near)[:len(kinds)], kinds, strict=False):
        start = (float(q[i, 0]), float(q[i, 1]), float((lo[i] + hi[i]) / 2))
        world = World(SMALL, lss=LSS, vt=VT, vo=VO)
        res = simulate(world, CertifiedController(back), make_target(kind, world), start,
                       duration=4.0, dt=0.02, seed=i)
        assert res.held, (kind, start)
        assert (back.margin(res.trace.p, res.trace.a) >= -1e-9).all()


@pytest.mark.slow
def test_map_moved_by_a_power_of_two_gives_the_same_refined_mesh(refined):
    """The room translated by (2**20, -2**18): the search works in the map's normalized frame,
    so the refined mesh is the same, vertex for vertex."""
    _, _, rk = refined
    off = np.array([2.0 ** 20, -2.0 ** 18])
    moved = Environment([tuple(off + np.array(p)) for p in [(0, 0), (6, 0), (6, 6), (0, 6)]])
    ck = certified_kernel(moved, LSS, VT, VO, h=0.5)
    outer = surveillance_kernel(moved, LSS, VT, VO, h=0.5, scheme="outer")
    mk = refine_certified(ck, outer, max_rounds=1)
    assert mk.certified
    assert np.array_equal(mk.field.points, rk.field.points)
    assert np.array_equal(mk.field.tri, rk.field.tri)
