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
from tether.tolerances import REL_LENGTH_TOL

_JSON_KEYS = {"boundary", "holes", "name"}


def _ring_array(coords: Any, where: str) -> np.ndarray:
    """Turn a list of ``[x, y]`` pairs into an ``(k, 2)`` float array, checking shape and values."""
    try:
        arr = np.asarray(coords, dtype=float)
    except (TypeError, ValueError) as exc:
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
    x, y = ring[:, 0], ring[:, 1]
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


def _at(geom: Any) -> str:
    """`` at (x, y)``: a point of ``geom`` (a location for a message), or ``""`` if empty."""
    if geom is None or geom.is_empty:
        return ""
    p = geom.representative_point() if geom.geom_type != "Point" else geom
    return f" at ({_fmt(p.x)}, {_fmt(p.y)})"


def _where_outside(outer: Polygon, hole: Polygon) -> str:
    """Where a hole leaves or touches the boundary ring, for the error message."""
    touch = outer.exterior.intersection(hole.exterior)
    if not touch.is_empty:
        return _at(touch)
    return _at(hole.difference(outer))


@dataclass(frozen=True, eq=False)
class Environment:
    """A polygonal map: the closed free space ``F`` bounded by an outer ring and hole rings.

    Parameters
    ----------
    boundary : array_like, shape (k, 2)
        Outer ring, any orientation, without or with a repeated closing vertex. Map units.
    holes : sequence of array_like
        Obstacle rings strictly inside the boundary, pairwise disjoint.
    name : str
        A label for reports.

    Raises
    ------
    InvalidMapError
        If a ring is degenerate or self-intersecting, a coordinate is not finite, a hole is not
        strictly inside the boundary, or two holes overlap or touch.
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
        span = float(np.linalg.norm(allpts.max(axis=0) - allpts.min(axis=0)))
        tol = REL_LENGTH_TOL * max(span, 1e-300)
        _validate_ring(boundary, "boundary", tol)
        outer = Polygon(boundary)
        hole_polys = []
        for k, h in enumerate(holes):
            _validate_ring(h, f"hole {k}", tol)
            hp = Polygon(h)
            if not outer.contains(hp) or outer.exterior.intersects(LinearRing(h)):
                raise InvalidMapError(f"hole {k}: not strictly inside the boundary"
                                      f"{_where_outside(outer, hp)}")
            for j, other in enumerate(hole_polys):
                if hp.intersects(other):
                    raise InvalidMapError(f"holes {j} and {k} overlap or touch"
                                          f"{_at(hp.intersection(other))}")
            hole_polys.append(hp)

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
        return turn < -1e-12

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

    @property
    def diameter(self) -> float:
        """Diagonal of the bounding box, map units."""
        x0, y0, x1, y1 = self.bounds
        return math.hypot(x1 - x0, y1 - y0)

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
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text)
    tmp.replace(path)


# ---------------------------------------------------------------------- readers
def from_dict(data: Any, where: str = "map") -> Environment:
    """Build an :class:`Environment` from the JSON map form, rejecting unknown keys.

    Raises
    ------
    InvalidMapError
        If keys are missing or unknown, or the geometry is invalid.
    """
    if not isinstance(data, dict):
        raise InvalidMapError(f"{where}: expected a JSON object with 'boundary' and 'holes'")
    unknown = set(data) - _JSON_KEYS
    if unknown:
        raise InvalidMapError(f"{where}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    if "boundary" not in data:
        raise InvalidMapError(f"{where}: missing key 'boundary'")
    holes = data.get("holes", [])
    if not isinstance(holes, list):
        raise InvalidMapError(f"{where}: 'holes' must be a list of rings")
    name = data.get("name", "")
    if not isinstance(name, str):
        raise InvalidMapError(f"{where}: 'name' must be a string")
    try:
        return Environment(data["boundary"], tuple(holes), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def from_geojson(data: Any, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a GeoJSON Polygon, Feature or one-feature collection."""
    if not isinstance(data, dict) or "type" not in data:
        raise InvalidMapError(f"{where}: not a GeoJSON object")
    kind = data["type"]
    if kind == "FeatureCollection":
        feats = data.get("features")
        if not isinstance(feats, list) or len(feats) != 1:
            raise InvalidMapError(f"{where}: a FeatureCollection must hold exactly one feature")
        return from_geojson(feats[0], where, name)
    if kind == "Feature":
        props = data.get("properties") or {}
        nm = props.get("name", name) if isinstance(props, dict) else name
        return from_geojson(data.get("geometry"), where, str(nm))
    if kind != "Polygon":
        raise InvalidMapError(f"{where}: GeoJSON geometry must be a Polygon, got {kind!r}")
    rings = data.get("coordinates")
    if not isinstance(rings, list) or not rings:
        raise InvalidMapError(f"{where}: Polygon has no coordinates")
    try:
        return Environment(rings[0], tuple(rings[1:]), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def from_wkt(text: str, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a WKT ``POLYGON``."""
    try:
        geom = shapely.from_wkt(text.strip())
    except shapely.errors.GEOSException as exc:
        raise InvalidMapError(f"{where}: malformed WKT ({exc})") from None
    if geom is None or geom.geom_type != "Polygon" or geom.is_empty:
        kind = "empty" if geom is None else geom.geom_type
        raise InvalidMapError(f"{where}: WKT must be a POLYGON, got {kind}")
    rings = [np.asarray(geom.exterior.coords)[:, :2]]
    rings += [np.asarray(r.coords)[:, :2] for r in geom.interiors]
    try:
        return Environment(rings[0], tuple(rings[1:]), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def load_map(path: str | Path) -> Environment:
    """Read a map file: ``.json`` (tether's form or GeoJSON), ``.geojson``, ``.wkt``, or a ROS
    ``map_server`` map ``.yaml`` (see :func:`tether.occupancy.read_ros_map`, default options).

    Raises
    ------
    InvalidMapError
        If the file is missing, of an unknown format, malformed, or the polygon is invalid. The
        message names the file and, for JSON, the line and column.
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
        text = p.read_text()
    except OSError as exc:
        raise InvalidMapError(f"{where}: cannot read ({exc.strerror})") from None
    if suffix == ".wkt":
        return from_wkt(text, where, p.stem)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidMapError(
            f"{where}: malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    if isinstance(data, dict) and "type" in data:
        return from_geojson(data, where, p.stem)
    env = from_dict(data, where)
    if not env.name:
        object.__setattr__(env, "name", p.stem)
    return env
