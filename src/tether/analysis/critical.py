"""Critical rod lengths of a map: the values of ``lss`` where the critical curves coincide.

On a map of lattice coordinates with a round ``lss`` the critical curves meet exactly: walls
exactly ``2·lss`` apart give one offset curve twice, a pillar exactly ``lss`` from a wall puts a
vertex on an offset curve, two vertices ``2·lss`` apart make their circles tangent. tether
decomposes such maps as they are (regions of positive area carry the exact structure whatever
coincides); but the answer can change on either side of such a length, and a user who asked for
0.5 m wants to know that 0.49 m and 0.51 m differ.

:func:`distance_events` lists the *distance events* of a map, the rod lengths at which

* a vertex lies on another vertex's circle (their distance is ``lss``), or two vertices'
  circles touch (their distance is ``2·lss``), and
* a vertex lies on an edge's offset curve (its distance to the edge, measured along the
  edge's free normal with the foot inside the edge, is ``lss``), or touches the offset of
  another edge of the same distance (``2·lss``: two walls or a wall and a pillar facing
  each other),

for pairs that see each other (the segment between them lies in the free space). These are the
coincidences lattice maps produce. Events among conchoids and extensions in general position
(say a conchoid through a vertex along a 3-4-5 triangle) are not listed.

:func:`near_critical` says whether ``lss`` lies within ``NEAR_CRITICAL_TOLS`` curve tolerances
of one; :func:`tether.analysis.analyze` then reports the verdicts at ``lss - delta`` and
``lss + delta`` too (:class:`CriticalLss`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from tether.environment import Environment
from tether.tolerances import REL_CURVE_TOL, REL_LENGTH_TOL

#: ``lss`` is near a critical length when within this many curve tolerances of it: curves
#: then lie within a few tolerances of their coincident position, near or below tether's
#: resolution (regions that thin join a neighbour, their boundaries cannot be crossed cleanly).
NEAR_CRITICAL_TOLS = 20.0
#: The verdicts beside a critical length are taken this many curve tolerances away (less when
#: another event lies closer: half the way to it, at least ``MIN_SIDE_TOLS``).
SIDE_TOLS = 100.0
MIN_SIDE_TOLS = 10.0
#: ``lss`` is the critical length itself within this many point tolerances
#: (``REL_LENGTH_TOL x`` the diameter): events that close are one critical length.
ON_CRITICAL_TOLS = 10.0


@dataclass(frozen=True)
class DistanceEvent:
    """A rod length ``value`` (map units) at which two features' critical curves coincide:
    features ``a`` and ``b`` (names, file numbering) at distance ``distance``, with
    ``value = distance / multiple`` (``multiple`` 1 or 2)."""

    value: float
    a: str
    b: str
    distance: float
    multiple: int

    def describe(self) -> str:
        """``V3–E7 at distance 2·lss`` as text."""
        times = "lss" if self.multiple == 1 else "2·lss"
        return f"{self.a}–{self.b} at distance {times}"

    def to_dict(self) -> dict:
        """The event as JSON-ready values (``value`` and ``distance`` in map units)."""
        return {"value": self.value, "features": [self.a, self.b], "distance": self.distance,
                "multiple": self.multiple}


def distance_events(env: Environment, lss_max: float, lss_min: float = 0.0
                    ) -> tuple[DistanceEvent, ...]:
    """Every distance event of the map at a rod length from ``lss_min`` to ``lss_max`` (map
    units), sorted by value (see the module's docstring). Computed in the normalized frame;
    only the pairs at a distance that makes such a length are tested for visibility."""
    inner, frame = env.internal, env.frame
    reach = 2.0 * lss_max * frame.scale * (1 + 1e-9)
    lo, hi = lss_min * frame.scale * (1 - 1e-9), lss_max * frame.scale * (1 + 1e-9)

    def wanted(d: np.ndarray) -> np.ndarray:  # d = m * value for m = 1 or 2
        return ((d >= lo) & (d <= hi)) | ((d >= 2 * lo) & (d <= 2 * hi))

    V = inner.vertices
    names = inner.vertex_map
    rows = []
    # vertex - vertex
    pts = shapely.points(V)
    i, j = shapely.STRtree(pts).query(pts, predicate="dwithin", distance=reach)
    keep = i < j
    i, j = i[keep], j[keep]
    d = np.hypot(*(V[i] - V[j]).T)
    keep = wanted(d)
    i, j, d = i[keep], j[keep], d[keep]
    seen = _sees(env, V[i], V[j])
    for a, b, dist in zip(i[seen].tolist(), j[seen].tolist(), d[seen].tolist(), strict=True):
        rows.append((f"V{names[a]}", f"V{names[b]}", dist))
    # vertex - edge: the foot of the free normal inside the edge
    A, B, tag_a, tag_b = inner.oriented_edges
    segs = shapely.linestrings(np.stack((A, B), axis=1))
    p, e = shapely.STRtree(segs).query(pts, predicate="dwithin", distance=reach)
    ok = (tag_a[e] != p) & (tag_b[e] != p)
    p, e = p[ok], e[ok]
    ab = B[e] - A[e]
    ll = np.einsum("ij,ij->i", ab, ab)
    t = np.einsum("ij,ij->i", V[p] - A[e], ab) / ll
    side = (ab[:, 0] * (V[p, 1] - A[e, 1]) - ab[:, 1] * (V[p, 0] - A[e, 0])) / np.sqrt(ll)
    ok = (t > 0) & (t < 1) & (side > 0) & wanted(side)  # free (left) side, foot inside
    p, e, t, side = p[ok], e[ok], t[ok], side[ok]
    foot = A[e] + t[:, None] * ab[ok]
    seen = _sees(env, V[p], foot)
    for a, b, dist in zip(p[seen].tolist(), e[seen].tolist(), side[seen].tolist(), strict=True):
        rows.append((f"V{names[a]}", f"E{names[b]}", dist))
    out = []
    for a, b, dist in rows:
        user = dist / frame.scale
        for m in (1, 2):
            if lss_min * (1 - 1e-9) <= user / m <= lss_max * (1 + 1e-9):
                out.append(DistanceEvent(user / m, a, b, user, m))
    return tuple(sorted(out, key=lambda ev: (ev.value, ev.a, ev.b, ev.multiple)))


def _sees(env: Environment, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whether the open segments ``p q`` (internal frame) lie in the free space (their ends
    pulled in by a relative ``1e-7``, so that ends on walls count)."""
    if len(p) == 0:
        return np.zeros(0, bool)
    d = q - p
    lines = shapely.linestrings(np.stack((p + 1e-7 * d, q - 1e-7 * d), axis=1))
    return np.asarray(shapely.covers(env.internal.polygon, lines), dtype=bool)


def near_critical(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL
                  ) -> tuple[tuple[DistanceEvent, ...], float, float]:
    """The critical length nearest ``lss`` if within ``NEAR_CRITICAL_TOLS`` curve tolerances:
    its distance events (those within ``ON_CRITICAL_TOLS`` point tolerances of it), the value,
    and the offset ``delta`` (map units) at which the lengths just below and above it are
    taken: ``SIDE_TOLS`` curve tolerances, or half the way to the next other event, at least
    ``MIN_SIDE_TOLS``. None near: ``((), nan, nan)``."""
    tol = rel_tol * env.diameter
    near, side = NEAR_CRITICAL_TOLS * tol, SIDE_TOLS * tol
    events = distance_events(env, lss + near + 2 * side, max(lss - near - 2 * side, 0.0))
    close = [ev for ev in events if abs(ev.value - lss) <= near]
    if not close:
        return (), math.nan, math.nan
    value = min(close, key=lambda ev: abs(ev.value - lss)).value
    same = ON_CRITICAL_TOLS * REL_LENGTH_TOL * env.diameter
    mine = tuple(ev for ev in events if abs(ev.value - value) <= same)
    others = [abs(ev.value - value) for ev in events if abs(ev.value - value) > same]
    delta = side if not others else max(MIN_SIDE_TOLS * tol, min(side, 0.5 * min(others)))
    return mine, value, delta


@dataclass(frozen=True)
class CriticalLss:
    """``lss`` lies within tether's resolution of the critical length ``value`` of the map
    (reached by the distance ``events``); the verdicts at ``value - delta`` (``below``) and
    ``value + delta`` (``above``) are given as dicts: ``lss``, ``strategy_exists``,
    ``counts``, ``verified``. ``on`` is the tolerance within which ``lss`` counts as the
    critical length itself (:attr:`side`)."""

    lss: float
    value: float
    delta: float
    on: float
    events: tuple[DistanceEvent, ...]
    below: dict
    above: dict

    @property
    def side(self) -> str:
        """``"on"`` the critical length (within ``on``: the decomposition at ``lss`` carries the
        exact coincidences), or ``"below"`` / ``"above"`` it (between the two, the arrangement
        is below tether's resolution: the verdict of that side is the one that holds)."""
        if abs(self.lss - self.value) <= self.on:
            return "on"
        return "below" if self.lss < self.value else "above"

    @property
    def same_verdict(self) -> bool:
        """Whether the verdicts below and above agree."""
        return self.below["strategy_exists"] == self.above["strategy_exists"]

    def to_dict(self) -> dict:
        """The critical length as JSON-ready values (lengths in map units)."""
        return {"lss": self.lss, "value": self.value, "side": self.side, "delta": self.delta,
                "events": [ev.to_dict() for ev in self.events],
                "below": self.below, "above": self.above}

    def describe(self) -> list[str]:
        """Plain sentences for the text output."""
        evs = "; ".join(ev.describe() for ev in self.events[:6])
        more = f" and {len(self.events) - 6} more" if len(self.events) > 6 else ""

        def word(v: dict) -> str:
            ok = "" if v["verified"] is not False else ", NOT verified"
            return (f"a strategy {'CAN exist' if v['strategy_exists'] else 'does NOT exist'} "
                    f"({v['counts']['regions']} regions{ok})")

        if self.side == "on":
            head = (f"lss {self.lss:g} is a critical length of this map: {evs}{more}. "
                    "The verdict above is for lss exactly.")
        else:
            head = (f"lss {self.lss:.12g} lies within tether's resolution just {self.side} "
                    f"the critical length {self.value:.12g} of this map ({evs}{more}): the "
                    f"verdict {self.side} it holds for lss {self.lss:.12g}.")
        return [head,
                f"  Just below, at lss {self.below['lss']:.12g} (- {self.delta:.3g}): "
                f"{word(self.below)}; just above, at lss {self.above['lss']:.12g}: "
                f"{word(self.above)}."]


def side_summary(verdict: Any) -> dict:
    """The short dict of a verdict kept in :class:`CriticalLss`."""
    return {"lss": verdict.dec.lss, "strategy_exists": verdict.strategy_exists,
            "counts": verdict.counts(), "verified": verdict.verified}


__all__ = ["CriticalLss", "DistanceEvent", "distance_events", "near_critical", "side_summary"]
