"""The map model: a polygon with holes, its named features, reflex and straight vertices, its
internal copy in the normalized frame, and its JSON form.

Feature names follow the file: vertices ``V0..V(n-1)`` and edges ``E0..E(n-1)`` in the order the
file gives them, boundary ring first, then each hole in order. Edge ``Ei`` runs from ``Vi`` to the
next vertex of the same ring. Orientation is normalized only to know each edge's free side; it
never renumbers anything.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from tether._util.memo import Memo, memo_field
from tether.environment.frame import (
    Frame,
    identity_frame,
    internal_rings,
    normalizing_frame,
    straight_flags,
)
from tether.environment.validate import check_resolution, check_rings, ring_array
from tether.errors import InvalidMapError
from tether.spatial import EdgeIndex
from tether.tolerances import REL_LENGTH_TOL

__all__ = ["Environment"]


def _signed_area(ring: np.ndarray) -> float:
    rel = ring - ring.mean(axis=0)  # centred: no cancellation at large offsets
    x, y = rel[:, 0], rel[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


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
    #: values derived on demand and kept (indexes, name tables): see :class:`Memo`
    memo: Memo = memo_field()

    def __post_init__(self) -> None:
        boundary = ring_array(self.boundary, "boundary")
        holes = tuple(ring_array(h, f"hole {k}") for k, h in enumerate(self.holes))
        object.__setattr__(self, "boundary", boundary)
        object.__setattr__(self, "holes", holes)
        check_rings(boundary, holes)
        check_resolution(self.rings, self.vertices, self.straight, self.wall_of,
                         self.next_vertex, self.diameter, self.bounds)

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
            out[start:start + len(r)] = straight_flags(r - r.mean(axis=0),
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
        """The normalized internal frame (:func:`~tether.environment.normalizing_frame` of the
        bounds); the identity for the internal map itself (set when it is built, see
        :meth:`_in_internal_frame`), so that normalizing is idempotent."""
        return normalizing_frame(self.bounds)

    @cached_property
    def internal(self) -> Environment:
        """The map the computation runs on: in :attr:`frame`, without its straight vertices.
        Its vertex ``j`` is this map's ``vertex_map[j]``, its edge ``k`` starts the wall named
        after this map's edge ``vertex_map[k]``. The internal map's own internal map is itself.
        """
        rings = internal_rings(self.rings, ~self.straight, self.frame)
        try:
            return Environment._in_internal_frame(rings[0], tuple(rings[1:]), self.name)
        except InvalidMapError as exc:  # pragma: no cover - removing straight vertices broke it
            raise InvalidMapError(f"without its straight vertices, {exc}") from None

    @classmethod
    def _in_internal_frame(cls, boundary: Any, holes: tuple[Any, ...], name: str
                           ) -> Environment:
        """A map given in the internal frame, without straight vertices (:attr:`internal`):
        its frame is the identity, its internal map itself, its vertex map the identity.

        The frame and the internal map are set before the map is validated: validation must
        see the internal map's own (identity) frame, never cache one computed from its
        normalized bounds (a square of side 4 had frame scale 1/4, its internal copy 1/2: every
        lss was halved twice on that copy).
        """
        inner = cls.__new__(cls)
        inner.__dict__.update(frame=identity_frame(), internal=inner)
        inner.__init__(boundary, holes, name)
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
        cache = self.memo.setdefault("edge_indexes", {})
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
        """Write the map as JSON to ``path`` (written whole, or not at all).

        Deprecated: the map model writes no file; use :func:`tether.io.save_map`.
        """
        from tether._util.files import atomic_output

        warnings.warn("Environment.save is deprecated and will be removed in the next release: "
                      "use tether.io.save_map(env, path)", DeprecationWarning, stacklevel=2)
        with atomic_output(Path(path)) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=1) + "\n")

    def __repr__(self) -> str:
        return (
            f"Environment(name={self.name!r}, vertices={self.n}, holes={len(self.holes)}, "
            f"reflex={int(self.reflex.sum())})"
        )

