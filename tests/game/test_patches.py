"""The field in patches (``tether.game.patches``) and the coarse field read on a fine mesh
(``certificate.interpolate_field``, ``first_field(coarse=...)``): a patch's LP never moves a
vertex outside the patch, a patch keeps its new arcs only when fewer of its triangles fail the
exact checks, degenerate patches are returned as they are, the interpolation reproduces a
linear field exactly, and on a small room the coarse-to-fine search ends with a field that
:func:`certify` passes on the whole fine mesh where the coarse field alone fails."""

from __future__ import annotations

import numpy as np
import pytest

from tether import Environment
from tether.errors import InvalidParameterError
from tether.game.certificate import ArcField, certify, first_field, free_mesh, interpolate_field
from tether.game.kernel import surveillance_kernel
from tether.game.patches import (
    clip_to_free,
    coarse_to_fine,
    lattice_points,
    patch_vertices,
    repair_patches,
    solve_patch,
)

ROOM4 = Environment([(0, 0), (4, 0), (4, 4), (0, 4)], name="room4")
LSS, VT, VO = 1.0, 0.3, 1.0


@pytest.fixture(scope="module")
def field():
    """Rods from 1 to 3 rad on the unit lattice of a 4 m room: blocked near the top wall."""
    lattice = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
    pts, tri, _ = free_mesh(ROOM4, 1.0, lattice)
    return ArcField(pts, tri, np.full(len(pts), 1.0), np.full(len(pts), 2.0))


@pytest.fixture(scope="module")
def passing():
    """The whole circle on the triangles of an 8 m room at least 2 m from its walls: every
    check passes (rods of 1 m stay inside; whole circles have no end condition)."""
    room = Environment([(0, 0), (8, 0), (8, 8), (0, 8)])
    lattice = np.stack(np.meshgrid(np.arange(9.0), np.arange(9.0)), -1).reshape(-1, 2)
    pts, tri, _ = free_mesh(room, 1.0, lattice)
    inner = ((pts[tri] >= 2) & (pts[tri] <= 6)).all(axis=(1, 2))
    good = ArcField(pts, tri[inner], np.full(len(pts), -1.0), np.full(len(pts), 2 * np.pi))
    assert len(good.tri) >= 16 and certify(good, room, LSS, VT, VO).passed
    return room, good


def test_a_patch_moves_only_its_free_vertices(field):
    """The lower half free, the rest (the ring of fixed vertices above it included) kept
    bit for bit; the patch's triangles fail no more than before, and the counts are those
    of ``certify`` run on the whole result."""
    bad = certify(field, ROOM4, LSS, VT, VO).bad
    assert bad.any()
    free = field.points[:, 1] < 1.5
    new, sub, before, after = solve_patch(ROOM4, field, free, LSS, VT, VO, rounds=3)
    assert np.array_equal(new.lo[~free], field.lo[~free])
    assert np.array_equal(new.w[~free], field.w[~free])
    assert np.array_equal(sub, np.flatnonzero(free[field.tri].any(axis=1)))
    assert after <= before == int(bad[sub].sum())
    assert int(certify(new, ROOM4, LSS, VT, VO).bad[sub].sum()) == after


def test_degenerate_patches_are_returned_as_they_are(field, passing):
    """No free vertex, or free vertices whose triangles all pass: the same field, no LP."""
    none = np.zeros(len(field.points), bool)
    new, sub, before, after = solve_patch(ROOM4, field, none, LSS, VT, VO)
    assert new is field and len(sub) == 0 and before == after == 0
    room, good = passing
    new, sub, before, after = solve_patch(room, good, np.ones(len(good.points), bool),
                                          LSS, VT, VO)
    assert new is good and len(sub) == len(good.tri) and before == after == 0
    with pytest.raises(InvalidParameterError, match="free must be a bool mask"):
        solve_patch(ROOM4, field, none[:3], LSS, VT, VO)


def test_repair_of_a_passing_field_changes_nothing(passing):
    room, good = passing
    out, checks, log = repair_patches(room, good, LSS, VT, VO)
    assert out is good and checks.passed and log == []
    with pytest.raises(InvalidParameterError, match="ring"):
        repair_patches(room, good, LSS, VT, VO, ring=-1)


def test_patch_vertices_grow_by_rings():
    tri = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 5, 6]])
    assert np.flatnonzero(patch_vertices(tri, [], ring=3)).tolist() == []
    assert np.flatnonzero(patch_vertices(tri, [3], ring=0)).tolist() == [4, 5, 6]
    assert np.flatnonzero(patch_vertices(tri, [3], ring=1)).tolist() == [2, 3, 4, 5, 6]


def test_interpolation_reproduces_a_linear_field():
    """Ends linear in the position are read back exactly at random points (a coarse mesh of
    the room, points anywhere in it, walls included)."""
    room = Environment([(0, 0), (5, 0), (5, 3), (0, 3)])
    pts, tri, _ = free_mesh(room, 1.0, lattice_points(room, 1.0))
    lo = 0.1 * pts[:, 0] - 0.05 * pts[:, 1]
    w = 1.0 + 0.02 * pts[:, 0]
    coarse = ArcField(pts, tri, lo, w)
    rng = np.random.default_rng(0)
    q = np.concatenate([rng.uniform([0, 0], [5, 3], (200, 2)), [[0.0, 0.0], [5.0, 1.3]]])
    g = interpolate_field(coarse, q, np.zeros((0, 3), int))
    assert np.allclose(g.lo, 0.1 * q[:, 0] - 0.05 * q[:, 1], atol=1e-12)
    assert np.allclose(g.w, 1.0 + 0.02 * q[:, 0], atol=1e-12)
    whole = interpolate_field(ArcField(pts, tri, lo, np.full(len(pts), 2 * np.pi)), q,
                              np.zeros((0, 3), int))
    assert (whole.w == 2 * np.pi).all()


@pytest.mark.slow
def test_first_field_from_a_coarse_field_is_its_interpolation():
    """``first_field(kern, coarse=f)``: the mesh of ``kern``'s lattice, ``f`` read at its
    vertices; the default (no ``coarse``) is the field from the kernel's bins."""
    room = Environment([(0, 0), (5, 0), (5, 3), (0, 3)])
    kern = surveillance_kernel(room, LSS, VT, VO, h=0.5, orientations=36)
    base = first_field(kern)
    coarse = ArcField(base.points, base.tri, base.lo + 0.1, base.w)
    fine_kern = surveillance_kernel(room, LSS, VT, VO, h=0.25, orientations=36)
    f = first_field(fine_kern, coarse=coarse)
    g = interpolate_field(coarse, f.points, f.tri)
    ref = first_field(fine_kern)
    assert np.array_equal(f.points, ref.points) and np.array_equal(f.tri, ref.tri)
    assert np.array_equal(f.lo, g.lo) and np.array_equal(f.w, g.w)


@pytest.mark.slow
def test_coarse_to_fine_certifies_a_room():
    """A 6 × 5 room, lss 1, vt/vo 0.3: the search at h = 1 leaves triangles failing; read at
    h = 0.5 and repaired in patches, the field passes every check on the whole fine mesh."""
    room = Environment([(0, 0), (6, 0), (6, 5), (0, 5)])
    f, checks, log = coarse_to_fine(room, LSS, VT, VO, h=0.5, coarse_h=1.0, orientations=36)
    assert not log[0]["coarse"]["certified"]
    assert checks.passed and certify(f, room, LSS, VT, VO).passed
    assert len(f.points) > 2 * log[0]["coarse"]["vertices"]
    assert sum(r["repaired"] for r in log[1:]) > 0


def test_clipped_arcs_are_free_from_their_stars(field):
    """Every clipped arc, sampled densely, is free from points sampled in every triangle of
    its vertex's star (an independent rod test); unclipped vertices keep their arcs."""
    from tether.arcs import rod_is_free_many

    bad = certify(field, ROOM4, LSS, VT, VO).free
    which = np.zeros(len(field.points), bool)
    which[field.tri[bad].ravel()] = True
    assert which.any()
    g = clip_to_free(ROOM4, field, which, LSS)
    assert np.array_equal(g.lo[~which], field.lo[~which])
    assert np.array_equal(g.w[~which], field.w[~which])
    rng = np.random.default_rng(1)
    bc = rng.dirichlet(np.ones(3), 40)
    changed = 0
    for v in np.flatnonzero(which):
        star = field.tri[(field.tri == v).any(axis=1)]
        pts = np.einsum("sk,tkd->tsd", bc, field.points[star]).reshape(-1, 2)
        a = g.lo[v] + np.linspace(0, g.w[v], 25)
        ok = rod_is_free_many(ROOM4, np.repeat(pts, len(a), axis=0), np.tile(a, len(pts)), LSS)
        assert ok.all(), v
        changed += g.w[v] != field.w[v] or g.lo[v] != field.lo[v]
    assert changed > 0
