"""The observer's admissible rod rates and the rates of the free-arc ends (``docs/formulas.md``,
"The observer's choice at each instant").

The state is ``(p, a)``: target position and rod orientation (observer at ``p + lss·u(a)``).
For a target velocity ``v`` the observer's only freedom is the rod rate ``ȧ``; its speed stays
within ``vo`` iff ``ȧ`` lies in the interval ``Ω(v, a)`` returned by :func:`rate_interval`.
Every motion of the paper is a point of ``Ω``: 0 is translation, the midpoint is the follow
law, the ends are the saturated rotations. Arc ends move while the target moves; their rates
(:func:`edge_end_rate`, :func:`vertex_end_rate`) are the compliant motions of §5.

All functions are vectorized with numpy broadcasting. Lengths in map units, velocities in map
units per second, angles in radians, rates in radians per second.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "edge_end_rate", "observer_velocity", "rate_interval", "step_rate_interval", "vertex_end_rate"
]


def rate_interval(v: Any, a: Any, lss: float, vo: float) -> tuple[np.ndarray, np.ndarray]:
    """The interval ``Ω(v, a) = [lo, hi]`` of rod rates that keep ``|Vo| <= vo``.

    Parameters
    ----------
    v : array_like, shape (..., 2)
        Target velocity; ``|v| <= vo`` is assumed (then ``lo <= 0 <= hi``).
    a : array_like
        Rod orientation (radians), broadcast against ``v[..., 0]``.
    lss, vo : float
        Rod length and observer speed bound.

    Returns
    -------
    lo, hi : ndarray
        ``(∓sqrt(vo² − v_r²) − v_s) / lss`` with ``v_r = v·u(a)``, ``v_s = v·u⊥(a)``.

    Examples
    --------
    A target running at 0.5 across a rod of length 1 pointing along +x (radians per second):

    >>> from tether.rates import rate_interval
    >>> lo, hi = rate_interval([0.0, 0.5], 0.0, lss=1.0, vo=1.0)
    >>> round(float(lo), 3), round(float(hi), 3)
    (-1.5, 0.5)
    """
    v = np.asarray(v, dtype=float)
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    vr = v[..., 0] * c + v[..., 1] * s
    vs = -v[..., 0] * s + v[..., 1] * c
    root = np.sqrt(np.maximum(vo * vo - vr * vr, 0.0))
    return (-root - vs) / lss, (root - vs) / lss


def observer_velocity(v: Any, a: Any, rate: Any, lss: float) -> np.ndarray:
    """Observer velocity ``Vo = v + lss·ȧ·u⊥(a)`` (C1), shape ``(..., 2)``."""
    v = np.asarray(v, dtype=float)
    a = np.asarray(a, dtype=float)
    r = lss * np.asarray(rate, dtype=float)
    return np.stack([v[..., 0] - r * np.sin(a), v[..., 1] + r * np.cos(a)], axis=-1)


def edge_end_rate(v: Any, b: Any, normal: Any, lss: float) -> np.ndarray:
    """Rate of an arc end ``b`` held by an edge (tip on the edge, free-side unit ``normal``).

    ``ḃ = −(n·v) / (lss·(n·u⊥(b)))``; infinite where the rod is parallel to the edge.
    """
    v = np.asarray(v, dtype=float)
    n = np.asarray(normal, dtype=float)
    b = np.asarray(b, dtype=float)
    den = lss * (-n[..., 0] * np.sin(b) + n[..., 1] * np.cos(b))
    num = -(n[..., 0] * v[..., 0] + n[..., 1] * v[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        return num / den


def vertex_end_rate(v: Any, p: Any, vertex: Any) -> np.ndarray:
    """Rate of an arc end held by a reflex vertex (rod grazing ``vertex``, target at ``p``).

    ``ḃ = −(d × v) / |d|²`` with ``d = vertex − p``.
    """
    v = np.asarray(v, dtype=float)
    d = np.asarray(vertex, dtype=float) - np.asarray(p, dtype=float)
    cross = d[..., 0] * v[..., 1] - d[..., 1] * v[..., 0]
    return -cross / (d[..., 0] ** 2 + d[..., 1] ** 2)


def step_rate_interval(v: Any, a: Any, lss: float, vo: float, dt: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The rod rates that keep the observer's *chord* over a step of ``dt`` s within ``vo·dt``.

    A sampled controller holds ``v`` and ``ȧ`` over the step: the target moves by ``v·dt`` and
    the rod turns by ``h = ȧ·dt``, so the observer moves by
    ``D = v·dt + lss·(u(a + h) − u(a))``. With ``w = v·dt − lss·u(a)``, ``|D| <= vo·dt`` iff
    ``cos(a + h − φ_w) <= k`` where ``φ_w = arg w`` and
    ``k = ((vo·dt)² − |w|² − lss²) / (2·lss·|w|)``: an interval of ``h`` containing 0 whenever
    ``|v| <= vo``. Exact, vectorized; it tends to :func:`rate_interval` as ``dt → 0``.

    Returns
    -------
    lo, hi : ndarray
        Bounds on ``ȧ`` (rad/s); when every turn is feasible (``k >= 1``) the bounds are ``∓π/dt``.
    """
    v = np.asarray(v, dtype=float)
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    vr = (v[..., 0] * c + v[..., 1] * s) * dt  # radial and tangential travel over the step
    vs = (-v[..., 0] * s + v[..., 1] * c) * dt
    # |w| − lss and 1 + k in forms free of cancellation (the interval is narrow when dt is small)
    wn = np.hypot(lss - vr, vs)
    w_minus_l = (vr * vr + vs * vs - 2.0 * lss * vr) / (wn + lss)
    with np.errstate(divide="ignore", invalid="ignore"):
        half = ((vo * dt) ** 2 - w_minus_l ** 2) / (4.0 * lss * wn)  # (1 + k) / 2
    beta = 2.0 * np.arcsin(np.sqrt(np.clip(half, 0.0, 1.0)))
    delta = np.arctan2(vs, lss - vr)
    full = half >= 1.0
    lo = np.where(full, -np.pi / dt, np.minimum(-beta - delta, 0.0) / dt)
    hi = np.where(full, np.pi / dt, np.maximum(beta - delta, 0.0) / dt)
    return lo, hi
