"""Target behaviours, all at speed at most ``vt`` and seeded through ``reset``'s generator.

``TARGETS`` maps a kind name to a factory ``factory(world, **options) -> Target``:

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
        self.walker = _Walker()
        self.walker.vt = world.vt
        self.walker.set_path(np.vstack([p, self.waypoints]))

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
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
        self.walker.tick(t)
        v = self.walker.velocity(p)
        if self.walker.done:
            self._new_goal(p)
            v = self.walker.velocity(p)
        return v


TargetFactory = Callable[..., Any]

#: Target kinds by name: ``TARGETS[kind](world, **options)``.
TARGETS: dict[str, TargetFactory] = {
    "path": PathTarget,
    "random": RandomTarget,
}


def make_target(kind: str, world: World, **options: Any) -> Any:
    """The target of kind ``kind`` (see :data:`TARGETS`)."""
    try:
        factory = TARGETS[kind]
    except KeyError:
        raise InvalidParameterError(
            f"unknown target kind {kind!r} (choose from {', '.join(sorted(TARGETS))})") from None
    return factory(world, **options)


def unit(x: float, y: float) -> np.ndarray:
    n = math.hypot(x, y)
    return np.array([x / n, y / n]) if n > 0 else np.zeros(2)


def _kernel_evader(world: World, **options: Any) -> Any:
    """The surveillance kernel's evader (:class:`tether.game.evader.KernelEvader`); reads the
    kernel from ``world.extra["kernel"]`` unless ``kernel=`` is given."""
    from tether.game.evader import KernelEvader

    return KernelEvader(**options)


TARGETS["kernel-evader"] = _kernel_evader
