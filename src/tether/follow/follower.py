"""The follower: one update per sensor reading, for a real robot's loop (``docs/practice.md``).

:class:`Follower` turns what the robot's sensor says of the target (its position, or nothing)
into a :class:`Command`: the observer's goal pose, its velocity and a status.

**Tracking** (the target is seen). The observation passes a gate and an alpha–beta filter (the
noise model below); the estimated target ``p`` and velocity ``v`` (clipped to ``vt``) drive one
of tether's controllers (``tether.strategies.CONTROLLERS``: the follow law by default, the
paper's with a verdict, the kernel's with a kernel) in the simulator's state, the rod
orientation ``a`` of the observer about the target; the commanded velocity is the controller's
``v + lss·ȧ·u⊥(a)`` plus a radial correction ``(lss − d)/(4·period)`` toward the rod length
(the controller keeps the distance exactly only in its own model), clipped to ``vo``. While the
observer is off the rod length by more than :data:`APPROACH_TOL` (a fraction of ``lss``), or
the controller finds no admissible rate (the rod squeezed, the target winning at this instant),
it heads straight (or round the corners on the way) for the pose at ``lss`` with the free rod
orientation nearest its own, at up to ``vo`` (``approaching`` in the command's reason).

**Searching** (no sighting now). From the last accepted sighting ``(t_s, p_s)`` the follower
keeps the cells of a grid the target can have reached, ``d(p_s, x) <= vt·(t − t_s) + r0``
(exact geodesic distances through the reflex vertices, :mod:`tether.follow.reachable`;
``r0 = 3σ + h/√2`` covers the noise and the cell), minus the cells seen empty since (a cell is
seen when its centre and its four corners are in view), which the target can re-enter only from
the cells still possible (an 8-neighbour growth of one cell per
``h/vt`` s); it heads to the observer pose that brings most of that set back in view soonest
(:mod:`tether.follow.search`, escape poses first).

**Lost**: before the first sighting; when the whole possible set has been seen empty (the
target left the map or the sensor missed it); when no reachable observer pose sees any of it;
after ``give_up`` seconds of search. The reason says which; a later sighting resumes tracking.

**Noise model.** An observation is the true position plus isotropic Gaussian noise of standard
deviation ``noise`` (map units) per axis. It is *gated*: outside the free space, or (tracking)
farther than ``gate + vt·Δt`` from the last estimate (``Δt`` since it), or (searching) outside
the reachable set widened by ``gate``, it is rejected (``gate`` defaults to ``3·noise·√2`` plus
1 % of ``lss``). A rejected observation while tracking is a detection that does not fit: the
follower coasts on its prediction (status ``tracking``, reason ``observation rejected by the
gate``); :data:`RETAKE_AFTER` rejections in a row and the next observation is taken as the
target's true position (a target that really moved faster than ``vt``). Accepted observations
update an alpha–beta filter, gains ``(1, 1)`` without noise (the observation is the position,
the velocity its difference) and ``(0.5, 0.1)`` with noise.

**Late observations.** ``update(t, observation, stamp=s)`` says the position was measured at
``s <= t``: the filter runs at ``s`` and predicts to ``t`` at constant velocity; the reachable set
counts from ``s``. Observations stamped before the last accepted one are ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tether._util.vocabulary import Vocabulary
from tether.arcs import free_arcs, rod_is_free
from tether.environment import Environment
from tether.errors import InvalidParameterError, TetherError
from tether.follow.reachable import Geodesics, ReachGrid, clear_segments, first_blocking_edge
from tether.follow.search import Plan, SearchPlanner
from tether.sim.protocols import World
from tether.strategies import CONTROLLERS

__all__ = ["APPROACH_TOL", "Command", "Follower", "RETAKE_AFTER", "Status"]

#: The observer is "at the rod length" within this fraction of ``lss``; farther, it approaches.
APPROACH_TOL = 0.1
#: Consecutive rejected observations after which the next one is taken as the truth.
RETAKE_AFTER = 3


class Status(Vocabulary):
    """What the follower is doing (:attr:`Command.status`)."""

    TRACKING = "tracking"  # the target is seen; the observer keeps the rod at lss
    SEARCHING = "searching"  # unseen; heading to the pose that sees most of where it can be
    LOST = "lost"  # no sighting yet, or no pose can see where it can be (reason says)


@dataclass(frozen=True, eq=False)
class Command:
    """One decision of the :class:`Follower`.

    Attributes
    ----------
    t : float
        The time of the update, s.
    pose : (x, y, heading)
        The observer's goal pose: position (map units, the map's frame) and heading (rad, CCW
        from +x; toward the target when tracking, toward the middle of the part of the set it
        will see when searching).
    velocity : ndarray, shape (2,)
        The observer's velocity until the next update, map units/s, ``|velocity| <= vo``
        (zero when lost).
    status : Status
        ``tracking``, ``searching`` or ``lost``.
    reason : str or None
        Why ``lost`` (or ``approaching`` while tracking off the rod length); ``None`` otherwise.
    target : ndarray or None
        The estimated target position now (tracking) or the last sighting (searching, lost).
    view : float or None
        Searching: the fraction of the possible set in view from the goal.
    """

    t: float
    pose: tuple[float, float, float]
    velocity: np.ndarray
    status: Status
    reason: str | None = None
    target: np.ndarray | None = None
    view: float | None = None

    def to_dict(self) -> dict:
        """The command as JSON-ready values."""
        return {"t": self.t, "pose": [x if math.isfinite(x) else None for x in self.pose],
                "velocity": self.velocity.tolist(),
                "status": str(self.status), "reason": self.reason,
                "target": None if self.target is None else self.target.tolist(),
                "view": self.view}


def _positive(name: str, value: Any, allow_zero: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number (got {value!r})") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise InvalidParameterError(f"{name} must be a finite number {'>=' if allow_zero else '>'}"
                                    f" 0 (got {value!r})")
    return v


def _point(name: str, value: Any) -> np.ndarray:
    try:
        p = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be (x, y) (got {value!r})") from None
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise InvalidParameterError(f"{name} must be two finite numbers (x, y) (got {value!r})")
    return p


def _u(a: float) -> np.ndarray:
    return np.array([math.cos(a), math.sin(a)])


def _clip(v: np.ndarray, vmax: float) -> np.ndarray:
    n = float(np.hypot(v[0], v[1]))
    return v * (vmax / n) if n > vmax else v


class Follower:
    """Keep a target in view at the rod length ``lss``, and find it again when it is lost.

    Parameters
    ----------
    env : Environment
        The map (its frame is the frame of every position).
    lss : float
        Rod length: the distance to keep, map units.
    vt, vo : float
        Speed bounds of the target and the observer, map units/s (``vo > vt >= 0``).
    rate : float
        The loop's rate, Hz: a command holds for ``1/rate`` s (the controller's step).
    controller : str
        A name of ``tether.strategies.CONTROLLERS`` (``follow``, ``translate``, ``paper`` with
        ``verdict``, ``kernel`` with ``kernel`` or a coarse one computed at construction).
    verdict, kernel : optional
        The :class:`~tether.analysis.Verdict` at ``lss`` (``paper``), a
        :class:`~tether.game.Kernel` (``kernel``).
    noise : float
        Standard deviation of the observation noise per axis, map units (the gate and filter).
    gate : float or None
        Gate radius, map units (default ``3·noise·√2 + 0.01·lss``).
    sensor_range : float or None
        The sensor's range, map units (``None``: line of sight only); bounds what the search
        counts as in view.
    cell : float or None
        Side of the grid's cells for the reachable set, map units (default: the map's diameter
        over 100).
    spacing : float or None
        Spacing of the search's grid poses (default ``4·cell``).
    give_up : float or None
        Seconds of search after which the follower says ``lost`` (``None``: never).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.follow import Follower
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> f = Follower(ell, lss=0.5, vt=0.3, vo=1.0, cell=0.25)
    >>> f.update(0.0, None).status, f.update(0.1, (1.5, 2.5), observer=(1.5, 2.0)).status
    ('lost', 'tracking')
    >>> cmd = f.update(0.2, None, observer=(3.5, 1.0))  # unseen, the robot round the corner
    >>> cmd.status, bool(abs(cmd.velocity).max() <= 1.0), cmd.view
    ('searching', True, 1.0)
    """

    def __init__(self, env: Environment, lss: float, vt: float, vo: float, *,
                 rate: float = 20.0, controller: str = "follow", verdict: Any = None,
                 kernel: Any = None, noise: float = 0.0, gate: float | None = None,
                 sensor_range: float | None = None, cell: float | None = None,
                 spacing: float | None = None, give_up: float | None = None) -> None:
        if not isinstance(env, Environment):
            raise InvalidParameterError(f"env must be an Environment (got {type(env).__name__})")
        self.env = env
        self.lss = _positive("lss", lss)
        self.vt = _positive("vt", vt, allow_zero=True)
        self.vo = _positive("vo", vo)
        if not self.vo > self.vt:
            raise InvalidParameterError(f"vo must exceed vt (vo={self.vo:g}, vt={self.vt:g})")
        self.period = 1.0 / _positive("rate", rate)
        self.noise = _positive("noise", noise, allow_zero=True)
        self.gate = (3.0 * math.sqrt(2.0) * self.noise + 0.01 * self.lss if gate is None
                     else _positive("gate", gate, allow_zero=True))
        self.sensor_range = None if sensor_range is None else _positive("sensor_range",
                                                                       sensor_range)
        self.give_up = None if give_up is None else _positive("give_up", give_up)
        if controller not in CONTROLLERS:
            raise InvalidParameterError(f"unknown controller {controller!r} (choose from "
                                        f"{', '.join(sorted(CONTROLLERS))})")
        if controller == "paper" and verdict is None:
            raise InvalidParameterError("the paper's controller needs verdict= (tether.analyze "
                                        "of the map's decomposition at lss)")
        extra = {} if kernel is None else {"kernel": kernel}
        self.world = World(env, self.lss, self.vt, self.vo, verdict=verdict, extra=extra)
        self.controller = CONTROLLERS[controller](self.world)
        self.controller_name = controller
        h = env.diameter / 100 if cell is None else _positive("cell", cell)
        self.grid = ReachGrid(env, h)
        self.geo = Geodesics(env, self.grid)
        self.planner = SearchPlanner(env, self.grid, self.vo, self.vt, self.lss,
                                     self.sensor_range,
                                     4 * h if spacing is None else _positive("spacing", spacing),
                                     clearance=min(0.5 * h, 0.1 * self.lss))
        self.r0 = 3.0 * self.noise + h / math.sqrt(2.0)
        self._alpha, self._beta = (1.0, 1.0) if self.noise == 0 else (0.5, 0.1)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, observer: Any = None) -> None:
        """Forget the target (status ``lost`` until a sighting); ``observer`` (x, y) sets the
        observer's position (otherwise it is placed at the first goal pose)."""
        self.observer = None if observer is None else _point("observer", observer)
        self.t: float | None = None
        self.p: np.ndarray | None = None  # filtered target position at self.t_seen
        self.v = np.zeros(2)
        self.t_seen: float | None = None
        self.rejected = 0
        self._last_velocity = np.zeros(2)
        self._tracking_started = False
        self._why_not = ""
        self._search_reset()

    def _search_reset(self) -> None:
        self.field: np.ndarray | None = None
        self.possible: np.ndarray | None = None
        self._growth = 0.0
        self._goal: int | None = None
        self.searching_since: float | None = None
        self.escape_vertex: int | None = None

    @property
    def searching(self) -> bool:
        """Whether a search is under way (the target unseen since a sighting)."""
        return self.field is not None

    def reachable(self, t: float | None = None) -> np.ndarray:
        """Centres (n, 2) of the cells the target can have reached by ``t`` (s; default the
        last update) since the last sighting: empty before any sighting."""
        if self.t_seen is None:
            return np.zeros((0, 2))
        t = self.t if t is None else float(t)
        field = self.field if self.field is not None else self.geo.field(self.p)
        return self.grid.centers[field <= self.vt * max(t - self.t_seen, 0.0) + self.r0]

    def possible_cells(self) -> np.ndarray:
        """Centres (n, 2) of the cells where the target can be now (the reachable set minus
        the cells seen empty): empty unless searching."""
        if self.possible is None:
            return np.zeros((0, 2))
        return self.grid.centers[self.possible]

    def reach_distance(self, points: Any) -> np.ndarray:
        """Exact geodesic distance (map units) from the last sighting to ``points`` (n, 2)."""
        if self.p is None:
            raise InvalidParameterError("no sighting yet: the reachable set is undefined")
        return self.geo.distance(self.p, np.asarray(points, dtype=float).reshape(-1, 2))

    # ------------------------------------------------------------------ the loop
    def update(self, t: float, observation: Any = None, stamp: float | None = None, *,
               observer: Any = None) -> Command:
        """One step of the loop at time ``t`` (s).

        Parameters
        ----------
        t : float
            Now, s (non-decreasing from one update to the next).
        observation : (x, y) or None
            The target's measured position (map units), or ``None`` when it is not seen.
        stamp : float or None
            When the observation was measured (s, ``<= t``); default ``t``.
        observer : (x, y) or None
            The observer's measured position (odometry); default: the last one moved by the
            last command's velocity.

        Returns
        -------
        Command
        """
        t = float(t)
        if not math.isfinite(t):
            raise InvalidParameterError(f"t must be a finite time in s (got {t!r})")
        if self.t is not None and t < self.t:
            raise InvalidParameterError(f"time went back: t={t:g} after t={self.t:g}")
        dt = self.period if self.t is None else t - self.t
        if observer is not None:
            self.observer = _point("observer", observer)
        elif self.observer is not None:
            self.observer = self.observer + self._last_velocity * dt
        self.t = t
        seen = False
        if observation is not None:
            obs = _point("observation", observation)
            s = t if stamp is None else float(stamp)
            if not math.isfinite(s) or s > t:
                raise InvalidParameterError(f"stamp must be a finite time <= t (got {stamp!r})")
            seen = self._accept(obs, s)
        if seen or (observation is not None and self.t_seen is not None
                    and not self.searching):
            cmd = self._track(t, None if seen else self._why_not)
        elif self.t_seen is None:
            cmd = self._lost(t, "no sighting of the target yet")
        else:
            cmd = self._search(t, dt)
        self._last_velocity = cmd.velocity
        return cmd

    # ------------------------------------------------------------------ sightings
    def _accept(self, obs: np.ndarray, s: float) -> bool:
        """Gate ``obs`` measured at ``s``; on acceptance run the filter and return True."""
        env = self.env
        if self.t_seen is not None and s <= self.t_seen:
            self._why_not = "observation older than the last one, ignored"
            return False
        if not bool(env.contains(obs[0], obs[1])):
            return self._reject()
        if self.t_seen is not None and self.rejected < RETAKE_AFTER:
            if self.searching:
                d = float(self.geo.distance(self.p, obs[None, :])[0])
                if d > self.vt * (s - self.t_seen) + self.r0 + self.gate:
                    return self._reject()
            elif float(np.hypot(*(obs - self.p))) > self.gate + self.vt * (s - self.t_seen):
                return self._reject()
        if self.t_seen is None or self.rejected >= RETAKE_AFTER or self.searching:
            self.p, self.v = obs, np.zeros(2)  # a fresh start: no velocity known yet
        else:
            gap = max(s - self.t_seen, 1e-9)
            pred = self.p + self.v * gap
            r = obs - pred
            self.p = pred + self._alpha * r
            self.v = _clip(self.v + self._beta * r / gap, self.vt)
        self.t_seen = s
        self.rejected = 0
        self._search_reset()
        return True

    def _reject(self) -> bool:
        self.rejected += 1
        self._why_not = "observation rejected by the gate"
        return False

    # ------------------------------------------------------------------ tracking
    def _target_now(self, t: float) -> np.ndarray:
        p = self.p + self.v * (t - self.t_seen)
        return p if bool(self.env.contains(p[0], p[1])) else self.p

    def _track(self, t: float, note: str | None = None) -> Command:
        p = self._target_now(t)
        v = self.v
        if self.observer is None:
            self.observer = p + self.lss * _u(self._free_angle(p, 0.0))
        o = self.observer
        d = float(np.hypot(*(o - p)))
        a = math.atan2(o[1] - p[1], o[0] - p[0]) if d > 0 else 0.0
        dt = self.period
        if abs(d - self.lss) <= APPROACH_TOL * self.lss and rod_is_free(self.env, p, a, self.lss):
            if not self._tracking_started:
                self.controller.reset(self.world, p, a)
                self._tracking_started = True
            c = self.controller.step(p, v, a, dt)
            if c.feasible:
                vel = c.velocity + (self.lss - d) / (4 * dt) * _u(a)
                vel = _clip(vel, self.vo)
                goal = p + v * dt + self.lss * _u(a + c.rate * dt)
                return self._command(t, goal, p, vel, Status.TRACKING, note)
        self._tracking_started = False
        goal = p + self.lss * _u(self._free_angle(p, a))
        way = goal if clear_segments(self.env, o, goal[None, :])[0] else self._waypoint(o, goal)
        step = way - o
        dist = float(np.hypot(*step))
        vel = step * (min(self.vo, dist / dt) / dist) if dist > 0 else np.zeros(2)
        return self._command(t, goal, p, vel, Status.TRACKING, note or "approaching")

    def _free_angle(self, p: np.ndarray, a: float) -> float:
        """The free rod orientation at ``p`` nearest ``a`` (``a`` itself when free or when the
        arcs cannot be computed there)."""
        try:
            fa = free_arcs(self.env, p, self.lss)
        except TetherError:
            return a
        if fa.full or fa.contains(a) or fa.empty:
            return a
        best, gap = a, math.inf
        for arc in fa.arcs:
            inset = min(0.05, 0.25 * arc.length)
            for end, toward in ((arc.start, inset), (arc.end, -inset)):
                g = abs((end - a + math.pi) % math.tau - math.pi)
                if g < gap:
                    best, gap = end + toward, g
        return best

    def _waypoint(self, o: np.ndarray, goal: np.ndarray) -> np.ndarray:
        dist, first = self.planner.travel(o, goal[None, :], self.planner._nav_to(goal[None, :]))
        if not np.isfinite(dist[0]) or first[0] < 0:
            return goal
        return self.planner.nav[first[0]]

    def _command(self, t: float, goal: np.ndarray, p: np.ndarray, vel: np.ndarray,
                 status: Status, reason: str | None, view: float | None = None) -> Command:
        heading = math.atan2(p[1] - goal[1], p[0] - goal[0])
        return Command(t, (float(goal[0]), float(goal[1]), heading), vel, status, reason,
                       p.copy(), view)

    # ------------------------------------------------------------------ searching
    def _start_search(self, t: float) -> None:
        self.field = self.geo.field(self.p)
        self.possible = self.field <= self.vt * max(t - self.t_seen, 0.0) + self.r0
        self._growth = 0.0
        self._goal = None
        self.searching_since = t
        corners: tuple[int, ...] = ()
        o = self.observer
        if o is not None:
            e = first_blocking_edge(self.env, o, self.p + self.v * (t - self.t_seen))
            if e is not None:
                _, _, ta, tb = self.env.oriented_edges
                j = min((int(ta[e]), int(tb[e])), key=lambda k: (
                    not self.env.reflex[k], float(np.hypot(*(self.env.vertices[k] - self.p)))))
                self.escape_vertex = j
                corners = (j,)
        self.planner.set_escape(self.p[None, :], corners)

    def _search(self, t: float, dt: float) -> Command:
        if not self.searching:
            self._start_search(t)
        radius = self.vt * (t - self.t_seen) + self.r0
        self._growth += self.vt * dt
        steps = int(self._growth // self.grid.h)
        self._growth -= steps * self.grid.h
        possible = self.grid.dilate(self.possible, steps) if steps else self.possible
        possible &= self.field <= radius
        o = self.observer
        if o is None:  # no pose known: look from the last sighting
            o = self.observer = self.p.copy()
        possible[self._seen_whole(o, np.flatnonzero(possible))] = False
        self.possible = possible
        if not possible.any():
            return self._lost(t, "the whole reachable set was seen without the target (it "
                                 "left the map, or the sensor missed it)")
        if self.give_up is not None and t - self.searching_since > self.give_up:
            return self._lost(t, f"searched for {t - self.searching_since:.3g} s "
                                 f"(give_up={self.give_up:g} s)")
        plan: Plan | None = self.planner.plan(o, possible, self._goal)
        if plan is None:
            return self._lost(t, f"no reachable observer pose sees any of the "
                                 f"{int(possible.sum())} cells where the target can be")
        self._goal = plan.goal
        step = plan.waypoint - o
        dist = float(np.hypot(*step))
        speed = min(self.vo, dist / self.period)
        vel = step * (speed / dist) if dist > 0 else np.zeros(2)
        return Command(t, plan.pose, vel, Status.SEARCHING, None, self.p.copy(), plan.view)

    def _seen_whole(self, o: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """The cells of ``idx`` seen whole from ``o``: the centre and the four corners (pulled
        in by 0.1 % of the side) in view, so that a target hiding in a corner of a cell whose
        centre is in view (beyond a door jamb) keeps the cell possible."""
        if not len(idx):
            return idx
        c = self.grid.centers[idx]
        ok = self.planner.sees(o, c)
        half = 0.4995 * self.grid.h
        for dx, dy in ((-half, -half), (half, -half), (half, half), (-half, half)):
            k = np.flatnonzero(ok)
            ok[k] = self.planner.sees(o, c[k] + (dx, dy))
        return idx[ok]

    def _lost(self, t: float, reason: str) -> Command:
        o = self.observer
        pose = (math.nan, math.nan, math.nan) if o is None else (float(o[0]), float(o[1]), 0.0)
        return Command(t, pose, np.zeros(2), Status.LOST, reason,
                       None if self.p is None else self.p.copy())
