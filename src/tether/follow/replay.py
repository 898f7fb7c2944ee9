"""A follower replayed on a recorded (or simulated) track, the target observed only while it is
in view: what ``tether follow`` runs and reports.

Each step of ``dt`` s: the target is at the track's position; it is *in view* when the segment
from the observer to it crosses no wall (:func:`tether.follow.reachable.clear_segments`) and,
with a sensor range, is no longer than the range. The follower then receives the position plus
Gaussian noise (``noise`` per axis, seeded), measured ``latency`` s earlier (stamped so), or
``None``; the observer moves by the commanded velocity (clipped to ``vo``) for ``dt``. A move
that would leave the free space or cross a wall is halved until it does not (at most 8 times,
then the observer stays): such steps are counted as ``blocked``. The observer's position is
given to the follower each step (exact odometry).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tether.arcs import free_arcs
from tether.environment import Environment
from tether.errors import InvalidParameterError, OutsideFreeSpaceError
from tether.follow.follower import APPROACH_TOL, Follower, Status
from tether.follow.reachable import clear_segments, first_blocking_edge
from tether.io.tracks import Track

__all__ = ["FollowRun", "Loss", "replay", "start_observer"]


@dataclass(frozen=True)
class Loss:
    """The target left view at ``t`` (s) because of ``cause`` (``occluded by V3``, ``occluded
    by E5``, ``out of range``); it was back in view at ``back`` (s), or never (``None``)."""

    t: float
    cause: str
    back: float | None

    @property
    def reacquisition(self) -> float | None:
        """Seconds out of view (``None``: not back before the end of the track)."""
        return None if self.back is None else self.back - self.t

    def to_dict(self) -> dict:
        """JSON-ready values (times in s)."""
        return {"t": self.t, "cause": self.cause, "back": self.back,
                "reacquisition": self.reacquisition}


@dataclass(frozen=True, eq=False)
class FollowRun:
    """A replayed run: per step the time ``t`` (s), ``target`` and ``observer`` (n, 2; map
    units), whether the target was ``seen`` and the follower's ``status``; the losses; the
    possible set while searching (``snapshots``: (t, cell centres) every ``snapshot_every``
    s); ``blocked`` moves; the largest observer speed over ``vo`` (``max_speed_ratio``); and,
    while tracking at the rod length, the largest ``| |target − observer| − lss |``
    (``max_rod_error``, map units)."""

    follower: str
    dt: float
    lss: float
    vo: float
    t: np.ndarray
    target: np.ndarray
    observer: np.ndarray
    seen: np.ndarray
    status: tuple[str, ...]
    losses: tuple[Loss, ...]
    blocked: int
    max_speed_ratio: float
    max_rod_error: float
    at_rod_length: float
    snapshots: tuple[tuple[float, np.ndarray], ...] = field(default=(), repr=False)

    @property
    def duration(self) -> float:
        """Replayed time, s."""
        return float(len(self.t) * self.dt)

    @property
    def time_in_view(self) -> float:
        """Seconds with the target in view."""
        return float(self.seen.sum() * self.dt)

    @property
    def percent_in_view(self) -> float:
        """Share of the run with the target in view, %."""
        return 100.0 * float(self.seen.mean()) if len(self.seen) else 0.0

    @property
    def reacquisitions(self) -> list[float]:
        """Seconds out of view of each loss that ended before the track did."""
        return [x.reacquisition for x in self.losses if x.back is not None]

    def to_dict(self, trace: bool = False) -> dict:
        """What ``tether follow --json`` prints (``trace``: the per-step arrays too)."""
        causes: dict[str, int] = {}
        for x in self.losses:
            causes[x.cause] = causes.get(x.cause, 0) + 1
        out = {
            "follower": self.follower, "duration": self.duration, "dt": self.dt,
            "time_in_view": self.time_in_view, "percent_in_view": self.percent_in_view,
            "losses": len(self.losses), "loss_causes": causes,
            "loss_events": [x.to_dict() for x in self.losses],
            "reacquisition_times": self.reacquisitions,
            "never_reacquired": sum(x.back is None for x in self.losses),
            "time_per_status": {s: self.dt * sum(1 for x in self.status if x == s)
                                for s in ("tracking", "searching", "lost")},
            "monitor": {"blocked_moves": self.blocked, "max_speed_ratio": self.max_speed_ratio,
                        "max_rod_error": self.max_rod_error,
                        "percent_in_view_at_rod_length": self.at_rod_length},
        }
        if trace:
            out["trace"] = {"t": self.t.tolist(), "target": self.target.tolist(),
                            "observer": self.observer.tolist(), "seen": self.seen.tolist(),
                            "status": list(self.status)}
        return out


# two free arcs whose widths differ by less than this (rad) are equally wide
WIDEST_TIE = 1e-9


def start_observer(env: Environment, p: np.ndarray, lss: float) -> np.ndarray:
    """The observer at ``lss`` from ``p`` in the middle of the widest free rod arc there (along
    +x when every orientation is free). Arcs within ``WIDEST_TIE`` rad of the widest tie (a
    symmetric corridor gives two equal arcs): the one whose middle is nearest +x wins, so the
    start does not depend on the order the arcs come in."""
    fa = free_arcs(env, p, lss)
    if fa.empty:
        raise OutsideFreeSpaceError(f"no free rod of length {lss:g} at the track's start "
                                    f"({p[0]:g}, {p[1]:g})")
    a = 0.0
    if not fa.full:
        widest = max(x.length for x in fa.arcs)
        mids = [x.start + 0.5 * x.length for x in fa.arcs if x.length >= widest - WIDEST_TIE]
        a = min(mids, key=lambda m: abs(math.remainder(m, 2.0 * math.pi)))
    return p + lss * np.array([math.cos(a), math.sin(a)])


def _cause(env: Environment, o: np.ndarray, p: np.ndarray, sensor_range: float | None) -> str:
    e = first_blocking_edge(env, o, p)
    if e is None:
        return "out of range"
    _, _, ta, tb = env.oriented_edges
    ends = [int(ta[e]), int(tb[e])]
    reflex = [j for j in ends if env.reflex[j]]
    if reflex:
        w = p - o
        d = [abs(w[0] * (env.vertices[j][1] - o[1]) - w[1] * (env.vertices[j][0] - o[0]))
             for j in reflex]
        return f"occluded by {env.vertex_name(reflex[int(np.argmin(d))])}"
    return f"occluded by {env.edge_name(e)}"


def _move(env: Environment, o: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, bool]:
    for k in range(9):
        q = o + step / (2 ** k)
        if bool(env.contains(q[0], q[1])) and clear_segments(env, o, q[None, :])[0]:
            return q, k > 0
    return o, True


def replay(env: Environment, track: Track, follower: Any, *, lss: float, vo: float,
           dt: float = 0.1, sensor_range: float | None = None, noise: float = 0.0,
           latency: float = 0.0, seed: int = 0, start: Any = None,
           snapshot_every: float = 1.0,
           progress: Callable[[str, float], None] | None = None) -> FollowRun:
    """Replay ``follower`` (a :class:`~tether.follow.Follower` or anything with its ``update``)
    on ``track``, the target observed only while in view (see the module).

    Parameters
    ----------
    env : Environment
        The map.
    track : Track
        The target's timed positions (map units, s).
    follower : Follower or SpinSearch
        Receives ``update(t, observation, stamp, observer=...)`` each step.
    lss, vo : float
        The rod length (map units) and the observer's speed bound (map units/s).
    dt : float
        Step, s.
    sensor_range : float or None
        Range of the sensor, map units (``None``: line of sight only).
    noise : float
        Standard deviation of the observation noise per axis, map units.
    latency : float
        Age of each observation when it arrives, s (stamped with its measurement time).
    seed : int
        Seeds the noise.
    start : (x, y) or None
        The observer's start (default :func:`start_observer` at the track's first point).
    snapshot_every : float
        Seconds between the recorded possible sets while searching.
    progress : callable or None
        ``progress(label, fraction)`` now and then.

    Returns
    -------
    FollowRun
    """
    for name, v in (("dt", dt), ("lss", lss), ("vo", vo)):
        if not (math.isfinite(v) and v > 0):
            raise InvalidParameterError(f"{name} must be a finite number > 0 (got {v!r})")
    if not (math.isfinite(noise) and noise >= 0 and math.isfinite(latency) and latency >= 0):
        raise InvalidParameterError("noise and latency must be finite numbers >= 0")
    rng = np.random.default_rng(seed)
    times = track.start + dt * np.arange(int(math.floor(track.duration / dt + 1e-9)) + 1)
    target = np.column_stack((np.interp(times, track.t, track.xy[:, 0]),
                              np.interp(times, track.t, track.xy[:, 1])))
    o = (start_observer(env, target[0], lss) if start is None
         else np.asarray(start, dtype=float).reshape(2))
    n = len(times)
    obs_path = np.empty((n, 2))
    seen = np.zeros(n, dtype=bool)
    status: list[str] = []
    losses: list[list] = []
    snaps: list[tuple[float, np.ndarray]] = []
    blocked, ratio, rod_err, at_len, in_view = 0, 0.0, 0.0, 0, 0
    next_snap = -math.inf
    for k, t in enumerate(times):
        p = target[k]
        obs_path[k] = o
        d = float(np.hypot(*(p - o)))
        seen[k] = clear_segments(env, o, p[None, :])[0] and (
            sensor_range is None or d <= sensor_range)
        if k and seen[k - 1] and not seen[k]:
            losses.append([float(t), _cause(env, o, p, sensor_range), None])
        elif k and seen[k] and not seen[k - 1] and losses and losses[-1][2] is None:
            losses[-1][2] = float(t)
        observation, stamp = None, None
        if seen[k]:
            stamp = float(t - latency)
            q = track.position(stamp) if latency else p
            observation = q + (rng.normal(0.0, noise, 2) if noise else 0.0)
        cmd = follower.update(float(t), observation, stamp, observer=o)
        status.append(str(cmd.status))
        if seen[k] and cmd.status == Status.TRACKING and cmd.reason is None:
            rod_err = max(rod_err, abs(d - lss))
        if seen[k]:
            in_view += 1
            at_len += abs(d - lss) <= APPROACH_TOL * lss
        if cmd.status == Status.SEARCHING and t >= next_snap and isinstance(follower, Follower):
            snaps.append((float(t), follower.possible_cells()))
            next_snap = t + snapshot_every
        vel = np.asarray(cmd.velocity, dtype=float)
        speed = float(np.hypot(*vel))
        ratio = max(ratio, speed / vo)
        if speed > vo:
            vel = vel * (vo / speed)
        o, hit = _move(env, o, vel * dt)
        blocked += hit
        if progress is not None and k % 200 == 0:
            progress("follow", k / n)
    return FollowRun(type(follower).__name__, float(dt), float(lss), float(vo), times, target,
                     obs_path, seen, tuple(status),
                     tuple(Loss(a, b, c) for a, b, c in losses), int(blocked), ratio, rod_err,
                     100.0 * at_len / in_view if in_view else 0.0, tuple(snaps))
