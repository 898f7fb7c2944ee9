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
from typing import Any

import numpy as np

from tether.arcs import rod_is_free_many
from tether.game.certificate import FULL, lifted_ends
from tether.rates import observer_velocity, step_rate_interval
from tether.sim.protocols import Command, Mode, World

__all__ = ["CertifiedController", "FieldArcs", "KernelController", "certified_of", "kernel_of"]

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
            f = self._field = FieldArcs(self.certified)
        return f

    def step_many(self, p: Any, v: Any, a: Any, dt: float) -> np.ndarray:
        """The rod rates (rad/s) of :meth:`step` for many states at once: target positions
        ``p`` (n, 2) and velocities ``v`` (n, 2) (map units, map units/s), rod orientations
        ``a`` (n,) (radians), one step of ``dt`` s. Row ``i`` is the rate ``step(p[i], v[i],
        a[i], dt)`` gives, to the last bit (the same operations, elementwise); the controller
        keeps no state between steps, so the rows are independent. This controller always
        has a rate (it never gives up), so no entry is NaN.
        """
        world = self.world
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        v = np.asarray(v, dtype=float).reshape(-1, 2)
        a = np.asarray(a, dtype=float).reshape(-1)
        n = len(p)
        r_lo, r_hi = step_rate_interval(v, a, world.lss, world.vo, dt)
        r_lo, r_hi = np.maximum(r_lo, -np.pi / dt), np.minimum(r_hi, np.pi / dt)
        lo, hi, ok = self.field.arcs(np.concatenate([p, p + v * dt]))
        lo0, lo1, ok0, ok1 = lo[:n], lo[n:], ok[:n], ok[n:]
        width, w0 = hi[n:] - lo1, hi[:n] - lo0
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
        """The rod rate that lands the next state in the field, for target velocity ``v``."""
        world = self.world
        lss, vo = world.lss, world.vo
        p = np.asarray(p, dtype=float)
        v = np.asarray(v, dtype=float)
        r_lo, r_hi = (float(x) for x in step_rate_interval(v, a, lss, vo, dt))
        r_lo, r_hi = max(r_lo, -np.pi / dt), min(r_hi, np.pi / dt)
        lo, hi, ok = self.certified.arcs(np.vstack([p, p + v * dt]))
        if not ok[1]:  # the target leaves the free space: nothing to aim at
            rate = min(max(0.0, r_lo), r_hi)
            return Command(rate, observer_velocity(v, a, rate, lss), Mode.CERTIFIED)
        width = hi[1] - lo[1]
        w0 = hi[0] - lo[0]
        if ok[0] and w0 < FULL:  # the state's relative place in its arc (an end if outside)
            x = float(np.mod(a - lo[0], math.tau))
            s = x / w0 if x <= w0 else (0.0 if math.tau - x < x - w0 else 1.0)
            aim = lo[1] + s * width
        else:
            aim = a
        end = _landing(a, a + r_lo * dt, a + r_hi * dt, lo[1], width, aim)
        rate = (end - a) / dt
        return Command(rate, observer_velocity(v, a, rate, lss), Mode.CERTIFIED)


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
    """:func:`_landing` for arrays (radians, all of one shape): the same candidates in the
    same order, the same strict comparisons, so each entry equals the scalar function's to
    the last bit."""
    base = lo + _TAU * np.floor((lo_reach - lo) / _TAU)  # the lift at or below
    best, best_d = np.zeros_like(a), np.full_like(a, np.inf)
    found = np.zeros(a.shape, dtype=bool)
    gap_best, gap_d = lo_reach.copy(), np.full_like(a, np.inf)
    for k in (-1, 0, 1, 2):
        a0 = base + k * _TAU
        a1 = a0 + width
        t = aim + _TAU * np.round((a0 + width / 2 - aim) / _TAU)  # aim lifted to this arc
        x0, x1 = np.maximum(a0, lo_reach), np.minimum(a1, hi_reach)
        meet = x0 <= x1
        c = np.minimum(np.maximum(t, x0), x1)
        d = np.abs(c - t)
        take = meet & (d < best_d)
        best, best_d, found = np.where(take, c, best), np.where(take, d, best_d), found | take
        for c, d in ((hi_reach, a0 - hi_reach), (lo_reach, lo_reach - a1)):
            take = ~meet & (d >= 0) & (d < gap_d)
            gap_best, gap_d = np.where(take, c, gap_best), np.where(take, d, gap_d)
    out = np.where(found, best, gap_best)
    return np.where(width >= FULL, np.minimum(np.maximum(a, lo_reach), hi_reach), out)


class FieldArcs:
    """The arcs of a certified field (:meth:`~tether.game.certified.CertifiedKernel.arcs`),
    with the per-triangle data computed once: the lifted ends of every triangle and whether
    its three arcs are whole circles. :meth:`arcs` gives the kernel's own values to the last
    bit (the same triangle, the same operations); a simulation asks for them every step.

    Parameters
    ----------
    certified : CertifiedKernel
    """

    def __init__(self, certified: Any) -> None:
        f = certified.field
        self.certified = certified
        self.L, self.H, _ = lifted_ends(f.lo, f.w, f.tri)
        self.whole = (f.w[f.tri] >= FULL).all(axis=1)
        self.xy = f.points[f.tri]  # (m, 3, 2), the field's frame

    def arcs(self, points: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arc ``[lo, hi]`` at each point (map units; radians, ``hi − lo = 2π`` for the
        whole circle) and whether the point lies in the mesh (NaN ends where not)."""
        ck = self.certified
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        t = ck.locate(pts)
        pts = ck.frame.to_internal(pts)
        ok = t >= 0
        lo = np.full(len(pts), np.nan)
        hi = np.full(len(pts), np.nan)
        if ok.any():
            tk = t[ok]
            lam = _barycentric(self.xy[tk], pts[ok])
            L, H = self.L[tk], self.H[tk]
            lo[ok] = lam[:, 0] * L[:, 0] + lam[:, 1] * L[:, 1] + lam[:, 2] * L[:, 2]
            hi[ok] = np.minimum(lam[:, 0] * H[:, 0] + lam[:, 1] * H[:, 1] + lam[:, 2] * H[:, 2],
                                lo[ok] + _TAU)
            whole = self.whole[tk]
            hi[np.flatnonzero(ok)[whole]] = lo[ok][whole] + _TAU
        return lo, hi, ok


def _barycentric(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (m, 3) of points ``pts`` (m, 2) in triangles ``tri`` (m, 3, 2):
    the formula of :mod:`tether.game.certified` (so the arcs agree to the last bit)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, pts - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / det
    l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / det
    return np.stack([1 - l1 - l2, l1, l2], axis=1)
