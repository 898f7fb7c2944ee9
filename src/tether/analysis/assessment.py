"""Start assessment: whether the start ``(x, y, a)`` is safe against target speed ``vt`` and
observer speed ``vo`` (``docs/strategy.md``).

``safe`` iff the rod is free, its cell survives the elimination, every concerning escape point
(:mod:`tether.analysis.escape_points`) has a non-negative margin ``|p − q| − L_g``
(straight-line distance: a lower bound on the target's path; the paper's ``L`` is reported
beside it), and no two reachable escape points conflict (Prop. 3 as a check: opposite senses
and neither order of the two sweeps finishes in time). Lengths in map units, angles in
radians, times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tether.analysis.elimination import Verdict
from tether.analysis.escape_points import (
    WALL_CODE,
    EscapeTable,
    escape_table_of,
    l_paper,
    l_safe,
    row_name,
    wall_contact_points,
)
from tether.arcs import rod_is_free
from tether.bounds import check_speeds

__all__ = ["Assessment", "EscapePoint", "assess", "critical_distance_field", "is_safe"]


@dataclass(frozen=True)
class EscapePoint:
    """An escape point within reach of a start: where, whose, the sweep and the distances."""

    kind: str  # "piece" or "vertex"
    point: tuple[float, float]
    cell: str | None
    piece: str | None
    distance: float  # |p − q|
    sweep: float  # Δ, rad
    sense: int  # +1 CCW, −1 CW, 0 for a vertex
    L: float  # paper's straight-dash bound
    L_g: float  # safe bound
    margin: float  # |p − q| − L_g
    goal: tuple[tuple[float, float], ...] = ()  # CCW arcs (start, end), rad; (0, 0) = all

    def to_dict(self) -> dict:
        """The escape point as JSON-ready values (map units, radians)."""
        return {"kind": self.kind, "point": list(self.point), "cell": self.cell,
                "piece": self.piece, "distance": self.distance, "sweep": self.sweep,
                "sense": self.sense, "L": self.L, "L_g": self.L_g, "margin": self.margin,
                "goal": [list(g) for g in self.goal]}


@dataclass(frozen=True)
class Assessment:
    """The analysis of a start ``(x, y, a)`` (see the module docstring).

    Examples
    --------
    Each escape point in reach lies farther (map units) than its safe bound ``L_g``:

    >>> from tether import Environment
    >>> from tether.analysis import analyze, assess
    >>> from tether.decomposition import decompose
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> start = assess(analyze(decompose(ell, 0.5)), vt=0.3, vo=1.0, x=1.0, y=1.0, a=0.0)
    >>> [(e.kind, round(e.distance, 3), round(e.L_g, 3)) for e in start.escape_points]
    [('vertex', 1.414, 0.303), ('wall', 1.118, 0.065)]
    """

    start: tuple[float, float, float]
    lss: float
    vt: float
    vo: float
    rod_free: bool
    cell: str | None
    survives: bool
    strategy_exists: bool
    escape_points: tuple[EscapePoint, ...]
    conflicts: tuple[tuple[int, int], ...]
    safe: bool
    reasons: tuple[str, ...]

    def to_dict(self) -> dict:
        """The assessment as JSON-ready values (the ``tether assess --json`` fields)."""
        return {"start": list(self.start), "lss": self.lss, "vt": self.vt, "vo": self.vo,
                "safe": self.safe, "cell": self.cell, "survives": self.survives,
                "rod_free": self.rod_free, "strategy_exists": self.strategy_exists,
                "reasons": list(self.reasons),
                "escape_points": [e.to_dict() for e in self.escape_points],
                "conflicts": [list(c) for c in self.conflicts]}


def _reach(vt: float, vo: float, lss: float) -> float:
    """Largest ``L_g`` any sweep can need (a half turn each way is at most 2π)."""
    return float(l_safe(math.tau, vt, vo, lss))


def assess(verdict: Verdict, vt: float, vo: float, x: float, y: float, a: float) -> Assessment:
    """Analyse the start ``(x, y, a)`` against speeds ``vt < vo`` (see the module docstring).

    Raises
    ------
    InvalidParameterError
        ``vo <= vt`` or non-positive speeds.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.analysis import analyze, assess
    >>> from tether.decomposition import decompose
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> verdict = analyze(decompose(ell, 0.5))
    >>> start = assess(verdict, vt=0.3, vo=1.0, x=1.0, y=1.0, a=0.0)
    >>> start.safe, start.cell
    (True, '(R5,*,*)')
    """
    dec = verdict.dec
    vt, vo, lss = check_speeds(vt, vo, dec.lss)
    env = dec.env
    p = np.array([x, y], float)
    reasons: list[str] = []
    free = bool(env.contains(x, y)) and rod_is_free(env, p, a, lss)
    cell = dec.cell_at(p, a)[0] if free else None
    survives = cell is not None and cell in verdict.surviving
    if not free:
        reasons.append(f"the rod from ({x:g}, {y:g}) at a={a:g} is not free")
    elif not verdict.strategy_exists:
        reasons.append("no cell survives the elimination: no strategy exists on this map "
                       "(Prop. 1); " + (verdict.story()[0] if verdict.story() else ""))
    elif cell is None:
        reasons.append("the target is on a region boundary (a critical curve): the cell is "
                       "undefined there")
    elif not survives:
        reasons.append(f"the rod is in cell {cell}, which the elimination removes: the target "
                       "can force a loss whatever the observer does (Prop. 1)")
    points: list[EscapePoint] = []
    pairs: list[tuple[int, int]] = []
    if free and verdict.strategy_exists:
        table = escape_table_of(verdict, vt / vo)
        points = _escape_points(table, p, a, vt, vo, lss, _arc_at(env, p, a, lss))
        for e in points:
            if e.margin < 0:
                where = (f"on {e.piece} of {e.cell}" if e.kind == "piece"
                         else f"at reflex vertex {e.piece} (plus the no-pivot radius "
                              f"{lss * vt / (vo + vt):.3g})" if e.kind == "vertex"
                         else f"where the rod would meet wall {e.piece} too steeply to slide")
                reasons.append(
                    f"escape point ({e.point[0]:.3g}, {e.point[1]:.3g}) {where} is "
                    f"{e.distance:.3g} away, closer than L_g = {e.L_g:.3g} (a "
                    f"{math.degrees(e.sweep):.0f}° {'CCW' if e.sense > 0 else 'CW'} sweep): "
                    "the target gets there before the rotation finishes")
                break
        pairs = conflicts(points, vt, vo, lss, a, _arc_at(env, p, a, lss))
        for i, j in pairs[:1]:
            reasons.append(
                f"escape points {i} and {j} need opposite sweeps and neither order finishes "
                "before the target reaches the other (Prop. 3)")
    safe = free and survives and not reasons
    if safe:
        reasons.append(f"the rod is in surviving cell {cell} and every escape point in reach "
                       "is farther than its L_g")
    return Assessment((float(x), float(y), float(a)), lss, vt, vo, free, cell, survives,
                      verdict.strategy_exists, tuple(points), tuple(pairs), safe,
                      tuple(reasons))


def _arc_at(env: Any, p: np.ndarray, a: float, lss: float) -> tuple[float, float] | None:
    """The free arc holding rod ``a`` at ``p`` (``None`` when FULL)."""
    from tether.arcs import free_arcs

    fa = free_arcs(env, p, lss)
    for arc in fa.arcs:
        if arc.contains(a):
            return (arc.start, arc.end)
    return None


def escape_rows(table: EscapeTable, p: np.ndarray, a: float, vt: float, vo: float,
                 lss: float, arc: tuple[float, float] | None = None) -> tuple[list[int], tuple]:
    """The rows of the concerning escape samples within reach, one per piece or vertex (the
    tightest), sorted by margin; and ``(Δ, σ, margin, points, distances)`` of every row
    (margin ``inf`` where the row does not concern the rod)."""
    concern, delta, sense, margin = table.margins(p, a, vt, vo, arc)
    qs = table.points_for(p, a)
    dist = np.hypot(*(qs - p).T)
    reach = _reach(vt, vo, lss) + lss
    best: dict[int, int] = {}
    for i in np.flatnonzero(concern & (dist <= reach)):
        k = int(table.piece[i])
        if k not in best or margin[i] < margin[best[k]]:
            best[k] = int(i)
    return sorted(best.values(), key=lambda i: margin[i]), (delta, sense, margin, qs, dist)


def escape_point(table: EscapeTable, i: int, values: tuple, vt: float, vo: float,
                  lss: float) -> EscapePoint:
    """Row ``i`` as an :class:`EscapePoint` (``values`` from :func:`escape_rows`)."""
    delta, sense, margin, qs, dist = values
    vertex = bool(table.piece[i] < 0)
    kind = "vertex" if table.is_vertex[i] else "wall" if table.is_wall[i] else "piece"
    return EscapePoint(kind, (float(qs[i, 0]), float(qs[i, 1])),
                       None if vertex else table.cell[i], row_name(int(table.piece[i])),
                       float(dist[i]), float(delta[i]), int(sense[i]),
                       float(l_paper(delta[i], vt, vo, lss)),
                       float(l_safe(delta[i], vt, vo, lss)), float(margin[i]),
                       tuple((float(g0), float(g1)) for g0, g1
                             in zip(table.g_start[i], table.g_end[i], strict=True)
                             if np.isfinite(g0)))


def _escape_points(table: EscapeTable, p: np.ndarray, a: float, vt: float, vo: float,
                   lss: float, arc: tuple[float, float] | None = None) -> list[EscapePoint]:
    """The concerning escape samples within reach, one per piece or vertex (the tightest),
    sorted by margin."""
    if not len(table):
        return []
    rows, values = escape_rows(table, p, a, vt, vo, lss, arc)
    return [escape_point(table, i, values, vt, vo, lss) for i in rows]


#: Directions sampled to find the orientations two goals share (0.25°).
_GRID = (np.arange(1440) + 0.5) * (math.tau / 1440)


def _in_arcs(arcs: tuple[tuple[float, float], ...], ang: np.ndarray) -> np.ndarray:
    """Whether each angle lies in one of the CCW arcs (``(s, s)``: the full circle)."""
    out = np.zeros(len(ang), dtype=bool)
    for s, e in arcs:
        width = (e - s) % math.tau or math.tau
        out |= np.mod(ang - s, math.tau) <= width
    return out


def _grid_sweeps(a: float, arc: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """Sweeps (rad) from ``a`` to every ``_GRID`` direction: inside the free ``arc`` (``inf``
    where the arc stops it; either sense when ``arc`` is ``None``) and unconstrained."""
    ccw = np.mod(_GRID - a, math.tau)
    cw = np.mod(a - _GRID, math.tau)
    anyway = np.minimum(ccw, cw)
    if arc is None:
        return anyway, anyway
    inside = np.minimum(np.where(ccw <= np.mod(arc[1] - a, math.tau), ccw, np.inf),
                        np.where(cw <= np.mod(a - arc[0], math.tau), cw, np.inf))
    return inside, anyway


def _common_sweep(a: float, gi: tuple, gj: tuple, arc: tuple[float, float] | None,
                  masks: tuple[np.ndarray, np.ndarray] | None = None,
                  grid_sweeps: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """Smallest sweep (rad, either sense, inside the free ``arc`` when it allows) from ``a``
    into an orientation both goals hold; ``inf`` when there is none. Rounded up by one grid
    step. ``masks`` (the goals' :func:`_in_arcs` over ``_GRID``) and ``grid_sweeps``
    (:func:`_grid_sweeps`): when already at hand."""
    mi, mj = masks if masks is not None else (_in_arcs(gi, _GRID), _in_arcs(gj, _GRID))
    both = mi & mj
    if not both.any():
        return math.inf
    inside, anyway = grid_sweeps if grid_sweeps is not None else _grid_sweeps(a, arc)
    best = float(inside[both].min())
    if not math.isfinite(best):
        # none reachable inside the arc now: the arc opens as the target moves (as in
        # :func:`sweeps`), so count the unconstrained sweep
        best = float(anyway[both].min())
    return best + math.tau / len(_GRID)


def conflicts(points: list[EscapePoint], vt: float, vo: float, lss: float,
               a: float | None = None, arc: tuple[float, float] | None = None
               ) -> list[tuple[int, int]]:
    """Pairs of escape points (indices into ``points``) that conflict (Prop. 3): they need
    opposite sweeps and no schedule serves both in time: neither order (serve one, then sweep
    back through it to the other) nor one sweep into an orientation both goals share
    finishes before the target can reach the escape point concerned. Every kind counts
    (pieces, reflex vertices, steep walls: all are escape points, erratum 12), each with its
    extra distance (the no-pivot radius at a vertex)."""
    out = []
    room = [e.distance - e.L_g - e.margin for e in points]  # the row's offset

    def lg(delta: float) -> float:  # :func:`l_safe` in scalar arithmetic
        return vt * lss * abs(delta) / (vo - vt)

    masks: dict[int, np.ndarray] = {}  # goal masks over _GRID, made once per point
    grid = None  # sweeps from ``a`` over _GRID, made once

    def mask(k: int) -> np.ndarray:
        if k not in masks:
            masks[k] = _in_arcs(points[k].goal, _GRID)
        return masks[k]

    for i, ei in enumerate(points):
        for j in range(i + 1, len(points)):
            ej = points[j]
            if ei.sense == ej.sense:
                continue
            di, dj = ei.distance - room[i], ej.distance - room[j]
            # i first then back to j: the sweep to j grows by twice Δ_i, and vice versa
            if dj >= lg(2 * ei.sweep + ej.sweep) or di >= lg(2 * ej.sweep + ei.sweep):
                continue
            if a is not None and ei.goal and ej.goal:
                if grid is None:
                    grid = _grid_sweeps(a, arc)
                both = _common_sweep(a, ei.goal, ej.goal, arc, (mask(i), mask(j)), grid)
                if min(di, dj) >= lg(both):
                    continue
            out.append((i, j))
    return out


def is_safe(verdict: Verdict, vt: float, vo: float, points: Any, angles: Any) -> np.ndarray:
    """Vectorized safe/unsafe over many starts ``(x, y, a)`` (points (m, 2), angles (m,)):
    the rod in a surviving cell and no concerning escape sample closer than its ``L_g``
    (the Prop. 3 check is left to :func:`assess`)."""
    dec = verdict.dec
    vt, vo, lss = check_speeds(vt, vo, dec.lss)
    pts = np.asarray(points, float).reshape(-1, 2)
    ang = np.broadcast_to(np.asarray(angles, float), (len(pts),))
    cells = dec.cell_at(pts, ang)
    ok = np.array([c is not None and c in verdict.surviving for c in cells], dtype=bool)
    if not verdict.strategy_exists or not ok.any():
        return ok
    table = escape_table_of(verdict, vt / vo)
    if not len(table):
        return ok
    for i in np.flatnonzero(ok):
        arc = _arc_at(dec.env, pts[i], float(ang[i]), lss)
        _, _, _, margin = table.margins(pts[i], float(ang[i]), vt, vo, arc)
        if np.any(margin < 0):
            ok[i] = False
    return ok


def critical_distance_field(verdict: Verdict, vt: float, vo: float, a: float, xs: np.ndarray,
                            ys: np.ndarray, paper: bool = False) -> np.ndarray:
    """``min_q (|p − q| − L_g(Δ_q))`` over a grid (for the second set of critical curves: its
    zero level is the locus of target positions at ``L_g`` from the escape points concerning
    orientation ``a``; with ``paper`` the paper's ``L`` instead)."""
    table = escape_table_of(verdict, vt / vo)
    X, Y = np.meshgrid(xs, ys)
    out = np.full(X.shape, np.inf)
    if not len(table):
        return out
    concern, delta, _ = table.sweeps(a)
    q = table.q[concern]
    if not len(q):
        return out
    lss = verdict.dec.lss
    bound = (l_paper(delta[concern], vt, vo, lss) if paper
             else l_safe(delta[concern], vt, vo, lss)) + table.offsets(vt, vo)[concern]
    wall = table.is_wall[concern]
    grid = np.column_stack((X.ravel(), Y.ravel()))
    for qi, bi in zip(q[~wall], bound[~wall], strict=True):
        out = np.minimum(out, np.hypot(X - qi[0], Y - qi[1]) - bi)
    if wall.any():  # distance to the translated wall (see EscapeTable.points_for)
        edges = WALL_CODE - table.piece[concern][wall]
        near = wall_contact_points(verdict.dec.env, edges, lss, grid, a)
        d = np.hypot(near[..., 0] - grid[:, 0], near[..., 1] - grid[:, 1]) - bound[wall][:, None]
        out = np.minimum(out, d.min(axis=0).reshape(X.shape))
    return out
