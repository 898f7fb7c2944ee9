"""The arrangement's faces traced from half-edges (``trace_faces``) against
``shapely.polygonize`` (``polygonize_faces``, the fallback and the previous method): the same
polygons (as sets of points: normalized geometries) and the same faces on both sides of every
part, on random segment arrangements and on the awkward cases (dangles, cut edges, islands
touching their face at a point, holes in holes, a bay closed at a point)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from tether._util.arrays import first_max_per_group
from tether.decomposition.faces import polygonize_faces, ring_segments, trace_faces


def _both(lines: list) -> tuple:
    noded = shapely.node(shapely.multilinestrings([shapely.linestrings(c) for c in lines]))
    parts = shapely.get_parts(noded)
    parts = parts[shapely.length(parts) > 0]
    pa, pb, powner = ring_segments(parts)
    longest = first_max_per_group(np.hypot(*(pb - pa).T), powner)
    traced = trace_faces(parts)
    assert traced is not None
    return traced, polygonize_faces(parts, pa, pb, powner, longest)


def _assert_same(lines: list) -> int:
    (faces, pf), (ref, ref_pf) = _both(lines)
    key = {shapely.to_wkb(g): i for i, g in enumerate(shapely.normalize(ref))}
    assert len(faces) == len(ref) == len(key)
    to_ref = np.array([key[shapely.to_wkb(g)] for g in shapely.normalize(faces)] + [-1])
    assert np.array_equal(np.sort(to_ref[pf], axis=1), np.sort(ref_pf, axis=1))
    assert shapely.is_valid(faces).all()
    return len(faces)


def _square(x0, y0, s):
    return [(x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s), (x0, y0)]


@pytest.mark.parametrize("seed", range(12))
def test_random_segments_match_polygonize(seed):
    rng = np.random.default_rng(seed)
    lines = [_square(0, 0, 10)]
    for _ in range(int(rng.integers(3, 25))):
        a, b = rng.uniform(-1, 11, 2), rng.uniform(-1, 11, 2)
        lines.append([tuple(a), tuple(b)])
    # some polylines, and segments on a coarse grid (shared end points, collinear overlaps)
    for _ in range(5):
        pts = rng.integers(0, 6, (int(rng.integers(2, 5)), 2)) * 2.0
        lines.append([tuple(p) for p in pts])
    _assert_same(lines)


def test_island_touching_its_face_at_a_point():
    # a triangle hanging from the square's corner-to-corner diagonal's middle, and a closed
    # ring (one part) touching the boundary at one node
    lines = [_square(0, 0, 10), [(5, 0), (4, 2), (6, 2), (5, 0)],
             [(10, 5), (8, 4), (8, 6), (10, 5)]]
    assert _assert_same(lines) == 3


def test_figure_eight_hole_bay_and_holes_in_holes():
    lines = [_square(0, 0, 20),
             _square(2, 2, 3), _square(5, 5, 3),  # two squares touching at (5, 5)
             # a C whose tips touch: the bay closed at (15, 15) is a face of its own
             [(15, 15), (12, 15), (12, 12), (18, 12), (18, 15), (15, 15)],
             [(15, 15), (15, 14), (16, 14), (16, 15)],
             _square(2, 12, 6), _square(3, 13, 4), _square(4, 14, 2)]  # nested
    _assert_same(lines)


def test_dangles_and_cut_edges_bound_no_face():
    lines = [_square(0, 0, 10), [(2, 2), (3, 3)],  # floating segment
             [(0, 5), (4, 5)],  # dangle from the wall
             _square(6, 6, 2), [(10, 7), (8, 7)],  # a hole bridged to the wall
             [(7, 0), (7, 1), (7.5, 1.5)]]  # dangling polyline
    (faces, pf), _ = _both(lines)
    _assert_same(lines)
    assert len(faces) == 2  # the square with its hole, the hole
    none = np.flatnonzero(pf[:, 0] < 0)  # the floating segment, two dangles, the bridge
    assert len(none) == 4 and (pf[none, 1] < 0).all()


def test_repeated_points_take_the_first_step_that_moves():
    parts = [shapely.linestrings(c) for c in ([(0, 0), (0, 0), (2, 0), (2, 2), (2, 2)],
                                              [(2, 2), (0, 2), (0, 2), (0, 0)],
                                              [(0, 0), (1, 1), (2, 2)])]
    faces, pf = trace_faces(np.asarray(parts, dtype=object))
    assert len(faces) == 2 and sorted(shapely.area(faces)) == [2.0, 2.0]
    assert pf.tolist() == [[0, -1], [1, -1], [0, 1]] or pf.tolist() == [[1, -1], [0, -1], [0, 1]]


def test_exactly_overlapping_directions_fall_back():
    # two parts leaving a node along the same direction: never after noding, but refused
    parts = [shapely.linestrings(c) for c in ([(0, 0), (1, 0), (1, 1)],
                                              [(0, 0), (2, 0), (2, 1)], [(1, 1), (2, 1)])]
    assert trace_faces(np.asarray(parts, dtype=object)) is None


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_origin_angle_order_is_the_lexsort(seed):
    """The half-edges' order by origin then angle (one sort of a combined key, checked) is
    the lexsort's: on random angles, on angles a few ulps apart (keys that round alike: the
    lexsort is made), on equal angles, and on a subset of the half-edges."""
    from tether.decomposition.faces import _by_origin_then_angle

    rng = np.random.default_rng(seed)
    n = 5000
    origin = rng.integers(0, 800, n)
    angle = rng.uniform(-np.pi, np.pi, n)
    angle[rng.random(n) < 0.02] = np.pi  # the ends of the range
    angle[rng.random(n) < 0.02] = -np.pi
    live = np.flatnonzero(rng.random(n) < 0.9)
    want = live[np.lexsort((angle[live], origin[live]))]
    assert np.array_equal(_by_origin_then_angle(origin, angle, live), want)
    near = angle.copy()
    k = rng.integers(0, n, 50)
    near[k] = np.nextafter(near[k - 1], 4.0)  # a neighbour's angle, one ulp up
    origin[k] = origin[k - 1]
    want = live[np.lexsort((near[live], origin[live]))]
    assert np.array_equal(_by_origin_then_angle(origin, near, live), want)
    near[k] = near[k - 1]  # ties: the lexsort's order (stable) all the same
    want = live[np.lexsort((near[live], origin[live]))]
    assert np.array_equal(_by_origin_then_angle(origin, near, live), want)


@pytest.mark.parametrize("seed", [0, 1])
def test_cycle_labels_are_the_cycles_least_half_edge(seed):
    """Labels by pointer doubling: each alive half-edge's cycle's least member (checked by
    walking each cycle), dead ones their own index, and the steps to it; cycles of 1 to
    ~5,000 half-edges. Laid out from those: the order of ``_cycle_order`` (list ranking,
    sorted)."""
    from tether.decomposition.faces import _cycle_labels, _cycle_order, _cycles_laid_out

    rng = np.random.default_rng(seed)
    n = 20_000
    alive = rng.random(n) < 0.8
    live = rng.permutation(np.flatnonzero(alive))
    cuts = np.unique(np.r_[0, rng.integers(0, len(live), 40), 5000, len(live)])
    nxt = np.arange(n)
    want = np.arange(n)
    steps = np.zeros(n, np.int64)
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):  # one cycle per run of ``live``
        cyc = live[a:b]
        nxt[cyc] = np.roll(cyc, -1)
        want[cyc] = cyc.min()
        least = int(np.argmin(cyc))
        steps[cyc] = (least - np.arange(len(cyc))) % len(cyc)
    label, off = _cycle_labels(nxt, alive)
    assert np.array_equal(label, want)
    assert np.array_equal(off, steps)
    assert np.array_equal(_cycles_laid_out(label, off, alive), _cycle_order(nxt, label, alive))
    none = np.zeros(n, bool)
    assert len(_cycles_laid_out(np.arange(n), np.zeros(n, np.int64), none)) == 0


def test_rings_ccw_is_geos_is_ccw():
    """The rings' orientation by shoelace sums (one bincount over all consecutive pairs) is
    GEOS's ``is_ccw`` ring by ring: random simple rings (star-shaped) either way round,
    specks of 1e-16 map units."""
    from tether.decomposition.faces import _rings_ccw

    rng = np.random.default_rng(4)
    sizes = rng.integers(4, 30, 3000)
    rings = []
    for k in sizes:
        t = (np.arange(k) + rng.uniform(0, 0.8, k)) * (2 * np.pi / k) * rng.choice([-1, 1])
        p = rng.uniform(0.2, 1.0, (k, 1)) * np.column_stack((np.cos(t), np.sin(t)))
        p = p * 1e-16 if rng.random() < 0.05 else rng.normal(0, 5, 2) + p
        rings.append(np.vstack((p, p[:1])))
    ptr = np.r_[0, np.cumsum(sizes + 1)]
    want = shapely.is_ccw(shapely.linearrings(np.vstack(rings), indices=np.repeat(
        np.arange(len(sizes)), sizes + 1)))
    got = _rings_ccw(np.vstack(rings), ptr)
    assert np.array_equal(got, want) and 0 < got.sum() < len(got)


def _drop_dangles_reference(origin, nodes):
    """The dangles' removal as it was (the half-edges leaving each tip found through a sort
    of the origins)."""
    from tether._util.arrays import ragged_arange

    alive = np.ones(len(origin), bool)
    deg = np.bincount(origin, minlength=nodes)
    order = np.argsort(origin, kind="stable")
    ptr = np.searchsorted(origin[order], np.arange(nodes + 1))
    tip = np.flatnonzero(deg == 1)
    while len(tip):
        he = order[ragged_arange(ptr[tip], ptr[tip + 1] - ptr[tip])]
        he = he[alive[he]]
        part = np.unique(he // 2)
        alive[2 * part] = alive[2 * part + 1] = False
        end = origin[np.concatenate((2 * part, 2 * part + 1))]
        np.subtract.at(deg, end, 1)
        tip = np.unique(end[deg[end] == 1])
    return alive


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_drop_dangles_equals_reference(seed):
    """Random graphs of parts (a few dense nodes, long dangling paths, isolated parts,
    loops at one node, paths ending on a loop): the same half-edges left."""
    from tether.decomposition.faces import _drop_dangles

    rng = np.random.default_rng(seed)
    nodes = 3000
    u = rng.integers(0, 300, 2000)
    v = rng.integers(0, 300, 2000)
    path = np.arange(300, 1300)  # paths of 1..50 parts hanging from the dense nodes
    cut = np.unique(rng.integers(0, len(path), 40))
    hang = rng.integers(0, 300, len(path))
    hang[np.r_[0, cut][1:] % len(path)] = -1
    pu = np.where(np.r_[True, np.isin(np.arange(1, len(path)), cut)], hang, path - 1)
    pu[pu < 0] = path[pu < 0] - 1
    iso = np.arange(1400, 1600).reshape(-1, 2)
    loops = rng.integers(0, 1600, 30)
    a = np.concatenate((u, pu, iso[:, 0], loops))
    b = np.concatenate((v, path, iso[:, 1], loops))
    origin = np.empty(2 * len(a), np.int64)
    origin[0::2], origin[1::2] = a, b
    got = _drop_dangles(origin, nodes)
    assert np.array_equal(got, _drop_dangles_reference(origin, nodes))
    assert 0 < (~got).sum() < len(got) - 1000
