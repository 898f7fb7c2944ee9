"""Timed target tracks: a person's positions ``(t, x, y)`` as recorded or simulated, replayed
with their own timing (:class:`Track`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tether.errors import InvalidParameterError

__all__ = ["Track"]


@dataclass(frozen=True, eq=False)
class Track:
    """A target's timed positions: ``t`` (shape (n,), seconds, strictly increasing) and ``xy``
    (shape (n, 2), map units, in the map's frame). Between samples the position is linear in
    time; before the first sample it is the first, after the last the last.

    Examples
    --------
    >>> from tether.io.tracks import Track
    >>> tr = Track([0.0, 2.0, 4.0], [(0, 0), (1, 0), (1, 1)])
    >>> tr.duration, tr.position(1.0).tolist(), tr.velocity(3.0).tolist()
    (4.0, [0.5, 0.0], [0.0, 0.5])
    >>> round(tr.max_speed, 3)
    0.5
    """

    t: np.ndarray
    xy: np.ndarray
    name: str = ""
    meta: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float).reshape(-1)
        xy = np.asarray(self.xy, dtype=float)
        if xy.ndim != 2 or xy.shape[1:] != (2,) or len(xy) != len(t):
            raise InvalidParameterError(
                f"track: need as many (x, y) pairs as times, got {len(t)} times and "
                f"positions of shape {xy.shape}")
        if len(t) < 1:
            raise InvalidParameterError("track: no samples")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xy))):
            raise InvalidParameterError("track: times and positions must be finite numbers")
        if len(t) > 1 and not np.all(np.diff(t) > 0):
            k = int(np.argmin(np.diff(t) > 0)) + 1
            raise InvalidParameterError(
                f"track: times must increase strictly (sample {k}: t={t[k]!r} after "
                f"t={t[k - 1]!r})")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "xy", xy)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def start(self) -> float:
        """Time of the first sample, s."""
        return float(self.t[0])

    @property
    def duration(self) -> float:
        """Time from the first sample to the last, s."""
        return float(self.t[-1] - self.t[0])

    def speeds(self) -> np.ndarray:
        """Speed on each segment between samples (shape (n-1,)), map units/s."""
        return np.hypot(*np.diff(self.xy, axis=0).T) / np.diff(self.t)

    @property
    def max_speed(self) -> float:
        """Largest segment speed, map units/s (0 for one sample)."""
        return float(self.speeds().max()) if len(self.t) > 1 else 0.0

    def position(self, t: float) -> np.ndarray:
        """Position at time ``t`` (s), linear between samples, held before and after."""
        return np.array([np.interp(t, self.t, self.xy[:, 0]),
                         np.interp(t, self.t, self.xy[:, 1])])

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (map units/s) of the segment that holds ``t`` (zero outside the track;
        at a sample, the segment that starts there)."""
        if len(self.t) < 2 or t < self.t[0] or t >= self.t[-1]:
            return np.zeros(2)
        k = int(np.searchsorted(self.t, t, side="right")) - 1
        return (self.xy[k + 1] - self.xy[k]) / (self.t[k + 1] - self.t[k])

    def shifted(self, dt: float) -> Track:
        """The same track with every time moved by ``dt`` s."""
        return Track(self.t + dt, self.xy, self.name, dict(self.meta))
