"""A follower without map reasoning, for comparison: the behaviour of the ROS 2 Nav2 Following
Server as its documentation describes it (keep a set distance to the detected pose; when the
detection is lost, rotate in place to look for it, for a bounded time).

:class:`SpinSearch` has the :class:`~tether.follow.Follower` interface (``update`` returns a
:class:`~tether.follow.Command`). While the target is seen it drives straight toward the point
at distance ``lss`` from the target on the line to the observer (no planner: with line of sight,
the straight line is free until the point itself). When the target is not seen it first goes on
to that point of the *last* sighting, then spins in place at ``spin_rate`` for up to
``spin_time`` s (10 s, the server's default search time), then stops: ``lost``. With tether's
sensor (line of sight all around, :func:`tether.follow.replay.replay`) the spin turns the
heading only; what the robot sees is decided by where it stands, so the spin is the wait of a
robot that does not move.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tether.errors import InvalidParameterError
from tether.follow.follower import Command, Status

__all__ = ["SpinSearch"]


class SpinSearch:
    """The Nav2-like follower (see the module).

    Parameters
    ----------
    lss, vo : float
        Distance to keep (map units) and the speed bound (map units/s).
    rate : float
        The loop's rate, Hz.
    spin_time : float
        How long to spin in place after the loss before giving up, s.
    spin_rate : float
        Turning rate while spinning, rad/s.

    Examples
    --------
    >>> from tether.follow.baseline import SpinSearch
    >>> b = SpinSearch(lss=0.5, vo=1.0)
    >>> b.update(0.0, (1.0, 1.0), observer=(2.0, 1.0)).status
    'tracking'
    >>> [b.update(t, None, observer=(1.5, 1.0)).status for t in (1.0, 5.0, 11.5)]
    ['searching', 'searching', 'lost']
    """

    def __init__(self, lss: float, vo: float, *, rate: float = 20.0, spin_time: float = 10.0,
                 spin_rate: float = 0.5) -> None:
        for name, v in (("lss", lss), ("vo", vo), ("rate", rate), ("spin_time", spin_time),
                        ("spin_rate", spin_rate)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InvalidParameterError(f"{name} must be a finite number > 0 (got {v!r})")
        self.lss, self.vo = float(lss), float(vo)
        self.period = 1.0 / float(rate)
        self.spin_time, self.spin_rate = float(spin_time), float(spin_rate)
        self.observer: np.ndarray | None = None
        self.last: np.ndarray | None = None
        self.t: float | None = None
        self.t_seen: float | None = None
        self.heading = 0.0
        self._vel = np.zeros(2)
        self._spin_since: float | None = None

    def update(self, t: float, observation: Any = None, stamp: float | None = None, *,
               observer: Any = None) -> Command:
        """One step at time ``t`` (s): as :meth:`tether.follow.Follower.update`."""
        t = float(t)
        dt = self.period if self.t is None else max(t - self.t, 0.0)
        self.t = t
        if observer is not None:
            self.observer = np.asarray(observer, dtype=float).reshape(2)
        elif self.observer is not None:
            self.observer = self.observer + self._vel * dt
        if observation is not None:
            self.last = np.asarray(observation, dtype=float).reshape(2)
            self.t_seen = t if stamp is None else float(stamp)
            if self.observer is None:
                self.observer = self.last + np.array([self.lss, 0.0])
        if self.last is None:
            return self._stop(t, Status.LOST, "no sighting of the target yet")
        o, p = self.observer, self.last
        d = float(np.hypot(*(o - p)))
        u = (o - p) / d if d > 0 else np.array([1.0, 0.0])
        goal = p + self.lss * u
        step = goal - o
        dist = float(np.hypot(*step))
        toward = math.atan2(p[1] - o[1], p[0] - o[0])
        if observation is not None or dist > 1e-9:
            self._spin_since = None
            speed = min(self.vo, dist / self.period)
            self._vel = step * (speed / dist) if dist > 0 else np.zeros(2)
            self.heading = toward
            status = Status.TRACKING if observation is not None else Status.SEARCHING
            return Command(t, (float(goal[0]), float(goal[1]), toward), self._vel, status,
                           None, p.copy())
        if self._spin_since is None:
            self._spin_since = t
        if t - self._spin_since > self.spin_time:
            return self._stop(t, Status.LOST, f"spun in place for {self.spin_time:g} s without "
                                              "seeing the target")
        self.heading = (self.heading + self.spin_rate * dt) % math.tau
        self._vel = np.zeros(2)
        return Command(t, (float(o[0]), float(o[1]), self.heading), self._vel,
                       Status.SEARCHING, None, p.copy())

    def _stop(self, t: float, status: Status, reason: str) -> Command:
        self._vel = np.zeros(2)
        o = self.observer
        pose = (math.nan, math.nan, math.nan) if o is None else (float(o[0]), float(o[1]),
                                                                 self.heading)
        return Command(t, pose, self._vel, status, reason,
                       None if self.last is None else self.last.copy())
