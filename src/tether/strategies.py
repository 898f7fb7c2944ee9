"""The players by name: the observer controllers and the target kinds of :mod:`tether.sim` and
:mod:`tether.game`, as ``tether simulate`` and the docs' tables choose them.

The registries sit above both packages, so that the simulation never imports the game.
"""

from __future__ import annotations

from typing import Any

from tether.errors import InvalidParameterError
from tether.game.controller import CertifiedController, KernelController
from tether.game.evader import KernelEvader
from tether.sim.controller import FollowController, PaperController, TranslateController
from tether.sim.protocols import World
from tether.sim.replay import PedestrianTarget, TrackTarget
from tether.sim.targets import (
    DashTarget,
    EscapeTarget,
    PathTarget,
    RandomTarget,
    SearchTarget,
    TangentialTarget,
    TargetFactory,
    WallTarget,
)

__all__ = ["CONTROLLERS", "TARGETS", "make_target"]


def _kernel_controller(world: World | None = None, **options: Any) -> Any:
    """The surveillance kernel's controller (:class:`tether.game.controller.KernelController`):
    follows ``world.extra["kernel"]``, computed there on demand (coarse grid, see
    :func:`tether.game.controller.kernel_of`) unless ``kernel=`` is given or the caller stored
    one (``tether simulate --kernel FILE.npz``)."""
    return KernelController(**options)


def _certified_controller(world: World | None = None, **options: Any) -> Any:
    """The certified kernel's controller (:class:`tether.game.controller.CertifiedController`):
    follows ``world.extra["certified"]``, computed there on demand (see
    :func:`tether.game.controller.certified_of`) unless ``certified=`` is given or the caller
    stored one (``tether simulate --controller certified --kernel FILE.npz``)."""
    return CertifiedController(**options)


def _kernel_evader(world: World, **options: Any) -> Any:
    """The surveillance kernel's evader (:class:`tether.game.evader.KernelEvader`); reads the
    kernel from ``world.extra["kernel"]`` unless ``kernel=`` is given."""
    return KernelEvader(**options)


#: Controllers by name: ``CONTROLLERS[name](world)``.
CONTROLLERS: dict[str, Any] = {
    "paper": PaperController,
    "follow": FollowController,
    "translate": TranslateController,
    "kernel": _kernel_controller,
    "certified": _certified_controller,
}

#: Target kinds by name: ``TARGETS[kind](world, **options)``.
TARGETS: dict[str, TargetFactory] = {
    "path": PathTarget,
    "random": RandomTarget,
    "wall": WallTarget,
    "tangential": TangentialTarget,
    "dash": DashTarget,
    "escape": EscapeTarget,
    "search": SearchTarget,
    "kernel-evader": _kernel_evader,
    "track": TrackTarget,
    "pedestrian": PedestrianTarget,
}


def make_target(kind: str, world: World, **options: Any) -> Any:
    """The target of kind ``kind`` (see :data:`TARGETS`).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.sim.protocols import World
    >>> from tether.strategies import TARGETS, make_target
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> world = World(ell, lss=0.5, vt=0.3, vo=1.0)
    >>> make_target("wall", world).name
    'wall'
    >>> sorted(TARGETS)
    ['dash', 'escape', 'kernel-evader', 'path', 'pedestrian', 'random', 'search', 'tangential',
     'track', 'wall']
    """
    try:
        factory = TARGETS[kind]
    except KeyError:
        raise InvalidParameterError(
            f"unknown target kind {kind!r} (choose from {', '.join(sorted(TARGETS))})") from None
    return factory(world, **options)
