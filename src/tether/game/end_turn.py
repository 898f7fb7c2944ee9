"""How fast an arc end of a certified field can turn along the map (check 3 of
:func:`~tether.game.certificate.certify`), and how far a half or whole turn needs
(``docs/certified.md``, "Big maps": why the office's doors do not bound its rod).

**The bound.** On a triangle the end ``e`` (``lo`` or ``hi``, radians) is linear with gradient
``G``. Check 3 asks, for every target velocity ``v = vt·u(θ)`` and the end's orientation ``a``,
``lss·G·v <= lss·Ωmax(v, a)`` (lower end) or ``lss·G·v >= lss·Ωmin(v, a)`` (upper end), with
``lss·Ωmax = sqrt(vo² − vt²cos²x) − vt·sin x`` and ``lss·Ωmin = −sqrt(vo² − vt²cos²x) −
vt·sin x`` (``x = θ − a``). In the frame ``(u(a), u⊥(a))`` and with ``H = lss·G + u⊥(a)``
(lower end), the lower end's condition reads ``H·u(θ) <= sqrt(vo² − vt²cos²x)/vt`` for every
``θ``: the right side is the support function of the ellipse ``K`` of semi-axes
``A = sqrt(vo² − vt²)/vt`` along ``u(a)`` and ``B = vo/vt`` along ``u⊥(a)`` (a norm, hence
convex), so the condition is ``H ∈ K``. The upper end's condition is ``−H ∈ K``, the same
since ``K`` is symmetric. So along a unit direction ``d`` at angle ``ψ`` from ``u(a)``, the
end's derivative ``G·d`` is at most ``t(ψ)/lss``, ``t(ψ)`` the distance from ``u⊥(a)`` (inside
``K``, as ``B > 1``) to ``K``'s boundary along ``d``, and at least ``−t(ψ + π)/lss``; both are
attained (a gradient ``G = t·d/lss`` passes check 3 before its margins).

**Turning.** Along a segment of direction ``d`` the end ``a(s)`` obeys
``da/ds <= t(angle(d) − a)/lss``; to turn by ``Δ`` it needs a length at least
``lss · min over a0 of ∫ over [a0, a0 + Δ] of dψ / t(ψ)`` (:func:`turn_length`; the same for
turning the other way, by the mirror symmetry of the game).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["end_rate", "turn_length"]


def end_rate(psi: np.ndarray | float, lss: float, vt: float, vo: float) -> np.ndarray:
    """The largest derivative (radians per map unit) of an arc end along a direction at angle
    ``psi`` (radians) from the end's orientation that check 3 allows (module docstring):
    ``t(psi)/lss``. Its least derivative along that direction is ``−end_rate(psi + π)``."""
    c, s = np.cos(psi), np.sin(psi)
    a2 = (vo * vo - vt * vt) / (vt * vt)
    b2 = (vo / vt) ** 2
    q = c * c / a2 + s * s / b2  # (t·c/A)² + (1 + t·s)²/B² = 1, a quadratic in t
    p = s / b2
    t = (-p + np.sqrt(p * p - q * (1 / b2 - 1))) / q
    return t / lss


def turn_length(delta: float, lss: float, vt: float, vo: float, n: int = 20_000) -> float:
    """The shortest segment (map units) along which an arc end can turn by ``delta`` radians
    (``0 < delta <= 2π``) under check 3: ``min over a0`` of ``∫ dψ / end_rate(ψ)`` over a
    window of length ``delta`` (midpoint rule on ``n`` points a turn; the integrand is smooth
    and positive, the error far below the digits printed)."""
    if not 0 < delta <= math.tau:
        raise ValueError(f"delta must be in (0, 2π], got {delta!r}")
    psi = (np.arange(n) + 0.5) * (math.tau / n)
    inv = 1.0 / end_rate(psi, lss, vt, vo) * (math.tau / n)
    k = max(1, round(delta / math.tau * n))
    run = np.concatenate([inv, inv[:k]]).cumsum()
    windows = run[k - 1:k - 1 + n] - np.concatenate([[0.0], run[:n - 1]])
    return float(windows.min())
