"""The three observer motions of the paper as velocity laws (``docs/formulas.md``, "The
observer's motions" and "Turning as fast as possible").

Every law takes the target position ``T``, the observer position ``O`` (so the rod is
``[T, O]``, its orientation ``a`` points from ``T`` to ``O``) and the target velocity ``Vt``,
and returns a :class:`Velocity`: the observer velocity, the rod rate ``ȧ`` and whether the law
is feasible within the observer's speed bound ``vo``. Every admissible law has the form
``Vo = Vt + |O-T| ȧ u⊥(a)`` (C1), so the distance stays constant.

The laws are plain-float code (no numpy) because the controller calls one every step: one
evaluation takes a few microseconds. Positions in map units, velocities in map units per second,
rates in radians per second.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "Law", "SPEED_SLACK", "Vec", "Velocity", "contact_vertex", "follow", "rotate", "slide_on_wall",
    "trace", "tractrix", "translate", "wall_contact_needed"
]

Vec = Sequence[float]

#: Relative slack when comparing a required speed with ``vo`` (rounding only).
SPEED_SLACK = 1e-12


class Velocity(NamedTuple):
    """An observer velocity and its rod rate.

    ``feasible`` is false when the motion would need a speed above ``vo``; ``vx, vy`` are then
    NaN (never an impossible velocity) and ``speed`` is the speed the motion would need.
    """

    vx: float
    vy: float
    rate: float  # rod rate ȧ, rad/s
    speed: float  # |Vo| required, map units/s
    feasible: bool


def _rod(T: Vec, O: Vec) -> tuple[float, float, float]:
    """Unit rod direction (ux, uy) from T to O and the rod length."""
    dx, dy = O[0] - T[0], O[1] - T[1]
    length = math.hypot(dx, dy)
    return dx / length, dy / length, length


def _result(vx: float, vy: float, rate: float, vo: float) -> Velocity:
    speed = math.hypot(vx, vy)
    if speed > vo * (1 + SPEED_SLACK):
        return Velocity(math.nan, math.nan, math.nan, speed, False)
    return Velocity(vx, vy, rate, speed, True)


# ---------------------------------------------------------------------- reactive
def translate(T: Vec, O: Vec, Vt: Vec, vo: float = math.inf) -> Velocity:
    """Reactive translation: the observer copies the target velocity (``ȧ = 0``).

    Examples
    --------
    >>> from tether.motion import translate
    >>> translate((0, 0), (1, 0), (0.3, 0.4), vo=1.0)
    Velocity(vx=0.3, vy=0.4, rate=0.0, speed=0.5, feasible=True)
    """
    return _result(Vt[0], Vt[1], 0.0, vo)


def follow(T: Vec, O: Vec, Vt: Vec, vo: float = math.inf) -> Velocity:
    """Reactive "hound" motion: the minimum-norm admissible velocity, ``Vo = (Vt·u) u``,
    ``ȧ = -(Vt·u⊥)/|O-T|``. Against a straight target the observer traces the tractrix.

    Examples
    --------
    The target runs up across a rod pointing along +x: the observer stays put and the rod turns
    clockwise at 1 rad/s.

    >>> from tether.motion import follow
    >>> follow((0, 0), (1, 0), (0.0, 1.0), vo=2.0)
    Velocity(vx=0.0, vy=0.0, rate=-1.0, speed=0.0, feasible=True)
    """
    ux, uy, length = _rod(T, O)
    radial = Vt[0] * ux + Vt[1] * uy
    tangential = -Vt[0] * uy + Vt[1] * ux
    return _result(radial * ux, radial * uy, -tangential / length, vo)


# ---------------------------------------------------------------------- rotational
def rotate(T: Vec, O: Vec, Vt: Vec, vo: float, sense: int) -> Velocity:
    """Saturated rotation in ``sense`` (+1 CCW, -1 CW) around a target with velocity ``Vt``.

    The observer copies the radial part ``v_r = Vt·u`` and spends the rest of ``vo`` on the
    tangent: ``ȧ = σ (sqrt(vo² - v_r²) - σ Vt·u⊥) / |O-T|``, so ``|Vo| = vo`` exactly
    (``docs/formulas.md``, "Distance bounds"). For a straight target this is the paper's
    ``w₊``/``w₋``. Feasible whenever
    ``|Vt| < vo``.

    Examples
    --------
    >>> from tether.motion import rotate
    >>> v = rotate((0, 0), (1, 0), (0.0, 1.0), vo=2.0, sense=1)
    >>> round(v.rate, 6), round(v.speed, 6), v.feasible
    (1.0, 2.0, True)
    """
    ux, uy, length = _rod(T, O)
    radial = Vt[0] * ux + Vt[1] * uy
    tangential = -Vt[0] * uy + Vt[1] * ux
    if radial * radial > vo * vo:
        return Velocity(math.nan, math.nan, math.nan, abs(radial), False)
    along = sense * math.sqrt(vo * vo - radial * radial)  # Vo·u⊥
    rate = (along - tangential) / length
    return Velocity(radial * ux - along * uy, radial * uy + along * ux, rate, vo, True)


# ---------------------------------------------------------------------- compliant
def slide_on_wall(T: Vec, O: Vec, Vt: Vec, wall_dir: Vec, vo: float) -> Velocity:
    """Observer end sliding along a wall line with unit direction ``e = wall_dir``, whose free
    side is on the left of ``e`` (``docs/formulas.md``, "The observer's motions").

    With ``α = a - γ`` the rod orientation relative to the wall and ``Vtx = Vt·e``,
    ``Vty = Vt·n``: ``ṡ = Vtx + Vty tan α``, ``ȧ = -Vty / (|O-T| cos α)``, ``Vo = ṡ e``.
    Infeasible when ``|ṡ| > vo`` (the rod is too close to perpendicular to the wall) or the rod
    is exactly perpendicular with ``Vty != 0``.

    Examples
    --------
    The target 0.5 above a wall along +x, the observer's end on the wall: a target running along
    the wall is matched without turning.

    >>> import math
    >>> from tether.motion import slide_on_wall
    >>> T, O = (0.0, 0.5), (math.sqrt(0.75), 0.0)
    >>> v = slide_on_wall(T, O, (0.5, 0.0), wall_dir=(1.0, 0.0), vo=1.0)
    >>> round(v.vx, 6), round(v.vy, 6), v.rate == 0, v.feasible
    (0.5, 0.0, True, True)
    """
    ux, uy, length = _rod(T, O)
    ex, ey = wall_dir
    cos_a = ux * ex + uy * ey  # cos α
    sin_a = -ux * ey + uy * ex  # sin α  (< 0: the target is on the free side)
    vtx = Vt[0] * ex + Vt[1] * ey
    vty = -Vt[0] * ey + Vt[1] * ex
    if abs(cos_a) < 1e-15:
        if vty == 0.0:
            return _result(vtx * ex, vtx * ey, 0.0, vo)
        return Velocity(math.nan, math.nan, math.nan, math.inf, False)
    sdot = vtx + vty * sin_a / cos_a
    rate = -vty / (length * cos_a)
    return _result(sdot * ex, sdot * ey, rate, vo)


def contact_vertex(T: Vec, O: Vec, Vt: Vec, vertex: Vec, vo: float) -> Velocity:
    """Rod kept in contact with a (reflex) vertex ``V`` lying on the rod (``docs/formulas.md``,
    "The observer's motions").

    With ``l_t = |T - V|``, ``l_o = |O-T| - l_t`` and ``u`` the rod direction:
    ``Vo = (Vt·u) u - (l_o/l_t)(Vt·u⊥) u⊥``, ``ȧ = -(Vt·u⊥)/l_t``; the speed is
    ``vt sqrt(1 + (l_o²/l_t² - 1) sin²θ_v)``, infeasible above ``vo``.

    Examples
    --------
    The rod pivots about a vertex at its middle: the observer mirrors the target's motion.

    >>> from tether.motion import contact_vertex
    >>> contact_vertex((0, 0), (1, 0), (0.0, 1.0), vertex=(0.5, 0.0), vo=2.0)
    Velocity(vx=0.0, vy=-1.0, rate=-2.0, speed=1.0, feasible=True)
    """
    ux, uy, length = _rod(T, O)
    lt = math.hypot(vertex[0] - T[0], vertex[1] - T[1])
    lo = length - lt
    radial = Vt[0] * ux + Vt[1] * uy
    tangential = -Vt[0] * uy + Vt[1] * ux
    k = -(lo / lt) * tangential
    return _result(radial * ux - k * uy, radial * uy + k * ux, -tangential / lt, vo)


def wall_contact_needed(Vt: Vec, wall_dir: Vec) -> bool:
    """Whether plain translation would push the observer into the wall: ``Vt·n < 0``."""
    ex, ey = wall_dir
    return -Vt[0] * ey + Vt[1] * ex < 0


# ---------------------------------------------------------------------- closed forms
def tractrix(s: Any, lss: float, side: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The follow motion's path against a target on the +x axis at ``(lss·s, 0)``
    (``docs/formulas.md``, "The observer's motions"): ``x_o = lss (s - tanh s)``,
    ``y_o = side · lss · sech s``.

    Examples
    --------
    >>> from tether.motion import tractrix
    >>> x, y = tractrix([0.0, 2.0], lss=1.0)
    >>> x.round(4).tolist(), y.round(4).tolist()
    ([0.0, 1.036], [1.0, 0.2658])
    """
    s = np.asarray(s, dtype=float)
    return lss * (s - np.tanh(s)), side * lss / np.cosh(s)


# ---------------------------------------------------------------------- integration
Law = Callable[[Vec, Vec, Vec], Velocity]


def trace(law: Law, target_velocity: Callable[[float, Vec, Vec], Vec], T0: Vec, O0: Vec,
          t_end: float, *, max_step: float = np.inf, rtol: float = 1e-10, atol: float = 1e-12,
          stop: Callable[[float, np.ndarray], float] | None = None) -> Any:
    """Integrate a law with ``scipy.integrate.solve_ivp`` (DOP853).

    The state is ``(Tx, Ty, Ox, Oy, a)`` with ``a`` the lifted rod orientation (integrated from
    the law's rate, so several turns are tracked). ``target_velocity(t, T, O)`` scripts the
    target (it may steer against the observer).
    Integration stops at ``t_end``, where the law becomes infeasible, or where ``stop(t, y)``
    crosses zero. Returns the ``solve_ivp`` solution with ``sol.infeasible`` set.
    """
    from scipy.integrate import solve_ivp

    infeasible = {"hit": False}

    def rhs(t: float, y: np.ndarray) -> list[float]:
        vt = target_velocity(t, (y[0], y[1]), (y[2], y[3]))
        v = law((y[0], y[1]), (y[2], y[3]), vt)
        if not v.feasible:
            infeasible["hit"] = True
            return [vt[0], vt[1], 0.0, 0.0, 0.0]
        return [vt[0], vt[1], v.vx, v.vy, v.rate]

    events = []
    if stop is not None:
        def ev(t: float, y: np.ndarray) -> float:
            return stop(t, y)

        ev.terminal = True
        events.append(ev)
    a0 = math.atan2(O0[1] - T0[1], O0[0] - T0[0])
    sol = solve_ivp(rhs, (0.0, t_end), [T0[0], T0[1], O0[0], O0[1], a0], method="DOP853",
                    rtol=rtol, atol=atol, max_step=max_step, events=events or None,
                    dense_output=True)
    sol.infeasible = infeasible["hit"]
    return sol

