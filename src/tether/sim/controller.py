"""Observer controllers: the rod rate each step (``math.md`` §10).

Every controller here picks a *preferred* rate (follow law, translation, or a saturated rotation
when the paper's trigger fires) and then makes it admissible in two stages:

1. clip it to the rates whose observer chord over the step stays within ``vo·dt``
   (:func:`tether.rates.step_rate_interval`, exact for a sampled controller), and
2. keep the rod in its free arc at the end of the step (compliant motion): the arc's ends at the
   next target position are computed exactly by :class:`tether.sim.local.LocalArcs`; if an end
   sweeps over the rod, the rod is pushed along with it.

If the two sets do not meet, the target has won at this instant and the command says why. The
controller never commands an observer chord above ``vo·dt``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tether.rates import step_rate_interval
from tether.sim.local import LocalArcs
from tether.sim.protocols import Command, World

#: Rates are chosen within ``vo·(1 − VO_MARGIN)`` so that rounding never exceeds ``vo``.
VO_MARGIN = 1e-9
#: Angular margin (rad) kept inside a free arc when the rod is pushed by one of its ends.
CONTACT_MARGIN = 1e-9


def _vel(v: np.ndarray, a: float, rate: float, lss: float) -> np.ndarray:
    return np.array([v[0] - lss * rate * math.sin(a), v[1] + lss * rate * math.cos(a)])


class _Compliant:
    """Shared machinery: the admissible step rates and compliance with the arc ends."""

    name = "base"

    def __init__(self, world: World | None = None) -> None:
        self.world = world
        self.local: LocalArcs | None = None
        if world is not None:
            self._prepare(world)

    def _prepare(self, world: World) -> None:
        self.world = world
        self.lss = float(world.lss)
        self.vt = float(world.vt)
        self.vo = float(world.vo)
        self.local = world.extra.get("_local_arcs")
        if self.local is None or self.local.lss != self.lss:
            self.local = LocalArcs(world.env, self.lss, pad=0.0)
            world.extra["_local_arcs"] = self.local

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        if self.world is not world or self.local is None:
            self._prepare(world)

    # the preferred motion ----------------------------------------------------------
    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        raise NotImplementedError

    # one step ---------------------------------------------------------------------
    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        want, mode = self.preferred(p, v, a, dt)
        return self.admissible(p, v, a, dt, want, mode)

    def admissible(self, p: np.ndarray, v: np.ndarray, a: float, dt: float, want: float,
                   mode: str) -> Command:
        """Make the preferred ``want`` (rad/s) admissible: chord within ``vo·dt`` and the rod in
        its free arc at the end of the step."""
        lo, hi = step_rate_interval(v, a, self.lss, self.vo * (1.0 - VO_MARGIN), dt)
        lo, hi = float(lo), float(hi)
        x1, y1 = float(p[0] + v[0] * dt), float(p[1] + v[1] * dt)
        ends = self.local.ends(x1, y1, a)
        if ends.free:
            hlo, hhi = -ends.cw_gap, ends.ccw_gap
            flo, fhi = ends.cw_feature, ends.ccw_feature
        elif ends.ccw_gap <= ends.cw_gap:  # an end swept over the rod: follow it out
            hlo, hhi, flo, fhi = ends.ccw_gap, math.inf, ends.ccw_feature, None
        else:
            hlo, hhi, flo, fhi = -math.inf, -ends.cw_gap, None, ends.cw_feature
        m = min(CONTACT_MARGIN, 0.25 * max(hhi - hlo, 0.0))
        clo = (hlo + m) / dt if math.isfinite(hlo) else -math.inf
        chi = (hhi - m) / dt if math.isfinite(hhi) else math.inf
        rlo, rhi = max(lo, clo), min(hi, chi)
        if rlo > rhi:
            return Command(math.nan, np.full(2, math.nan), "lost", False,
                           self._why(p, v, a, dt, lo, hi, clo, chi, flo, fhi))
        rate = min(max(want, rlo), rhi)
        if (rate == clo and clo > lo) or (rate == chi and chi < hi) or not ends.free:
            mode = "compliant"
        return Command(rate, _vel(v, a, rate, self.lss), mode)

    def _why(self, p: np.ndarray, v: np.ndarray, a: float, dt: float, lo: float, hi: float,
             clo: float, chi: float, flo: str | None, fhi: str | None) -> str:
        """Words for an arc end the observer cannot follow."""
        if clo > hi:
            feat, need, have = flo, clo, hi
        else:
            feat, need, have = fhi, chi, lo
        text = (f"rate needed beyond vo: the arc end {feat} moves at {need:.4g} rad/s, the "
                f"observer can turn at most {have:.4g} rad/s")
        env = self.world.env
        if feat and feat.startswith("V"):
            vtx = env.vertices[int(feat[1:])]
            lt = float(np.hypot(*(vtx - p)))
            bound = self.lss * self.vt / (self.vo + self.vt)
            text += (f" (pivot about {feat} with l_t = {lt:.4g} "
                     f"{'<' if lt < bound else '>='} Lss·vt/(vo+vt) = {bound:.4g})")
        elif feat and feat.startswith("E"):
            text += f" (wall {feat} met with the rod too steep to slide)"
        return text


class FollowController(_Compliant):
    """Reactive motion only: the follow law (``ȧ = −v·u⊥/lss``), compliant at arc ends."""

    name = "follow"

    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        return (-(-v[0] * math.sin(a) + v[1] * math.cos(a)) / self.lss, "reactive")

    def mode_at(self, p: np.ndarray, v: np.ndarray, a: float) -> str:
        return "reactive"


class TranslateController(_Compliant):
    """Reactive motion by translation (``ȧ = 0``), compliant at arc ends."""

    name = "translate"

    def preferred(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> tuple[float, str]:
        return 0.0, "reactive"


#: Controllers by name: ``CONTROLLERS[name](world)``.
CONTROLLERS: dict[str, Any] = {
    "follow": FollowController,
    "translate": TranslateController,
}
