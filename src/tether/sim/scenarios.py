"""The paper's examples, live: scripted runs that retell the stories of Figs. 7 and 8.

* :func:`fig7`: the convex corner (a square obstacle in a room). The target walks along the
  obstacle's top side toward its reflex corner and turns down its right side; the observer,
  trailing behind, must rotate away from the corner before the target is ``L_g`` (plus the
  no-pivot radius) from it, or it pivots about the vertex too fast.
* :func:`fig8`: the non-convex corner (a room's corner). The target walks along the bottom wall
  into the corner and up the right wall with the rod pointing ahead, at the wall; the observer
  slides, rotates before its tip meets the right wall head-on (the escapable split at the
  corner), then slides on.

Each returns ``(world, result)``; ``result.modes`` is the mode sequence. The controller is a
name of :mod:`tether.sim.controller`'s (``"paper"``, ``"follow"``, ``"translate"``) or a factory
``controller(world)``, for example ``tether.strategies.CONTROLLERS["kernel"]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from tether import examples
from tether.analysis.elimination import analyze
from tether.decomposition import decompose
from tether.sim.controller import FollowController, PaperController, TranslateController
from tether.sim.protocols import World
from tether.sim.simulate import SimResult, simulate
from tether.sim.targets import PathTarget

__all__ = ["fig7", "fig8"]

#: The controllers of the simulation by name.
_CONTROLLERS: dict[str, Callable[[World], Any]] = {
    "paper": PaperController, "follow": FollowController, "translate": TranslateController}


def _controller(controller: str | Callable[[World], Any], world: World) -> Any:
    return (_CONTROLLERS[controller] if isinstance(controller, str) else controller)(world)


def _world(name: str, lss: float, vt: float, vo: float) -> World:
    env = examples.load(name)
    dec = decompose(env, lss)
    return World(env, lss, vt, vo, dec, analyze(dec, near_critical=False))


def fig7(controller: str | Callable[[World], Any] = "paper", vt: float = 0.5,
         vo: float = 1.0, dt: float = 0.02) -> tuple[World, SimResult]:
    """Convex corner: target along the obstacle, around its reflex corner (see module doc)."""
    w = _world("convex_corner", 2.0, vt, vo)
    target = PathTarget(w, waypoints=[[0.3, 0.3], [0.3, -4.5]])
    ctrl = _controller(controller, w)
    return w, simulate(w, ctrl, target, (-3.5, 0.3, math.pi), duration=22.0, dt=dt)


def fig8(controller: str | Callable[[World], Any] = "paper", vt: float = 0.5,
         vo: float = 1.0, dt: float = 0.02) -> tuple[World, SimResult]:
    """Non-convex corner: slide, rotate, slide (see module doc)."""
    w = _world("nonconvex_corner", 2.0, vt, vo)
    target = PathTarget(w, waypoints=[[9.2, 0.8], [9.2, 6.0]])
    ctrl = _controller(controller, w)
    return w, simulate(w, ctrl, target, (3.0, 0.8, 0.0), duration=25.0, dt=dt)
