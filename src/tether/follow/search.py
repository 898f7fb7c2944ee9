"""Where to look for an unseen target: candidate observer poses, what each sees of the set where
the target can be, how soon the observer gets there, and the way there.

**Candidates**, in three tiers (a tier's score is multiplied by its weight, so a higher tier wins
a near tie):

1. *escape poses* of the loss (weight :data:`ESCAPE_WEIGHT`): the corner pose beside the reflex
   vertex that cut the line of sight when the target left view (where it escaped), and the
   last sighting itself;
2. *corner poses* (weight :data:`CORNER_WEIGHT`): beside every reflex vertex of the map (pushed
   into the free space along the bisector of its free cone, by ``clearance``);
3. *grid poses* (weight 1): free points on a square lattice of spacing ``spacing``.

**Score** of a candidate ``c``: the fraction of the possible set in view from ``c`` (line of
sight, within the sensor range), discounted by the observer's travel time ``τ_c`` (its geodesic
distance over ``vo``): ``view(c)·exp(−τ_c/T)`` with ``T = lss/vt``, the time the set's radius
takes to grow by one rod length. The observer heads to the best candidate; it keeps its current
goal while that still scores at least :data:`KEEP` of the best (no dithering between near ties).

**Travel** goes through the corner poses: the geodesic from the observer to a candidate bends
only there (:class:`tether.follow.reachable.Geodesics` on the pushed vertices; a bend ``ε`` off
the corner lengthens a path by at most ``2ε`` per bend).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from tether.environment import Environment
from tether.follow.reachable import ReachGrid, clear_segments, visible_from

__all__ = ["CORNER_WEIGHT", "ESCAPE_WEIGHT", "KEEP", "Plan", "SearchPlanner"]

#: Score weight of the escape poses of the loss (tier 1).
ESCAPE_WEIGHT = 1.2
#: Score weight of the poses beside the map's reflex vertices (tier 2).
CORNER_WEIGHT = 1.1
#: The current goal is kept while its score is at least this fraction of the best.
KEEP = 0.9


class Plan:
    """One decision of the search: the goal ``pose`` (x, y, heading rad), the next
    ``waypoint`` on the way (x, y), the goal's ``view`` (fraction of the set in view from it),
    its travel time ``eta`` (s) and its tier (1, 2 or 3)."""

    __slots__ = ("eta", "goal", "pose", "tier", "view", "waypoint")

    def __init__(self, goal: int, pose: tuple[float, float, float], waypoint: np.ndarray,
                 view: float, eta: float, tier: int) -> None:
        self.goal, self.pose, self.waypoint = goal, pose, waypoint
        self.view, self.eta, self.tier = view, eta, tier


def _pushed_corners(env: Environment, clearance: float) -> tuple[np.ndarray, np.ndarray]:
    """Each reflex vertex moved ``clearance`` into the free space along its cone's bisector
    (those that land outside the free space are dropped), and the vertex index of each."""
    idx = env.reflex_indices
    if not len(idx):
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    d_out, d_in = env.cone
    out = -(d_out[idx] + d_in[idx])
    n = np.linalg.norm(out, axis=1)
    out = np.where(n[:, None] > 1e-12, out / np.maximum(n, 1e-300)[:, None], 0.0)
    pts = env.vertices[idx] + clearance * out
    ok = env.contains(pts[:, 0], pts[:, 1]) & (env.boundary_distance(pts[:, 0], pts[:, 1])
                                               > 0.5 * clearance)
    return pts[ok], idx[ok]


class SearchPlanner:
    """Candidate poses and their views of the grid ``grid`` in ``env`` (see the module).

    Parameters
    ----------
    env, grid : Environment, ReachGrid
        The map and the grid of the possible set.
    vo, vt, lss : float
        Observer and target speed bounds (map units/s) and the rod length (map units).
    sensor_range : float or None
        The sensor's range (map units); ``None``: unlimited line of sight.
    spacing : float
        Spacing of the grid poses (map units).
    clearance : float
        How far the corner poses stand off their vertex (map units).
    """

    def __init__(self, env: Environment, grid: ReachGrid, vo: float, vt: float, lss: float,
                 sensor_range: float | None, spacing: float, clearance: float) -> None:
        self.env, self.grid = env, grid
        self.vo, self.vt, self.lss = vo, vt, lss
        self.range = sensor_range
        self.horizon = lss / vt if vt > 0 else math.inf
        self.nav, self.nav_vertex = _pushed_corners(env, clearance)
        lattice = ReachGrid(env, spacing)
        far = env.boundary_distance(lattice.centers[:, 0], lattice.centers[:, 1]) > clearance
        self.static = np.vstack((self.nav, lattice.centers[far]))
        self.static_tier = np.r_[np.full(len(self.nav), 2), np.full(int(far.sum()), 3)]
        self.tier = self.static_tier.copy()
        self._nav_graph()
        self.static_view = self.view_matrix(self.static)
        self.static_reach = self._nav_to(self.static)
        self.extra = np.zeros((0, 2))
        self.extra_view = np.zeros((len(grid), 0), dtype=bool)
        self.extra_reach = np.zeros((len(self.nav), 0))

    # ------------------------------------------------------------------ precomputed
    def _nav_graph(self) -> None:
        k = len(self.nav)
        vis = np.zeros((k, k), dtype=bool)
        if k > 1:
            i, j = np.triu_indices(k, 1)
            ok = clear_segments(self.env, self.nav[i], self.nav[j])
            vis[i[ok], j[ok]] = vis[j[ok], i[ok]] = True
        w = np.linalg.norm(self.nav[:, None, :] - self.nav[None, :, :], axis=2)
        self.nav_dist = (dijkstra(csr_matrix(np.where(vis, w, 0.0)), directed=False)
                         if k else np.zeros((0, 0)))

    def sees(self, source: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Whether ``source`` sees each of ``points`` (line of sight within the range)."""
        if self.range is None:
            return visible_from(self.env, source, points)
        ok = np.hypot(points[:, 0] - source[0], points[:, 1] - source[1]) <= self.range
        idx = np.flatnonzero(ok)
        ok[idx] = visible_from(self.env, source, points[idx])
        return ok

    def view_matrix(self, poses: np.ndarray) -> np.ndarray:
        """(m, c) booleans: whether cell ``i`` is seen from pose ``j`` (one row per cell, so
        that the rows of the possible cells are gathered and summed, a few hundred rows
        rather than a product over the whole grid)."""
        out = np.zeros((len(self.grid), len(poses)), dtype=bool)
        for j, c in enumerate(poses):
            out[:, j] = self.sees(c, self.grid.centers)
        return out

    def _nav_to(self, poses: np.ndarray) -> np.ndarray:
        """(k, c) geodesic distance from each corner pose to each of ``poses`` via the graph."""
        k = len(self.nav)
        if not k or not len(poses):
            return np.zeros((k, len(poses)))
        a = np.repeat(self.nav, len(poses), axis=0)
        b = np.tile(poses, (k, 1))
        ok = clear_segments(self.env, a, b).reshape(k, len(poses))
        last = np.where(ok, np.linalg.norm(poses[None, :, :] - self.nav[:, None, :], axis=2),
                        np.inf)
        return np.min(self.nav_dist[:, :, None] + last[None, :, :], axis=1)

    # ------------------------------------------------------------------ per loss
    def set_escape(self, poses: np.ndarray, vertices: tuple[int, ...] = ()) -> None:
        """The tier-1 candidates of the current loss (replacing the previous loss's): extra
        ``poses`` (n, 2), and the corner poses beside the reflex ``vertices`` (map vertex
        indices; their views are the corner poses' own, computed once)."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 2)
        self.extra = poses
        self.extra_view = self.view_matrix(poses)
        self.extra_reach = self._nav_to(poses)
        self.tier = self.static_tier.copy()
        self.tier[np.flatnonzero(np.isin(self.nav_vertex, list(vertices)))] = 1

    # ------------------------------------------------------------------ per update
    def poses(self) -> np.ndarray:
        """Every candidate pose (tier 1 first), shape (c, 2)."""
        return np.vstack((self.extra, self.static))

    def travel(self, observer: np.ndarray, poses: np.ndarray, reach: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Geodesic distance from ``observer`` to each pose and the first corner on the way
        (−1: straight there)."""
        direct = np.where(visible_from(self.env, observer, poses),
                          np.linalg.norm(poses - observer, axis=1), np.inf)
        if not len(self.nav):
            return direct, np.full(len(poses), -1)
        to_nav = np.where(visible_from(self.env, observer, self.nav),
                          np.linalg.norm(self.nav - observer, axis=1), np.inf)
        via = to_nav[:, None] + reach
        k = np.argmin(via, axis=0)
        best = via[k, np.arange(len(poses))]
        first = np.where(direct <= best, -1, k)
        return np.minimum(direct, best), first

    def plan(self, observer: np.ndarray, possible: np.ndarray, current: int | None
             ) -> Plan | None:
        """The best candidate for the possible set ``possible`` (booleans over the grid's
        cells) from ``observer``; ``None`` when no reachable pose sees any of the set."""
        idx = np.flatnonzero(possible)
        if not len(idx):
            return None
        view = np.r_[np.count_nonzero(self.extra_view[idx], axis=0),
                     np.count_nonzero(self.static_view[idx], axis=0)] / len(idx)
        poses = self.poses()
        reach = np.hstack((self.extra_reach, self.static_reach))
        dist, first = self.travel(observer, poses, reach)
        eta = dist / self.vo
        tier = np.r_[np.ones(len(self.extra), dtype=int), self.tier]
        weight = np.choose(tier - 1, [ESCAPE_WEIGHT, CORNER_WEIGHT, 1.0])
        score = np.where(np.isfinite(eta) & (view > 0),
                         view * np.exp(-eta / self.horizon) * weight, -1.0)
        best = int(np.argmax(score))
        if score[best] <= 0:
            return None
        if current is not None and current < len(score) and score[current] >= KEEP * score[best]:
            best = current
        goal = poses[best]
        ne = len(self.extra)
        col = self.extra_view[:, best] if best < ne else self.static_view[:, best - ne]
        seen = col & possible
        centre = self.grid.centers[seen].mean(axis=0)
        heading = math.atan2(centre[1] - goal[1], centre[0] - goal[0])
        way = goal if first[best] < 0 else self.nav[first[best]]
        return Plan(best, (float(goal[0]), float(goal[1]), heading), way, float(view[best]),
                    float(eta[best]), int(tier[best]))
