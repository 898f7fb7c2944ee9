"""Simulated people: pedestrians walking journeys through a map's free space, with the
collision-free speed model of the crowd simulator jupedsim (optional extra ``tether[crowd]``).

Each person starts at a random point (seeded; a radius and a bit, :data:`START_MARGIN`, inside
the walkable area), walks to a sequence of goals (random, seeded, or
given) and, having reached the last, starts over at the first, for ``duration`` s; its position
is sampled every ``dt`` s into a :class:`~tether.io.tracks.Track`.

Scale. jupedsim's parameters are physical (metres, seconds). A map's unit is taken as
``metres_per_unit`` metres (1 by default: ROS maps are in metres, and a polygon map declares
no unit, so it is read as metres); the
geometry is scaled to metres for jupedsim and the positions back to map units. The desired
speed ``speed`` is in map units/s; by default :data:`DESIRED_SPEED` (1.34 m/s, Weidmann's mean
free walking speed; jupedsim 1.4's own parameter default is 1.2 m/s) converted to map units.
The docs' runs use ``vt`` = 0.3 map units/s, so they give ``speed`` explicitly.

Walkable area. The map's free space (a shapely polygon with holes) shrunk by the person's
radius (:data:`RADIUS`, 0.2 m, jupedsim's default), so that a person's centre keeps a body's
half-width off every wall; only the largest piece is kept when the shrinking splits it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon

from tether.environment import Environment
from tether.errors import InvalidParameterError, TetherError
from tether.io.tracks import Track

__all__ = [
    "CrowdUnavailableError", "DESIRED_SPEED", "MODEL_STEP", "RADIUS", "RANDOM_GOALS", "SPEED_TOL",
    "START_MARGIN", "pedestrian_tracks", "walkable_area"
]

#: Default desired walking speed, m/s (Weidmann's mean free walking speed).
DESIRED_SPEED = 1.34
#: A person's radius, m (jupedsim's default); the free space is shrunk by it.
RADIUS = 0.2
#: Relative tolerance on sampled speeds: the model never moves a person faster than its
#: desired speed, so a segment of a track is at most ``speed·(1 + SPEED_TOL)`` (float rounding).
SPEED_TOL = 1e-6
#: Internal step of the crowd model, s (at most; a divisor of ``dt``).
MODEL_STEP = 0.01
#: Starts are placed ``(1 + START_MARGIN)`` radii inside the walkable area (jupedsim refuses a
#: person within one radius of its edge) and as far apart from each other.
START_MARGIN = 0.05
#: How many random goals each person's journey loops through.
RANDOM_GOALS = 8


class CrowdUnavailableError(TetherError, ImportError):
    """jupedsim (the optional extra ``tether[crowd]``) is not installed."""


def _jupedsim() -> Any:
    try:
        import jupedsim
    except ImportError:
        raise CrowdUnavailableError("simulated people need `pip install tether[crowd]` "
                                    "(the jupedsim crowd simulator)") from None
    return jupedsim


def walkable_area(env: Environment, clearance: float) -> Polygon:
    """The free space of ``env`` shrunk by ``clearance`` map units: its largest piece.

    Raises
    ------
    InvalidParameterError
        If nothing is left (the map is narrower than twice the clearance everywhere).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.sim.crowd import walkable_area
    >>> room = Environment([(0, 0), (4, 0), (4, 3), (0, 3)])
    >>> [round(b, 9) for b in walkable_area(room, 0.2).bounds]
    [0.2, 0.2, 3.8, 2.8]
    """
    area = env.polygon.buffer(-float(clearance), join_style="mitre")
    if area.geom_type == "MultiPolygon":
        area = max(area.geoms, key=lambda g: g.area)
    if area.is_empty or area.area <= 0:
        raise InvalidParameterError(
            f"map {env.name!r}: no walkable area left once {clearance:g} map units (a person's "
            "radius) are kept off the walls")
    return shapely.normalize(area)


def _random_points(area: Polygon, count: int, rng: np.random.Generator,
                   spacing: float = 0.0) -> np.ndarray:
    """``count`` uniform random points of ``area``, at least ``spacing`` apart when possible
    (rejection sampling: up to 10000 tries a point)."""
    shapely.prepare(area)
    x0, y0, x1, y1 = area.bounds
    out: list[np.ndarray] = []
    for _ in range(count):
        for _ in range(10000):
            q = rng.uniform((x0, y0), (x1, y1))
            if shapely.contains_xy(area, q[0], q[1]) and all(
                    math.hypot(*(q - o)) >= spacing for o in out):
                break
        else:
            raise InvalidParameterError(
                f"cannot place {count} people {spacing:g} map units apart in the walkable area")
        out.append(q)
    return np.array(out).reshape(-1, 2)


def _check(count: int, seed: int, duration: float, dt: float, speed: float,
           scale: float) -> None:
    if not (isinstance(count, int | np.integer) and count >= 1):
        raise InvalidParameterError(f"count must be a whole number >= 1 (got {count!r})")
    if not (isinstance(seed, int | np.integer) and seed >= 0):
        raise InvalidParameterError(f"seed must be a whole number >= 0 (got {seed!r})")
    for name, v in (("duration", duration), ("dt", dt), ("speed", speed),
                    ("metres_per_unit", scale)):
        if not (math.isfinite(v) and v > 0):
            raise InvalidParameterError(f"{name} must be a finite number > 0 (got {v!r})")


def pedestrian_tracks(env: Environment, count: int, seed: int, *, speed: float | None = None,
                      duration: float = 60.0, goals: Sequence[Sequence[float]] | None = None,
                      dt: float = 0.05, metres_per_unit: float = 1.0,
                      progress: Callable[[str, float], None] | None = None) -> list[Track]:
    """``count`` people walking journeys in ``env``'s free space (jupedsim's collision-free
    speed model), sampled every ``dt`` s for ``duration`` s.

    Parameters
    ----------
    env : Environment
        The map; its unit is ``metres_per_unit`` metres.
    count : int
        Number of people (they avoid each other).
    seed : int
        Seeds the starts and the random goals: the same seed gives the same tracks.
    speed : float, optional
        Desired walking speed, map units/s; default :data:`DESIRED_SPEED` m/s in map units.
    duration, dt : float
        Walking time and sampling step, s.
    goals : sequence of (x, y), optional
        Goals every person walks through in order, then over again (map units, inside the
        walkable area). Default: each person its own :data:`RANDOM_GOALS` random goals.
    metres_per_unit : float
        Metres in one map unit (scales the person's radius and the default speed).
    progress : callable, optional
        ``progress(stage, fraction)`` for long walks.

    Returns
    -------
    list of Track
        One track a person, named ``person_000``..., times ``0, dt, ...`` up to ``duration``;
        ``meta`` records the model, the seed and the desired speed.

    Raises
    ------
    CrowdUnavailableError
        Without jupedsim (``pip install tether[crowd]``).
    InvalidParameterError
        A bad count, time, speed or goal.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.sim.crowd import pedestrian_tracks
    >>> room = Environment([(0, 0), (6, 0), (6, 4), (0, 4)])
    >>> (person,) = pedestrian_tracks(room, 1, seed=3, speed=0.5, duration=2.0, dt=0.5)
    >>> person.t.tolist(), person.max_speed <= 0.5 * (1 + 1e-6)
    ([0.0, 0.5, 1.0, 1.5, 2.0], True)
    """
    scale = float(metres_per_unit)
    v0 = DESIRED_SPEED / scale if speed is None else float(speed)
    _check(count, seed, float(duration), float(dt), v0, scale)
    jps = _jupedsim()
    radius = RADIUS / scale
    area = walkable_area(env, radius)
    # jupedsim places a person only farther than its radius from the walkable area's edge
    inner = walkable_area(env, (2 + START_MARGIN) * radius)
    rng = np.random.default_rng(seed)
    starts = _random_points(inner, int(count), rng, spacing=2 * (1 + START_MARGIN) * radius)
    given = None if goals is None else _given_goals(area, goals)
    metres = shapely.affinity.scale(area, scale, scale, origin=(0, 0))
    substeps = max(1, math.ceil(dt / MODEL_STEP - 1e-9))
    sim = jps.Simulation(model=jps.CollisionFreeSpeedModel(), geometry=metres,
                         dt=dt / substeps)
    ids = []
    for start in starts:
        pts = given if given is not None else _random_points(inner, RANDOM_GOALS, rng)
        journey, first = _looping_journey(jps, sim, pts * scale, 2 * radius * scale)
        ids.append(sim.add_agent(jps.CollisionFreeSpeedModelAgentParameters(
            position=tuple(start * scale), journey_id=journey, stage_id=first,
            desired_speed=v0 * scale, radius=radius * scale)))
    n = int(math.floor(duration / dt + 1e-9)) + 1
    xy = np.empty((n, len(ids), 2))
    xy[0] = starts
    for k in range(1, n):
        for _ in range(substeps):
            sim.iterate()
        xy[k] = [sim.agent(i).position for i in ids]
        if progress is not None and k % 200 == 0:
            progress("walk", k / n)
    if progress is not None:
        progress("walk", 1.0)
    xy[1:] /= scale
    t = np.arange(n) * float(dt)
    meta = {"source": "jupedsim CollisionFreeSpeedModel", "seed": int(seed), "speed": v0,
            "radius": radius}
    return [Track(t, xy[:, j], f"person_{j:03d}", dict(meta)) for j in range(len(ids))]


def _given_goals(area: Polygon, goals: Sequence[Sequence[float]]) -> np.ndarray:
    pts = np.asarray(goals, dtype=float)
    if pts.ndim != 2 or pts.shape[1:] != (2,) or len(pts) < 1 or not np.all(np.isfinite(pts)):
        raise InvalidParameterError("goals must be a list of finite (x, y) pairs")
    inside = shapely.contains_xy(area, pts[:, 0], pts[:, 1])
    if not inside.all():
        k = int(np.argmin(inside))
        raise InvalidParameterError(
            f"goal {k} ({pts[k, 0]:g}, {pts[k, 1]:g}) is not in the walkable area (the free "
            "space kept a person's radius off the walls)")
    return pts


def _looping_journey(jps: Any, sim: Any, pts: np.ndarray, reach: float) -> tuple[int, int]:
    """A journey through waypoint stages at ``pts`` (metres), the last leading back to the
    first; returns its id and the first stage's."""
    stages = [sim.add_waypoint_stage((float(x), float(y)), reach) for x, y in pts]
    if len(stages) == 1:  # one goal: walk there and stay (a second stage at the same point)
        stages.append(sim.add_waypoint_stage((float(pts[0, 0]), float(pts[0, 1])), reach))
    journey = jps.JourneyDescription(stages)
    for a, b in zip(stages, stages[1:] + stages[:1], strict=True):
        journey.set_transition_for_stage(a, jps.Transition.create_fixed_transition(b))
    return sim.add_journey(journey), stages[0]
