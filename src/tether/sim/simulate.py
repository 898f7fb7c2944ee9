"""The simulator: a target against a controller, with a monitor independent of both.

State ``(p, a)``: target position and rod orientation; the observer is ``p + lss·u(a)``, so the
distance is exact at every sample and never integrated. Each step of ``dt`` s the target picks
``v`` (clipped to ``|v| <= vt``), the controller picks the rod rate, and both are held over the
step: ``p ← p + v·dt``, ``a ← a + ȧ·dt``.

The **monitor** looks only at the states, never at what the controller believes: after every step
the rod must be free (:func:`tether.arcs.rod_is_free`), the observer in the free space, and the
observer's chord ``|O' − O|`` at most ``vo·dt``. The first failure is located by bisection on the
step, and the run ends ``lost`` at that time with the reason in words. Mode switches (when the
controller offers ``mode_at``) and piece crossings (when the world has a decomposition) are
located the same way and logged as events.

**Sensing delay** (``delay = D`` s, ``docs/certified.md``, "Sensing delay"): the controller is
given the target's position ``k = ceil(D/dt)`` steps late (``D`` rounded up to a whole number
of steps) and the velocity it had then; before the start the target stood at its start. The
observer is then ``q + lss·u(a)`` with ``q`` the *seen* position, and the monitor checks the
*true* line of sight, the segment from the observer to the target ``p``, the observer's chord,
and the distance ``|o − p|`` within ``lss ± vt·k·dt``.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tether.arcs import rod_is_free
from tether.errors import InvalidParameterError, OutsideFreeSpaceError
from tether.sim.protocols import Command, Controller, Outcome, Target, World

__all__ = [
    "CLEAR_TOLS", "Event", "LOCATE_ITERS", "Monitor", "MonitorStats", "SPEED_TOL", "SimResult",
    "Trace", "check_start", "save_trace", "simulate"
]

#: The monitor accepts observer chords up to ``vo·dt·(1 + SPEED_TOL)``.
SPEED_TOL = 1e-6
#: Bisection steps used to locate an event inside a step (2^-30 of a step).
LOCATE_ITERS = 30
#: The monitor's shortcut: a rod whose segment keeps more than this many length tolerances
#: (:attr:`Environment.length_tol`) off the walls, from a target inside, is free.
CLEAR_TOLS = 1e3


@dataclass(frozen=True)
class Event:
    """Something that happened at time ``t`` (s): ``kind`` is ``mode``, ``crossing`` or
    ``loss``; ``detail`` says what in words."""

    t: float
    kind: str
    detail: str

    def to_dict(self) -> dict:
        """The event as JSON-ready values (time in seconds)."""
        return {"t": self.t, "kind": self.kind, "detail": self.detail}


@dataclass(frozen=True)
class MonitorStats:
    """What the monitor measured over the run.

    ``max_speed_ratio`` is the largest observer chord over ``vo·dt``; ``min_clearance`` the
    smallest distance from the observer to the obstacle boundary (map units; 0 in contact);
    ``max_distance_error`` the largest deviation from ``lss`` of the target–observer distance at
    mid-step when both move in straight lines between samples (map units; zero at the samples).
    """

    max_speed_ratio: float
    min_clearance: float
    max_distance_error: float

    def to_dict(self) -> dict:
        """The statistics as JSON-ready values."""
        return {"max_speed_ratio": self.max_speed_ratio, "min_clearance": self.min_clearance,
                "max_distance_error": self.max_distance_error}


@dataclass(frozen=True, eq=False)
class Trace:
    """Samples of a run: times (s), target ``p`` (n, 2), rod ``a`` (rad), observer (n, 2), and
    per step (n − 1 rows) the mode, the rod rate (rad/s) and the chord speed ratio; with a
    sensing delay, ``seen`` (n, 2): the target's position the controller was given."""

    t: np.ndarray
    p: np.ndarray
    a: np.ndarray
    observer: np.ndarray
    mode: tuple[str, ...]
    rate: np.ndarray
    speed_ratio: np.ndarray
    seen: np.ndarray | None = None


    def __len__(self) -> int:
        return len(self.t)

    def to_dict(self) -> dict:
        """The trace as JSON-ready lists (times in seconds, positions in map units)."""
        return {"t": self.t.tolist(), "target": self.p.tolist(), "a": self.a.tolist(),
                "observer": self.observer.tolist(), "mode": list(self.mode),
                "rate": self.rate.tolist(), "speed_ratio": self.speed_ratio.tolist(),
                **({"seen": self.seen.tolist()} if self.seen is not None else {})}


@dataclass(frozen=True, eq=False)
class SimResult:
    """Outcome of :func:`simulate`: ``held`` for the whole duration or ``lost`` at ``lost_at``
    (s) with ``reason``; time per mode (s), monitor statistics, events and the trace.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.sim.controller import FollowController
    >>> from tether.sim.protocols import World
    >>> from tether.sim.simulate import simulate
    >>> from tether.strategies import make_target
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> world = World(ell, lss=0.5, vt=0.3, vo=1.0)
    >>> result = simulate(world, FollowController(), make_target("random", world),
    ...                   (1.0, 1.0, 1.5708), duration=1.0, dt=0.05)
    >>> result.held, len(result.trace), result.monitor.max_speed_ratio <= 1
    (True, 21, True)
    """

    outcome: Outcome | str
    lost_at: float | None
    reason: str | None
    duration: float
    dt: float
    seed: int
    start: tuple[float, float, float]
    controller: str
    target: str
    mode_time: dict[str, float]
    monitor: MonitorStats
    events: tuple[Event, ...]
    trace: Trace = field(repr=False)
    delay: float = 0.0
    delay_steps: int = 0

    @property
    def held(self) -> bool:
        """Whether the target stayed in sight for the whole duration."""
        return self.outcome == Outcome.HELD

    @property
    def modes(self) -> list[str]:
        """The sequence of modes, consecutive repeats collapsed."""
        seq: list[str] = []
        for m in self.trace.mode:
            if not seq or seq[-1] != m:
                seq.append(m)
        return seq

    def to_dict(self, trace: bool = False) -> dict:
        """The result as JSON-ready values; with ``trace`` the whole trace too."""
        d = {"outcome": self.outcome, "lost_at": self.lost_at, "reason": self.reason,
             "duration": self.duration, "dt": self.dt, "seed": self.seed,
             "start": list(self.start), "controller": self.controller, "target": self.target,
             "mode_time": dict(self.mode_time), "modes": self.modes,
             "monitor": self.monitor.to_dict(), "steps": len(self.trace) - 1,
             "events": [e.to_dict() for e in self.events]}
        if self.delay > 0:
            d["delay"], d["delay_steps"] = self.delay, self.delay_steps
        if trace:
            d["trace"] = self.trace.to_dict()
        return d


def _u(a: float) -> np.ndarray:
    return np.array([math.cos(a), math.sin(a)])


def _name(obj: Any) -> str:
    return str(getattr(obj, "name", type(obj).__name__))


class Monitor:
    """The independent checks of one step (see the module docstring)."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.env = world.env
        self.lss = world.lss
        self.max_ratio = 0.0
        self.min_clear = math.inf
        self.max_derr = 0.0
        self._walls = world.env.polygon.boundary  # what env.boundary_distance measures to
        self._clear = CLEAR_TOLS * world.env.length_tol

    def observer(self, p: np.ndarray, a: float) -> np.ndarray:
        """The observer's position for target ``p`` and rod orientation ``a``, map units."""
        return p + self.lss * _u(a)

    def ok(self, p: np.ndarray, a: float) -> bool:
        """Whether the configuration is admissible: observer in the free space, rod free.

        The exact rod test (:func:`tether.arcs.rod_is_free`) runs unless the rod is clear
        of the walls: a target inside the free space and the rod's segment farther than
        ``CLEAR_TOLS`` length tolerances from every wall (GEOS's distance) put the whole rod
        and the observer inside, and every way the rod test blocks needs a wall within one
        tolerance of the rod (a crossing, a target on an edge, a vertex on the rod's line),
        so the answer is the same."""
        o = self.observer(p, a)
        if (float(shapely.distance(self._walls, shapely.linestrings([p, o]))) > self._clear
                and bool(self.env.contains(p[0], p[1]))):
            return True
        return bool(self.env.contains(o[0], o[1])) and rod_is_free(self.env, p, a, self.lss)

    def ok_seen(self, p: np.ndarray, q: np.ndarray, a: float) -> bool:
        """With a sensing delay: whether the observer ``q + lss·u(a)`` (``q`` the seen
        target) is in the free space and the line of sight from it to the true target ``p``
        is free (the exact rod test from ``p`` toward the observer)."""
        o = self.observer(q, a)
        d = o - p
        return bool(self.env.contains(o[0], o[1])) and rod_is_free(
            self.env, p, math.atan2(d[1], d[0]), float(np.hypot(d[0], d[1])))

    def why_seen(self, p: np.ndarray, q: np.ndarray, a: float) -> str:
        """Words for a failure of :meth:`ok_seen`."""
        o = self.observer(q, a)
        if not bool(self.env.contains(o[0], o[1])):
            return self.why(q, a)
        d = np.where(self.env.reflex, _seg_dist_points(self.env.vertices, p, o), np.inf)
        return f"line of sight occluded by {self.env.vertex_name(int(np.argmin(d)))}"

    def why(self, p: np.ndarray, a: float) -> str:
        """Words for an inadmissible configuration: which wall or vertex is in the way."""
        env = self.env
        o = self.observer(p, a)
        if not bool(env.contains(o[0], o[1])):
            A, B, _, _ = env.oriented_edges
            i = int(np.argmin(_seg_dist(o, A, B)))
            return f"observer pushed into {env.edge_name(i)}"
        verts = env.vertices
        d = _seg_dist_points(verts, p, o)
        refl = env.reflex
        d = np.where(refl, d, d + 1e9)
        j = int(np.argmin(d))
        return f"rod occluded by {env.vertex_name(j)}"

    def measure(self, p0: np.ndarray, a0: float, p1: np.ndarray, a1: float, dt: float,
                q0: np.ndarray | None = None, q1: np.ndarray | None = None) -> float:
        """Record the step's statistics; return the chord speed ratio. With a sensing delay
        the observer is at the seen targets ``q0``, ``q1`` plus the rod."""
        o0 = self.observer(p0 if q0 is None else q0, a0)
        o1 = self.observer(p1 if q1 is None else q1, a1)
        ratio = float(np.linalg.norm(o1 - o0)) / (self.world.vo * dt)
        self.max_ratio = max(self.max_ratio, ratio)
        mid = 0.5 * (o0 + o1) - 0.5 * (p0 + p1)
        self.max_derr = max(self.max_derr, abs(float(np.linalg.norm(mid)) - self.lss))
        self.min_clear = min(self.min_clear, float(shapely.distance(
            self._walls, shapely.Point(float(o1[0]), float(o1[1])))))
        return ratio

    def stats(self) -> MonitorStats:
        """The worst values seen so far."""
        return MonitorStats(self.max_ratio, self.min_clear if math.isfinite(self.min_clear)
                            else 0.0, self.max_derr)


def _seg_dist(o: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    e = B - A
    t = np.clip(np.einsum("ij,ij->i", o - A, e) / np.einsum("ij,ij->i", e, e), 0, 1)
    return np.linalg.norm(A + t[:, None] * e - o, axis=1)


def _seg_dist_points(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    e = b - a
    t = np.clip((pts - a) @ e / float(e @ e), 0, 1)
    return np.linalg.norm(a + t[:, None] * e - pts, axis=1)


def check_start(world: World, x: float, y: float, a: float) -> None:
    """Raise a :class:`~tether.errors.TetherError` unless ``(x, y, a)`` is a valid start:
    target in the free space, rod free, ``vo > vt``."""
    if not world.vo > world.vt:
        raise InvalidParameterError(f"vo must exceed vt (vo={world.vo:g}, vt={world.vt:g})")
    if not all(math.isfinite(float(c)) for c in (x, y, a)):
        raise InvalidParameterError("start must be three finite numbers x y a")
    env = world.env
    if not bool(env.contains(x, y)) or float(env.boundary_distance(x, y)) <= env.length_tol:
        raise OutsideFreeSpaceError(f"start target ({x:g}, {y:g}) is not inside the free space")
    if not rod_is_free(env, (x, y), a, world.lss):
        raise OutsideFreeSpaceError(
            f"start rod from ({x:g}, {y:g}) at a={a:g} rad (length {world.lss:g}) is not free")


def _clip_speed(v: Any, vt: float) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(2)
    if not np.all(np.isfinite(v)):
        return np.zeros(2)
    n = float(np.hypot(v[0], v[1]))
    return v * (vt / n) if n > vt else v


def _keep_inside(world: World, p: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """Shrink ``v`` so that the target stays strictly inside the free space over the step (the
    walls stop a target; targets are expected to steer clear of them themselves)."""
    env = world.env
    margin = 1e3 * env.length_tol
    for _ in range(12):
        q = p + v * dt
        if bool(env.contains(q[0], q[1])) and float(env.boundary_distance(q[0], q[1])) > margin:
            return v
        v = 0.5 * v
    return np.zeros(2)


def _locate(bad: Callable[[np.ndarray, float], bool], p: np.ndarray, v: np.ndarray, a: float,
            rate: float, h: float) -> float:
    """Smallest fraction ``s`` of the step at which ``bad(p + s·v·h, a + s·rate·h)`` holds
    (false at 0, true at 1), by bisection."""
    lo, hi = 0.0, 1.0
    for _ in range(LOCATE_ITERS):
        mid = 0.5 * (lo + hi)
        if bad(p + mid * h * v, a + mid * h * rate):
            hi = mid
        else:
            lo = mid
    return hi


def simulate(world: World, controller: Controller, target: Target,
             start: tuple[float, float, float], duration: float = 20.0, dt: float = 0.02,
             seed: int = 0, monitor: bool = True,
             progress: Callable[[str, float], None] | None = None,
             delay: float = 0.0) -> SimResult:
    """Run ``target`` against ``controller`` from ``start = (x, y, a)`` for ``duration`` s.

    Parameters
    ----------
    world : World
        Map, rod length and speeds (and the decomposition/verdict when computed).
    controller, target : Controller, Target
        Objects following :mod:`tether.sim.protocols`.
    start : (x, y, a)
        Target position (map units) and rod orientation (radians).
    duration, dt : float
        Simulated time and step, seconds.
    seed : int
        Seeds the target's generator.
    monitor : bool
        Check every step (the default). Without it only the controller's own infeasibility ends
        a run, which is useful only to measure the controller's cost.
    progress : callable, optional
        ``progress(stage, fraction)`` for long runs.
    delay : float
        Sensing delay, seconds (module docstring): the controller sees the target
        ``ceil(delay/dt)`` steps late. 0: no delay.

    Raises
    ------
    InvalidParameterError, OutsideFreeSpaceError
        Bad speeds or step, or a start that is not a free rod in the free space.

    Examples
    --------
    The follow law against a target walking 2 map units along an L-shaped room, rod 0.5 long
    (``vt/vo = 0.3``), and the same walk toward the far wall of a 1.5 × 3 room with a rod of 1:

    >>> from tether import Environment
    >>> from tether.sim.controller import FollowController
    >>> from tether.sim.protocols import World
    >>> from tether.sim.simulate import simulate
    >>> from tether.strategies import make_target
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> world = World(ell, lss=0.5, vt=0.3, vo=1.0)
    >>> target = make_target("path", world, waypoints=[(1.0, 1.0), (3.0, 1.0)])
    >>> result = simulate(world, FollowController(), target, (1.0, 1.0, 1.5708), duration=2.0,
    ...                   dt=0.05)
    >>> result.outcome, result.modes
    ('held', ['reactive'])
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> world = World(room, lss=1.0, vt=0.3, vo=1.0)
    >>> target = make_target("path", world, waypoints=[(0.75, 1.2), (0.75, 2.9)])
    >>> result = simulate(world, FollowController(), target, (0.75, 1.2, 1.5708), duration=8.0,
    ...                   dt=0.05)
    >>> result.outcome, round(result.lost_at, 2)  # seconds
    ('lost', 2.65)
    >>> result.reason
    'rate needed beyond vo: ... (wall E2 met with the rod too steep to slide)'
    """
    if not (dt > 0 and duration >= 0 and math.isfinite(dt) and math.isfinite(duration)):
        raise InvalidParameterError(f"need dt > 0 and duration >= 0 (dt={dt}, duration={duration})")
    if not (math.isfinite(delay) and delay >= 0):
        raise InvalidParameterError(f"the delay must be a finite number >= 0 s, got {delay}")
    x, y, a = (float(c) for c in start)
    check_start(world, x, y, a)
    lag = int(math.ceil(delay / dt - 1e-9)) if delay > 0 else 0  # whole steps
    reach = world.vt * lag * dt  # how far the true target may be from the seen one
    seen_v: list[np.ndarray] = []  # the target's velocity per step, for the seen one

    rng = np.random.default_rng(seed)
    p = np.array([x, y])
    q = p.copy()  # the seen target (p itself without delay)
    qs = [q.copy()]
    controller.reset(world, p.copy(), a)
    world.extra["controller"] = controller  # white-box targets attack a copy of it
    target.reset(world, p.copy(), a, rng)
    mon = Monitor(world)
    dec = world.decomposition
    region = int(dec.region_at(p)[0]) if dec is not None else -1
    mode_at = getattr(controller, "mode_at", None)

    nsteps = int(math.ceil(duration / dt - 1e-9))
    ts, ps, as_ = [0.0], [p.copy()], [a]
    modes: list[str] = []
    rates: list[float] = []
    ratios: list[float] = []
    events: list[Event] = []
    mode_time: dict[str, float] = {}
    outcome, lost_at, reason = Outcome.HELD, None, None
    prev_mode = None
    t = 0.0
    for k in range(nsteps):
        h = min(dt, duration - t)
        if h <= 0:
            break
        v = _clip_speed(target.velocity(t, p.copy(), a), world.vt)
        v = _keep_inside(world, p, v, h)
        seen_v.append(v)
        vq = v if not lag else (seen_v[k - lag] if k >= lag else np.zeros(2))
        cmd: Command = controller.step((q if lag else p).copy(), vq, a, h)
        if not cmd.feasible or not math.isfinite(cmd.rate):
            outcome, lost_at = Outcome.LOST, t
            reason = cmd.reason or "no admissible rod rate (the controller gave up)"
            events.append(Event(t, "loss", reason))
            break
        rate = float(cmd.rate)
        p1 = p + v * h
        q1 = q + vq * h if lag else p1
        a1 = a + rate * h
        mode = cmd.mode
        if prev_mode is not None and mode != prev_mode:
            te = t
            if mode_at is not None and mode_at(p, v, a) == prev_mode:
                s = _locate(lambda q, b, m=prev_mode, v=v: mode_at(q, v, b) != m, p, v, a, rate, h)
                te = t + s * h
            events.append(Event(te, "mode", f"{prev_mode} -> {mode}"))
        prev_mode = mode
        ratio = mon.measure(p, a, p1, a1, h, *((q, q1) if lag else ()))
        lost_now = None
        if monitor:
            if ratio > 1.0 + SPEED_TOL:
                lost_now = (t, f"rate needed beyond vo: the observer's chord was {ratio:.6g} "
                               f"times vo·dt")
            elif lag:
                lost_now = _check_seen(mon, p, q, v, vq, a, rate, h, t, reach)
            elif not mon.ok(p1, a1):
                s = _locate(lambda q, b: not mon.ok(q, b), p, v, a, rate, h)
                ps_, as_s = p + s * v * h, a + s * rate * h
                words = mon.why(ps_, as_s)
                if dec is not None:
                    r1 = int(dec.region_at(p1)[0])
                    if r1 != region and region >= 0 and r1 >= 0:
                        piece = _piece_between(dec, region, r1)
                        words = (f"no continuation across {piece} (R{region} -> R{r1}): "
                                 f"{words}")
                lost_now = (t + s * h, words)
        if dec is not None and lost_now is None:
            r1 = int(dec.region_at(p1)[0])
            if r1 >= 0 and r1 != region:
                if region >= 0:
                    s = _locate(lambda q, b, r=region: int(dec.region_at(q)[0]) != r,
                                p, v, a, 0.0, h)
                    events.append(Event(t + s * h, "crossing",
                                        f"{_piece_between(dec, region, r1)}: R{region} -> R{r1}"))
                region = r1
        modes.append(mode)
        rates.append(rate)
        ratios.append(ratio)
        mode_time[mode] = mode_time.get(mode, 0.0) + h
        if lost_now is not None:
            outcome, lost_at, reason = Outcome.LOST, lost_now[0], lost_now[1]
            events.append(Event(lost_at, "loss", reason))
            p, a, t, q = p1, a1, t + h, q1
            qs.append(q.copy())
            ts.append(t)
            ps.append(p.copy())
            as_.append(a)
            break
        p, a, t, q = p1, a1, t + h, q1
        qs.append(q.copy())
        ts.append(t)
        ps.append(p.copy())
        as_.append(a)
        if progress is not None and k % 200 == 0:
            progress("simulate", t / duration if duration else 1.0)
    if progress is not None:
        progress("simulate", 1.0)
    P = np.array(ps).reshape(-1, 2)
    A = np.array(as_, dtype=float)
    Q = np.array(qs).reshape(-1, 2) if lag else P
    O = Q + world.lss * np.column_stack((np.cos(A), np.sin(A)))
    trace = Trace(np.array(ts), P, A, O, tuple(modes), np.array(rates), np.array(ratios),
                  Q if lag else None)
    return SimResult(outcome, lost_at, reason, float(duration), float(dt), int(seed),
                     (x, y, float(start[2])), _name(controller), _name(target),
                     {m: round(s, 12) for m, s in mode_time.items()}, mon.stats(),
                     tuple(events), trace, float(delay) if lag else 0.0, lag)


#: Relative slack of the monitor's distance check with a delay (rounding of the positions).
DISTANCE_TOL = 1e-9


def _check_seen(mon: Monitor, p: np.ndarray, q: np.ndarray, v: np.ndarray, vq: np.ndarray,
                a: float, rate: float, h: float, t: float, reach: float
                ) -> tuple[float, str] | None:
    """The monitor's checks of one step with a sensing delay (module docstring): ``None``,
    or the time of the first failure in the step (bisection) and words for it."""
    p1, q1, a1 = p + v * h, q + vq * h, a + rate * h
    o1 = mon.observer(q1, a1)
    dist = float(np.hypot(*(o1 - p1)))
    if abs(dist - mon.lss) > reach + DISTANCE_TOL * max(1.0, mon.lss):
        return (t + h, f"distance observer-target {dist:.6g} outside lss +/- vt·delay "
                       f"({mon.lss - reach:.6g} to {mon.lss + reach:.6g})")
    if mon.ok_seen(p1, q1, a1):
        return None
    lo, hi = 0.0, 1.0
    for _ in range(LOCATE_ITERS):
        mid = 0.5 * (lo + hi)
        if mon.ok_seen(p + mid * h * v, q + mid * h * vq, a + mid * h * rate):
            lo = mid
        else:
            hi = mid
    return (t + hi * h, mon.why_seen(p + hi * h * v, q + hi * h * vq, a + hi * h * rate))


def _piece_between(dec: Any, r0: int, r1: int) -> str:
    """Name of a piece between regions ``r0`` and ``r1`` (``P?`` if they only touch)."""
    from tether.analysis.connectivity import piece_regions

    a, b = piece_regions(dec).T
    hit = np.flatnonzero(((a == r0) & (b == r1)) | ((a == r1) & (b == r0)))
    return dec.pieces[int(hit[0])].name if len(hit) else "P?"


# ------------------------------------------------------------------------------ traces
def save_trace(result: SimResult, path: str | Path) -> None:
    """Write the run's trace to ``path``: ``.json`` (result and trace), ``.csv`` (one row per
    sample: t, x, y, a, ox, oy, mode, rate, speed_ratio) or ``.npz`` (arrays)."""
    path = Path(path)
    suffix = path.suffix.lower()
    tr = result.trace
    if suffix == ".json":
        path.write_text(json.dumps(result.to_dict(trace=True), indent=1) + "\n")
    elif suffix == ".csv":
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t", "x", "y", "a", "ox", "oy", "mode", "rate", "speed_ratio"])
            for i in range(len(tr)):
                step = i < len(tr.mode)
                w.writerow([repr(float(tr.t[i])), repr(float(tr.p[i, 0])),
                            repr(float(tr.p[i, 1])), repr(float(tr.a[i])),
                            repr(float(tr.observer[i, 0])), repr(float(tr.observer[i, 1])),
                            tr.mode[i] if step else "",
                            repr(float(tr.rate[i])) if step else "",
                            repr(float(tr.speed_ratio[i])) if step else ""])
    elif suffix == ".npz":
        with path.open("wb") as fh:
            np.savez(fh, t=tr.t, p=tr.p, a=tr.a, observer=tr.observer,
                     mode=np.array(tr.mode, dtype=str), rate=tr.rate,
                     speed_ratio=tr.speed_ratio,
                     result=np.array(json.dumps(result.to_dict())))
    else:
        raise InvalidParameterError(f"{path}: trace must end in .json, .csv or .npz")
