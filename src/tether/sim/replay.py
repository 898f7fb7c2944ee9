"""Replayed targets: a recorded track (kind ``track``) or a simulated person (kind
``pedestrian``) walked with its own timing.

The simulator steps with its own ``dt``; at every step the replayed target returns the velocity
that brings it exactly to the track's position at the end of the step (the track's mean velocity
over ``[t, t + dt]``, taken from where the target is), so that it is at ``track.position(t)`` at
every sample. Simulation time 0 is the track's first sample; after the last sample the target
stands still.

Speed. A track segment faster than ``vt`` (beyond :data:`SPEED_TOL`) cannot be replayed under
the speed bound: by default the target refuses it in one line naming the first such segment;
with ``speed="clip"`` each such segment is slowed to ``vt`` (it takes ``length / vt`` s instead
of its own time, and every later sample comes later by the delays so far) and the clipped
segments are listed in :attr:`TrackTarget.clipped`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from tether.arcs import rod_is_free
from tether.errors import InvalidParameterError, InvalidTrackError, OutsideFreeSpaceError
from tether.io.tracks import Track, read_track
from tether.sim.protocols import World

__all__ = [
    "ANGLES", "PedestrianTarget", "SPEED_POLICIES", "SPEED_TOL", "START_TOL", "TrackTarget",
    "clip_track", "free_rod_angle", "overspeed"
]

#: A segment is faster than ``vt`` when its speed exceeds ``vt·(1 + SPEED_TOL)``.
SPEED_TOL = 1e-9
#: What to do with segments faster than ``vt``: refuse the track, or slow them to ``vt``.
SPEED_POLICIES = ("refuse", "clip")
#: A run's start agrees with the track's first position within ``START_TOL`` times the map's
#: diameter.
START_TOL = 1e-9
#: Rod orientations tried by :func:`free_rod_angle`.
ANGLES = 72


def overspeed(track: Track, vt: float) -> np.ndarray:
    """Indices of the segments of ``track`` faster than ``vt`` (beyond :data:`SPEED_TOL`).

    Examples
    --------
    >>> from tether.io.tracks import Track
    >>> from tether.sim.replay import overspeed
    >>> overspeed(Track([0, 1, 2, 3], [(0, 0), (0.2, 0), (1.2, 0), (1.2, 0.3)]), 0.3).tolist()
    [1]
    """
    return np.flatnonzero(track.speeds() > vt * (1 + SPEED_TOL)) if len(track) > 1 else \
        np.zeros(0, dtype=int)


def clip_track(track: Track, vt: float) -> tuple[Track, list[dict]]:
    """``track`` with every segment faster than ``vt`` slowed to ``vt``, and the list of those
    segments: ``{"segment": k, "t": start time (s), "speed": its speed (map units/s),
    "delay": time it adds (s)}``.

    Examples
    --------
    >>> from tether.io.tracks import Track
    >>> from tether.sim.replay import clip_track
    >>> slow, clipped = clip_track(Track([0, 1, 2], [(0, 0), (2, 0), (2, 0.5)]), 1.0)
    >>> slow.t.tolist(), clipped
    ([0.0, 2.0, 3.0], [{'segment': 0, 't': 0.0, 'speed': 2.0, 'delay': 1.0}])
    """
    fast = overspeed(track, vt)
    if not len(fast):
        return track, []
    steps = np.diff(track.t)
    lengths = np.hypot(*np.diff(track.xy, axis=0).T)
    slowed = steps.copy()
    slowed[fast] = lengths[fast] / vt
    t = track.t[0] + np.concatenate([[0.0], np.cumsum(slowed)])
    speeds = track.speeds()
    clipped = [{"segment": int(k), "t": float(track.t[k]), "speed": float(speeds[k]),
                "delay": float(slowed[k] - steps[k])} for k in fast]
    return Track(t, track.xy, track.name, {**track.meta, "clipped_to": vt}), clipped


def free_rod_angle(world: World, p: Any, heading: Any = None) -> float:
    """A rod orientation (radians) whose rod of length ``world.lss`` from ``p`` is free: the one
    nearest to behind the target (opposite ``heading``, a direction; 0 rad when ``heading`` is
    none or zero) among :data:`ANGLES` evenly spaced ones.

    Raises
    ------
    OutsideFreeSpaceError
        If no such rod is free.
    """
    x, y = float(p[0]), float(p[1])
    moving = heading is not None and float(np.hypot(*heading)) > 0
    back = math.atan2(float(heading[1]), float(heading[0])) + math.pi if moving else 0.0
    for k in range(ANGLES):
        # 0, +1, -1, +2, -2, ... steps of 2π/ANGLES away from behind
        a = back + (k + 1) // 2 * (1 if k % 2 else -1) * (2 * math.pi / ANGLES)
        a = math.remainder(a, 2 * math.pi)
        if rod_is_free(world.env, (x, y), a, world.lss):
            return a
    raise OutsideFreeSpaceError(f"no free rod of length {world.lss:g} from the track's start "
                                f"({x:g}, {y:g})")


class TrackTarget:
    """Replays a :class:`~tether.io.tracks.Track` with its own timing (see the module
    docstring).

    Parameters
    ----------
    world : World
        The scene (its ``vt`` bounds the replay).
    track : Track, optional
        The track; else ``path`` (and ``topic``/``columns``) is read with
        :func:`tether.io.tracks.read_track`.
    dt : float
        The simulator's step, s (the replay is exact at its samples).
    duration : float, optional
        The run's duration, s, when it is not a multiple of ``dt`` (its last step is shorter).
    speed : {"refuse", "clip"}
        What to do with segments faster than ``vt``.

    Raises
    ------
    InvalidTrackError
        With ``speed="refuse"``, a segment faster than ``vt``: one line naming the first, its
        time and speed, and how many there are.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.io.tracks import Track
    >>> from tether.sim.controller import FollowController
    >>> from tether.sim.protocols import World
    >>> from tether.sim.simulate import simulate
    >>> from tether.strategies import make_target
    >>> room = Environment([(0, 0), (4, 0), (4, 3), (0, 3)])
    >>> world = World(room, lss=0.5, vt=0.3, vo=1.0)
    >>> walk = Track([0, 4, 6], [(1, 1), (2, 1), (2, 1.5)])
    >>> target = make_target("track", world, track=walk, dt=0.1)
    >>> res = simulate(world, FollowController(), target, (1, 1, 3.1416), duration=6, dt=0.1)
    >>> res.trace.p[40].round(9).tolist(), res.trace.p[-1].round(9).tolist()
    ([2.0, 1.0], [2.0, 1.5])
    """

    name = "track"

    def __init__(self, world: World, track: Track | None = None,
                 path: str | Path | None = None, topic: str | None = None,
                 columns: Any = None, dt: float | None = None, duration: float | None = None,
                 speed: str = "refuse") -> None:
        if track is None:
            if path is None:
                raise InvalidParameterError("target 'track' needs a track (--track FILE)")
            track = read_track(path, topic=topic, columns=columns)
        where = str(path) if path is not None else (track.name or "(unnamed)")
        if dt is None or not (math.isfinite(dt) and dt > 0):
            raise InvalidParameterError(f"target 'track' needs the simulation step dt > 0 "
                                        f"(got {dt!r})")
        if speed not in SPEED_POLICIES:
            raise InvalidParameterError(f"track speed policy must be one of "
                                        f"{', '.join(SPEED_POLICIES)} (got {speed!r})")
        self.source = track
        self.speed_policy = speed
        fast = overspeed(track, world.vt)
        if len(fast) and speed == "refuse":
            k = int(fast[0])
            raise InvalidTrackError(
                f"track {where}: segment {k} (t={track.t[k]:g} s to {track.t[k + 1]:g} s) runs "
                f"at {track.speeds()[k]:.6g} map units/s, faster than vt={world.vt:g}; "
                f"{len(fast)} of {len(track) - 1} segments are (--track-speed clip replays "
                "them at vt)")
        self.track, self.clipped = clip_track(track, world.vt)
        self.dt = float(dt)
        self.duration = None if duration is None else float(duration)

    @property
    def start(self) -> np.ndarray:
        """The track's first position, the run's start (map units)."""
        return self.track.xy[0].copy()

    def start_angle(self, world: World) -> float:
        """A free rod orientation at the start, behind the target's first motion (radians)."""
        return free_rod_angle(world, self.start, self.track.velocity(self.track.start))

    def report(self) -> dict:
        """What the replay changed: the speed policy, the clipped segments and the total delay
        (s), JSON-ready."""
        return {"name": self.source.name, "samples": len(self.source),
                "duration": self.track.duration, "speed_policy": self.speed_policy,
                "clipped_segments": list(self.clipped),
                "delay": float(sum(c["delay"] for c in self.clipped))}

    def deviation(self, t: np.ndarray, p: np.ndarray) -> float:
        """The largest distance (map units) between the positions ``p`` (n, 2) of a run at
        times ``t`` (s) and the track's: zero up to rounding, unless the simulator stopped the
        target at a wall the track crosses or grazes."""
        t = np.asarray(t, dtype=float) + self.track.start
        want = np.column_stack([np.interp(t, self.track.t, self.track.xy[:, 0]),
                                np.interp(t, self.track.t, self.track.xy[:, 1])])
        return float(np.hypot(*(np.asarray(p, dtype=float) - want).T).max(initial=0.0))

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run from ``p``, which must be the track's first position."""
        tol = START_TOL * world.env.diameter
        if float(np.hypot(*(np.asarray(p, float) - self.start))) > tol:
            raise InvalidParameterError(
                f"the run starts at ({p[0]:g}, {p[1]:g}) but the track at ({self.start[0]:g}, "
                f"{self.start[1]:g}): give the track's start or none")

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The velocity that reaches the track's position at the end of this step (map
        units/s)."""
        h = self.dt if self.duration is None else min(self.dt, self.duration - t)
        if h <= 0:
            return np.zeros(2)
        goal = self.track.position(self.track.start + t + h)
        return (goal - np.asarray(p, dtype=float)) / h


class PedestrianTarget(TrackTarget):
    """One simulated person (:func:`tether.sim.crowd.pedestrian_tracks`, jupedsim) replayed as a
    track: seeded, walking random goals at ``speed`` map units/s (default ``vt``, the target's
    speed bound), sampled every ``sample_dt`` s for the run's ``duration`` s (``walk`` s, 60 by
    default, when the run's duration is not given).

    Raises
    ------
    tether.sim.crowd.CrowdUnavailableError
        Without jupedsim (``pip install tether[crowd]``).
    """

    name = "pedestrian"

    def __init__(self, world: World, seed: int = 0, speed: float | None = None,
                 dt: float | None = None, duration: float | None = None,
                 walk: float = 60.0, sample_dt: float = 0.05, goals: Any = None,
                 metres_per_unit: float = 1.0) -> None:
        from tether.sim.crowd import pedestrian_tracks

        length = float(duration) if duration else float(walk)
        (person,) = pedestrian_tracks(world.env, 1, seed,
                                      speed=world.vt if speed is None else speed,
                                      duration=length, goals=goals, dt=sample_dt,
                                      metres_per_unit=metres_per_unit)
        # the model keeps a person at its desired speed up to float rounding: "clip" absorbs
        # that rounding and reports any segment it slowed
        super().__init__(world, track=person, dt=dt, duration=duration, speed="clip")
