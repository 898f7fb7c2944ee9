"""Faces traced tile by tile (tether/decomposition/tiles.py ``trace_tile``,
tether/decomposition/faces.py ``local_faces``): the faces and the faces on the two sides of
every part are those that ``trace_faces`` traces on all the parts at once, up to the faces'
numbering (each face compared as the set of its rings' exact coordinates); on the test maps,
the bundled examples, floor plans, random maps and the lattice maps, with grids cut by hand
through a face's anchor, a margin so small that most faces are retried, and a map whose outer
wall has a cavity (the unbounded face's walk has a smallest point there, which must not be
retried without end). And a brute force: every face a task delivers, on any region, is a face
of the whole."""

from __future__ import annotations

import functools

import lattice_maps as lm
import numpy as np
import pytest
import shapely
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE, STAR_HOLE, SerialExecutor, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tether.decomposition.tiles as tiles_mod
from tether import Environment
from tether.arcs import check_lss
from tether.curves import critical_curves
from tether.decomposition.arrangement import arrangement
from tether.decomposition.faces import FaceRings, part_ends
from tether.decomposition.tiles import TileGrid, grown, trace_tile
from tether.examples import load as load_example
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


@functools.lru_cache(maxsize=4)
def _whole(env, lss):
    """The untiled arrangement of ``env`` at ``lss`` (map units), internal frame (kept for
    the next test that asks)."""
    inner = env.internal
    lss = check_lss(lss * env.frame.scale, inner)
    return arrangement(inner, critical_curves(inner, lss), REL_CURVE_TOL * inner.diameter)


def _face_keys(faces):
    """Each face as the sorted tuple of its rings, each ring the sorted tuple of its exact
    vertices (a ring may start anywhere); ``faces`` polygons or a :class:`FaceRings` (whose
    areas must be its polygons' areas, bit for bit)."""
    if isinstance(faces, FaceRings):
        polys = faces.polygons()
        np.testing.assert_array_equal(faces.area, shapely.area(polys))
        faces = polys
    keys = []
    for f in faces:
        rings = [shapely.get_exterior_ring(f)] + [
            shapely.get_interior_ring(f, i) for i in range(shapely.get_num_interior_rings(f))]
        keys.append(tuple(sorted(tuple(sorted(map(tuple, shapely.get_coordinates(r)[:-1]
                                                  .tolist()))) for r in rings)))
    return keys


def assert_same_faces(whole, faces, part_faces):
    """``faces``, ``part_faces`` are ``whole``'s faces and part faces up to renumbering."""
    ka, kb = _face_keys(whole.faces), _face_keys(faces)
    index = {k: i for i, k in enumerate(ka)}
    assert len(index) == len(ka) == len(kb)
    m = np.array([index[k] for k in kb], dtype=np.int64)
    assert sorted(m.tolist()) == list(range(len(ka))), "faces matched one to one"
    mapped = np.where(part_faces >= 0, np.r_[m, -1][part_faces], -1)
    np.testing.assert_array_equal(np.sort(mapped, axis=1), np.sort(whole.part_faces, axis=1))


def _traced(whole, tiles, log=None):
    coords, count = part_ends(whole.parts)[:2]
    log = {} if log is None else log
    got = tiles_mod._faces_in_tiles(coords, count, tiles, SerialExecutor(), lambda s, f: None, log)
    assert got is not None and not log["face_fallback"]
    return got[:2]


@pytest.mark.parametrize("env,tiles", [
    (L_SHAPE, (5, 4)), pytest.param(L_SHAPE, (2, 2), marks=pytest.mark.slow),
    pytest.param(SQUARE_HOLE, (3, 3), marks=pytest.mark.slow),
    pytest.param(STAR_HOLE, (5, 4), marks=pytest.mark.slow),
    pytest.param(GENERIC, (2, 2), marks=pytest.mark.slow),
    pytest.param(GENERIC, (5, 4), marks=pytest.mark.slow)])
def test_test_maps_same_faces(env, tiles):
    whole = _whole(env, 1.0)
    assert_same_faces(whole, *_traced(whole, tiles))


def test_cut_through_a_face_anchor(monkeypatch):
    """Cuts made by hand exactly through the anchor (smallest point) of a face: the point
    goes to the tile right of and above the cuts, and each face is delivered once."""
    whole = _whole(L_SHAPE, 1.0)
    f = whole.faces[len(whole.faces) // 2]
    xy = shapely.get_coordinates(shapely.get_exterior_ring(f))
    p = xy[np.lexsort((xy[:, 1], xy[:, 0]))[0]]
    grid = TileGrid(np.array([p[0]]), np.array([p[1]]))
    monkeypatch.setattr(tiles_mod, "tile_grid", lambda xy, shape: grid)
    assert_same_faces(whole, *_traced(whole, (2, 2)))


def test_outer_cavity_not_retried_without_end():
    """A map whose outer wall has a cavity opening to the right: the unbounded face's walk
    has its smallest point in a stretch at the cavity's bottom, with a left turn there; as the
    retry region grows the stretch reaches smaller points, and the retries stop."""
    env = Environment([(0, 0), (10, 0), (10, 3), (4, 3), (4, 7), (10, 7), (10, 10),
                       (0, 10)], (), "cavity")
    whole = _whole(env, 1.5)
    log = {}
    assert_same_faces(whole, *_traced(whole, (4, 4), log))
    assert log["face_retries"] < 64


@pytest.mark.slow
def test_small_margin_many_retries(monkeypatch):
    monkeypatch.setattr(tiles_mod, "FACE_MARGIN", 0.004)
    whole = _whole(load_example("gallery"), 1.0)
    log = {}
    assert_same_faces(whole, *_traced(whole, (3, 3), log))
    assert log["face_retries"] >= 9


@pytest.mark.slow
@pytest.mark.parametrize("name", ["rectangle", "convex_corner", "nonconvex_corner",
                                  "gallery"])
def test_bundled_examples_same_faces(name):
    env = load_example(name)
    whole = _whole(env, (env.bounds[2] - env.bounds[0]) / 8)
    for tiles in [(3, 3), (6, 5)]:
        assert_same_faces(whole, *_traced(whole, tiles))


@pytest.mark.slow
@pytest.mark.parametrize("n,seed,tiles", [(100, 1, (3, 3)), (300, 2, (4, 4)),
                                          (300, 5, (8, 8))])
def test_floor_plans_same_faces(n, seed, tiles):
    env = floor_plan(n, seed)
    whole = _whole(env, (env.bounds[2] - env.bounds[0]) / 15)
    assert_same_faces(whole, *_traced(whole, tiles))


@pytest.mark.slow
@pytest.mark.parametrize("family", ["corridor", "pillars_half", "steps"])
def test_lattice_maps_same_faces(family):
    for lss in lm.ROUND_LSS:
        env = lm.env_of(lm.families(lss)[family], family)
        whole = _whole(env, lss)
        assert_same_faces(whole, *_traced(whole, (3, 2)))


@pytest.mark.slow
@given(env=random_maps(), frac=st.floats(0.05, 0.5), nx=st.integers(1, 6),
       ny=st.integers(1, 6))
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_maps_same_faces(env, frac, nx, ny):
    whole = _whole(env, frac * env.diameter)
    assert_same_faces(whole, *_traced(whole, (nx, ny)))


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=6, deadline=None)
def test_any_region_delivers_faces_of_the_whole(seed):
    """Brute force: a random box as the trust region, the parts meeting it grown by a random
    margin sent, every point owned: each face delivered is a face of the whole, and its
    rings' half-edges are on that face in the whole."""
    whole = _whole(L_SHAPE, 1.0)
    rng = np.random.default_rng(seed)
    coords, count = part_ends(whole.parts)[:2]
    start = np.cumsum(count) - count
    plo, phi = np.minimum.reduceat(coords, start), np.maximum.reduceat(coords, start)
    lo = plo.min(axis=0) + rng.uniform(-0.1, 0.6, 2) * (phi.max(axis=0) - plo.min(axis=0))
    trust = np.r_[lo, lo + rng.uniform(0.05, 0.6, 2) * (phi.max(axis=0) - plo.min(axis=0))]
    margin = rng.uniform(0.001, 0.2) * float(np.ptp(coords, axis=0).max())
    send = grown(trust, 2 * margin)
    sel = np.flatnonzero(np.all(phi >= send[:2], axis=1) & np.all(plo <= send[2:], axis=1))
    xy = coords[np.concatenate([np.arange(start[k], start[k] + count[k]) for k in sel])] \
        if len(sel) else np.zeros((0, 2))
    got = trace_tile(xy, count[sel], trust, grown(trust, 1.5 * margin),
                     np.unique(coords, axis=0), ())
    assert got is not None
    xy_f, offsets, he, face = got[:4]
    faces = shapely.from_ragged_array(shapely.GeometryType.POLYGON, xy_f, offsets) \
        if len(xy_f) else np.zeros(0, dtype=object)
    index = {k: i for i, k in enumerate(_face_keys(whole.faces))}
    m = np.array([index[k] for k in _face_keys(faces)], dtype=np.int64)  # KeyError: not one
    ghe = 2 * sel[he // 2] + he % 2
    assert np.isin(m[face], whole.part_faces[ghe // 2]).all()


def test_face_tasks_free_arcs_same_structures():
    """With the map and lss, the face tasks also compute their faces' points and free arcs
    (``FaceArcs``): the same faces in the free space, resolved alike, with the same
    structures as ``face_arcs`` on the whole's faces."""
    from tether.decomposition.structure import face_arcs, structure_ids_of

    env, lss = L_SHAPE, 1.0
    whole = _whole(env, lss)
    inner = env.internal
    lss_in = check_lss(lss * env.frame.scale, inner)
    tol = REL_CURVE_TOL * inner.diameter
    coords, count = part_ends(whole.parts)[:2]
    log = {}
    faces, pf, fa = tiles_mod._faces_in_tiles(coords, count, (4, 3), SerialExecutor(),
                                              lambda s, f: None, log, (inner, lss_in, tol))
    assert_same_faces(whole, faces, pf)
    wa = face_arcs(inner, whole.faces, tol, whole.grid, lss_in)

    def by_face(a, nfaces):
        ok = a.keep[a.resolved]
        sid, structs = structure_ids_of(inner.n, a.full, a.point, a.start_code, a.end_code,
                                        len(ok))
        out = np.full(nfaces, -2, dtype=object)  # -2: not in the free space
        out[a.keep] = -1  # not resolved
        out[ok] = [tuple(structs.pairs[structs.ptr[i]:structs.ptr[i + 1]].tolist())
                   if i >= 2 else i for i in sid.tolist()]
        return out

    index = {k: i for i, k in enumerate(_face_keys(whole.faces))}
    m = np.array([index[k] for k in _face_keys(faces)], dtype=np.int64)
    want = by_face(wa, len(whole.faces))
    got = by_face(fa, len(faces))
    assert list(got) == list(want[m])


# ------------------------------------------- the main process's faces and parts as arrays
def test_face_rings_and_part_lines_make_the_geometries_exactly():
    """:class:`FaceRings` and :class:`PartLines` (what a decomposition in tiles keeps in the
    main process instead of polygons and linestrings) make, for any ids, the very polygons
    and linestrings they were read from (``equals_exact`` with tolerance 0: the same
    coordinates in the same order), and joining split ragged arrays renumbers them in order;
    checked against shapely's own ragged arrays of the untiled arrangement."""
    from tether.decomposition.faces import PartLines

    whole = _whole(L_SHAPE, 1.0)
    kind, xy, (ring_off, face_off) = shapely.to_ragged_array(whole.faces)
    assert kind == shapely.GeometryType.POLYGON
    area = shapely.area(whole.faces)
    cut = len(whole.faces) // 3  # the same faces in two pieces, joined
    pieces = []
    for lo, hi in ((0, cut), (cut, len(whole.faces))):
        r0, r1 = face_off[lo], face_off[hi]
        pieces.append(FaceRings(xy[ring_off[r0]:ring_off[r1]],
                                ring_off[r0:r1 + 1] - ring_off[r0], face_off[lo:hi + 1] - r0,
                                area[lo:hi]))
    faces = FaceRings.joined(pieces)
    assert len(faces) == len(whole.faces)
    rng = np.random.default_rng(0)
    for ids in (np.arange(len(faces)), rng.permutation(len(faces))[:50], np.array([3, 3, 0]),
                np.zeros(0, np.int64)):
        assert shapely.equals_exact(faces[ids], whole.faces[ids], 0).all()
    assert shapely.equals_exact(faces[7], whole.faces[7], 0)
    np.testing.assert_array_equal(faces.area, area)
    coords, count = part_ends(whole.parts)[:2]
    parts = PartLines(coords, count, shapely.length(whole.parts))
    assert len(parts) == len(whole.parts)
    for ids in (np.arange(len(parts)), rng.permutation(len(parts))[:50], np.zeros(0, np.int64)):
        assert shapely.equals_exact(parts[ids], whole.parts[ids], 0).all()
    assert shapely.equals_exact(parts.lines(), whole.parts, 0).all()
    np.testing.assert_array_equal(part_ends(parts)[4], part_ends(whole.parts)[4])


@pytest.mark.slow
def test_tiled_arrangement_holds_arrays_with_the_whole_lengths_and_areas():
    """The arrangement noded and traced in tiles holds its parts and faces as ragged arrays
    (no linestring or polygon per part or face in the main process), with the parts'
    lengths and the faces' areas that the untiled arrangement's geometries give: the
    lengths bit for bit (the same parts), the areas to rounding (a ring may start at
    another vertex)."""
    from tether.decomposition.faces import PartLines
    from tether.decomposition.tiles import tiled_noder

    env = L_SHAPE
    inner = env.internal
    lss = check_lss(1.0 * env.frame.scale, inner)
    tol = REL_CURVE_TOL * inner.diameter
    curves = critical_curves(inner, lss)
    whole = arrangement(inner, curves, tol)
    tiled = arrangement(inner, curves, tol, tiled_noder((3, 2), SerialExecutor(), tol))
    assert isinstance(tiled.parts, PartLines) and isinstance(tiled.faces, FaceRings)
    key = {shapely.get_coordinates(p).tobytes(): k for k, p in enumerate(whole.parts)}
    m = np.array([key[shapely.get_coordinates(p).tobytes()] for p in tiled.parts.lines()])
    np.testing.assert_array_equal(tiled.part_lengths(), whole.part_lengths()[m])
    np.testing.assert_allclose(np.sort(tiled.faces.area), np.sort(shapely.area(whole.faces)),
                               rtol=1e-12, atol=0)
