"""A hand-built arc field for an open room at any speed ratio, certified by the exact checks
(``docs/certified.md``, "Where no field is certified": vt/vo = 0.9).

The search (:mod:`tether.game.field_lp`) has no core model above ``vt/vo = 1/√2``. In a room
that is wide against ``lss`` a *radial* field needs none: around a centre ``c``, with ``ρ``
and ``ψ`` the polar radius and angle of the target, the arc at ``p`` is

- the whole circle for ``ρ <= ρ1`` (a disc clear of walls by more than ``lss``),
- ``[ψ + π − α(ρ), ψ + π + α(ρ)]`` beyond: centred on the direction from the target to
  ``c``, with a half-width ``α`` that falls from ``π`` at ``ρ1`` to ``alpha_wall`` and stays
  there up to the walls.

Both ends have the form ``ψ + π + κ(ρ)``. In the rod's frame ``u = u(end)``,
``u⊥ = u(end + π/2)``, check 3 on an end with gradient ``G`` asks, for every target velocity
``v`` with ``|v| <= vt``, ``v·(lss·G + u⊥) <= sqrt(vo² − (v·u)²)`` (lower end; the upper end
is the same with ``v`` and ``−v`` exchanged). The right side is the support function of the
ellipse with semi-axes ``sqrt(vo² − vt²)/vt`` along ``u`` and ``vo/vt`` along ``u⊥``: the end
can follow the target iff ``lss·G + u⊥`` lies in that ellipse. For an end pointing *away*
from ``c`` (``κ = π``) with ``α`` constant, ``lss·G + u⊥ = (1 + lss/ρ)·u⊥``, so the end is
followed only for ``ρ >= lss·vt/(vo − vt)`` (9 ``lss`` at 0.9): the observer, ``lss`` beyond
the target on the same ray, must turn about ``c`` as fast as the target does. Every radial
field has such an end somewhere (its gap opens at ``ρ1`` and must end up away from ``c``),
hence ``ρ1`` and a room wide against ``lss``.

:func:`radial_profile` tabulates ``α(ρ)``: from the smallest ``ρ1`` where the whole circle
may open, ``α`` falls as fast as :func:`~tether.game.certificate.end_slack` (the checks' own
bound) allows with a slack ``need`` left over, on a range of orientations as wide as a
triangle of the mesh spans. :func:`radial_field` puts it on the mesh of
:func:`~tether.game.certificate.free_mesh` and runs :func:`~tether.game.certificate.certify`:
the profile is only a search, the checks are the proof.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game.certificate import ArcField, certify, end_slack, free_mesh
from tether.game.certified import CertifiedKernel

__all__ = ["ALPHA_WALL", "NEED", "radial_field", "radial_profile"]

#: Half-width (radians) of the arcs near the walls: the direction to the centre of a square
#: room lies within π/4 of every wall's inward normal, so π/5 leaves 9° to spare at corners.
ALPHA_WALL = math.pi / 5
#: Slack (map units per second, in units of ``lss·rate``) each end keeps at the profile's
#: samples, above the checks' own :data:`~tether.game.certificate.MARGIN`.
NEED = 0.015
_STEP = 0.05  # profile step in ρ, in units of lss
_RATES = np.linspace(0.0, 1.0, 41)  # candidate −lss·dα/dρ per step


def _slack(rho: float, alpha: float, n: np.ndarray, vt: float, vo: float,
           span: float) -> np.ndarray:
    """The smaller end slack of :func:`end_slack` at radius ``rho`` (lss units), half-width
    ``alpha`` and each rate ``n = −lss·α'``, with the ends' orientation ranges widened by
    ``(n + 1/ρ)·span`` (how far an end moves across a triangle of diameter ``span·lss``)."""
    k = len(n)
    d = (n + 1.0 / rho) * span
    g_lo = np.stack([n, np.full(k, 1.0 / rho)], axis=1)  # polar frame at ψ = 0
    g_hi = np.stack([-n, np.full(k, 1.0 / rho)], axis=1)
    s_lo = end_slack(g_lo, math.pi - alpha - d, math.pi - alpha + d, 1.0, vt, vo, False)
    s_hi = end_slack(g_hi, math.pi + alpha - d, math.pi + alpha + d, 1.0, vt, vo, True)
    return np.minimum(s_lo, s_hi)


def radial_profile(vt: float, vo: float, span: float = 1.0, need: float = NEED,
                   alpha_wall: float = ALPHA_WALL, rho_max: float = 200.0,
                   rho_start: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """The half-width ``α(ρ)`` of a radial field, for ``lss`` = 1.

    Parameters
    ----------
    vt, vo : float
        Speeds, ``0 < vt < vo`` (lss per second).
    span : float
        Diameter of the mesh's triangles in units of ``lss``: each end is checked on the range
        of orientations it takes across such a triangle.
    need : float
        Slack the ends keep (units of ``lss·rate``, lss per second).
    alpha_wall : float
        Half-width (radians) where the profile stops falling.
    rho_max : float
        Give up beyond this radius (lss).
    rho_start : float
        The smallest radius (lss) tried for ``ρ1``.

    Returns
    -------
    rho, alpha : ndarray
        Radii (units of ``lss``, from ``ρ1`` where the whole circle opens) and the
        half-widths there (radians, ``π`` at ``ρ1``, ``alpha_wall`` at the last one), every 0.05.

    Raises
    ------
    InvalidParameterError
        If the profile does not reach ``alpha_wall`` within ``rho_max``.

    Examples
    --------
    >>> from tether.game.radial import radial_profile
    >>> rho, alpha = radial_profile(0.3, 1.0, alpha_wall=2.5)  # doctest: +SKIP
    >>> float(rho[0]), float(alpha[0]), float(alpha[-1])  # doctest: +SKIP
    (0.5, 3.141592653589793, 2.5)
    """
    rho = rho_start
    while _slack(rho, math.pi, np.zeros(1), vt, vo, span)[0] < need:
        rho += _STEP
        if rho > rho_max:
            raise InvalidParameterError(f"no radial field: the whole circle cannot open "
                                        f"within {rho_max:g} lss at vt/vo = {vt / vo:g}")
    radii, halves, alpha = [rho], [math.pi], math.pi
    while alpha > alpha_wall:
        ok = _RATES[_slack(rho, alpha, _RATES, vt, vo, span) >= need]
        alpha = max(alpha - (ok.max() if len(ok) else 0.0) * _STEP, alpha_wall)
        rho += _STEP
        radii.append(rho)
        halves.append(alpha)
        if rho > rho_max:
            raise InvalidParameterError(f"no radial field: the arcs do not narrow to "
                                        f"{alpha_wall:g} rad within {rho_max:g} lss")
    return np.array(radii), np.array(halves)


def radial_field(env: Environment, lss: float, vt: float, vo: float, h: float,
                 center: tuple[float, float] | None = None, need: float = NEED,
                 alpha_wall: float = ALPHA_WALL) -> CertifiedKernel:
    """The radial field of :func:`radial_profile` on the mesh of spacing ``h``, checked.

    Parameters
    ----------
    env : Environment
        The map (an open room: the field has no cores around obstacles).
    lss, vt, vo : float
        Rod length (map units) and speeds (map units per second).
    h : float
        Mesh spacing (map units); the profile is checked on triangles of diameter ``2·h``.
    center : (float, float), optional
        The centre ``c`` (map units; default the middle of the map's bounding box).
    need, alpha_wall : float
        As in :func:`radial_profile`.

    Returns
    -------
    CertifiedKernel
        In the identity frame; ``certified`` says whether every check passed (only then is
        anything claimed). ``log`` holds ``{"radial": ...}`` with the profile's ``ρ1`` and end.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.game.radial import radial_field
    >>> room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])
    >>> ck = radial_field(room, 0.15, 0.9, 1.0, h=0.075)  # doctest: +SKIP
    >>> ck.certified  # doctest: +SKIP
    True
    """
    if not (math.isfinite(h) and h > 0):
        raise InvalidParameterError(f"the mesh spacing h must be a finite number > 0, got {h}")
    t0 = time.perf_counter()
    x0, y0, x1, y1 = env.bounds
    c = np.array([(x0 + x1) / 2, (y0 + y1) / 2] if center is None else center, dtype=float)
    radii, halves = radial_profile(vt, vo, span=2 * h / lss, need=need, alpha_wall=alpha_wall)
    xs, ys = np.arange(x0, x1 + h / 2, h), np.arange(y0, y1 + h / 2, h)
    lattice = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    pts, tri, _ = free_mesh(env, h, lattice)
    d = pts - c
    rho, psi = np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0])
    alpha = np.interp(rho, radii * lss, halves)
    whole = alpha >= math.pi
    lo = np.where(whole, psi, psi + math.pi - alpha)  # whole circles: the gap centre is ψ
    w = np.where(whole, math.tau, 2 * alpha)
    f = ArcField(pts, tri, lo, w)
    checks = certify(f, env, lss, vt, vo)
    log = [{"radial": {"center": c.tolist(), "rho1": float(radii[0] * lss),
                       "rho_wall": float(radii[-1] * lss), "alpha_wall": alpha_wall}}]
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0)
