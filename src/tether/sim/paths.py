"""Shortest paths for targets: a visibility graph of the free space shrunk by a clearance.

Targets walk polylines that keep ``clearance`` map units off the walls (a target on a wall is
outside the model, ``docs/conventions.md``). The graph's nodes are the vertices of the shrunk
free space;
two nodes are joined when the segment between them stays inside it. Lengths in map units.
"""

from __future__ import annotations

import math
from typing import Any

import networkx as nx
import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from tether.environment import Environment

__all__ = ["PathPlanner"]


class PathPlanner:
    """Shortest collision-free paths in ``env`` at ``clearance`` from its walls."""

    def __init__(self, env: Environment, clearance: float | None = None) -> None:
        self.env = env
        c = 1e-3 * env.diameter if clearance is None else float(clearance)
        shrunk = env.polygon.buffer(-c, join_style="mitre")
        if shrunk.is_empty:
            shrunk = env.polygon.buffer(-1e-6 * env.diameter, join_style="mitre")
        if shrunk.geom_type == "MultiPolygon":
            shrunk = max(shrunk.geoms, key=lambda g: g.area)
        self.space: Polygon = shrunk
        self._check = shrunk.buffer(1e-9 * env.diameter)
        shapely.prepare(self._check)
        rings = [shrunk.exterior, *shrunk.interiors]
        nodes = np.array([c for r in rings for c in list(r.coords)[:-1]], dtype=float)
        self.nodes = nodes
        g = nx.Graph()
        for i in range(len(nodes)):
            g.add_node(i)
        for i in range(len(nodes)):
            for j in range(i + 1, len(nodes)):
                if self.visible(nodes[i], nodes[j]):
                    g.add_edge(i, j, weight=float(np.linalg.norm(nodes[i] - nodes[j])))
        self.graph = g

    def visible(self, p: Any, q: Any) -> bool:
        """Whether the segment ``p–q`` stays in the shrunk free space."""
        p, q = tuple(map(float, p)), tuple(map(float, q))
        if p == q:
            return bool(self._check.covers(Point(p)))
        return bool(self._check.covers(LineString([p, q])))

    def contains(self, p: Any) -> bool:
        """Whether point ``p`` lies in the shrunk free space."""
        return bool(self._check.covers(Point(float(p[0]), float(p[1]))))

    def contains_many(self, pts: Any) -> np.ndarray:
        """:meth:`contains` for many points (n, 2) at once (a point covered by a polygon is a
        point that intersects it, so the answers are the same)."""
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        return shapely.intersects_xy(self._check, pts[:, 0], pts[:, 1])

    def path(self, p: Any, q: Any) -> np.ndarray:
        """Shortest path from ``p`` to ``q`` as waypoints (k, 2), ``p`` first and ``q`` last;
        just ``[p]`` when ``q`` cannot be reached."""
        p = np.asarray(p, dtype=float)
        q = np.asarray(q, dtype=float)
        if self.visible(p, q):
            return np.array([p, q])
        g = self.graph.copy()
        s, t = "s", "t"
        for key, pt in ((s, p), (t, q)):
            g.add_node(key)
            for i, nd in enumerate(self.nodes):
                if self.visible(pt, nd):
                    g.add_edge(key, i, weight=float(np.linalg.norm(pt - nd)))
        try:
            route = nx.shortest_path(g, s, t, weight="weight")
        except (nx.NetworkXNoPath, nx.NodeNotFound):
            return np.array([p])
        pts = [p] + [self.nodes[i] for i in route[1:-1]] + [q]
        return np.array(pts)

    def distance(self, p: Any, q: Any) -> float:
        """Length of the shortest path (inf when unreachable)."""
        pts = self.path(p, q)
        if len(pts) == 1:
            return 0.0 if np.allclose(pts[0], q) else math.inf
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())

    def random_point(self, rng: np.random.Generator) -> np.ndarray:
        """A uniformly random point of the shrunk free space."""
        x0, y0, x1, y1 = self.space.bounds
        for _ in range(10000):
            pt = rng.uniform((x0, y0), (x1, y1))
            if self.contains(pt):
                return pt
        rp = self.space.representative_point()
        return np.array([rp.x, rp.y])
