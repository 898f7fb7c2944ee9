"""The kernel controller: each step, the rate in Ω that keeps the next state deepest in the kernel.

It follows the :class:`~tether.sim.protocols.Controller` protocol. The look-ahead is one step of
the kernel's game (the time ``h/vt`` the target needs to cross a cell), not the simulator's
step: with a fine simulator step every candidate would land on almost the same state. The
depth is the kernel's signed Euclidean depth (:attr:`tether.game.kernel.Kernel.depth`), so the
controller also moves away from the kernel's boundary in position, not only in orientation.
Candidates whose rod would not be free at the end of the simulator's step (exact test,
:func:`tether.arcs.rod_is_free_many`) are discarded.
"""

from __future__ import annotations

import math
import weakref
from typing import Any

import numpy as np

from tether.arcs import rod_is_free_many
from tether.game.certificate import FULL
from tether.rates import observer_velocity, step_rate_interval
from tether.sim.protocols import Command, Mode, World

__all__ = ["CertifiedController", "FieldArcs", "KernelController",
           "certified_of", "kernel_of", "landing_many", "rate_interval_one"]

_TAU = math.tau


def kernel_of(world: World) -> Any:
    """``world.extra["kernel"]``, computed and stored there when missing: on a coarse grid
    (1/50 of the map's size, 90 orientations, about a second); compute a finer one with
    :func:`~tether.game.kernel.surveillance_kernel` and put it in ``world.extra`` for real
    use."""
    k = world.extra.get("kernel")
    if k is None:
        from tether.game.kernel import surveillance_kernel

        x0, y0, x1, y1 = world.env.bounds
        k = surveillance_kernel(world.env, world.lss, world.vt, world.vo,
                                h=max(x1 - x0, y1 - y0) / 50, orientations=90)
        world.extra["kernel"] = k
    return k


class KernelController:
    """Choose ``ȧ ∈ Ω(v, a)`` maximizing the kernel depth of the state one game step ahead.

    Parameters
    ----------
    kernel : Kernel, optional
        The kernel to follow; by default ``world.extra["kernel"]`` at :meth:`reset` (computed
        and stored there if missing, see :func:`kernel_of`).
    candidates : int
        Number of rates sampled evenly in ``Ω`` (plus 0 and the follow law, its midpoint).
        ``Ω`` is the exact interval of the simulator's step (its chord stays within ``vo·dt``,
        :func:`tether.rates.step_rate_interval`).
    """

    name = "kernel"

    def __init__(self, kernel: Any = None, candidates: int = 33) -> None:
        self.kernel = kernel
        self.candidates = int(candidates)
        self.world: World | None = None

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        """Start a run: take the kernel of ``world`` (computed if none was given)."""
        self.world = world
        if self.kernel is None:
            self.kernel = kernel_of(world)

    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        """The rod rate keeping the next state deepest in the kernel, for target velocity ``v``."""
        k = self.kernel
        world = self.world
        lss, vo = world.lss, world.vo
        p = np.asarray(p, dtype=float)
        v = np.asarray(v, dtype=float)
        lo, hi = (float(x) for x in step_rate_interval(v, a, lss, vo, dt))
        lo, hi = max(lo, -np.pi / dt), min(hi, np.pi / dt)
        rates = np.unique(np.r_[np.linspace(lo, hi, self.candidates), 0.0, (lo + hi) / 2])
        rates = rates[(rates >= lo) & (rates <= hi)]
        nxt = p + v * dt
        free = rod_is_free_many(world.env, np.repeat(nxt[None, :], len(rates), axis=0),
                                a + rates * dt, lss)
        if not free.any():
            return Command(float("nan"), np.full(2, np.nan), Mode.KERNEL, feasible=False,
                           reason="no admissible rate keeps the rod free")
        rates = rates[free]
        tau = k.grid.h / k.vt
        ahead = np.repeat((p + v * tau)[None, :], len(rates), axis=0)
        score = k.depth_at(ahead, a + rates * tau) - 1e-9 * np.abs(rates - (lo + hi) / 2)
        rate = float(rates[int(np.argmax(score))])
        return Command(rate, observer_velocity(v, a, rate, lss), Mode.KERNEL)


def certified_of(world: World) -> Any:
    """``world.extra["certified"]``, computed and stored there when missing
    (:func:`~tether.game.certified.certified_kernel` at its default spacing, 1/40 of the map's
    size: seconds on a room, minutes on a large map), for the sensing delay
    ``world.extra["delay"]`` (seconds, default 0)."""
    ck = world.extra.get("certified")
    if ck is None:
        from tether.game.certified import certified_kernel

        ck = certified_kernel(world.env, world.lss, world.vt, world.vo,
                              delay=world.extra.get("delay", 0.0))
        world.extra["certified"] = ck
    return ck


class CertifiedController:
    """Keep the state in the certified kernel's arc field
    (:class:`~tether.game.certified.CertifiedKernel`).

    Each step, the orientation at the end of the step is chosen among those the observer can
    reach (the exact interval of the step's chord, :func:`tether.rates.step_rate_interval`)
    that lie in the field's arc at the target's next position, as near as possible to the
    state's relative place in the arc (``s = (a − lo)/(hi − lo)``; where the arc is the whole
    circle, as near as possible to ``a``). From a state of a certified field such an
    orientation always exists (``docs/certified.md``, "The argument", (A6): a continuous
    trajectory that stays in the field has a chord of at most ``vo·dt``), so the state is in
    the field, and the rod free, at every step. A state outside the field (or a field that is
    not certified) gets the reachable orientation nearest to the arc, and no promise.

    Parameters
    ----------
    certified : CertifiedKernel, optional
        The field to follow; by default ``world.extra["certified"]`` at :meth:`reset`
        (computed and stored there if missing, see :func:`certified_of`).
    """

    name = "certified"

    def __init__(self, certified: Any = None) -> None:
        self.certified = certified
        self.world: World | None = None

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        """Start a run: take the certified kernel of ``world`` (computed if none was given)."""
        self.world = world
        if self.certified is None:
            self.certified = certified_of(world)
        self._field = None

    @property
    def field(self) -> FieldArcs:
        """The field's arcs with their per-triangle data cached (built at first use)."""
        f = getattr(self, "_field", None)
        if f is None or f.certified is not self.certified:
            f = self._field = FieldArcs.of(self.certified)
        return f

    def step_many(self, p: Any, v: Any, a: Any, dt: float) -> np.ndarray:
        """The rod rates (rad/s) of :meth:`step` for many states at once: target positions
        ``p`` (n, 2) and velocities ``v`` (n, 2) (map units, map units/s), rod orientations
        ``a`` (n,) (radians), one step of ``dt`` s. Row ``i`` is the rate ``step(p[i], v[i],
        a[i], dt)`` gives, to the last bit (the same operations, elementwise); the controller
        keeps no state between steps, so the rows are independent. This controller always
        has a rate (it never gives up), so no entry is NaN.
        """
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        v = np.asarray(v, dtype=float).reshape(-1, 2)
        a = np.asarray(a, dtype=float).reshape(-1)
        n = len(p)
        lo, hi, ok = self.certified.arcs(np.concatenate([p, p + v * dt]))
        return self._rates(v, a, dt, (lo[:n], hi[:n], ok[:n]), (lo[n:], hi[n:], ok[n:]))

    def rollout(self, p: Any, v: Any, a: Any, dt: float) -> np.ndarray:
        """The rod orientations (radians, (m, n + 1)) along ``m`` known target paths: starts
        ``p`` (m, 2) (map units) and ``a`` (m,), velocities ``v`` (m, n, 2) (map units/s),
        one per step of ``dt`` s. Row ``i`` is what ``n`` calls of :meth:`step` give, to the
        last bit: ``p ← p + v[i, k]·dt``, ``a ← a + rate·dt``. The target's positions do not
        depend on the rates, so the arcs at all of them are found in one call."""
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        v = np.asarray(v, dtype=float)
        m, n = v.shape[:2]
        P = np.empty((m, n + 1, 2))
        P[:, 0] = p
        for k in range(n):
            P[:, k + 1] = P[:, k] + v[:, k] * dt
        lo, hi, ok = (x.reshape(m, n + 1) for x in self.certified.arcs(P.reshape(-1, 2)))
        A = np.empty((m, n + 1))
        A[:, 0] = np.asarray(a, dtype=float).reshape(-1)
        for k in range(n):
            rate = self._rates(v[:, k], A[:, k], dt, (lo[:, k], hi[:, k], ok[:, k]),
                               (lo[:, k + 1], hi[:, k + 1], ok[:, k + 1]))
            A[:, k + 1] = A[:, k] + rate * dt
        return A

    def _rates(self, v: np.ndarray, a: np.ndarray, dt: float, now: tuple, nxt: tuple
               ) -> np.ndarray:
        """The rates of :meth:`step_many` from the arcs ``(lo, hi, ok)`` at the targets now
        and after the step."""
        world = self.world
        r_lo, r_hi = step_rate_interval(v, a, world.lss, world.vo, dt)
        r_lo, r_hi = np.maximum(r_lo, -np.pi / dt), np.minimum(r_hi, np.pi / dt)
        (lo0, hi0, ok0), (lo1, hi1, ok1) = now, nxt
        width, w0 = hi1 - lo1, hi0 - lo0
        rel = ok0 & (w0 < FULL)  # the state's relative place in its arc (an end if outside)
        with np.errstate(invalid="ignore"):
            x = np.mod(a - lo0, _TAU)
            s = np.where(x <= w0, x / np.where(rel, w0, 1.0),
                         np.where(_TAU - x < x - w0, 0.0, 1.0))
        aim = np.where(rel & ok1, lo1 + s * width, a)
        end = landing_many(a, a + r_lo * dt, a + r_hi * dt, np.where(ok1, lo1, 0.0),
                           np.where(ok1, width, 0.0), aim)
        off = np.minimum(np.maximum(0.0, r_lo), r_hi)  # the target leaves the free space
        return np.where(ok1, (end - a) / dt, off)

    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        """The rod rate that lands the next state in the field, for target velocity ``v``.

        Plain floats throughout (one state: no arrays to build), with numpy's own functions
        for the transcendental ones, so the rate equals :meth:`step_many`'s to the last bit.
        """
        px, py, vx, vy, a = float(p[0]), float(p[1]), float(v[0]), float(v[1]), float(a)
        rate = self._rate_one(px, py, vx, vy, a, dt)
        r = self.world.lss * rate
        velocity = np.array([vx - r * float(np.sin(a)), vy + r * float(np.cos(a))])
        return Command(rate, velocity, Mode.CERTIFIED)

    def _rate_one(self, px: float, py: float, vx: float, vy: float, a: float, dt: float
                  ) -> float:
        """The rate of :meth:`step` (rad/s) from plain floats."""
        world = self.world
        r_lo, r_hi = rate_interval_one(vx, vy, a, world.lss, world.vo, dt)
        r_lo, r_hi = max(r_lo, -np.pi / dt), min(r_hi, np.pi / dt)
        field = self.field
        ok1, lo1, hi1 = field.arc_one(px + vx * dt, py + vy * dt)
        if not ok1:  # the target leaves the free space: nothing to aim at
            return min(max(0.0, r_lo), r_hi)
        width = hi1 - lo1
        ok0, lo0, hi0 = field.arc_one(px, py)
        w0 = hi0 - lo0
        if ok0 and w0 < FULL:  # the state's relative place in its arc (an end if outside)
            x = (a - lo0) % _TAU
            s = x / w0 if x <= w0 else (0.0 if _TAU - x < x - w0 else 1.0)
            aim = lo1 + s * width
        else:
            aim = a
        end = _landing(a, a + r_lo * dt, a + r_hi * dt, lo1, width, aim)
        return (end - a) / dt


def _landing(a: float, lo_reach: float, hi_reach: float, lo: float, width: float,
             aim: float) -> float:
    """The orientation in ``[lo_reach, hi_reach]`` (reachable, lifted around ``a``) nearest to
    ``aim`` among those in the arc ``[lo, lo + width]`` (any lift); if the two do not meet,
    the reachable orientation nearest to the arc."""
    if width >= FULL:
        return min(max(a, lo_reach), hi_reach)
    base = lo + math.tau * math.floor((lo_reach - lo) / math.tau)  # the lift at or below
    best, best_d = None, math.inf
    gap_best, gap_d = lo_reach, math.inf
    for k in (-1, 0, 1, 2):
        a0 = base + k * math.tau
        a1 = a0 + width
        t = aim + math.tau * round((a0 + width / 2 - aim) / math.tau)  # aim lifted to this arc
        x0, x1 = max(a0, lo_reach), min(a1, hi_reach)
        if x0 <= x1:
            c = min(max(t, x0), x1)
            d = abs(c - t)
            if d < best_d:
                best, best_d = c, d
        else:  # apart: the reachable end nearest to this lift of the arc
            for c, d in ((hi_reach, a0 - hi_reach), (lo_reach, lo_reach - a1)):
                if 0 <= d < gap_d:
                    gap_best, gap_d = c, d
    return best if best is not None else gap_best


def landing_many(a: np.ndarray, lo_reach: np.ndarray, hi_reach: np.ndarray, lo: np.ndarray,
                 width: np.ndarray, aim: np.ndarray) -> np.ndarray:
    """:func:`_landing` for arrays (radians, shape (n,)): the same candidates, and the first
    of the nearest in the scalar function's order (its strict comparisons keep the first),
    so each entry equals the scalar function's to the last bit."""
    a, lo_reach, hi_reach, lo, width, aim = (np.asarray(x, dtype=float).reshape(-1) for x in
                                             (a, lo_reach, hi_reach, lo, width, aim))
    base = lo + _TAU * np.floor((lo_reach - lo) / _TAU)  # the lift at or below
    a0 = base[:, None] + _LIFTS * _TAU  # (n, 4): the lifts k = -1, 0, 1, 2
    a1 = a0 + width[:, None]
    t = aim[:, None] + _TAU * np.round((a0 + (width / 2)[:, None] - aim[:, None]) / _TAU)
    x0, x1 = np.maximum(a0, lo_reach[:, None]), np.minimum(a1, hi_reach[:, None])
    meet = x0 <= x1
    c = np.minimum(np.maximum(t, x0), x1)
    d = np.where(meet, np.abs(c - t), np.inf)
    rows = np.arange(len(a))
    k = np.argmin(d, axis=1)  # the first of the nearest
    found = d[rows, k] < np.inf
    # apart: the reachable end nearest to each lift, in the order (hi end, lo end) per lift
    gd = np.stack([a0 - hi_reach[:, None], lo_reach[:, None] - a1], axis=2).reshape(-1, 8)
    gd = np.where(np.repeat(~meet, 2, axis=1) & (gd >= 0), gd, np.inf)
    g = np.argmin(gd, axis=1)
    gap = np.where(gd[rows, g] < np.inf, np.where(g % 2 == 0, hi_reach, lo_reach), lo_reach)
    out = np.where(found, c[rows, k], gap)
    return np.where(width >= FULL, np.minimum(np.maximum(a, lo_reach), hi_reach), out)


_LIFTS = np.array([-1.0, 0.0, 1.0, 2.0])


def rate_interval_one(vx: float, vy: float, a: float, lss: float, vo: float, dt: float
                      ) -> tuple[float, float]:
    """:func:`tether.rates.step_rate_interval` for one state, in plain floats (rad/s): the
    same operations, numpy's functions for ``cos``, ``sin``, ``hypot``, ``arcsin``,
    ``arctan2`` (so the bounds are the vectorized ones to the last bit)."""
    c, s = float(np.cos(a)), float(np.sin(a))
    vr = (vx * c + vy * s) * dt  # radial and tangential travel over the step
    vs = (-vx * s + vy * c) * dt
    wn = float(np.hypot(lss - vr, vs))
    w_minus_l = (vr * vr + vs * vs - 2.0 * lss * vr) / (wn + lss)
    num, den = (vo * dt) ** 2 - w_minus_l * w_minus_l, 4.0 * lss * wn
    with np.errstate(divide="ignore", invalid="ignore"):
        half = num / den if den != 0.0 else float(np.float64(num) / np.float64(den))
    beta = 2.0 * float(np.arcsin(np.sqrt(min(max(half, 0.0), 1.0))))
    delta = float(np.arctan2(vs, lss - vr))
    if half >= 1.0:
        return -np.pi / dt, np.pi / dt
    return min(-beta - delta, 0.0) / dt, max(beta - delta, 0.0) / dt


#: Relative error bound of a float orientation determinant (Shewchuk's ``ccwerrboundA`` is
#: about 3.3e-16 of the sum of the two products' magnitudes): signs beyond 30 times it are sure.
_ORIENT_TOL = 1e-14

_FIELDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class FieldArcs:
    """The arcs of a certified field at one point at a time, in plain floats
    (:meth:`arc_one`): the kernel's own values
    (:meth:`~tether.game.certified.CertifiedKernel.arcs`) to the last bit (the same triangle,
    the same operations), with each triangle's corners and lifted ends
    (:meth:`~tether.game.certified.CertifiedKernel.triangle_ends`) kept as Python floats and
    a bucket grid to find the triangle; a simulation asks for them every step.

    Parameters
    ----------
    certified : CertifiedKernel
    """

    def __init__(self, certified: Any) -> None:
        f = self.field = certified.field
        self.certified = certified
        self.L, self.H, self.whole = certified.triangle_ends()
        self.xy = f.points[f.tri]  # (m, 3, 2), the field's frame
        self._origin = tuple(float(x) for x in certified.frame.origin)
        self._scale = float(certified.frame.scale)
        self._rows = [(*map(float, xy.ravel()), *map(float, lo), *map(float, hi), bool(w))
                      for xy, lo, hi, w in zip(self.xy, self.L, self.H, self.whole,
                                               strict=True)]
        e1, e2 = self.xy[:, 1] - self.xy[:, 0], self.xy[:, 2] - self.xy[:, 0]
        p1, p2 = e1[:, 0] * e2[:, 1], e1[:, 1] * e2[:, 0]
        turn = p1 - p2
        sure = np.abs(turn) > _ORIENT_TOL * (np.abs(p1) + np.abs(p2))
        # the sign that makes each triangle counter-clockwise; 0 (never sure) where flat
        self._sign = np.where(sure, np.sign(turn), 0.0).tolist()
        self._grid()

    @classmethod
    def of(cls, certified: Any) -> FieldArcs:
        """The one :class:`FieldArcs` of a field (kept while the field lives; built again
        if its ``field`` was replaced)."""
        f = _FIELDS.get(certified)
        if f is None or f.field is not certified.field:
            f = _FIELDS[certified] = cls(certified)
        return f

    def _grid(self) -> None:
        """A bucket grid over the mesh: each cell lists (in ascending order) the triangles
        whose bounding box meets it, so a point's cell holds every triangle that may hold
        the point."""
        lo, hi = self.xy.min(axis=1), self.xy.max(axis=1)
        x0 = lo.min(axis=0)
        span = np.maximum(hi.max(axis=0) - x0, 1e-12)
        cell = max(float(np.sqrt(span[0] * span[1] / max(len(lo), 1))), 1e-12)
        shape = np.maximum(np.ceil(span / cell).astype(int), 1)
        pad = 1e-9 * float(span.max())  # a box on a cell line goes into both cells
        i0 = np.clip(np.floor((lo - pad - x0) / cell).astype(int), 0, shape - 1)
        i1 = np.clip(np.floor((hi + pad - x0) / cell).astype(int), 0, shape - 1)
        cells: list[list[int]] = [[] for _ in range(int(shape[0] * shape[1]))]
        for t, (a0, b0, a1, b1) in enumerate(zip(i0[:, 0], i0[:, 1], i1[:, 0], i1[:, 1],
                                                 strict=True)):
            for ix in range(a0, a1 + 1):
                for iy in range(b0, b1 + 1):
                    cells[ix * shape[1] + iy].append(t)
        self._cells = [tuple(c) for c in cells]
        self._g0 = (float(x0[0]) - pad, float(x0[1]) - pad)
        self._g1 = (float(x0[0] + shape[0] * cell) + pad, float(x0[1] + shape[1] * cell) + pad)
        self._cell, self._shape = cell, (int(shape[0]), int(shape[1]))
        self._x0 = (float(x0[0]), float(x0[1]))

    def _locate_one(self, x: float, y: float) -> int | None:
        """The triangle holding the internal point ``(x, y)``, -1 where none does, or None
        where a determinant's sign is too near 0 to be sure (the caller asks the kernel's
        exact :meth:`~tether.game.certified.CertifiedKernel.locate` instead)."""
        if not (self._g0[0] <= x <= self._g1[0] and self._g0[1] <= y <= self._g1[1]):
            return -1
        ix = min(max(int((x - self._x0[0]) / self._cell), 0), self._shape[0] - 1)
        iy = min(max(int((y - self._x0[1]) / self._cell), 0), self._shape[1] - 1)
        found = -1
        rows, sign = self._rows, self._sign
        for t in self._cells[ix * self._shape[1] + iy]:
            ax, ay, bx, by, cx, cy = rows[t][:6]
            sg = sign[t]
            inside = True
            for ux, uy, wx, wy in ((bx - ax, by - ay, x - ax, y - ay),
                                   (cx - bx, cy - by, x - bx, y - by),
                                   (ax - cx, ay - cy, x - cx, y - cy)):
                p1, p2 = ux * wy, uy * wx
                d, err = sg * (p1 - p2), _ORIENT_TOL * (abs(p1) + abs(p2))
                if d < -err:  # surely outside (counter-clockwise triangles)
                    break
                if d <= err:  # on or near this edge's line: not sure
                    inside = False
            else:
                if not inside or found >= 0:  # near an edge, or two triangles hold it
                    return None
                found = t
        return found

    def arc_one(self, px: float, py: float) -> tuple[bool, float, float]:
        """:meth:`arcs` at one point ``(px, py)`` (map units) in plain floats: whether it lies
        in the mesh, and the arc's ends (radians, NaN off the mesh)."""
        x, y = (px - self._origin[0]) * self._scale, (py - self._origin[1]) * self._scale
        t = self._locate_one(x, y)
        if t is None:
            t = int(self.certified.locate(np.array([[px, py]]))[0])
        if t < 0:
            return False, math.nan, math.nan
        ax, ay, bx, by, cx, cy, L0, L1, L2, H0, H1, H2, whole = self._rows[t]
        v0x, v0y, v1x, v1y, v2x, v2y = bx - ax, by - ay, cx - ax, cy - ay, x - ax, y - ay
        det = v0x * v1y - v0y * v1x
        l1 = (v2x * v1y - v2y * v1x) / det
        l2 = (v0x * v2y - v0y * v2x) / det
        l0 = 1 - l1 - l2
        lo = l0 * L0 + l1 * L1 + l2 * L2
        if whole:
            return True, lo, lo + _TAU
        return True, lo, min(l0 * H0 + l1 * H1 + l2 * H2, lo + _TAU)
