"""Validation of a map: each ring alone, holes against the boundary and each other, coordinate
range, and resolution (walls and gaps thinner than tether resolves); every problem is an
:class:`~tether.errors.InvalidMapError` naming the ring, vertex or edge and where it is."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LinearRing, Polygon

from tether.environment.frame import normalizing_frame
from tether.errors import InvalidMapError
from tether.tolerances import (
    COORD_MAX,
    MAX_VERTICES,
    MIN_DIAMETER,
    MIN_DIAMETER_REL,
    REL_FEATURE_TOL,
    REL_LENGTH_TOL,
)

__all__ = ["check_resolution", "check_rings", "ring_array"]


def ring_array(coords: Any, where: str) -> np.ndarray:
    """Turn a list of ``[x, y]`` pairs into an ``(k, 2)`` float array, checking shape and values."""
    try:
        arr = np.asarray(coords, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidMapError(f"{where}: coordinates must be [x, y] number pairs") from exc
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InvalidMapError(f"{where}: coordinates must be a list of [x, y] pairs")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
        raise InvalidMapError(f"{where}: vertex {bad} has a non-finite coordinate")
    if len(arr) >= 2 and np.array_equal(arr[0], arr[-1]):
        arr = arr[:-1]  # an explicit closing vertex (WKT, GeoJSON) is not a vertex of its own
    return arr



def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _validate_ring(ring: np.ndarray, where: str, tol: float) -> None:
    """Check one ring alone: enough distinct vertices, no repeats, no self-intersection."""
    if len(np.unique(ring, axis=0)) < 3:
        raise InvalidMapError(f"{where}: needs at least 3 distinct vertices, got {len(ring)}")
    step = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    if np.any(step <= tol):
        i = int(np.flatnonzero(step <= tol)[0])
        j = (i + 1) % len(ring)
        raise InvalidMapError(
            f"{where}: vertices {i} and {j} repeat the same point "
            f"({_fmt(ring[i, 0])}, {_fmt(ring[i, 1])})"
        )
    rel = ring - ring[0]
    far = rel[int(np.argmax(np.linalg.norm(rel, axis=1)))]
    if np.all(np.abs(rel[:, 0] * far[1] - rel[:, 1] * far[0]) <= tol * np.linalg.norm(far)):
        raise InvalidMapError(f"{where}: the ring has zero area (all vertices collinear)")
    if not LinearRing(ring).is_simple:
        reason = shapely.is_valid_reason(Polygon(ring))
        m = re.search(r"\[([^\]]+)\]", reason)
        at = ""
        if m:
            xs = m.group(1).split()
            at = " near (" + ", ".join(_fmt(float(v)) for v in xs[:2]) + ")"
        raise InvalidMapError(f"{where}: the ring intersects itself{at}")


def _check_coordinate_range(pts: np.ndarray) -> None:
    """Reject maps whose coordinates or size are beyond what doubles resolve (see
    ``COORD_MAX``, ``MIN_DIAMETER`` and ``MIN_DIAMETER_REL`` in :mod:`tether.tolerances`)."""
    big = np.abs(pts).max(axis=1)
    if np.any(big > COORD_MAX):
        k = int(np.flatnonzero(big > COORD_MAX)[0])
        raise InvalidMapError(f"vertex V{k} ({_fmt(pts[k, 0])}, {_fmt(pts[k, 1])}) is beyond "
                              f"±{COORD_MAX:g}: rescale or translate the map")
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = math.hypot(*(hi - lo))
    reach = float(np.abs(pts).max())
    if size < MIN_DIAMETER or size < MIN_DIAMETER_REL * reach:
        raise InvalidMapError(
            f"the map is {size:.3g} across at coordinates up to {reach:.3g}: too small to "
            f"resolve (at least {MIN_DIAMETER:g} and {MIN_DIAMETER_REL:g} × the largest "
            "coordinate); rescale or translate the map")


def _hole_outside_where(outer: Polygon, hole: np.ndarray, first: int) -> str:
    """Where a hole leaves the boundary: its first vertex outside, or a point where it crosses
    the boundary."""
    inside = shapely.intersects_xy(outer, hole[:, 0], hole[:, 1])
    if not np.all(inside):
        j = int(np.flatnonzero(~inside)[0])
        return (f"vertex V{first + j} ({_fmt(hole[j, 0])}, {_fmt(hole[j, 1])}) lies outside "
                "the boundary")
    at = outer.exterior.intersection(LinearRing(hole)).representative_point()
    return f"it crosses the boundary near ({_fmt(at.x)}, {_fmt(at.y)})"


def _ring_name(k: int) -> str:
    return "the boundary" if k == 0 else f"hole {k - 1}"


def _check_touch(rings: list[np.ndarray], firsts: list[int], ka: int, kb: int) -> None:
    """Two rings (indices into ``rings``; 0 is the boundary) whose interiors do not overlap
    may meet only at single points that are a vertex of both (coincident vertices: holes
    touching the boundary or each other, as in maps traced from occupancy grids). Refuse a
    shared segment, and a vertex of one ring lying inside an edge of the other (naming the
    vertex and the edge: a vertex added there makes the map acceptable)."""
    a, b = rings[ka], rings[kb]
    ra, rb = LinearRing(a), LinearRing(b)
    if not ra.intersects(rb):
        return
    both = f"{_ring_name(ka)} and {_ring_name(kb)}"
    meet = ra.intersection(rb)
    for part in shapely.get_parts(meet):
        if shapely.get_dimensions(part) > 0:
            xy = shapely.get_coordinates(part)
            raise InvalidMapError(
                f"{both} touch along a segment from ({_fmt(xy[0, 0])}, {_fmt(xy[0, 1])}) to "
                f"({_fmt(xy[-1, 0])}, {_fmt(xy[-1, 1])}): rings may touch only at single "
                "points where both have a vertex")
    for (kp, p, fp), (ke, e, fe) in (((ka, a, firsts[ka]), (kb, b, firsts[kb])),
                                     ((kb, b, firsts[kb]), (ka, a, firsts[ka]))):
        ring_e = LinearRing(e)
        on = np.flatnonzero(shapely.intersects_xy(ring_e, p[:, 0], p[:, 1]))
        for j in on.tolist():
            if np.any(np.all(e == p[j], axis=1)):
                continue  # a vertex of both rings: the touch tether takes
            segs = shapely.linestrings(np.stack((e, np.roll(e, -1, axis=0)), axis=1))
            d = shapely.distance(segs, shapely.points(p[j]))
            i = int(np.argmin(d))
            x, y = _fmt(p[j, 0]), _fmt(p[j, 1])
            raise InvalidMapError(
                f"vertex V{fp + j} ({x}, {y}) of {_ring_name(kp)} lies on edge E{fe + i} of "
                f"{_ring_name(ke)}, between the edge's ends: rings may touch only at a vertex "
                f"of both; add a vertex at ({x}, {y}) to E{fe + i}")
    # (two edges crossing at a point inside both would make the interiors overlap: refused
    # before this check)


def _check_polygon_valid(boundary: np.ndarray, holes: tuple[np.ndarray, ...]) -> None:
    """The last check of a map whose rings meet only at coincident vertices: the free space
    must be a valid polygon (OGC, as shapely tests it), i.e. its interior connected. Rings
    touching each other in a loop (a hole touching the boundary twice, two holes touching at
    two points, a chain of holes from wall to wall) cut it in pieces."""
    poly = Polygon(boundary, list(holes))
    if shapely.is_valid(poly):
        return
    reason = shapely.is_valid_reason(poly)
    m = re.search(r"\[([^\]]+)\]", reason)
    at = ""
    if m:
        xs = m.group(1).split()
        at = " near (" + ", ".join(_fmt(float(v)) for v in xs[:2]) + ")"
    what = reason.split("[")[0].strip().lower()
    if "disconnected" in what:
        raise InvalidMapError(f"the rings touch in a loop that cuts the free space in two{at}: "
                              "remove one of the touching points")
    raise InvalidMapError(f"the free space is not a valid polygon ({what}){at}")



def check_rings(boundary: np.ndarray, holes: tuple[np.ndarray, ...]) -> None:
    """Check the rings (as :func:`ring_array` returns them) of a map: the coordinate range, each
    ring alone, the vertex count, each hole inside the boundary and apart from the other holes
    (touching only at coincident vertices), and the free space a valid polygon."""
    allpts = np.vstack((boundary, *holes)) if holes else boundary
    _check_coordinate_range(allpts)
    span = math.hypot(*(allpts.max(axis=0) - allpts.min(axis=0)))
    tol = REL_LENGTH_TOL * max(span, 1e-300)
    _validate_ring(boundary, "boundary", tol)
    if len(allpts) > MAX_VERTICES:
        raise InvalidMapError(f"{len(allpts)} vertices, more than tether takes "
                              f"({MAX_VERTICES})")
    outer = Polygon(boundary)
    hole_polys: list[Polygon] = []
    rings = [boundary, *holes]
    firsts = np.cumsum([0] + [len(r) for r in rings]).tolist()
    for k, h in enumerate(holes):
        _validate_ring(h, f"hole {k}", tol)
        hp = Polygon(h)
        if not outer.covers(hp):
            raise InvalidMapError(f"hole {k}: not inside the boundary: "
                                  f"{_hole_outside_where(outer, h, firsts[k + 1])}")
        _check_touch(rings, firsts, 0, k + 1)
        for j, other in enumerate(hole_polys):
            if hp.intersects(other):
                if shapely.relate_pattern(hp, other, "T********"):
                    at = hp.intersection(other).representative_point()
                    raise InvalidMapError(f"holes {j} and {k} overlap near "
                                          f"({_fmt(at.x)}, {_fmt(at.y)})")
                _check_touch(rings, firsts, j + 1, k + 1)
        hole_polys.append(hp)
    if holes:
        _check_polygon_valid(boundary, holes)


def check_resolution(rings: tuple[np.ndarray, ...], vertices: np.ndarray, straight: np.ndarray,
                     wall: np.ndarray, nxt: np.ndarray, diameter: float,
                     bounds: tuple[float, float, float, float]) -> None:
    """Reject walls and gaps thinner than ``REL_FEATURE_TOL`` times the diameter: a vertex (not
    straight) closer than that to a wall it does not bound. A wall is a maximal run of edges
    joined by straight vertices, named after its first edge.

    The arguments are the map's (:class:`~tether.environment.Environment`): its rings, its
    vertices, their ``straight`` flags, ``wall_of``, ``next_vertex``, its diameter and bounds.
    """
    keep = ~straight
    frame = normalizing_frame(bounds)  # not the map's frame: never cached during validation
    V = frame.to_internal(vertices)
    limit = REL_FEATURE_TOL * diameter * frame.scale
    prev_kept = np.empty(len(vertices), dtype=int)
    start = 0
    for r in rings:
        idx = np.arange(start, start + len(r))
        kept = idx[keep[idx]]
        prev_kept[kept] = np.roll(kept, 1)
        start += len(r)
    pts = np.flatnonzero(keep)
    segs = shapely.linestrings(np.stack((V, V[nxt]), axis=1))
    pi, ei = shapely.STRtree(segs).query(shapely.points(V[pts]), predicate="dwithin",
                                         distance=limit)
    j = pts[pi]
    ok = (wall[ei] != j) & (wall[ei] != prev_kept[j])
    # rings touching at a vertex of both: that vertex lies on the other ring's edges from the
    # coincident vertex (exactly, distance 0): no gap, exempt. Any other vertex near a wall
    # (the other ring's next vertices included) is still checked.
    at_end = (np.all(V[j] == V[ei], axis=1) | np.all(V[j] == V[nxt[ei]], axis=1))
    ok &= ~at_end
    j, ei = j[ok], ei[ok]
    a, b = V[ei], V[nxt[ei]]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", V[j] - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    dist = np.hypot(*(a + t[:, None] * ab - V[j]).T)
    close = np.flatnonzero(dist < limit)
    if len(close):
        k = close[int(np.argmin(dist[close]))]
        scale = frame.scale
        raise InvalidMapError(
            f"V{j[k]} is {_fmt(dist[k] / scale)} from wall E{wall[ei[k]]}: a wall or gap "
            f"thinner than tether's resolution ({REL_FEATURE_TOL:g} x the map's diameter = "
            f"{_fmt(limit / scale)}); widen it or remove it")

