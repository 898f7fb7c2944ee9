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
from tether.game.certificate import FULL
from tether.rates import observer_velocity, step_rate_interval
from tether.sim.protocols import Command, Mode, World

__all__ = ["CertifiedController", "KernelController", "certified_of", "kernel_of"]


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
