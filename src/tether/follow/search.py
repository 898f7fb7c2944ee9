"""Where to look for an unseen target: candidate observer poses, what each sees of the set where
the target can be, how soon the observer gets there, and the way there.

**Candidates**, in three tiers (a tier's score is multiplied by its weight, so a higher tier wins
a near tie):

1. *escape poses* of the loss (weight :data:`ESCAPE_WEIGHT`): beside the reflex vertex that cut
   the line of sight when the target left view (the point where it escaped), and the last
   sighting itself;
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


def _pushed_corners(env: Environment, clearance: float) -> np.ndarray:
    """Each reflex vertex moved ``clearance`` into the free space along its cone's bisector
    (those that land outside the free space are dropped)."""
    idx = env.reflex_indices
    if not len(idx):
        return np.zeros((0, 2))
    d_out, d_in = env.cone
    out = -(d_out[idx] + d_in[idx])
    n = np.linalg.norm(out, axis=1)
    out = np.where(n[:, None] > 1e-12, out / np.maximum(n, 1e-300)[:, None], 0.0)
    pts = env.vertices[idx] + clearance * out
    ok = env.contains(pts[:, 0], pts[:, 1]) & (env.boundary_distance(pts[:, 0], pts[:, 1])
                                               > 0.5 * clearance)
    return pts[ok]


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
        self.nav = _pushed_corners(env, clearance)
        lattice = ReachGrid(env, spacing)
        far = env.boundary_distance(lattice.centers[:, 0], lattice.centers[:, 1]) > clearance
        self.static = np.vstack((self.nav, lattice.centers[far]))
        self.static_tier = np.r_[np.full(len(self.nav), 2), np.full(int(far.sum()), 3)]
        self._nav_graph()
        self.static_view = self.view_matrix(self.static)
        self.static_reach = self._nav_to(self.static)
        self.extra = np.zeros((0, 2))
        self.extra_view = np.zeros((0, len(grid)), dtype=np.float32)
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
        ok = visible_from(self.env, source, points)
        if self.range is not None:
            ok &= np.linalg.norm(points - source, axis=1) <= self.range
        return ok

    def view_matrix(self, poses: np.ndarray) -> np.ndarray:
        """(c, m) float32: 1 where pose ``i`` sees cell ``j``."""
        out = np.zeros((len(poses), len(self.grid)), dtype=np.float32)
        for i, c in enumerate(poses):
            out[i] = self.sees(c, self.grid.centers)
        return out

    def _nav_to(self, poses: np.ndarray) -> np.ndarray:
        """(k, c) geodesic distance from each corner pose to each of ``poses`` via the graph."""
        k = len(self.nav)
        if not k or not len(poses):
            return np.zeros((k, len(poses)))
        last = np.full((k, len(poses)), np.inf)
        for j in range(k):
            ok = clear_segments(self.env, self.nav[j], poses)
            last[j, ok] = np.linalg.norm(poses[ok] - self.nav[j], axis=1)
        return np.min(self.nav_dist[:, :, None] + last[None, :, :], axis=1)

    # ------------------------------------------------------------------ per loss
    def set_escape(self, poses: np.ndarray) -> None:
        """The tier-1 poses of the current loss (replacing the previous loss's)."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 2)
        self.extra = poses
        self.extra_view = self.view_matrix(poses)
        self.extra_reach = self._nav_to(poses)

    # ------------------------------------------------------------------ per update
    def poses(self) -> np.ndarray:
        """Every candidate pose (tier 1 first), shape (c, 2)."""
        return np.vstack((self.extra, self.static))

    def travel(self, observer: np.ndarray, poses: np.ndarray, reach: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Geodesic distance from ``observer`` to each pose and the first corner on the way
        (−1: straight there)."""
        direct = np.where(clear_segments(self.env, observer, poses),
                          np.linalg.norm(poses - observer, axis=1), np.inf)
        if not len(self.nav):
            return direct, np.full(len(poses), -1)
        to_nav = np.where(clear_segments(self.env, observer, self.nav),
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
        weights = possible.astype(np.float32)
        total = float(weights.sum())
        if total <= 0:
            return None
        view = np.r_[self.extra_view @ weights, self.static_view @ weights] / total
        poses = self.poses()
        reach = np.hstack((self.extra_reach, self.static_reach))
        dist, first = self.travel(observer, poses, reach)
        eta = dist / self.vo
        tier = np.r_[np.ones(len(self.extra), dtype=int), self.static_tier]
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
        row = self.extra_view[best] if best < ne else self.static_view[best - ne]
        seen = (row > 0) & possible
        centre = self.grid.centers[seen].mean(axis=0)
        heading = math.atan2(centre[1] - goal[1], centre[0] - goal[0])
        way = goal if first[best] < 0 else self.nav[first[best]]
        return Plan(best, (float(goal[0]), float(goal[1]), heading), way, float(view[best]),
                    float(eta[best]), int(tier[best]))
