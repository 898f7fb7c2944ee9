"""The kernel's evader: the target move for which no admissible rate stays inside the kernel.

It follows the :class:`~tether.sim.protocols.Target` protocol. Each step it tries ``directions``
headings at full speed ``vt``; for each, the observer's best answer is the rate in ``Ω`` whose
state one game step ahead (``h/vt``) has the highest :attr:`~tether.game.kernel.Kernel.level`
(the iteration that removed it from the kernel: the discrete game's time-to-win), ties broken
by the kernel depth; the evader takes the heading whose best answer is lowest. From a state
of level ``n`` the discrete game guarantees a heading whose every answer has a level below
``n``, so the evader wins in at most ``n`` game steps there (up to the differences between
the discrete and the continuous game). Headings whose
game step would leave the free space are not tried. The kernel is ``world.extra["kernel"]``
unless given (computed and stored there when missing).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tether.game.controller import kernel_of
from tether.rates import rate_interval
from tether.sim.protocols import World

__all__ = ["KernelEvader"]


class KernelEvader:
    """Target that drives the state out of (or deeper outside) the kernel.

    Parameters
    ----------
    kernel : Kernel, optional
        By default ``world.extra["kernel"]`` at :meth:`reset`.
    directions : int
        Headings tried, evenly spaced.
    candidates : int
        Observer rates sampled in ``Ω`` for each heading.
    """

    name = "kernel-evader"

    def __init__(self, kernel: Any = None, directions: int = 32, candidates: int = 25) -> None:
        self.kernel = kernel
        self.directions = int(directions)
        self.candidates = int(candidates)
        self.world: World | None = None
        psi = np.arange(self.directions) * (2 * math.pi / self.directions)
        self._units = np.column_stack([np.cos(psi), np.sin(psi)])

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Start a run: take the kernel of ``world`` (computed if none was given)."""
        self.world = world
        if self.kernel is None:
            self.kernel = kernel_of(world)

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The target velocity (map units/s) after which no observer answer stays in the kernel."""
        k = self.kernel
        w = self.world
        p = np.asarray(p, dtype=float)
        tau = k.grid.h / k.vt
        v = self._units * w.vt
        ahead = p[None, :] + v * tau
        ok = w.env.contains(ahead[:, 0], ahead[:, 1])
        ok &= w.env.boundary_distance(ahead[:, 0], ahead[:, 1]) > k.grid.h / 4
        if not ok.any():
            return np.zeros(2)
        v, ahead = v[ok], ahead[ok]
        lo, hi = rate_interval(v, a, w.lss, w.vo)
        s = np.linspace(0.0, 1.0, self.candidates)
        rates = lo[:, None] + (hi - lo)[:, None] * s[None, :]  # (headings, candidates)
        pts = np.repeat(ahead, self.candidates, axis=0)
        ang = (a + rates * tau).ravel()
        lev = k.level_at(pts, ang).reshape(rates.shape).astype(float)
        d = k.depth_at(pts, ang).reshape(rates.shape)
        # the observer's best answer per heading: highest level, then deepest
        score = lev + 1e-3 * np.tanh(d)
        best = score.max(axis=1)
        return v[int(np.argmin(best))]
