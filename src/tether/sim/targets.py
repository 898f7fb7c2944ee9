"""Target behaviours, all at speed at most ``vt`` and seeded through ``reset``'s generator.

:data:`tether.strategies.TARGETS` maps a kind name to a factory
``factory(world, **options) -> Target``:

* ``path``: waypoints (``waypoints=`` array or ``path=`` file of ``x y`` rows / JSON list), walked
  at constant speed ``vt`` (then the target stops).
* ``random``: random reachable goals, walked along shortest paths in the free space.
* ``wall``: the paper's antagonist, running along the obstacle boundary (just off the walls).
* ``tangential``: runs perpendicular to the rod, in the sense the observer is turning (the
  worst case of §3), steering off walls.
* ``dash``: runs the shortest path to the escape point the observer is least ready for.
* ``escape``: the Prop. 1 evader, crossing the piece recorded by the elimination for the cell
  the rod is in.
* ``search``: a white-box adversary that tries many velocity sequences over a short horizon
  against a copy of the controller and plays the one bringing the monitor closest to a loss.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tether.errors import InvalidParameterError
from tether.sim.paths import PathPlanner
from tether.sim.protocols import World

__all__ = [
    "DashTarget", "EscapeTarget", "PathTarget", "RandomTarget", "SearchTarget", "TangentialTarget",
    "TargetFactory", "WallTarget", "read_waypoints", "unit"
]


def _planner(world: World) -> PathPlanner:
    """One planner per world (cached in ``world.extra``)."""
    pl = world.extra.get("_planner")
    if pl is None:
        pl = PathPlanner(world.env, clearance=world.extra.get("clearance"))
        world.extra["_planner"] = pl
    return pl


class _Walker:
    """Walks a polyline at speed ``vt``; stops at its end."""

    def __init__(self) -> None:
        self.points = np.zeros((0, 2))
        self.k = 0
        self.vt = 0.0
        self.t_last: float | None = None
        self.dt = 0.0

    def set_path(self, pts: np.ndarray) -> None:
        self.points = np.asarray(pts, dtype=float).reshape(-1, 2)
        self.k = 1 if len(self.points) > 1 else len(self.points)

    @property
    def done(self) -> bool:
        return self.k >= len(self.points)

    def tick(self, t: float) -> None:
        if self.t_last is not None and t > self.t_last:
            self.dt = t - self.t_last
        self.t_last = t

    def velocity(self, p: np.ndarray) -> np.ndarray:
        """Velocity toward the current waypoint, at most ``vt`` and not overshooting it in one
        step (when the step is known)."""
        while not self.done:
            d = self.points[self.k] - p
            n = float(np.hypot(d[0], d[1]))
            if n <= 1e-9 * max(1.0, self.vt):
                self.k += 1
                continue
            speed = self.vt if self.dt <= 0 else min(self.vt, n / self.dt)
            return d * (speed / n)
        return np.zeros(2)


class PathTarget:
    """Walks given waypoints at constant speed ``vt`` (then stops)."""

    name = "path"

    def __init__(self, world: World, waypoints: Any = None, path: str | Path | None = None,
                 loop: bool = False) -> None:
        if waypoints is None and path is None:
            raise InvalidParameterError("target 'path' needs waypoints (--path FILE)")
        pts = read_waypoints(path) if waypoints is None else np.asarray(waypoints, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1 or not np.all(np.isfinite(pts)):
            raise InvalidParameterError("waypoints must be a list of finite (x, y) pairs")
        self.waypoints = pts
        self.loop = loop
        self.walker = _Walker()

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p``: walk to the waypoints."""
        self.walker = _Walker()
        self.walker.vt = world.vt
        self.walker.set_path(np.vstack([p, self.waypoints]))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity along the path at time ``t`` (s), map units/s."""
        self.walker.tick(t)
        if self.walker.done and self.loop:
            self.walker.set_path(np.vstack([p, self.waypoints]))
        return self.walker.velocity(p)


def read_waypoints(path: str | Path | None) -> np.ndarray:
    """Waypoints from a file: JSON (a list of pairs, or ``{"waypoints": [...]}``) or text with
    one ``x y`` (or ``x,y``) pair a line (``#`` comments)."""
    if path is None:
        raise InvalidParameterError("no waypoint file given")
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise InvalidParameterError(f"{p}: cannot read waypoints ({exc.strerror})") from None
    try:
        if p.suffix.lower() == ".json":
            data = json.loads(text)
            if isinstance(data, dict):
                data = data.get("waypoints")
            pts = np.asarray(data, dtype=float)
        else:
            rows = [ln.split("#")[0].replace(",", " ").split() for ln in text.splitlines()]
            pts = np.array([[float(r[0]), float(r[1])] for r in rows if r], dtype=float)
    except (ValueError, TypeError, IndexError, json.JSONDecodeError) as exc:
        raise InvalidParameterError(f"{p}: bad waypoints ({exc})") from None
    if pts.ndim != 2 or pts.shape[1:] != (2,) or len(pts) == 0:
        raise InvalidParameterError(f"{p}: waypoints must be (x, y) pairs")
    return pts


class RandomTarget:
    """Random reachable goals, walked along shortest paths in the free space."""

    name = "random"

    def __init__(self, world: World) -> None:
        self.walker = _Walker()

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p`` with the generator ``rng``: pick the first goal."""
        self.planner = _planner(world)
        self.rng = rng
        self.walker = _Walker()
        self.walker.vt = world.vt
        self._new_goal(p)

    def _new_goal(self, p: np.ndarray) -> None:
        for _ in range(20):
            route = self.planner.path(p, self.planner.random_point(self.rng))
            if len(route) > 1:
                self.walker.set_path(route)
                return
        self.walker.set_path(np.array([p]))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity toward the current goal at time ``t`` (s), map units/s."""
        self.walker.tick(t)
        v = self.walker.velocity(p)
        if self.walker.done:
            self._new_goal(p)
            v = self.walker.velocity(p)
        return v


def _lookahead_ok(planner: PathPlanner, p: np.ndarray, v: np.ndarray, horizon: float) -> bool:
    return planner.contains(p + v * horizon) and planner.visible(p, p + v * horizon)


def _steer(planner: PathPlanner, p: np.ndarray, v: np.ndarray, horizon: float) -> np.ndarray:
    """``v`` turned as little as possible so that ``horizon`` s of it stay in the free space."""
    n = float(np.hypot(*v))
    if n == 0:
        return v
    base = math.atan2(v[1], v[0])
    for turn in np.radians([0, 15, -15, 30, -30, 50, -50, 75, -75, 100, -100, 135, -135, 180]):
        w = n * np.array([math.cos(base + turn), math.sin(base + turn)])
        if _lookahead_ok(planner, p, w, horizon):
            return w
    return np.zeros(2)


class WallTarget:
    """The paper's antagonist: walks around the nearest obstacle boundary, just off it."""

    name = "wall"

    def __init__(self, world: World) -> None:
        self.walker = _Walker()

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p``: walk around the nearest obstacle boundary, in a random sense."""
        planner = _planner(world)
        rings = [np.asarray(r.coords)[:-1] for r in (planner.space.exterior,
                                                     *planner.space.interiors)]
        from shapely.geometry import LinearRing, Point

        dist = [LinearRing(r).distance(Point(p)) for r in rings]
        ring = rings[int(np.argmin(dist))]
        if rng.random() < 0.5:
            ring = ring[::-1]
        k = int(np.argmin(np.hypot(*(ring - p).T)))
        loop = np.vstack([ring[k:], ring[:k]] * 20)
        route = planner.path(p, loop[0])
        self.walker = _Walker()
        self.walker.vt = world.vt
        self.walker.set_path(np.vstack([route, loop[1:]]))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity along the boundary at time ``t`` (s), map units/s."""
        self.walker.tick(t)
        return self.walker.velocity(p)


class TangentialTarget:
    """Runs perpendicular to the rod in the sense the observer is turning (the worst case of
    §3), turning as little as needed to stay off the walls."""

    name = "tangential"

    def __init__(self, world: World) -> None:
        pass

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p`` with rod orientation ``a`` (radians)."""
        self.planner = _planner(world)
        self.vt = world.vt
        self.lss = world.lss
        self.a_prev = a
        self.sense = 1.0 if rng.random() < 0.5 else -1.0

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity across the rod (see the class) at time ``t`` (s), map units/s."""
        da = a - self.a_prev
        if abs(da) > 1e-12:
            self.sense = math.copysign(1.0, da)
        self.a_prev = a
        # the observer turning CCW moves along +u⊥; the target runs the other way along the
        # tangent, which makes the sweep slowest (θ = π − ... in §3)
        v = -self.sense * self.vt * np.array([-math.sin(a), math.cos(a)])
        return _steer(self.planner, p, v, 0.1 * self.lss / max(self.vt, 1e-12))


class DashTarget:
    """Knows the decomposition and the rod: runs the shortest path to the escape point with the
    smallest margin for the current rod (re-chosen every ``replan`` s); wanders when none."""

    name = "dash"

    def __init__(self, world: World, replan: float = 0.5) -> None:
        self.replan = float(replan)

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p``: read the escape table of the world's verdict."""
        from tether.analysis.escape_points import escape_table_of

        self.planner = _planner(world)
        self.table = (escape_table_of(world.verdict, world.vt / world.vo)
                      if world.verdict is not None else None)
        self.world = world
        self.rng = rng
        self.walker = _Walker()
        self.walker.vt = world.vt
        self.t_plan = -math.inf

    def _plan(self, p: np.ndarray, a: float) -> None:
        goal = None
        if self.table is not None and len(self.table):
            concern, _, _, margin = self.table.margins(p, a, self.world.vt, self.world.vo)
            if concern.any():
                goal = self.table.points_for(p, a)[int(np.argmin(margin))]
        if goal is None or not self.planner.contains(goal):
            if goal is None:
                goal = self.planner.random_point(self.rng)
            else:
                goal = _nearest_inside(self.planner, goal)
        self.walker.set_path(self.planner.path(p, goal))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity toward the planned escape point at time ``t`` (s), map units/s; replans."""
        self.walker.tick(t)
        if t - self.t_plan >= self.replan or self.walker.done:
            self._plan(p, a)
            self.t_plan = t
        return self.walker.velocity(p)


def _nearest_inside(planner: PathPlanner, q: np.ndarray) -> np.ndarray:
    from shapely.geometry import Point
    from shapely.ops import nearest_points

    pt = nearest_points(planner.space, Point(q))[0]
    return np.array([pt.x, pt.y])


class EscapeTarget:
    """The Prop. 1 evader: for the cell the rod is in, crosses the piece that the elimination
    recorded for it (into the region where the rod has no surviving continuation); on a map
    with a strategy it behaves like ``dash``."""

    name = "escape"

    def __init__(self, world: World) -> None:
        self.dash = DashTarget(world)

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p`` with rod orientation ``a`` (radians)."""
        self.world = world
        self.planner = _planner(world)
        self.walker = _Walker()
        self.walker.vt = world.vt
        ver = world.verdict
        self.record = {e.cell_name: e for e in ver.eliminated} if ver is not None else {}
        self.use_dash = ver is None or ver.strategy_exists
        if self.use_dash:
            self.dash.reset(world, p, a, rng)
        self.cell: str | None = None
        self.round = math.inf

    def _plan(self, p: np.ndarray, cell: str) -> None:
        dec = self.world.decomposition
        rec = self.record.get(cell)
        if rec is None:
            return
        piece = dec.pieces[rec.piece]
        q, n, eps = np.array(piece.sample), np.array(piece.normal), piece.eps
        to = rec.escapes_to
        side = 1.0 if piece.regions[0] == to else -1.0
        beyond = q + side * max(eps * 4, 1e-6) * n
        route = self.planner.path(p, _nearest_inside(self.planner, q))
        self.walker.set_path(np.vstack([route, beyond[None], (beyond + side * 0.05 * n)[None]]))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity at time ``t`` (s), map units/s."""
        if self.use_dash:
            return self.dash.velocity(t, p, a)
        self.walker.tick(t)
        cell = self.world.decomposition.cell_at(p, a)[0]
        if cell is not None and cell != self.cell:
            # follow the elimination downward: re-plan when the rod's cell fell in an earlier
            # round than the committed one (progress), or when the plan is used up; a detour
            # through other regions on the way does not reset the plan
            rec = self.record.get(cell)
            if rec is not None and (rec.round < self.round or self.walker.done):
                self.cell, self.round = cell, rec.round
                self._plan(p, cell)
        elif self.walker.done and self.cell is not None:
            self._plan(p, self.cell)
        return self.walker.velocity(p)


class SearchTarget:
    """White-box adversary: every ``period`` s it tries ``headings`` constant headings (and as
    many two-leg turns) over ``horizon`` s against a copy of the controller, scoring each by
    the smallest slack the rod keeps to its arc ends (a controller failure scores −1), and
    plays the worst for the observer. Non-shortest paths included (Becerra 2010).

    A controller that keeps no state between steps may offer ``rollout(p, v, a, dt)``: the
    orientations (m, n + 1) along ``m`` target paths of known velocities ``v`` (m, n, 2),
    each row what its ``step`` gives one by one (NaN from a step where it has no rate); the
    plans are then scored all at once, with the same scores
    (:meth:`~tether.game.controller.CertifiedController.rollout`). Otherwise each plan plays
    against a copy of the controller."""

    name = "search"

    def __init__(self, world: World, horizon: float = 1.0, period: float = 0.5,
                 headings: int = 8) -> None:
        self.horizon, self.period, self.headings = float(horizon), float(period), int(headings)

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p`` with rod orientation ``a`` (radians)."""
        from tether.sim.local import LocalArcs

        self.world = world
        self.planner = _planner(world)
        self.rng = rng
        self.controller = world.extra.get("controller")
        self.local = world.extra.get("_local_arcs") or LocalArcs(world.env, world.lss)
        self.t_plan = -math.inf
        self.plan: list[np.ndarray] = []
        self.leg = 0.0
        self.dt = 0.02

    def _scores(self, p: np.ndarray, a: float, cands: list[list[np.ndarray]]) -> list[float]:
        """The score of each candidate plan (see the class): all at once through the
        controller's ``rollout`` when it has one (the same numbers as :meth:`_score`), else
        one plan at a time."""
        if self.controller is None or not hasattr(self.controller, "rollout"):
            return [self._score(p.copy(), a, legs) for legs in cands]
        return self._score_many(p, a, cands).tolist()

    def _score_many(self, p: np.ndarray, a: float, cands: list[list[np.ndarray]]
                    ) -> np.ndarray:
        """:meth:`_score` of every plan in one pass. A plan's target path does not depend on
        the controller, so the paths, their tests against the walls and the controller's
        orientations along them (``rollout``: a stateless controller's steps, to the last
        bit) come first; then each plan is read step by step, stopping where the loop
        returns (the same tests in the same order)."""
        m, dt = len(cands), self.dt
        n = max(1, int(round(self.horizon / dt)))
        legs = np.array([[np.asarray(v, dtype=float) for v in c] for c in cands])  # (m, 2, 2)
        V = np.concatenate([np.repeat(legs[:, :1], n // 2, axis=1),
                            np.repeat(legs[:, 1:], n - n // 2, axis=1)], axis=1)  # (m, n, 2)
        P = np.empty((m, n + 1, 2))
        P[:, 0] = np.asarray(p, dtype=float)
        for k in range(n):
            P[:, k + 1] = P[:, k] + V[:, k] * dt
        inside = self.planner.contains_many(P[:, 1:].reshape(-1, 2)).reshape(m, n)
        A = self.controller.rollout(P[:, 0], V, np.full(m, float(a)), dt)
        score = np.empty(m)
        for i in range(m):
            score[i] = self._read_plan(P[i, 1:], A[i], inside[i], n)
        return score

    def _read_plan(self, P: np.ndarray, A: np.ndarray, inside: np.ndarray, n: int) -> float:
        """The score of one plan from its positions after each step ``P`` (n, 2), its
        orientations ``A`` (n + 1) and its wall tests: :meth:`_score`'s returns."""
        worst = math.inf
        for k in range(n):
            if not inside[k]:
                return math.inf  # the walls stop this plan: not a threat
            if not math.isfinite(A[k + 1]):  # the controller gave up
                return -1.0 + k / n
            e = self.local.ends(float(P[k, 0]), float(P[k, 1]), float(A[k + 1]))
            if not e.free:
                return -1.0 + k / n
            worst = min(worst, e.ccw_gap, e.cw_gap)
        return worst

    def _score(self, p: np.ndarray, a: float, legs: list[np.ndarray]) -> float:
        import copy

        ctrl = copy.copy(self.controller)
        dt = self.dt
        n = max(1, int(round(self.horizon / dt)))
        worst = math.inf
        for k in range(n):
            v = legs[0] if k < n // 2 else legs[1]
            q = p + v * dt
            if not self.planner.contains(q):
                return math.inf  # the walls stop this plan: not a threat
            cmd = ctrl.step(p, v, a, dt) if ctrl is not None else None
            if cmd is not None and not cmd.feasible:
                return -1.0 + k / n
            a = a + (cmd.rate if cmd is not None else 0.0) * dt
            p = q
            e = self.local.ends(float(p[0]), float(p[1]), a)
            if not e.free:
                return -1.0 + k / n
            worst = min(worst, e.ccw_gap, e.cw_gap)
        return worst

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The searched velocity at time ``t`` (s), map units/s."""
        if self.plan and t > self.t_plan:
            self.dt = max(min(t - self.last_t, 0.1), 1e-4) if hasattr(self, "last_t") else 0.02
        self.last_t = t
        if t - self.t_plan >= self.period or not self.plan:
            vt = self.world.vt
            base = self.rng.uniform(0, 2 * math.pi)
            angs = base + np.arange(self.headings) * (2 * math.pi / self.headings)
            cands = [[vt * np.array([math.cos(h), math.sin(h)])] * 2 for h in angs]
            turns = angs + (math.pi / 2) * self.rng.choice([-1, 1], len(angs))
            cands += [[vt * np.array([math.cos(h), math.sin(h)]),
                       vt * np.array([math.cos(g), math.sin(g)])]
                      for h, g in zip(angs, turns, strict=True)]
            scores = self._scores(p, a, cands)
            best = int(np.argmin(scores))
            self.plan = cands[best] if math.isfinite(scores[best]) else \
                [self.planner.path(p, self.planner.random_point(self.rng))[-1] - p] * 2
            self.t_plan = t
        v = self.plan[0] if t - self.t_plan < self.horizon / 2 else self.plan[1]
        n = float(np.hypot(*v))
        v = v * (self.world.vt / n) if n > 0 else v
        return _steer(self.planner, p, v, 0.05 * self.world.lss / max(self.world.vt, 1e-12))


TargetFactory = Callable[..., Any]


def unit(x: float, y: float) -> np.ndarray:
    """The unit vector along ``(x, y)``, or zero for the zero vector."""
    n = math.hypot(x, y)
    return np.array([x / n, y / n]) if n > 0 else np.zeros(2)


def __getattr__(name: str) -> Any:
    """``TARGETS`` and ``make_target``, deprecated here: the registry is
    :data:`tether.strategies.TARGETS` (it names the kernel's evader too, which the simulation
    does not import)."""
    if name in ("TARGETS", "make_target"):
        import warnings

        import tether.strategies

        warnings.warn(f"tether.sim.targets.{name} is deprecated and will be removed in the "
                      f"next release: use tether.strategies.{name}", DeprecationWarning,
                      stacklevel=2)
        return getattr(tether.strategies, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
