"""``L*`` on real escape points: the kernel's critical distance against the paper's ``L`` and
the safe ``L_g`` (issue #11, ``docs/formulas.md``, "Distance bounds"; ``docs/kernel.md``).

For an escape sample ``q`` of :func:`tether.analysis.escape_table` (a point just inside a
surviving cell, next to a piece the rod must not cross outside its goal), a rod orientation
``a`` in the cell's arc at ``q`` and not in the goal, and a heading ``ψ`` of a target running
straight at ``q``: the starts ``p(s) = q − s·(cos ψ, sin ψ)``, ``s ≥ 0``, carry the rod at ``a``.
The paper's distance bound ``L`` (the faster saturated rotation to the goal against that
straight dash, :func:`tether.bounds.distance_bound`) is necessary: closer than ``L`` the dash
wins. ``L_g = vt·Lss·Δ/(vo − vt)`` is sufficient for this one escape point. The kernel's ``L*``
(:meth:`~tether.game.kernel.Kernel.critical_distance`: walking from the far start toward ``q``,
the distance at which the state leaves the kernel) should satisfy ``L ≤ L* ≤ L_g``, up to the
grid (:func:`resolution`); ``L* > L_g`` can also be genuine: another threat (a wall, another
escape point) near the line, which ``L_g`` of this one point ignores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tether.analysis.escape_points import EscapeTable, l_safe
from tether.arcs import rod_is_free_many
from tether.bounds import distance_bound, thetas

__all__ = [
    "LStarCase", "concerning_orientations", "lstar_cases", "paper_bounds", "resolution",
    "summary"
]



@dataclass(frozen=True)
class LStarCase:
    """One escape point, orientation and heading: the three distances (map units)."""

    row: int  # row of the escape table
    piece: int  # piece index of the row
    q: tuple[float, float]
    a: float  # rod orientation, rad
    psi: float  # target heading toward q, rad
    sweep: float  # Δ to the goal, rad
    sense: int  # +1 CCW, -1 CW (of Δ)
    L: float
    L_g: float
    l_star: float | None  # None: the far start itself is outside the kernel
    length: float  # length of the line searched (from q)
    tol: float  # the grid's resolution on L* (see :func:`resolution`)

    @property
    def lower_ok(self) -> bool:
        """``L ≤ L*`` within ``tol``."""
        return self.l_star is None or self.l_star >= self.L - self.tol

    @property
    def upper_ok(self) -> bool:
        """``L* ≤ L_g`` within ``tol``."""
        return self.l_star is not None and self.l_star <= self.L_g + self.tol

    def to_dict(self) -> dict:
        """The row as JSON-ready values (map units, radians)."""
        return {"row": self.row, "piece": self.piece, "q": list(self.q), "a": self.a,
                "psi": self.psi, "sweep": self.sweep, "sense": self.sense, "L": self.L,
                "L_g": self.L_g, "l_star": self.l_star, "length": self.length, "tol": self.tol}


def resolution(kernel: Any) -> float:
    """How far ``L*`` may sit from the continuous answer because of the grid alone (map units):
    the look-up rounds a start to its lattice point (up to ``h/√2`` along the line) and its
    orientation to a bin (half a bin of sweep, worth ``L_g(δ/2)`` of distance), and the
    search along the line steps by at most ``h/4``; rounded up to ``h + L_g(δ/2)``. The inner
    scheme's conservative rounding of the observer's reachable bins (at most a bin per game
    step) is not in it: it may add up over the steps of a rotation."""
    g = kernel.grid
    return float(g.h + l_safe(g.delta / 2, kernel.vt, kernel.vo, kernel.lss))


def _sense_sweeps(table: EscapeTable, i: int, a: float) -> tuple[float, float, bool]:
    """Sweeps (rad) from ``a`` to the goal of row ``i`` counter-clockwise and clockwise within
    the cell's arc (``inf`` where the arc does not reach the goal that way), and whether ``a``
    concerns the row (in the cell's arc, not in the goal)."""
    ks, ke = float(table.k_start[i]), float(table.k_end[i])
    gs, ge = table.g_start[i], table.g_end[i]
    valid = np.isfinite(gs)
    gs, ge = gs[valid], ge[valid]
    klen = math.fmod(ke - ks + 2 * math.tau, math.tau) or math.tau
    in_k = (a - ks) % math.tau <= klen
    glen = np.mod(ge - gs, math.tau)
    glen = np.where(glen == 0.0, math.tau, glen)
    in_g = bool(np.any(np.mod(a - gs, math.tau) <= glen))
    ccw = np.mod(gs - a, math.tau)
    cw = np.mod(a - ge, math.tau)
    full = klen >= math.tau
    ccw = ccw[full | (ccw <= (ke - a) % math.tau)]
    cw = cw[full | (cw <= (a - ks) % math.tau)]
    return (float(ccw.min()) if len(ccw) else math.inf,
            float(cw.min()) if len(cw) else math.inf, bool(in_k and not in_g))


def paper_bounds(table: EscapeTable, i: int, a: float, psi: float, vt: float, vo: float
                 ) -> tuple[float, int, float, float] | None:
    """``(Δ, σ, L, L_g)`` for row ``i``, rod ``a`` and a target heading ``psi`` straight at the
    escape point; ``L`` is the faster of the two senses (each to its own nearest goal end),
    ``L_g`` that of the smaller sweep. ``None`` when ``a`` does not concern the row."""
    lss = table.verdict.dec.lss
    d_ccw, d_cw, concern = _sense_sweeps(table, i, a)
    if not concern or not math.isfinite(min(d_ccw, d_cw)):
        return None
    ls = []
    for sense, d in ((1, d_ccw), (-1, d_cw)):
        if math.isfinite(d):
            th0, thf = thetas(a, a + sense * d, psi, sense)
            ls.append(float(distance_bound(th0, thf, vt, vo, lss)))
    delta, sense = (d_ccw, 1) if d_ccw <= d_cw else (d_cw, -1)
    return delta, sense, min(ls), float(l_safe(delta, vt, vo, lss))


def concerning_orientations(table: EscapeTable, i: int,
                            fractions: tuple[float, ...] = (0.25, 0.5, 0.75),
                            samples: int = 360) -> list[float]:
    """Rod orientations (rad) at the fractions ``fractions`` of the orientations that concern
    row ``i`` (in the row's arc, not in the goal, and free at ``q`` itself; ``samples`` evenly
    over the row's arc, the ends left out).

    The row's arc is widened over the blocked gaps next to the cell (:func:`_widened`), and is
    the full circle when the cell's arc is the only one at ``q``; the rods inside the gaps are
    left out here: a case starts with the rod free at ``q``."""
    ks, ke = float(table.k_start[i]), float(table.k_end[i])
    klen = (ke - ks) % math.tau or math.tau
    cand = (ks + klen * (np.arange(1, samples) / samples)) % math.tau
    dec = table.verdict.dec
    q = np.asarray(table.q[i], float)
    free = rod_is_free_many(dec.env, np.repeat(q[None, :], len(cand), axis=0), cand, dec.lss)
    good = [float(a) for a, f in zip(cand, free, strict=True)
            if f and _sense_sweeps(table, i, float(a))[2]]
    if not good:
        return []
    return [good[min(len(good) - 1, int(f * len(good)))] for f in fractions]


def lstar_cases(kernel: Any, table: EscapeTable, rows: Any = None,
                fractions: tuple[float, ...] = (0.25, 0.5, 0.75), headings: int = 16,
                reach: float = 1.5, samples: int = 400) -> list[LStarCase]:
    """The cases of the module docstring for the piece rows ``rows`` of ``table`` (default:
    all piece rows) against ``kernel`` (same map and ``lss``).

    Orientations: :func:`concerning_orientations`. Headings: ``headings`` evenly spaced, kept
    where the whole line from ``q`` back to ``length = reach·L_g + 3·tol`` keeps the rod at
    ``a`` free (checked every ``h/4``), so that a state off the kernel on it is not just a
    collision. Per orientation, the heading with the largest paper ``L`` (the worst straight
    dash) among those kept.
    """
    env, lss = kernel.grid.env, kernel.lss
    vt, vo = kernel.vt, kernel.vo
    tol = resolution(kernel)
    if rows is None:
        rows = np.flatnonzero(table.piece >= 0)
    psis = np.arange(headings) * (math.tau / headings)
    out = []
    for i in rows:
        i = int(i)
        q = table.q[i]
        for a in concerning_orientations(table, i, fractions):
            best = None
            for psi in psis:
                pb = paper_bounds(table, i, a, float(psi), vt, vo)
                if pb is None:
                    break
                delta, sense, L, Lg = pb
                length = reach * Lg + 3 * tol
                n = max(2, int(math.ceil(length / (kernel.grid.h / 4))) + 1)
                s = np.linspace(0.0, length, n)
                pts = q[None, :] - s[:, None] * np.array([math.cos(psi), math.sin(psi)])
                ok = env.contains(pts[:, 0], pts[:, 1]).all() and rod_is_free_many(
                    env, pts, np.full(n, a), lss).all()
                if ok and (best is None or L > best[2]):
                    best = (float(psi), delta, L, Lg, sense, length, pts[-1])
            if best is None:
                continue
            psi, delta, L, Lg, sense, length, far = best
            cd = kernel.critical_distance(q, far, a, samples=samples)
            out.append(LStarCase(i, int(table.piece[i]), (float(q[0]), float(q[1])), float(a),
                                 psi, delta, sense, L, Lg, cd["l_star"], length, tol))
    return out


def summary(cases: list[LStarCase]) -> dict:
    """Counts: cases, ``L ≤ L*`` and ``L* ≤ L_g`` within the tolerance, far start outside."""
    return {"cases": len(cases),
            "lower_ok": sum(c.lower_ok for c in cases),
            "upper_ok": sum(c.upper_ok for c in cases),
            "start_outside": sum(c.l_star is None for c in cases)}
