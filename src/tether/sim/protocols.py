"""What the simulator expects of a controller and of a target.

State: target position ``p`` (shape (2,)), rod orientation ``a`` (radians); the observer is at
``p + lss·u(a)``. Each step the target picks ``v`` (``|v| <= vt``), the controller sees ``v``
and picks the rod rate; the observer velocity is ``v + lss·ȧ·u⊥(a)``
(``docs/formulas.md``, "Keeping the distance").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from tether._util.vocabulary import Vocabulary
from tether.environment import Environment

__all__ = ["Command", "Controller", "Mode", "Outcome", "Target", "World"]


class Mode(Vocabulary):
    """What a controller did at a step (:attr:`Command.mode`); the values are the words that
    the JSON output and the traces print."""

    REACTIVE = "reactive"  # the observer keeps the rod's angle to the target's motion
    ROTATIONAL = "rotational"  # turning toward a goal orientation
    COMPLIANT = "compliant"  # held at an end of the admissible rate interval
    KERNEL = "kernel"  # following the surveillance kernel
    CERTIFIED = "certified"  # keeping the state in the certified kernel's arc field
    LOST = "lost"  # no admissible rate: the target has won


class Outcome(Vocabulary):
    """How a run ended (:attr:`tether.sim.SimResult.outcome`)."""

    HELD = "held"
    LOST = "lost"


@dataclass(frozen=True, eq=False)
class World:
    """Everything a controller or a target may know about the scene.

    ``decomposition`` / ``verdict`` are a :class:`~tether.decomposition.Decomposition` and its
    :class:`~tether.analysis.Verdict` when computed; ``extra`` holds anything else a target kind
    needs (a controller to attack, a kernel, waypoints).
    """

    env: Environment
    lss: float  # rod length, map units
    vt: float  # target speed bound, map units/s
    vo: float  # observer speed bound, map units/s
    decomposition: Any = None
    verdict: Any = None
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Command:
    """One control decision.

    ``rate`` is the rod rate ȧ (rad/s), ``velocity`` the observer velocity (map units/s),
    ``mode`` a :class:`Mode` (a plain string is accepted from other controllers).
    When no admissible rate exists, ``feasible`` is false, ``rate`` is NaN and ``reason`` says
    why (the target has won at this instant).
    """

    rate: float
    velocity: np.ndarray
    mode: Mode | str
    feasible: bool = True
    reason: str | None = None


@runtime_checkable
class Controller(Protocol):
    """Chooses the rod rate each step."""

    def reset(self, world: World, p: np.ndarray, a: float) -> None:
        """Called once before a run, with the start state."""

    def step(self, p: np.ndarray, v: np.ndarray, a: float, dt: float) -> Command:
        """The command for a step of ``dt`` s from state ``(p, a)`` under target velocity ``v``."""


@runtime_checkable
class Target(Protocol):
    """Chooses the target velocity each step (``|v| <= vt``)."""

    def reset(self, world: World, p: np.ndarray, a: float, rng: np.random.Generator) -> None:
        """Called once before a run, with the start state and a seeded generator."""

    def velocity(self, t: float, p: np.ndarray, a: float) -> np.ndarray:
        """The target velocity at time ``t`` (s) from state ``(p, a)``."""
