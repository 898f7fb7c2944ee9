"""Exact free arcs against brute force, hand-derived labels, the rod test against shapely."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from conftest import MAPS, SQUARE_HOLE, interior_points, random_maps
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether import (
    Environment,
    InvalidParameterError,
    OutsideFreeSpaceError,
    free_arcs,
    free_arcs_many,
    rod_is_free,
    rod_is_free_many,
)
from tether.arcs import TWO_PI, table_entry

END_MARGIN = 1e-6  # radians: sampled orientations this close to an arc end are not compared


def arcs_predict(table, i: int, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(free predicted by the arcs, near an arc end) for the sampled angles of point i."""
    rows = table.rows_of(i)
    if table.full[i]:
        return np.ones(len(angles), bool), np.zeros(len(angles), bool)
    pred = np.zeros(len(angles), bool)
    near = np.zeros(len(angles), bool)
    for s, e in zip(table.start[rows], table.end[rows], strict=True):
        pred |= (angles - s) % TWO_PI <= (e - s) % TWO_PI
        for end in (s, e):
            near |= np.abs((angles - end + math.pi) % TWO_PI - math.pi) < END_MARGIN
    return pred, near


def disagreements(env: Environment, pts: np.ndarray, lss: float, nang: int, seed: int) -> int:
    rng = np.random.default_rng(seed)
    table = free_arcs_many(env, pts, lss)
    bad = 0
    for i, p in enumerate(pts):
        angles = rng.uniform(0, TWO_PI, nang)
        brute = rod_is_free_many(env, np.broadcast_to(p, (nang, 2)), angles, lss)
        pred, near = arcs_predict(table, i, angles)
        bad += int(np.sum((pred != brute) & ~near))
    return bad


@pytest.mark.slow
@pytest.mark.parametrize("lss", [0.7, 2.0, 5.0])
def test_arcs_agree_with_brute_force_rod_test(any_map, lss):
    pts = interior_points(any_map, 25, seed=int(lss * 10))
    assert disagreements(any_map, pts, lss, 20_000, seed=1) == 0


def test_brute_force_can_disagree():
    """The comparison is not vacuous: arcs of a different rod length disagree."""
    env = SQUARE_HOLE
    pts = interior_points(env, 20, seed=3)
    table = free_arcs_many(env, pts, 2.0)
    rng = np.random.default_rng(0)
    angles = rng.uniform(0, TWO_PI, 5000)
    bad = 0
    for i, p in enumerate(pts):
        brute = rod_is_free_many(env, np.broadcast_to(p, (5000, 2)), angles, 3.0)
        pred, near = arcs_predict(table, i, angles)
        bad += int(np.sum((pred != brute) & ~near))
    assert bad > 0


@pytest.mark.slow
def test_rod_test_agrees_with_shapely_covers(any_map):
    """Independent check of the rod test itself: shapely's exact predicate on random rods."""
    rng = np.random.default_rng(7)
    pts = interior_points(any_map, 1000, seed=11)
    ang = rng.uniform(0, TWO_PI, len(pts))
    lss = any_map.diameter * rng.uniform(0.05, 0.5, len(pts))
    ours = np.array([rod_is_free(any_map, p, a, s) for p, a, s in zip(pts, ang, lss, strict=True)])
    tips = pts + lss[:, None] * np.column_stack((np.cos(ang), np.sin(ang)))
    rods = shapely.linestrings(np.stack((pts, tips), axis=1))
    theirs = shapely.covers(any_map.polygon, rods)
    assert np.array_equal(ours, theirs)
    assert ours.any() and not ours.all()


@pytest.mark.parametrize(("p", "a", "lss", "free"), [
    # tip exactly on the floor: contact is free
    ((3.0, 2.0), -math.pi / 2, 2.0, True),
    ((3.0, 2.0), -math.pi / 2, 2.0 + 1e-6, False),
    # rod grazing the hole's corner (6,6) from outside, along the diagonal: free
    ((7.0, 5.0), 3 * math.pi / 4, 3.0, True),
    # rod through the hole's corner (6,6) diagonally into the hole: blocked
    ((7.0, 7.0), 5 * math.pi / 4, 3.0, False),
    # rod ending exactly at the hole's corner (6,6) from the diagonal outside: free
    ((7.0, 7.0), 5 * math.pi / 4, math.sqrt(2.0), True),
    # rod running along the top edge of the hole (y=6) from x=7 to x=3: grazes it, free
    ((7.0, 6.0 + 0.0), math.pi, 4.0, True),
    # rod into the room corner (0,0) exactly: free; beyond it: blocked
    ((1.0, 1.0), 5 * math.pi / 4, math.sqrt(2.0), True),
    ((1.0, 1.0), 5 * math.pi / 4, math.sqrt(2.0) + 1e-6, False),
])
def test_rod_test_degenerate_contacts(p, a, lss, free):
    assert rod_is_free(SQUARE_HOLE, p, a, lss) is free


# ---------------------------------------------------------------------- labels
def structure(env, p, lss):
    return free_arcs(env, p, lss).structure


def test_single_wall_closer_than_lss_labels_both_ends_with_that_edge():
    # math.md §7 type A: room [0,12]^2, L=2, just below the offset of the floor
    assert structure(SQUARE_HOLE, (9, 1.9), 2.0) == {("E0", "E0")}
    assert structure(SQUARE_HOLE, (9, 2.1), 2.0) == "FULL"


def test_reflex_corner_gives_a_vertex_label():
    # type C: across the extension of E5 (the hole's top edge) through reflex V6=(6,6)
    assert structure(SQUARE_HOLE, (7, 6.001), 2.0) == {("E6", "E5")}
    assert structure(SQUARE_HOLE, (7, 5.999), 2.0) == {("E6", "V6")}


@pytest.mark.parametrize("h", [2e-5, 1e-6, 1e-3])
def test_edge_nearly_in_line_still_ends_the_arc(h):
    # issue #9: q sits delta = 1e-4 inside the vertex circle B(V6) and h above the extension of
    # E5 (the hole's top edge, y = 6) through V6 = (6, 6). Rotating CW from pi + 0.01 the tip
    # lands on E5 (at x = q_x - sqrt(lss^2 - h^2), inside [4, 6]) before the rod body reaches
    # V6, so the arc end is E5, although E5's blocked interval is only ~ h * delta / lss^2
    # radians wide (5e-10 for h = 2e-5: below ANGLE_TOL, yet no tangency).
    lss, delta = 2.0, 1e-4
    q = np.array([6 + lss - delta, 6 + h])
    tip_x = q[0] - math.sqrt(lss**2 - h**2)
    assert 4 < tip_x < 6 and np.hypot(*(q - (6, 6))) < lss  # exact: E5 is met before V6
    assert structure(SQUARE_HOLE, q, lss) == {("E6", "E5")}


def test_vertex_circle_examples():
    d = 2.0 / math.sqrt(2)
    assert structure(SQUARE_HOLE, (6 + d + 0.01, 6 + d + 0.01), 2.0) == "FULL"
    assert structure(SQUARE_HOLE, (6 + d - 0.01, 6 + d - 0.01), 2.0) == {("E6", "E5")}
    r = np.array([math.cos(math.radians(100)), math.sin(math.radians(100))])
    assert structure(SQUARE_HOLE, np.array([6, 6]) + 2.01 * r, 2.0) == {("E5", "E5")}
    assert structure(SQUARE_HOLE, np.array([6, 6]) + 1.99 * r, 2.0) == {("V6", "E5")}
    # convex room corner, direction 45 degrees
    assert structure(SQUARE_HOLE, (d + 0.01, d + 0.01), 2.0) == {("E3", "E0"), ("E0", "E3")}
    assert structure(SQUARE_HOLE, (d - 0.01, d - 0.01), 2.0) == {("E0", "E3")}


ROOM = [[0, 0], [12, 0], [12, 12], [0, 12]]


def across(env, p, normal, lss, eps=1e-4):
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    p = np.asarray(p, float)
    return {structure(env, p + eps * n, lss), structure(env, p - eps * n, lss)}


def test_two_reflex_vertices_same_side_relabel():
    env = Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],
                             [[4, 2], [4, 2.8], [5, 2.8], [5, 2]]))
    v6, v10 = np.array([3, 3.0]), np.array([5, 2.8])
    d = (v6 - v10) / np.linalg.norm(v6 - v10)
    assert across(env, v6 + 0.5 * d, (-d[1], d[0]), 3.0) == {
        frozenset({("V6", "E3")}), frozenset({("V10", "E3")})}


def test_two_reflex_vertices_opposite_sides_close_an_arc():
    env = Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],
                             [[4.5, 2.5], [4.5, 3.5], [5.5, 3.5], [5.5, 2.5]]))
    v6, v8 = np.array([3, 3.0]), np.array([4.5, 2.5])
    d = (v6 - v8) / np.linalg.norm(v6 - v8)
    assert across(env, v6 + 0.5 * d, (-d[1], d[0]), 3.0) == {
        frozenset({("V9", "E3")}), frozenset({("V9", "E3"), ("V6", "V8")})}


def test_conchoid_examples():
    p = np.array([2.226499, 4.160251])  # pole (3,3), base the floor, L=5
    u = np.array([3, 3.0]) - p
    n = (-u[1], u[0])
    same = Environment(ROOM, ([[2, 2], [2, 3], [3, 3], [3, 2]],))
    assert across(same, p, n, 5.0) == {frozenset({("E0", "E3")}), frozenset({("V6", "E3")})}
    opposite = Environment(ROOM, ([[3, 3], [3, 4], [4, 4], [4, 3]],))
    assert across(opposite, p, n, 5.0) == {
        frozenset({("V6", "E3")}), frozenset({("V6", "E3"), ("E0", "V4")})}


# ---------------------------------------------------------------------- properties
def check_label_invariants(env: Environment, table, npts: int) -> None:
    for i in range(npts):
        fa = table_entry(env, table, i, (0.0, 0.0), 1.0)
        starts = [a.start_feature for a in fa.arcs]
        ends = [a.end_feature for a in fa.arcs]
        assert len(set(starts)) == len(starts) and len(set(ends)) == len(ends)
        for name in starts + ends:
            if name[0] == "V":
                assert env.reflex[int(name[1:])], f"convex vertex {name} bounds a free arc"
        assert list(table.start[table.rows_of(i)]) == sorted(table.start[table.rows_of(i)])


@pytest.mark.slow
def test_labels_are_unique_and_vertex_labels_are_reflex(any_map):
    pts = interior_points(any_map, 2000, seed=5)
    for lss in (0.7, 2.0, 5.0):
        check_label_invariants(any_map, free_arcs_many(any_map, pts, lss), len(pts))


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.3, 8.0), seed=st.integers(0, 10_000))
def test_random_polygons_agree_with_brute_force(env, lss, seed):
    pts = interior_points(env, 6, seed=seed)
    assert disagreements(env, pts, lss, 3000, seed=seed) == 0
    check_label_invariants(env, free_arcs_many(env, pts, lss), len(pts))


def test_vectorized_equals_scalar():
    pts = interior_points(SQUARE_HOLE, 50, seed=2)
    table = free_arcs_many(SQUARE_HOLE, pts, 2.5)
    for i, p in enumerate(pts):
        one = free_arcs(SQUARE_HOLE, p, 2.5)
        rows = table.rows_of(i)
        assert [a.start for a in one.arcs] == list(table.start[rows])
        assert one.full == table.full[i]


def test_full_and_empty():
    assert free_arcs(SQUARE_HOLE, (2, 9), 1.0).full
    tiny = Environment([[0, 0], [1, 0], [1, 1], [0, 1]])
    fa = free_arcs(tiny, (0.5, 0.5), 3.0)
    assert fa.empty and fa.structure == "EMPTY" and not fa.contains(0.3)


# ---------------------------------------------------------------------- errors
@pytest.mark.parametrize(("p", "message"), [
    ((5.0, 5.0), "outside the free space"),  # inside the hole
    ((20.0, 5.0), "outside the free space"),
    ((4.0, 5.0), "on the boundary of the free space"),
])
def test_points_outside_are_rejected(p, message):
    with pytest.raises(OutsideFreeSpaceError, match=message):
        free_arcs(SQUARE_HOLE, p, 2.0)


@pytest.mark.parametrize("lss", [0.0, -1.0, float("nan"), float("inf"), "x"])
def test_bad_lss(lss):
    with pytest.raises(InvalidParameterError, match="lss"):
        free_arcs(SQUARE_HOLE, (1, 1), lss)
    with pytest.raises(InvalidParameterError):
        rod_is_free(SQUARE_HOLE, (1, 1), 0.0, lss)


def test_maps_fixture_is_diverse():
    assert any(m.holes for m in MAPS) and any(not m.reflex.any() for m in MAPS)
