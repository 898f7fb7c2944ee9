"""Rings touching at a vertex of both (OGC-valid maps, e.g. vectorized from occupancy grids).

A hole may touch the boundary or another hole at a single point where both rings have a
vertex. The free space near that point is several wedges (between the obstacles meeting
there); no rod passes through the point from one wedge to another. These tests check that
such maps are accepted, decomposed right (sampling, line scans), that the free arcs and the
rod test block the rod through the point (against a brute-force segment test), and that the
invalid touches are refused with one clear line.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon

from tether.arcs import free_arcs, rod_is_free
from tether.cli import main
from tether.decomposition import check, decompose
from tether.decomposition.scan import scan
from tether.environment import Environment
from tether.errors import InvalidMapError
from tether.io import from_dict

#: name -> (boundary, holes, the touching point)
MAPS = {
    # an L-shaped room whose reflex notch corner (2, 2) touches the hole [2,3]x[1,2]
    "notch": ([[0, 0], [4, 0], [4, 4], [2, 4], [2, 2], [0, 2]],
              [[[2, 1], [3, 1], [3, 2], [2, 2]]], (2.0, 2.0)),
    # two diagonal obstacle squares (two diagonal pixels) touching at (2, 2)
    "diagonal": ([[0, 0], [4, 0], [4, 4], [0, 4]],
                 [[[1, 1], [2, 1], [2, 2], [1, 2]], [[2, 2], [3, 2], [3, 3], [2, 3]]],
                 (2.0, 2.0)),
    # two thin triangles tip to tip: one free wedge of ~273 degrees (reflex) at (3, 3)
    "reflex": ([[0, 0], [6, 0], [6, 6], [0, 6]],
               [[[3, 3], [5, 2.5], [5, 3.2]], [[3, 3], [4.2, 5], [3.6, 5]]], (3.0, 3.0)),
    # a hole's apex on a boundary vertex that is straight for the boundary (kept: touching)
    "flat": ([[0, 0], [2, 0], [4, 0], [4, 4], [0, 4]], [[[2, 0], [3, 1], [1, 1]]], (2.0, 0.0)),
    # a slanted triangle whose apex touches a reflex boundary vertex
    "slanted": ([[0, 0], [5, 0], [5, 4], [3, 4], [2.5, 2.5], [0, 4]],
                [[[2.5, 2.5], [3.5, 1.0], [1.5, 1.2]]], (2.5, 2.5)),
}
LSS = (0.5, 1.0, 2.0)
#: lss 1 in the fast tier, the others in the slow one
LSS_TIERS = [pytest.param(v, marks=() if v == 1.0 else pytest.mark.slow) for v in LSS]


def _env(name: str) -> Environment:
    b, h, _ = MAPS[name]
    return Environment(b, tuple(h), name)


@pytest.mark.parametrize("name", sorted(MAPS))
def test_valid_by_ogc_and_accepted(name):
    b, h, at = MAPS[name]
    assert shapely.is_valid(Polygon(b, h))
    env = _env(name)
    touch = np.flatnonzero(env.touching)
    assert len(touch) == 2
    assert np.all(env.vertices[touch] == at)
    assert env.coincident[touch].tolist() == [touch[0]] * 2
    assert not env.straight[touch].any()
    assert env.internal.touching.sum() == 2  # the internal map keeps the touch


def test_touching_vertices_are_reflex_for_their_own_ring():
    for name in ("notch", "diagonal", "reflex"):
        env = _env(name)
        assert env.reflex[env.touching].all(), name


@pytest.mark.slow
@pytest.mark.parametrize("lss", LSS_TIERS)
@pytest.mark.parametrize("name", sorted(MAPS))
def test_decomposition_checks_and_scans_clean(name, lss):
    env = _env(name)
    dec = decompose(env, lss)
    npts, bad = scan(dec, 20)
    assert npts > 1000
    assert bad == ()
    report = check(dec, per_region=10, lines=0)
    assert report.ok, report


# ---------------------------------------------------------------------- rods at the point
def _brute_free(env: Environment, touch: tuple[float, float], p: np.ndarray, a: float,
                lss: float) -> bool:
    """Independent rod test with shapely: the rod segment lies in the closed free space (up
    to 1e-9) and, if it passes through the touching point, it stays in one piece of the free
    space near that point (the obstacles meet there: no rod passes between them)."""
    u = np.array([math.cos(a), math.sin(a)])
    q = p + lss * u
    seg = LineString([p, q])
    poly = Polygon(env.boundary, list(env.holes))
    if not poly.buffer(1e-9).covers(seg):
        return False
    P = np.asarray(touch)
    if seg.distance(Point(P)) < 1e-9 and min(np.linalg.norm(P - p),
                                             np.linalg.norm(P - q)) > 1e-6:
        r = 0.5 * min(np.linalg.norm(P - p), np.linalg.norm(P - q), 0.1)
        pieces = shapely.get_parts(poly.intersection(Point(P).buffer(r, quad_segs=64)))
        before = Point(P - 0.5 * r * u)
        after = Point(P + 0.5 * r * u)
        return any(pc.covers(before) and pc.covers(after) for pc in pieces)
    return True


#: (map, target point, whether the rod from it through the touching point is free)
THROUGH = [
    ("notch", (2.3, 2.2), False),     # top-right wedge -> bottom-left wedge
    ("notch", (1.7, 1.75), False),    # and back
    ("diagonal", (1.8, 2.3), False),  # top-left wedge -> bottom-right wedge
    ("diagonal", (2.2, 1.75), False),
    ("reflex", (3.26, 3.15), False),  # small wedge -> reflex wedge
    ("slanted", (2.5 + 0.3 * math.cos(0.2), 2.5 + 0.3 * math.sin(0.2)), False),  # right -> left
    # in the reflex wedge, both obstacles on one side: the rod grazes the point (free)
    ("reflex", (3 + 0.3 * math.cos(math.radians(280)), 3 + 0.3 * math.sin(math.radians(280))),
     True),
]


@pytest.mark.parametrize("lss", LSS)
@pytest.mark.parametrize(("name", "p", "free"), THROUGH)
def test_rod_through_touching_point(name, p, free, lss):
    env = _env(name)
    P = np.asarray(MAPS[name][2])
    p = np.asarray(p, dtype=float)
    a = math.atan2(*(P - p)[::-1])
    assert np.linalg.norm(P - p) < lss  # the rod reaches past the point
    assert _brute_free(env, MAPS[name][2], p, a, lss) is free
    assert free_arcs(env, p, lss).contains(a) is free
    assert rod_is_free(env, p, a, lss) is free


@pytest.mark.slow
@pytest.mark.parametrize("lss", LSS_TIERS)
@pytest.mark.parametrize(("name", "p", "free"), THROUGH)
def test_free_arcs_match_brute_force_near_the_point(name, p, free, lss):
    env = _env(name)
    p = np.asarray(p, dtype=float)
    arcs = free_arcs(env, p, lss)
    ends = np.array([x for arc in arcs.arcs for x in (arc.start, arc.end)])
    angles = np.linspace(0.0, 2 * math.pi, 240, endpoint=False) + 1e-3
    for a in angles:
        if len(ends) and np.min(np.abs((a - ends + math.pi) % (2 * math.pi) - math.pi)) < 1e-6:
            continue
        assert arcs.contains(a) == _brute_free(env, MAPS[name][2], p, a, lss), (p, a)
        assert rod_is_free(env, p, a, lss) == arcs.contains(a), (p, a)


def test_labels_name_the_first_coincident_vertex():
    env = _env("reflex")  # V4 and V7 coincide; grazing the point is one feature: V4
    rng = np.random.default_rng(1)
    pts = rng.uniform(2.0, 4.0, size=(400, 2))
    pts = pts[env.contains(pts[:, 0], pts[:, 1]) & (env.boundary_distance(*pts.T) > 1e-3)]
    names = {f for p in pts for arc in free_arcs(env, p, 1.0).arcs
             for f in (arc.start_feature, arc.end_feature)}
    assert "V4" in names
    assert "V7" not in names


# ---------------------------------------------------------------------- refused maps
BAD = [
    # two holes sharing an edge
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[1, 1], [2, 1], [2, 2], [1, 2]],
                                         [[2, 1], [3, 1], [3, 2], [2, 2]]]),
     "hole 0 and hole 1 touch along a segment from (2, "),
    # a hole along the boundary
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[1, 0], [2, 0], [2, 1]]]),
     "the boundary and hole 0 touch along a segment from ("),
    # a hole's vertex inside a boundary edge
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[2, 0], [3, 1], [1, 1]]]),
     "vertex V4 (2, 0) of hole 0 lies on edge E0 of the boundary, between the edge's ends: "
     "rings may touch only at a vertex of both; add a vertex at (2, 0) to E0"),
    # a hole's vertex inside another hole's edge
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[1, 1], [2, 1], [2, 2], [1, 2]],
                                         [[2, 1.5], [3, 1], [3, 2]]]),
     "vertex V8 (2, 1.5) of hole 1 lies on edge E5 of hole 0, between the edge's ends"),
    # overlapping holes
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[1, 1], [2, 1], [2, 2], [1, 2]],
                                         [[1.5, 1.5], [3, 1.5], [3, 3]]]),
     "holes 0 and 1 overlap near ("),
    # a hole outside
    (([[0, 0], [4, 0], [4, 4], [0, 4]], [[[3, 3], [5, 3], [5, 5]]]),
     "hole 0: not inside the boundary: vertex V5 (5, 3) lies outside the boundary"),
    # a hole touching the boundary at two vertices: the free space cut in two
    (([[0, 0], [2, 0], [4, 0], [4, 4], [2, 4], [0, 4]], [[[2, 0], [3, 2], [2, 4], [1, 2]]]),
     "the rings touch in a loop that cuts the free space in two"),
]


@pytest.mark.parametrize(("rings", "message"), BAD)
def test_invalid_touches_refused_with_one_line(rings, message):
    b, h = rings
    assert not shapely.is_valid(Polygon(b, h)) or "lies on edge" in message
    with pytest.raises(InvalidMapError) as info:
        Environment(b, tuple(h))
    text = str(info.value)
    assert message in text
    assert "\n" not in text


def test_edge_interior_message_from_a_map_file(tmp_path, capsys):
    data = {"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "holes": [[[2, 0], [3, 1], [1, 1]]]}
    with pytest.raises(InvalidMapError, match=r"^map: vertex V4 \(2, 0\) of hole 0 lies on "
                       r"edge E0 of the boundary, between the edge's ends: .*add a vertex "
                       r"at \(2, 0\) to E0$"):
        from_dict(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "add a vertex at (2, 0) to E0" in err
    # with the vertex added, the map is taken (the flat boundary vertex is kept: it touches)
    data["boundary"].insert(1, [2, 0])
    env = from_dict(data)
    assert env.touching.sum() == 2


def test_resolution_check_still_refuses_near_misses():
    # the hole's tip 1e-6 off the notch corner: a gap thinner than the resolution
    b = [[0, 0], [4, 0], [4, 4], [2, 4], [2, 2], [0, 2]]
    with pytest.raises(InvalidMapError, match="thinner than tether's resolution"):
        Environment(b, ([[2, 1], [3, 1], [3, 2], [2 + 1e-6, 2 + 1e-6]],))


def test_cli_decompose_touching_map(tmp_path, capsys):
    b, h, _ = MAPS["notch"]
    path = tmp_path / "notch.json"
    path.write_text(json.dumps({"name": "notch", "boundary": b, "holes": h}))
    assert main(["decompose", str(path), "--lss", "1"]) == 0
    out = capsys.readouterr().out
    assert "region" in out.lower()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["diagonal", "reflex"])
def test_escape_table_vertex_rows_lie_in_the_free_space(name):
    from tether.analysis import analyze, escape_table_of

    env = _env(name)
    t = escape_table_of(analyze(decompose(env, 1.0)))
    rows = t.piece < 0  # the vertex rows: a point just off each reflex vertex
    q = t.q[rows]
    assert np.all(env.contains(q[:, 0], q[:, 1]))
    assert np.all(env.boundary_distance(q[:, 0], q[:, 1]) > 0)
    # at the touching point only a reflex free wedge gives a row ("reflex": one, "diagonal":
    # none, both wedges being right angles)
    at = np.all(env.vertices[t.reflex] == MAPS[name][2], axis=1)
    assert at.sum() == (1 if name == "reflex" else 0)
