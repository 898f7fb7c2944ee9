"""The map: a polygon with holes, its named features, validation, readers and writers.

Feature names follow the file: vertices ``V0..V(n-1)`` and edges ``E0..E(n-1)`` in the order the
file gives them, boundary ring first, then each hole in order. Edge ``Ei`` runs from ``Vi`` to the
next vertex of the same ring. Orientation is normalized only to know each edge's free side; it
never renumbers anything.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LinearRing, Polygon

from tether.errors import InvalidMapError
from tether.spatial import EdgeIndex
from tether.tolerances import (
    COORD_MAX,
    MAX_MAP_BYTES,
    MAX_VERTICES,
    MIN_DIAMETER,
    MIN_DIAMETER_REL,
    REL_FEATURE_TOL,
    REL_LENGTH_TOL,
    REL_STRAIGHT_TOL,
)

_JSON_KEYS = {"boundary", "holes", "name"}


def _ring_array(coords: Any, where: str) -> np.ndarray:
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


def _signed_area(ring: np.ndarray) -> float:
    rel = ring - ring.mean(axis=0)  # centred: no cancellation at large offsets
    x, y = rel[:, 0], rel[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


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


def _straight_flags(ring: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
    """Straight vertices of one ring (see :attr:`Environment.straight`): first each vertex
    against its neighbours, then each run of straight vertices against the chord of the kept
    vertices around it (so that a long, gently curving chain is not flattened). Vertices
    flagged in ``keep`` are never straight."""
    k = len(ring)
    prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    flags = _near_chord(ring, prev, nxt)
    if keep is not None:
        flags &= ~keep
    for _ in range(k):
        if flags.all() or not flags.any():
            break
        bad = _worst_in_runs(ring, flags)
        if not bad:
            break
        flags[bad] = False
    return flags


def _near_chord(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether points ``p`` lie within ``REL_STRAIGHT_TOL |b - a|`` of chords ``a-b`` and
    between their ends."""
    ab = b - a
    ap = p - a
    cross = np.abs(ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0])
    ll = np.einsum("ij,ij->i", ab, ab)
    along = np.einsum("ij,ij->i", ab, ap)
    return (cross <= REL_STRAIGHT_TOL * ll) & (along > 0) & (along < ll)


def _worst_in_runs(ring: np.ndarray, flags: np.ndarray) -> list[int]:
    """For each run of straight vertices whose kept ends' chord does not hold every vertex of
    the run, the vertex farthest from that chord (to be kept after all)."""
    k = len(ring)
    kept = np.flatnonzero(~flags)
    out = []
    for a, b in zip(kept, np.roll(kept, -1), strict=True):
        run = (np.arange(a + 1, a + 1 + (b - a - 1) % k)) % k
        if len(run) == 0:
            continue
        pa = np.repeat(ring[a][None], len(run), axis=0)
        pb = np.repeat(ring[b][None], len(run), axis=0)
        ok = _near_chord(ring[run], pa, pb)
        if not ok.all():
            ab = ring[b] - ring[a]
            ap = ring[run] - ring[a]
            dev = np.abs(ab[0] * ap[:, 1] - ab[1] * ap[:, 0])
            out.append(int(run[int(np.argmax(np.where(ok, -1.0, dev)))]))
    return out


def _check_resolution(env: Environment) -> None:
    """Reject walls and gaps thinner than ``REL_FEATURE_TOL`` times the diameter: a vertex (not
    straight) closer than that to a wall it does not bound. A wall is a maximal run of edges
    joined by straight vertices, named after its first edge."""
    keep = ~env.straight
    frame = normalizing_frame(env.bounds)  # not env.frame: never cached during validation
    V = frame.to_internal(env.vertices)
    limit = REL_FEATURE_TOL * env.diameter * frame.scale
    wall = env.wall_of
    prev_kept = np.empty(env.n, dtype=int)
    start = 0
    for r in env.rings:
        idx = np.arange(start, start + len(r))
        kept = idx[keep[idx]]
        prev_kept[kept] = np.roll(kept, 1)
        start += len(r)
    pts = np.flatnonzero(keep)
    nxt = env.next_vertex
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


def _point_set_diameter(pts: np.ndarray) -> float:
    """Largest distance between two of the points (m, 2): exact over the convex hull's
    vertices (in chunks), computed about their centre (no cancellation at large offsets)."""
    c = pts.mean(axis=0)
    hull = shapely.convex_hull(shapely.multipoints(pts - c))
    h = shapely.get_coordinates(hull)
    if len(h) > 4000:  # a huge hull: its width over many directions (relative error 1e-7)
        ang = np.linspace(0.0, math.pi, 8192, endpoint=False)
        proj = h @ np.vstack((np.cos(ang), np.sin(ang)))
        return float((proj.max(axis=0) - proj.min(axis=0)).max())
    best = 0.0
    for lo in range(0, len(h), 1000):
        d = h[lo:lo + 1000, None, :] - h[None, :, :]
        best = max(best, float(np.sqrt(np.einsum("ijk,ijk->ij", d, d).max())))
    return best


@dataclass(frozen=True)
class Frame:
    """A similarity to the internal frame: ``internal = (user - origin) * scale``; ``scale``
    is a power of two, so lengths convert exactly and angles are unchanged."""

    origin: np.ndarray
    scale: float

    def to_internal(self, pts: Any) -> np.ndarray:
        """User points (m, 2) to internal ones."""
        return (np.asarray(pts, dtype=float) - self.origin) * self.scale

    def to_user(self, pts: Any) -> np.ndarray:
        """Internal points (m, 2) to user ones."""
        return np.asarray(pts, dtype=float) / self.scale + self.origin

    def geometry_to_user(self, geom: Any) -> Any:
        """A shapely geometry from internal to user coordinates."""
        return shapely.transform(geom, self.to_user)


_SQRT_HALF = math.sqrt(0.5)


def normalizing_frame(bounds: tuple[float, float, float, float]) -> Frame:
    """The internal frame of a map with these bounds ``(xmin, ymin, xmax, ymax)``: origin at
    the box's centre, scale a power of two bringing the box's diagonal near 1 (so that scaling
    is exact). A pure function of the bounds: a map scaled by ``2**k`` gets the scale times
    ``2**-k`` and the same internal map."""
    x0, y0, x1, y1 = bounds
    origin = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])
    # the diameter from the centred box: no cancellation at large offsets
    diam = math.hypot(x1 - origin[0], y1 - origin[1]) + math.hypot(origin[0] - x0,
                                                                   origin[1] - y0)
    # the nearest power of two on the log scale, decided on the mantissa (exact, and the same
    # for the map scaled by any power of two; round(log2(diam)) was not, at half-way ties
    # such as a square of side 2^k)
    mantissa, exponent = math.frexp(diam)
    return Frame(origin, 2.0 ** -(exponent if mantissa >= _SQRT_HALF else exponent - 1))


@dataclass(frozen=True, eq=False)
class Environment:
    """A polygonal map: the closed free space ``F`` bounded by an outer ring and hole rings.

    Parameters
    ----------
    boundary : array_like, shape (k, 2)
        Outer ring, any orientation, without or with a repeated closing vertex. Map units.
    holes : sequence of array_like
        Obstacle rings inside the boundary, with disjoint interiors. A hole may touch the
        boundary or another hole at single points where both rings have a vertex (coincident
        vertices), as long as the free space stays a valid polygon (connected interior).
    name : str
        A label for reports.

    Raises
    ------
    InvalidMapError
        If a ring is degenerate or self-intersecting, a coordinate is not finite, a hole is not
        inside the boundary, two holes overlap, two rings touch along a segment or at a
        vertex of one ring lying inside an edge of the other (the message names both and says
        where to add a vertex), or touching rings cut the free space in two.
    """

    boundary: np.ndarray
    holes: tuple[np.ndarray, ...] = ()
    name: str = ""

    def __post_init__(self) -> None:
        boundary = _ring_array(self.boundary, "boundary")
        holes = tuple(_ring_array(h, f"hole {k}") for k, h in enumerate(self.holes))
        object.__setattr__(self, "boundary", boundary)
        object.__setattr__(self, "holes", holes)
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
        _check_resolution(self)

    # ------------------------------------------------------------------ structure
    @property
    def rings(self) -> tuple[np.ndarray, ...]:
        """The rings in file order: boundary first, then the holes."""
        return (self.boundary, *self.holes)

    @cached_property
    def vertices(self) -> np.ndarray:
        """All vertices ``V0..V(n-1)`` in file order, shape (n, 2), map units."""
        return np.vstack(self.rings)

    @property
    def n(self) -> int:
        """Number of vertices (= number of edges)."""
        return len(self.vertices)

    @cached_property
    def ring_of(self) -> np.ndarray:
        """Index of the ring (0 = boundary) that each vertex belongs to, shape (n,)."""
        return np.concatenate([np.full(len(r), k) for k, r in enumerate(self.rings)])

    @cached_property
    def next_vertex(self) -> np.ndarray:
        """For each vertex ``Vi``, the index of the next vertex of its ring (end of ``Ei``)."""
        out, start = [], 0
        for r in self.rings:
            idx = np.arange(start, start + len(r))
            out.append(np.roll(idx, -1))
            start += len(r)
        return np.concatenate(out)

    @cached_property
    def prev_vertex(self) -> np.ndarray:
        """For each vertex ``Vi``, the index of the previous vertex of its ring."""
        prev = np.empty(self.n, dtype=int)
        prev[self.next_vertex] = np.arange(self.n)
        return prev

    @cached_property
    def free_on_left(self) -> np.ndarray:
        """For each edge ``Ei`` as given, whether the free space lies on its left, shape (n,)."""
        flags = []
        for k, r in enumerate(self.rings):
            ccw = _signed_area(r) > 0
            flags.append(np.full(len(r), ccw if k == 0 else not ccw))
        return np.concatenate(flags)

    @cached_property
    def oriented_edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Edges directed so that the free side is on the left.

        Returns
        -------
        A, B : ndarray, shape (n, 2)
            Start and end points of each edge ``Ei`` after orientation.
        tag_a, tag_b : ndarray of int, shape (n,)
            Indices of the vertices at ``A`` and ``B``.
        """
        i = np.arange(self.n)
        j = self.next_vertex
        left = self.free_on_left
        tag_a = np.where(left, i, j)
        tag_b = np.where(left, j, i)
        return self.vertices[tag_a], self.vertices[tag_b], tag_a, tag_b

    @cached_property
    def free_normals(self) -> np.ndarray:
        """Unit normal of each edge pointing into the free space, shape (n, 2)."""
        A, B, _, _ = self.oriented_edges
        d = B - A
        d = d / np.linalg.norm(d, axis=1)[:, None]
        return np.column_stack((-d[:, 1], d[:, 0]))

    @cached_property
    def cone(self) -> tuple[np.ndarray, np.ndarray]:
        """Free cone at each vertex: unit directions ``(d_out, d_in)``; the cone runs CCW from
        ``d_out`` (along the outgoing oriented edge) to ``d_in`` (back along the incoming one)."""
        A, B, tag_a, tag_b = self.oriented_edges
        d_out = np.empty((self.n, 2))
        d_in = np.empty((self.n, 2))
        d_out[tag_a] = B - A
        d_in[tag_b] = A - B
        d_out /= np.linalg.norm(d_out, axis=1)[:, None]
        d_in /= np.linalg.norm(d_in, axis=1)[:, None]
        return d_out, d_in

    @cached_property
    def reflex(self) -> np.ndarray:
        """Whether each vertex is reflex (interior angle of the free space > 180 degrees)."""
        d_out, d_in = self.cone
        # Walking along the oriented boundary (free on the left), a right turn is reflex.
        turn = d_in[:, 1] * d_out[:, 0] - d_in[:, 0] * d_out[:, 1]  # cross(-d_in, d_out)
        return (turn < -1e-12) & ~self.straight

    @cached_property
    def straight(self) -> np.ndarray:
        """Whether each vertex is straight: within ``REL_STRAIGHT_TOL`` of the chord joining
        the neighbours kept around it (see :mod:`tether.tolerances`), shape (n,). A straight
        vertex is no feature of the free space: it gets no curves and no regions, and the
        computation runs on the map without it (:attr:`internal`)."""
        out = np.zeros(self.n, dtype=bool)
        touch = self.touching
        start = 0
        for r in self.rings:
            out[start:start + len(r)] = _straight_flags(r - r.mean(axis=0),
                                                        touch[start:start + len(r)])
            start += len(r)
        return out

    @cached_property
    def coincident(self) -> np.ndarray:
        """For each vertex, the smallest index of a vertex at exactly the same point (itself
        when it is alone there), shape (n,). Vertices of different rings coincide where rings
        touch (a hole touching the boundary or another hole at a vertex of both); such a point
        is one feature of the free space: free-arc labels name it by this first vertex."""
        V = self.vertices
        order = np.lexsort((V[:, 1], V[:, 0]))
        s = V[order]
        new = np.r_[True, np.any(s[1:] != s[:-1], axis=1)]  # == on floats: -0.0 is 0.0
        group = np.empty(self.n, dtype=np.int64)
        group[order] = np.cumsum(new) - 1
        first = np.full(int(group.max()) + 1, self.n, dtype=np.int64)
        np.minimum.at(first, group, np.arange(self.n))
        return first[group]

    @cached_property
    def touching(self) -> np.ndarray:
        """Whether each vertex coincides with a vertex of another ring (rings touching there),
        shape (n,). A touching vertex is never straight (it is a vertex of the free space's
        pinch), and no rod passes through it from one side of the touching obstacles to the
        other (:func:`tether.arcs.rod_is_free_many`)."""
        c = self.coincident
        counts = np.bincount(c, minlength=self.n)
        return counts[c] > 1

    @cached_property
    def wall_of(self) -> np.ndarray:
        """For each edge ``Ei``, the file index of the first edge of its wall, shape (n,). A
        wall is a maximal run of edges joined by straight vertices; results name it after that
        edge (``E<wall_of[i]>``), and a straight vertex's name never appears."""
        keep = ~self.straight
        wall = np.empty(self.n, dtype=int)
        start = 0
        for r in self.rings:
            idx = np.arange(start, start + len(r))
            kept = idx[keep[idx]]
            pos = np.searchsorted(kept, idx, side="right") - 1  # -1: before the first kept one
            wall[idx] = kept[pos]  # pos -1 wraps to the ring's last kept vertex
            start += len(r)
        return wall

    @cached_property
    def frame(self) -> Frame:
        """The normalized internal frame (:func:`normalizing_frame` of the bounds); the
        identity for the internal map itself, so that normalizing is idempotent."""
        if self.__dict__.get("_is_internal"):
            return Frame(np.zeros(2), 1.0)
        return normalizing_frame(self.bounds)

    @cached_property
    def internal(self) -> Environment:
        """The map the computation runs on: in :attr:`frame`, without its straight vertices.
        Its vertex ``j`` is this map's ``vertex_map[j]``, its edge ``k`` starts the wall named
        after this map's edge ``vertex_map[k]``. The internal map's own internal map is itself.
        """
        if self.__dict__.get("_is_internal"):
            return self
        keep = ~self.straight
        rings, start = [], 0
        for r in self.rings:
            rings.append(self.frame.to_internal(r[keep[start:start + len(r)]]))
            start += len(r)
        # Flagged before it is validated: validation must see the internal map's own (identity)
        # frame, never cache one computed from its normalized bounds (a square of side 4 had
        # frame scale 1/4, its internal copy 1/2: every lss was halved twice on that copy).
        inner = object.__new__(Environment)
        inner.__dict__["_is_internal"] = True
        try:
            inner.__init__(rings[0], tuple(rings[1:]), self.name)
        except InvalidMapError as exc:  # pragma: no cover - removing straight vertices broke it
            raise InvalidMapError(f"without its straight vertices, {exc}") from None
        inner.__dict__["vertex_map"] = np.arange(inner.n)
        return inner

    @property
    def is_internal(self) -> bool:
        """Whether this map is already in the internal frame (computation runs on it as is)."""
        return self.internal is self

    @cached_property
    def vertex_map(self) -> np.ndarray:
        """For each vertex of :attr:`internal`, its index in this map (file numbering)."""
        return np.flatnonzero(~self.straight)

    @cached_property
    def code_map(self) -> np.ndarray:
        """Feature codes of :attr:`internal` (edge ``k`` = ``k``, vertex ``j`` = ``n' + j``) to
        this map's codes; an internal edge maps to the first file edge of its wall."""
        vm = self.vertex_map
        return np.concatenate((vm, self.n + vm))

    def feature_names_map(self) -> dict[str, str]:
        """Internal feature names to this map's (file) names, e.g. ``{"E3": "E5"}``."""
        vm = self.vertex_map.tolist()
        out = {f"E{k}": f"E{v}" for k, v in enumerate(vm)}
        out.update({f"V{k}": f"V{v}" for k, v in enumerate(vm)})
        return out

    @property
    def reflex_indices(self) -> np.ndarray:
        """Indices of the reflex vertices."""
        return np.flatnonzero(self.reflex)

    @cached_property
    def polygon(self) -> Polygon:
        """The free space as a shapely polygon (prepared for fast predicates)."""
        poly = Polygon(self.boundary, list(self.holes))
        shapely.prepare(poly)
        return poly

    @cached_property
    def bounds(self) -> tuple[float, float, float, float]:
        """Bounding box ``(xmin, ymin, xmax, ymax)`` in map units."""
        lo = self.boundary.min(axis=0)
        hi = self.boundary.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @cached_property
    def diameter(self) -> float:
        """The map's diameter: the largest distance between two vertices, map units. Unlike
        the bounding box's diagonal it does not change when the map is rotated, so neither do
        the tolerances relative to it."""
        return _point_set_diameter(self.boundary)

    @property
    def length_tol(self) -> float:
        """Length tolerance in map units: ``REL_LENGTH_TOL`` times the map diameter."""
        return REL_LENGTH_TOL * self.diameter

    @property
    def area(self) -> float:
        """Area of the free space, square map units."""
        return float(self.polygon.area)

    def edge_name(self, i: int) -> str:
        """Name of edge ``i`` (``"E3"``)."""
        return f"E{int(i)}"

    def vertex_name(self, j: int) -> str:
        """Name of vertex ``j`` (``"V5"``)."""
        return f"V{int(j)}"

    # ------------------------------------------------------------------ queries
    def edge_index(self, reach: float) -> EdgeIndex:
        """Grid index of the oriented edges for queries of radius ``reach`` (cached per reach)."""
        cache = self.__dict__.setdefault("_edge_indexes", {})
        key = float(reach)
        if key not in cache:
            A, B, _, _ = self.oriented_edges
            cache[key] = EdgeIndex.build(A, B, key * (1 + 1e-9) + self.length_tol)
        return cache[key]

    def contains(self, x: Any, y: Any) -> np.ndarray:
        """Whether points lie in the closed free space (vectorized over ``x, y``)."""
        return shapely.intersects_xy(self.polygon, x, y)

    def boundary_distance(self, x: Any, y: Any) -> np.ndarray:
        """Distance from points to the boundary of the free space, map units."""
        pts = shapely.points(np.asarray(x, float), np.asarray(y, float))
        return shapely.distance(self.polygon.boundary, pts)

    # ------------------------------------------------------------------ output
    def to_dict(self) -> dict:
        """The JSON map form ``{"name", "boundary", "holes"}`` (rings without closing vertex)."""
        return {
            "name": self.name,
            "boundary": self.boundary.tolist(),
            "holes": [h.tolist() for h in self.holes],
        }

    def summary(self) -> dict:
        """Counts, reflex vertices, area and bounding box, as a JSON-ready dict."""
        return {
            "name": self.name,
            "vertices": self.n,
            "edges": self.n,
            "holes": len(self.holes),
            "reflex_vertices": [self.vertex_name(j) for j in self.reflex_indices],
            "straight_vertices": [self.vertex_name(j) for j in np.flatnonzero(self.straight)],
            "area": self.area,
            "bounding_box": list(self.bounds),
        }

    def save(self, path: str | Path) -> None:
        """Write the map as JSON to ``path`` (written whole, or not at all)."""
        _write_atomic(Path(path), json.dumps(self.to_dict(), indent=1) + "\n")

    def __repr__(self) -> str:
        return (
            f"Environment(name={self.name!r}, vertices={self.n}, holes={len(self.holes)}, "
            f"reflex={int(self.reflex.sum())})"
        )


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all (:func:`tether._util.files.atomic_output`)."""
    from tether._util.files import atomic_output

    with atomic_output(path) as tmp:
        tmp.write_text(text)


# ---------------------------------------------------------------------- readers
#: Integer literals longer than this are rejected while parsing (coordinates are ordinary
#: numbers; Python refuses to convert integers of thousands of digits anyway).
_MAX_INT_DIGITS = 400


def _show(value: Any) -> str:
    """A short JSON-like rendering of a value for messages: ``"3"``, ``true``, ``an object``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, str):
        text = json.dumps(value)
        return text if len(text) <= 30 else text[:27] + '..."'
    return repr(value)[:30]


def _check_text(text: str, path: str) -> None:
    """Reject strings that cannot be printed (lone surrogates from ``\\ud800`` escapes)."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise InvalidMapError(f"{path}: not valid Unicode text (character {exc.start} is a "
                              "lone surrogate)") from None


def _number(value: Any, path: str) -> float:
    """A JSON number as a finite float; booleans, strings, null... rejected with the path."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InvalidMapError(f"{path}: expected a number, got {_show(value)}")
    try:
        f = float(value)
    except OverflowError:
        raise InvalidMapError(f"{path}: number too large for a coordinate") from None
    if not math.isfinite(f):
        raise InvalidMapError(f"{path}: non-finite coordinate {_show(value)}")
    return f


def _ring_list(value: Any, path: str, *, extra_dims: bool = False) -> list[list[float]]:
    """Check a JSON ring (a list of ``[x, y]`` pairs) element by element, naming the field.

    With ``extra_dims`` (GeoJSON positions), positions may carry a third or fourth number
    (altitude, measure), which is checked and dropped.
    """
    if not isinstance(value, list):
        raise InvalidMapError(f"{path}: expected a list of [x, y] pairs, got {_show(value)}")
    if len(value) > MAX_VERTICES:
        raise InvalidMapError(f"{path}: {len(value)} vertices, more than tether takes "
                              f"({MAX_VERTICES})")
    out = []
    for i, pt in enumerate(value):
        where = f"{path}[{i}]"
        if not isinstance(pt, list):
            raise InvalidMapError(f"{where}: expected an [x, y] pair, got {_show(pt)}")
        if len(pt) != 2 and not (extra_dims and 2 <= len(pt) <= 4):
            raise InvalidMapError(f"{where}: expected an [x, y] pair, got {len(pt)} values (a "
                                  "ring is a list of [x, y] pairs)")
        out.append([_number(v, f"{where}[{k}]") for k, v in enumerate(pt)][:2])
    return out


def _rings_list(value: Any, path: str, *, extra_dims: bool = False) -> list[list[list[float]]]:
    """A JSON list of rings, checked with :func:`_ring_list`."""
    if not isinstance(value, list):
        raise InvalidMapError(f"{path}: expected a list of rings, got {_show(value)}")
    rings = [_ring_list(r, f"{path}[{k}]", extra_dims=extra_dims) for k, r in enumerate(value)]
    total = sum(len(r) for r in rings)
    if total > MAX_VERTICES:
        raise InvalidMapError(f"{path}: {total} vertices in all, more than tether takes "
                              f"({MAX_VERTICES})")
    return rings


def from_dict(data: Any, where: str = "map") -> Environment:
    """Build an :class:`Environment` from the JSON map form, rejecting unknown keys.

    Raises
    ------
    InvalidMapError
        If keys are missing or unknown, a value has the wrong JSON type (the message names the
        field, e.g. ``holes[0][2][1]: expected a number, got "3"``), or the geometry is invalid.
    """
    if not isinstance(data, dict):
        raise InvalidMapError(f"{where}: expected a JSON object with 'boundary' and 'holes', "
                              f"got {_show(data)}")
    unknown = set(data) - _JSON_KEYS
    if unknown:
        raise InvalidMapError(f"{where}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    if "boundary" not in data:
        raise InvalidMapError(f"{where}: missing key 'boundary'")
    name = data.get("name", "")
    if not isinstance(name, str):
        raise InvalidMapError(f"{where}: name: expected a string, got {_show(name)}")
    _check_text(name, f"{where}: name")
    try:
        boundary = _ring_list(data["boundary"], "boundary")
        holes = _rings_list(data.get("holes", []), "holes")
        if len(boundary) + sum(map(len, holes)) > MAX_VERTICES:
            raise InvalidMapError(f"more than {MAX_VERTICES} vertices in all")
        return Environment(boundary, tuple(holes), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


_GEOMETRY_TYPES = {"Point", "MultiPoint", "LineString", "MultiLineString", "Polygon",
                   "MultiPolygon", "GeometryCollection"}


def from_geojson(data: Any, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a GeoJSON Polygon, Feature or one-feature collection.

    A Feature's geometry must be a Polygon (not another Feature); positions may carry an
    altitude, which is dropped. Messages name the field (``features[0].geometry.type``).
    """
    try:
        return _from_geojson(data, "", name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def _from_geojson(data: Any, path: str, name: str) -> Environment:
    here = path or "GeoJSON"
    if not isinstance(data, dict):
        raise InvalidMapError(f"{here}: expected a GeoJSON object, got {_show(data)}")
    kind = data.get("type")
    if not isinstance(kind, str):
        raise InvalidMapError(f"{path + '.' if path else ''}type: expected a string, got "
                              f"{_show(kind)}")
    dot = path + "." if path else ""
    if kind == "FeatureCollection":
        if path:
            raise InvalidMapError(f"{here}: a FeatureCollection cannot be nested")
        feats = data.get("features")
        if not isinstance(feats, list) or len(feats) != 1:
            got = f"{len(feats)} features" if isinstance(feats, list) else _show(feats)
            raise InvalidMapError(f"{dot}features: a FeatureCollection must hold exactly one "
                                  f"feature, got {got}")
        return _from_geojson(feats[0], f"{dot}features[0]", name)
    if kind == "Feature":
        if path.endswith("geometry"):
            raise InvalidMapError(f"{here}: expected a Polygon geometry, got a Feature "
                                  "(a Feature cannot be nested in a Feature)")
        props = data.get("properties") or {}
        if not isinstance(props, dict):
            raise InvalidMapError(f"{dot}properties: expected an object or null, got "
                                  f"{_show(props)}")
        nm = props.get("name", name)
        if not isinstance(nm, str):
            raise InvalidMapError(f"{dot}properties.name: expected a string, got {_show(nm)}")
        _check_text(nm, f"{dot}properties.name")
        if "geometry" not in data or data["geometry"] is None:
            raise InvalidMapError(f"{dot}geometry: missing (a Feature needs a Polygon)")
        return _from_geojson(data["geometry"], f"{dot}geometry", nm)
    if kind != "Polygon":
        what = "geometry" if kind in _GEOMETRY_TYPES else "GeoJSON type"
        raise InvalidMapError(f"{dot}type: must be a Polygon, got the {what} {kind!r}")
    rings = _rings_list(data.get("coordinates"), f"{dot}coordinates", extra_dims=True)
    if not rings:
        raise InvalidMapError(f"{dot}coordinates: the Polygon has no rings")
    return Environment(rings[0], tuple(rings[1:]), name)


_WKT_KEYWORD = re.compile(r"\s*(SRID=\d+;\s*)?([A-Za-z]+)")


def from_wkt(text: str, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a WKT ``POLYGON`` (Z and M values are dropped)."""
    m = _WKT_KEYWORD.match(text)
    if not m:
        start = " ".join(text.split())[:30]
        raise InvalidMapError(f"{where}: not WKT: expected POLYGON ((x y, ...)), got "
                              f"{start!r}" if start else f"{where}: the file is empty")
    keyword = m.group(2).upper()
    if m.group(1):  # EWKT's spatial reference: coordinates are taken as they are
        text = text[m.start(2):]
    if keyword != "POLYGON":
        raise InvalidMapError(f"{where}: WKT must be a POLYGON, got {keyword} (a type tether "
                              "does not take)")
    try:
        geom = shapely.from_wkt(text.strip())
    except (shapely.errors.GEOSException, ValueError) as exc:
        msg = " ".join(str(exc).split())
        msg = msg if len(msg) <= 120 else msg[:117] + "..."
        raise InvalidMapError(f"{where}: malformed WKT ({msg})") from None
    if geom is None or geom.geom_type != "Polygon" or geom.is_empty:
        kind = "empty" if geom is None or geom.is_empty else geom.geom_type
        raise InvalidMapError(f"{where}: WKT must be a non-empty POLYGON, got {kind}")
    rings = [np.asarray(geom.exterior.coords)[:, :2]]
    rings += [np.asarray(r.coords)[:, :2] for r in geom.interiors]
    if sum(map(len, rings)) > MAX_VERTICES:
        raise InvalidMapError(f"{where}: more than {MAX_VERTICES} vertices in all")
    try:
        return Environment(rings[0], tuple(rings[1:]), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def _decode(raw: bytes, where: str, json_like: bool) -> str:
    """Decode a map file: UTF-8 (with or without BOM); UTF-16/32 with a BOM, or JSON in
    UTF-16/32 without one. Binary and other encodings are rejected with the offending byte."""
    for bom, bom_codec in ((b"\xff\xfe\x00\x00", "utf-32"), (b"\x00\x00\xfe\xff", "utf-32"),
                       (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"),
                       (b"\xef\xbb\xbf", "utf-8-sig")):
        if raw.startswith(bom):
            codec = bom_codec
            break
    else:
        codec = json.detect_encoding(raw) if json_like and b"\x00" in raw[:4] else "utf-8"
    try:
        text = raw.decode(codec)
    except UnicodeDecodeError as exc:
        byte = raw[exc.start]
        line = raw[:exc.start].count(b"\n") + 1
        if b"\x00" in raw[:4096] or _looks_binary(raw):
            raise InvalidMapError(f"{where}: a binary file, not a map (byte 0x{byte:02x} at "
                                  f"offset {exc.start})") from None
        raise InvalidMapError(f"{where}: not {codec.upper()} text (byte 0x{byte:02x} at line "
                              f"{line}, offset {exc.start}); save the map as UTF-8") from None
    if "\x00" in text:
        raise InvalidMapError(f"{where}: a binary file, not a map (NUL character at offset "
                              f"{text.index(chr(0))})")
    return text


def _looks_binary(raw: bytes) -> bool:
    head = raw[:4096]
    controls = sum(b < 9 or 13 < b < 32 for b in head)
    return controls > len(head) // 20


def _parse_int(text: str) -> int:
    if len(text) > _MAX_INT_DIGITS:
        raise InvalidMapError(f"an integer of {len(text)} digits; coordinates must be ordinary "
                              f"numbers (at most {_MAX_INT_DIGITS} digits)")
    return int(text)


def _parse_json(text: str, where: str) -> Any:
    try:
        return json.loads(text, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise InvalidMapError(
            f"{where}: malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None
    except RecursionError:
        raise InvalidMapError(f"{where}: JSON nested too deeply (a map needs 3 or 4 levels of "
                              "arrays)") from None
    except ValueError as exc:  # e.g. Python's limit on integer digits
        raise InvalidMapError(f"{where}: unreadable JSON ({' '.join(str(exc).split())})") \
            from None


def load_map(path: str | Path) -> Environment:
    """Read a map file: ``.json`` (tether's form or GeoJSON), ``.geojson``, ``.wkt``, or a ROS
    ``map_server`` map ``.yaml`` (see :func:`tether.occupancy.read_ros_map`, default options).

    Files must be text: UTF-8 (UTF-16/32 JSON is also read), at most ``MAX_MAP_BYTES`` bytes
    and ``MAX_VERTICES`` vertices (:mod:`tether.tolerances`).

    Raises
    ------
    InvalidMapError
        If the file is missing, of an unknown format, binary, too large, malformed, of the wrong
        JSON types, or the polygon is invalid. The message names the file and, for JSON, the
        line and column or the field (``holes[0][2][1]``).
    """
    p = Path(path)
    where = str(path)
    suffix = p.suffix.lower()
    if suffix in {".yaml", ".yml"}:
        from tether.occupancy import read_ros_map

        return read_ros_map(p)
    if suffix not in {".json", ".geojson", ".wkt"}:
        raise InvalidMapError(f"{where}: unknown map format {suffix or '(none)'!r}; "
                              "use .json, .geojson, .wkt or a ROS map .yaml")
    try:
        if p.is_dir():
            raise InvalidMapError(f"{where}: is a folder, not a map file")
        size = p.stat().st_size
        if size > MAX_MAP_BYTES:
            raise InvalidMapError(f"{where}: {size} bytes, larger than tether reads "
                                  f"({MAX_MAP_BYTES} bytes)")
        raw = p.read_bytes()
    except InvalidMapError:
        raise
    except ValueError as exc:  # an embedded NUL byte
        raise InvalidMapError(f"{where!r}: not a usable file name ({exc})") from None
    except OSError as exc:
        raise InvalidMapError(f"{where}: cannot read ({exc.strerror or exc})") from None
    if not raw.strip():
        raise InvalidMapError(f"{where}: the file is empty")
    text = _decode(raw, where, json_like=suffix != ".wkt")
    if suffix == ".wkt":
        return from_wkt(text, where, p.stem)
    data = _parse_json(text, where)
    if isinstance(data, dict) and "type" in data:
        return from_geojson(data, where, p.stem)
    env = from_dict(data, where)
    if not env.name:
        object.__setattr__(env, "name", p.stem)
    return env
