"""The internal frame the computation runs in: a similarity that centres the map and scales it by
a power of two (lengths convert exactly, angles are unchanged), and the straight vertices that
the internal map leaves out (see ``docs/conventions.md``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from tether.tolerances import REL_STRAIGHT_TOL

__all__ = ["Frame", "identity_frame", "internal_rings", "normalizing_frame", "straight_flags"]


@dataclass(frozen=True)
class Frame:
    """A similarity to the internal frame: ``internal = (user - origin) * scale``; ``scale``
    is a power of two, so lengths convert exactly and angles are unchanged."""

    origin: np.ndarray
    scale: float

    def to_internal(self, pts: Any) -> np.ndarray:
        """User points (m, 2) to internal ones."""
        return (np.asarray(pts, dtype=float) - self.origin) * self.scale

    def to_user(self, pts: Any) -> np.ndarray:
        """Internal points (m, 2) to user ones."""
        return np.asarray(pts, dtype=float) / self.scale + self.origin

    def geometry_to_user(self, geom: Any) -> Any:
        """A shapely geometry from internal to user coordinates."""
        return shapely.transform(geom, self.to_user)


_SQRT_HALF = math.sqrt(0.5)


def normalizing_frame(bounds: tuple[float, float, float, float]) -> Frame:
    """The internal frame of a map with these bounds ``(xmin, ymin, xmax, ymax)``: origin at
    the box's centre, scale a power of two bringing the box's diagonal near 1 (so that scaling
    is exact). A pure function of the bounds: a map scaled by ``2**k`` gets the scale times
    ``2**-k`` and the same internal map."""
    x0, y0, x1, y1 = bounds
    origin = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])
    # the diameter from the centred box: no cancellation at large offsets
    diam = math.hypot(x1 - origin[0], y1 - origin[1]) + math.hypot(origin[0] - x0,
                                                                   origin[1] - y0)
    # the nearest power of two on the log scale, decided on the mantissa (exact, and the same
    # for the map scaled by any power of two; round(log2(diam)) was not, at half-way ties
    # such as a square of side 2^k)
    mantissa, exponent = math.frexp(diam)
    return Frame(origin, 2.0 ** -(exponent if mantissa >= _SQRT_HALF else exponent - 1))



def identity_frame() -> Frame:
    """The frame of a map already in the internal frame: ``internal = user``."""
    return Frame(np.zeros(2), 1.0)


def internal_rings(rings: tuple[np.ndarray, ...], keep: np.ndarray,
                   frame: Frame) -> list[np.ndarray]:
    """The rings of the internal map: each ring's vertices flagged in ``keep`` (indexed over all
    rings in order), in ``frame``."""
    out, start = [], 0
    for r in rings:
        out.append(frame.to_internal(r[keep[start:start + len(r)]]))
        start += len(r)
    return out


def straight_flags(ring: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
    """Straight vertices of one ring (see :attr:`Environment.straight`): first each vertex
    against its neighbours, then each run of straight vertices against the chord of the kept
    vertices around it (so that a long, gently curving chain is not flattened). Vertices
    flagged in ``keep`` are never straight."""
    k = len(ring)
    prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    flags = _near_chord(ring, prev, nxt)
    if keep is not None:
        flags &= ~keep
    for _ in range(k):
        if flags.all() or not flags.any():
            break
        bad = _worst_in_runs(ring, flags)
        if not bad:
            break
        flags[bad] = False
    return flags


def _near_chord(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether points ``p`` lie within ``REL_STRAIGHT_TOL |b - a|`` of chords ``a-b`` and
    between their ends."""
    ab = b - a
    ap = p - a
    cross = np.abs(ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0])
    ll = np.einsum("ij,ij->i", ab, ab)
    along = np.einsum("ij,ij->i", ab, ap)
    return (cross <= REL_STRAIGHT_TOL * ll) & (along > 0) & (along < ll)


def _worst_in_runs(ring: np.ndarray, flags: np.ndarray) -> list[int]:
    """For each run of straight vertices whose kept ends' chord does not hold every vertex of
    the run, the vertex farthest from that chord (to be kept after all)."""
    k = len(ring)
    kept = np.flatnonzero(~flags)
    out = []
    for a, b in zip(kept, np.roll(kept, -1), strict=True):
        run = (np.arange(a + 1, a + 1 + (b - a - 1) % k)) % k
        if len(run) == 0:
            continue
        pa = np.repeat(ring[a][None], len(run), axis=0)
        pb = np.repeat(ring[b][None], len(run), axis=0)
        ok = _near_chord(ring[run], pa, pb)
        if not ok.all():
            ab = ring[b] - ring[a]
            ap = ring[run] - ring[a]
            dev = np.abs(ab[0] * ap[:, 1] - ab[1] * ap[:, 0])
            out.append(int(run[int(np.argmax(np.where(ok, -1.0, dev)))]))
    return out

