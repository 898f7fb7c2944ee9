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

from typing import Any

import numpy as np

from tether.arcs import rod_is_free_many
from tether.rates import observer_velocity, step_rate_interval
from tether.sim.protocols import Command, Mode, World

__all__ = ["KernelController", "kernel_of"]


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
