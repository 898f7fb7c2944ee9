"""Rotation time, the paper's distance bound ``L`` and the worst-case (steering target) bound.

Conventions (``docs/conventions.md``, "Frames and angles"; ``docs/formulas.md``, "Turning as
fast as possible"): the paper's angle ``θ = a - ψ + π/2`` is the angle from the
target velocity (heading ``ψ``) to the CCW tangent ``u⊥(a)`` of the rod orientation ``a``.
Angles are *lifted* (not reduced mod 2π): the sense of a rotation from ``theta0`` to
``thetaf`` is the sign of ``thetaf - theta0`` and several turns are allowed. Times in seconds,
lengths in map units, speeds in map units per second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from scipy.special import ellipe, ellipeinc

from tether.errors import InvalidParameterError
from tether.tolerances import SPEED_GAP_REL, VALUE_MAX

__all__ = [
    "Rotation", "TABLE_MAX_M", "TABLE_MIN_SIZE", "best_rotation", "bound_report",
    "check_speeds", "distance_bound", "ellipe_inc", "rotation_time", "thetas",
    "worst_case_distance", "worst_case_time", "worst_straight_time"
]



def check_speeds(vt: Any, vo: Any, lss: Any) -> tuple[float, float, float]:
    """Validate ``0 <= vt < vo`` and ``lss > 0``, all finite; return them as floats.

    Each of ``vt`` (unless 0), ``vo`` and ``lss`` must lie in ``[1/VALUE_MAX, VALUE_MAX]`` and
    ``vo - vt > SPEED_GAP_REL * vo`` (:mod:`tether.tolerances`), so that every product and
    quotient computed from them is finite and keeps its digits.

    Raises
    ------
    InvalidParameterError
        If a value is not a finite number, ``vt < 0``, ``vo <= vt``, ``lss <= 0`` or a value is
        out of the ranges above.
    """
    vals = []
    for name, v in (("vt", vt), ("vo", vo), ("lss", lss)):
        try:
            f = float(v)
        except (TypeError, ValueError, OverflowError):
            raise InvalidParameterError(f"{name} must be a number, got {v!r}") from None
        if isinstance(v, bool):
            raise InvalidParameterError(f"{name} must be a number, got {v!r}")
        if not math.isfinite(f):
            raise InvalidParameterError(f"{name} must be finite, got {v!r}")
        vals.append(f)
    vt_, vo_, lss_ = vals
    if vt_ < 0:
        raise InvalidParameterError(f"vt must be >= 0, got {vt_:g}")
    if vo_ <= vt_:
        raise InvalidParameterError(
            f"vo must exceed vt (the observer cannot rotate otherwise), "
            f"got vo={vo_:g} <= vt={vt_:g}"
        )
    if lss_ <= 0:
        raise InvalidParameterError(f"lss must be a finite length > 0, got {lss_:g}")
    for name, f in (("vt", vt_), ("vo", vo_), ("lss", lss_)):
        if f > VALUE_MAX or (0 < f < 1 / VALUE_MAX):
            raise InvalidParameterError(
                f"{name} = {f:g} is out of range: use {1 / VALUE_MAX:g} <= {name} <= "
                f"{VALUE_MAX:g}" + (" (or vt = 0)" if name == "vt" else ""))
    if vo_ - vt_ <= SPEED_GAP_REL * vo_:
        raise InvalidParameterError(
            f"vo must exceed vt by more than {SPEED_GAP_REL:g} × vo, got vo={vo_:.17g}, "
            f"vt={vt_:.17g}")
    return vt_, vo_, lss_


def _finite(name: str, x: Any) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InvalidParameterError(f"{name} must be finite")
    return arr


#: Arrays at least this large use the interpolation table for E(φ|m) (scipy below it).
TABLE_MIN_SIZE = 4096
#: The table is used for m = (vt/vo)² up to this value; beyond it the integrand varies too
#: sharply near φ = π/2 and scipy is used.
TABLE_MAX_M = 0.97
_TABLE_INTERVALS = 8192


@lru_cache(maxsize=16)
def _ellipe_table(m: float) -> tuple[float, np.ndarray, np.ndarray, float]:
    """E(φ|m) and its derivative sqrt(1 - m sin²φ) on a uniform grid of [0, π/2]."""
    grid = np.linspace(0.0, math.pi / 2, _TABLE_INTERVALS + 1)
    return grid[1], ellipeinc(grid, m), np.sqrt(1.0 - m * np.sin(grid) ** 2), float(ellipe(m))


def ellipe_inc(phi: np.ndarray, m: float) -> np.ndarray:
    """Incomplete elliptic integral of the second kind ``E(φ|m)`` for any real ``φ``.

    Equals ``scipy.special.ellipeinc``; for large arrays with ``m <= TABLE_MAX_M`` it uses the
    quasi-periodicity ``E(φ + kπ) = E(φ) + 2k E(m)``, oddness, and cubic Hermite interpolation
    on a table of 8,193 exact values and derivatives (absolute error about 2e-15, about five
    times faster than scipy).
    """
    phi = np.asarray(phi, dtype=float)
    if phi.size < TABLE_MIN_SIZE or m > TABLE_MAX_M:
        return ellipeinc(phi, m)
    h, E, D, complete = _ellipe_table(float(m))
    k = np.floor(phi / math.pi + 0.5)
    r = phi - k * math.pi
    x = np.abs(r) / h
    i = np.minimum(x.astype(np.int64), _TABLE_INTERVALS - 1)
    t = x - i
    t2 = t * t
    t3 = t2 * t
    val = ((2 * t3 - 3 * t2 + 1) * E[i] + (t3 - 2 * t2 + t) * h * D[i]
           + (3 * t2 - 2 * t3) * E[i + 1] + (t3 - t2) * h * D[i + 1])
    return 2.0 * complete * k + np.copysign(val, r)


def rotation_time(theta0: Any, thetaf: Any, vt: float, vo: float, lss: float) -> Any:
    """Time of the saturated rotation from ``theta0`` to ``thetaf`` (lifted radians) while the
    target runs straight at speed ``vt`` (``docs/formulas.md``, "Turning as fast as possible").

    ``T = lss/(vo²-vt²) [vo |E(θf|m) - E(θ0|m)| + vt (sin θf - sin θ0)]`` with ``m = (vt/vo)²``.
    Vectorized over ``theta0`` and ``thetaf``.

    Returns
    -------
    float or ndarray
        Seconds; 0 where ``theta0 == thetaf``.

    Raises
    ------
    InvalidParameterError
        On non-finite angles or invalid speeds (see :func:`check_speeds`).

    Examples
    --------
    A quarter turn at ``vt = 1``, ``vo = 2``, ``lss = 1`` (seconds):

    >>> import math
    >>> from tether.bounds import rotation_time
    >>> round(float(rotation_time(0.0, math.pi / 2, vt=1.0, vo=2.0, lss=1.0)), 5)
    1.31164
    >>> round(float(rotation_time(0.0, math.pi / 2, vt=0.0, vo=2.0, lss=1.0)), 5)  # lss·Δ/vo
    0.7854
    """
    vt, vo, lss = check_speeds(vt, vo, lss)
    t0 = _finite("theta0", theta0)
    tf = _finite("thetaf", thetaf)
    m = (vt / vo) ** 2
    dE = np.abs(ellipe_inc(tf, m) - ellipe_inc(t0, m))
    T = lss / (vo * vo - vt * vt) * (vo * dE + vt * (np.sin(tf) - np.sin(t0)))
    T = np.maximum(T, 0.0)  # rounding only: the integrand is positive
    return float(T) if T.ndim == 0 else T


def distance_bound(theta0: Any, thetaf: Any, vt: float, vo: float, lss: float) -> Any:
    """The paper's ``L(x, y, θ) = vt * rotation_time(...)``: how far the target runs (straight)
    during the rotation, map units. Vectorized like :func:`rotation_time`.

    Examples
    --------
    >>> import math
    >>> from tether.bounds import distance_bound
    >>> round(float(distance_bound(0.0, math.pi / 2, vt=1.0, vo=2.0, lss=1.0)), 5)  # map units
    1.31164
    """
    return vt * rotation_time(theta0, thetaf, vt, vo, lss)


def worst_case_time(sweep: Any, vt: float, vo: float, lss: float) -> Any:
    """Guaranteed time to sweep ``|sweep|`` radians whatever the target does
    (``docs/formulas.md``, "Distance bounds"):
    ``T_g = lss |Δ| / (vo - vt)``, tight against a target running tangentially. Seconds."""
    vt, vo, lss = check_speeds(vt, vo, lss)
    d = np.abs(_finite("sweep", sweep))
    out = lss * d / (vo - vt)
    return float(out) if np.ndim(out) == 0 else out


def worst_case_distance(sweep: Any, vt: float, vo: float, lss: float) -> Any:
    """Guaranteed distance bound ``L_g = vt * T_g`` (map units): if the target's path distance to
    the escape point exceeds it when the rotation starts, the rotation finishes first."""
    return vt * worst_case_time(sweep, vt, vo, lss)


def worst_straight_time(sweep: Any, vt: float, vo: float, lss: float) -> Any:
    """Rotation time against the worst *straight* heading for a sweep ``|Δ| <= 2π``: the sweep
    centred on ``θ = 0`` (``docs/formulas.md``, "Turning as fast as possible"). Seconds."""
    d = np.abs(_finite("sweep", sweep))
    return rotation_time(-d / 2, d / 2, vt, vo, lss)


def thetas(a0: Any, af: Any, psi: Any, sense: int) -> tuple[Any, Any]:
    """The paper's lifted ``(θ0, θf)`` for turning the rod from orientation ``a0`` to ``af``
    (mod 2π) in sense ``sense`` (+1 CCW, -1 CW) while the target heads ``psi``. Radians."""
    if sense not in (1, -1):
        raise InvalidParameterError(f"sense must be +1 (CCW) or -1 (CW), got {sense!r}")
    a0 = _finite("a0", a0)
    af = _finite("af", af)
    psi = _finite("psi", psi)
    th0 = a0 - psi + math.pi / 2
    delta = np.mod(sense * (af - a0), math.tau)
    thf = th0 + sense * delta
    if th0.ndim == 0 and thf.ndim == 0:
        return float(th0), float(thf)
    return th0, thf


@dataclass(frozen=True)
class Rotation:
    """The faster saturated rotation between two rod orientations against a straight target."""

    sense: int  # +1 CCW, -1 CW
    theta0: float  # lifted paper angle at the start, radians
    thetaf: float  # lifted paper angle at the goal, radians
    time: float  # seconds
    distance_bound: float  # vt * time, map units (the paper's L)
    worst_case_time: float  # lss |Δ| / (vo - vt), seconds
    worst_case_distance: float  # vt * worst_case_time, map units

    def to_dict(self) -> dict:
        """The rotation as JSON-ready values (angles in radians, time in seconds)."""
        return {
            "sense": self.sense,
            "theta0": self.theta0,
            "thetaf": self.thetaf,
            "rotation_time": self.time,
            "distance_bound": self.distance_bound,
            "worst_case_time": self.worst_case_time,
            "worst_case_distance": self.worst_case_distance,
        }


def best_rotation(a0: float, af: float, psi: float, vt: float, vo: float, lss: float) -> Rotation:
    """The faster of the CCW and CW saturated rotations turning the rod from ``a0`` to ``af``
    (radians, mod 2π) while the target runs straight at ``vt`` with heading ``psi``."""
    best = None
    for sense in (1, -1):
        th0, thf = thetas(a0, af, psi, sense)
        t = rotation_time(th0, thf, vt, vo, lss)
        if best is None or t < best[0]:
            best = (t, sense, th0, thf)
    t, sense, th0, thf = best
    tg = worst_case_time(thf - th0, vt, vo, lss)
    return Rotation(sense, th0, thf, t, vt * t, tg, vt * tg)


def bound_report(theta0: float, thetaf: float, vt: float, vo: float, lss: float) -> dict:
    """The ``tether bound`` result: rotation time and distance bound for the given lifted
    angles, and the worst-case (steering target) time and distance for the same sweep.

    Examples
    --------
    >>> import math
    >>> from tether.bounds import bound_report
    >>> report = bound_report(0.0, math.pi / 2, vt=1.0, vo=2.0, lss=1.0)
    >>> {key: round(float(value), 5) for key, value in report.items()
    ...  if key in ("distance_bound", "worst_case_distance")}
    {'distance_bound': 1.31164, 'worst_case_distance': 1.5708}
    """
    t = rotation_time(theta0, thetaf, vt, vo, lss)
    tg = worst_case_time(thetaf - theta0, vt, vo, lss)
    return {
        "rotation_time": t,
        "distance_bound": vt * t,
        "worst_case_time": tg,
        "worst_case_distance": vt * tg,
    }
