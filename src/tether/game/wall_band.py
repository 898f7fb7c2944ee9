"""A hand-built arc field for a map with holes at any speed ratio: whole circles away from the
walls, partial arcs in a band along them (``docs/certified.md``, "Where no field is certified":
the gallery at 0.9), checked by :func:`~tether.game.certificate.certify`.

Near a wall an arc must leave out the directions into it; far from every wall (more than
``lss``) every orientation is free, and a whole-circle arc needs no lift and no end check. So
the arcs here are the whole circle in a *core* (the points at least ``depth`` from every wall,
its convex corners rounded along circles of radius ``rounding``) and ``[θ − α, θ + α]`` in the
band between the core and the walls:

- ``α`` is a function of the depth in the band (:func:`band_depth`, the distance to the walls
  along straight walls): :func:`wall_profile` widens it from ``alpha_wall`` at the wall to
  ``π`` at the core as fast as the checks' own bound allows on a straight wall, times ``pace``.
- ``θ`` points into the core: the direction to its nearest point (:func:`core_direction`, the
  core shrunk by ``inset``), or (``direction="saddle"``) the harmonic direction of
  :func:`saddle_direction`, with one prescribed zero of index −1.

The gap direction must wind once around the outer boundary and once around every hole
(Poincaré–Hopf: singular points of total index ``1 − k`` with ``k`` holes). With the core a
single region that holds every singular point, none needs a core of its own: the saddle of
``direction="saddle"`` lies in it, and :func:`core_direction` has no singular point in the
band at all. What costs is the band: the ends turn with ``θ`` where the core's edge bends
(the radial field's bound: at its rounded corners the core's edge needs a radius of about
``lss·vt/(vo − vt)``, :mod:`tether.game.radial`), and around an obstacle's convex corner.
The construction is only a search: :func:`certify` is the proof.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse.linalg import splu
from scipy.spatial import cKDTree

from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game.certificate import ArcField, certify, end_slack, free_mesh, hat_gradients
from tether.game.certified import CertifiedKernel
from tether.game.radial import radial_profile

__all__ = ["arc_halfwidth", "band_depth", "core_direction", "rounded_core", "saddle_direction",
           "wall_band_field", "wall_loops", "wall_profile"]

_TAU = math.tau
#: Segments per quarter circle of the core's arcs: the direction to a polygon's nearest point
#: is constant along each segment and turns in fans at its vertices, so the segments must be
#: much shorter than the mesh's edges for the interpolated direction to turn smoothly.
_SEGS = 1024


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles (radians) into ``(-π, π]``, by the complex argument."""
    return np.angle(np.exp(1j * np.asarray(x)))


def wall_loops(env: Environment, h: float, points: np.ndarray
               ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The wall points of :func:`free_mesh` (spacing ``h/2`` or closer) loop by loop, in order.

    Returns, per ring of ``env`` (the outer boundary first): ``(index, normal, s)`` with
    ``index`` the mesh vertex of each wall point in ``points``, ``normal`` the inward normal's
    angle (radians; at a wall vertex the bisector of its two walls' normals) and ``s`` the
    arclength along the loop (map units)."""
    A, B, _, _ = env.oriented_edges
    nrm = env.free_normals
    tree = cKDTree(points)
    out, start = [], 0
    for ring in env.rings:
        k = len(ring)
        idx, ang, arc, s = [], [], [], 0.0
        for e in range(start, start + k):
            a, b = A[e], B[e]
            length = float(np.hypot(*(b - a)))
            n = max(1, math.ceil(length / (h / 2)))
            t = np.arange(n) / n
            piece = a + t[:, None] * (b - a)
            prev = start + (e - start - 1) % k
            bis = nrm[e] + nrm[prev]
            angles = np.full(n, math.atan2(nrm[e][1], nrm[e][0]))
            angles[0] = math.atan2(bis[1], bis[0])
            dist, j = tree.query(piece)
            if dist.max() > 1e-9 * max(1.0, h):
                raise InvalidParameterError("the wall points are not vertices of the mesh")
            idx.append(j)
            ang.append(angles)
            arc.append(s + t * length)
            s += length
        out.append((np.concatenate(idx), np.concatenate(ang), np.concatenate(arc)))
        start += k
    return out


def _smoothed(angle: np.ndarray, s: np.ndarray, total: float, smooth: float,
              tilt: float) -> np.ndarray:
    """The normals' angles averaged (as unit vectors) with a Gaussian of width ``smooth`` in
    arclength around the closed loop of length ``total``, kept within ``tilt`` of ``angle``."""
    if smooth <= 0:
        return angle.copy()
    d = s[:, None] - s[None, :]
    d = d - total * np.round(d / total)
    wgt = np.exp(-0.5 * (d / smooth) ** 2)
    z = wgt @ np.exp(1j * angle)
    dev = np.clip(_wrap(np.angle(z) - angle), -tilt, tilt)
    return angle + dev


def _singular(points: np.ndarray, z0: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """``S(p) = −arg(p − z0) + Σ_j arg(p − c_j)`` (radians, wrapped) at each point."""
    d = points - z0
    s = -np.arctan2(d[:, 1], d[:, 0])
    for c in centres:
        d = points - c
        s = s + np.arctan2(d[:, 1], d[:, 0])
    return _wrap(s)


def saddle_direction(env: Environment, points: np.ndarray, tri: np.ndarray, h: float,
                     z0: tuple[float, float], smooth: float = 0.0, tilt: float = 0.0,
                     weight: np.ndarray | None = None) -> np.ndarray:
    """The direction ``θ`` (radians, one value per vertex of the mesh ``points``, ``tri`` of
    :func:`free_mesh` at spacing ``h``) of the module docstring: index ``−1`` at ``z0`` and
    ``+1`` around a point inside each hole, harmonic otherwise, the walls' inward normals
    (smoothed over ``smooth`` map units, within ``tilt`` radians of the normal) on the walls.
    ``weight`` (per triangle, default 1) weighs each triangle's term of the energy: a small
    weight lets the direction turn there (in the core, where it does not matter).

    Raises
    ------
    InvalidParameterError
        If ``z0`` is not in the free space or the boundary data do not close around a loop
        (``z0`` must lie in the outer boundary, outside every hole).
    """
    z = np.asarray(z0, dtype=float)
    if not shapely.contains_xy(env.polygon, z[0], z[1]):
        raise InvalidParameterError(f"the saddle {tuple(z)} is not in the free space")
    centres = np.array([shapely.Polygon(r).representative_point().coords[0]
                        for r in env.rings[1:]]).reshape(-1, 2)
    S = _singular(points, z, centres)
    xy = points[tri]
    hat = hat_gradients(xy)
    area = 0.5 * np.abs((xy[:, 1, 0] - xy[:, 0, 0]) * (xy[:, 2, 1] - xy[:, 0, 1])
                        - (xy[:, 1, 1] - xy[:, 0, 1]) * (xy[:, 2, 0] - xy[:, 0, 0]))
    st = S[tri]
    lift = np.stack([st[:, 0], st[:, 0] + _wrap(st[:, 1] - st[:, 0]),
                     st[:, 0] + _wrap(st[:, 2] - st[:, 0])], axis=1)
    gs = np.einsum("tvk,tv->tk", hat, lift)
    winds = np.abs(_wrap(st[:, 1] - st[:, 0]) + _wrap(st[:, 2] - st[:, 1])
                   + _wrap(st[:, 0] - st[:, 2])) > 1.0
    gs[winds] = 0.0  # the triangle holding z0: its gradient is not a lift of S
    if weight is not None:
        area = area * weight
    n = len(points)
    # stiffness K = Σ_T area·hat_i·hat_j and the load of S: b_i = −Σ_T area·hat_i·∇S_T
    kij = np.einsum("t,tik,tjk->tij", area, hat, hat)
    rows = np.repeat(tri, 3, axis=1).ravel()
    cols = np.tile(tri, (1, 3)).ravel()
    K = sparse.csr_matrix((kij.ravel(), (rows, cols)), shape=(n, n))
    b = -np.bincount(tri.ravel(), weights=np.einsum("t,tik,tk->ti", area, hat, gs).ravel(),
                     minlength=n)
    loops = wall_loops(env, h, points)
    data = np.zeros(n)
    on_wall = np.zeros(n, dtype=bool)
    member = []
    for idx, ang, s in loops:
        total = float(s[-1] + np.hypot(*(points[idx[0]] - points[idx[-1]])))
        target = _smoothed(ang, s, total, smooth, tilt) - S[idx]
        step = _wrap(np.diff(np.append(target, target[0])))
        if abs(step.sum()) > 1e-6:
            raise InvalidParameterError("the walls' normals do not close around a loop: "
                                        "the saddle must lie inside the outer boundary")
        lifted = target[0] + np.concatenate([[0.0], np.cumsum(step[:-1])])
        lifted -= _TAU * np.round(lifted.mean() / _TAU)
        data[idx] = lifted
        on_wall[idx] = True
        member.append(idx)
    used = np.zeros(n, dtype=bool)
    used[tri] = True  # free_mesh keeps lattice points inside holes too: no triangle there
    inner = np.flatnonzero(used & ~on_wall)
    wall = np.flatnonzero(on_wall)
    lu = splu(K[inner][:, inner].tocsc())
    k_iw = K[inner][:, wall]

    def solve(bdata: np.ndarray) -> np.ndarray:
        phi = np.zeros(n)
        phi[wall] = bdata[wall]
        phi[inner] = lu.solve(b[inner] - k_iw @ bdata[wall])
        return phi

    def energy(phi: np.ndarray) -> float:
        g = np.einsum("tvk,tv->tk", hat, phi[tri]) + gs
        return float((area * (g * g).sum(axis=1)).sum())

    # the holes' data are defined up to 2π each: φ is affine in those multiples, so its
    # energy is a quadratic in them; the least one among small multiples is taken
    base = solve(data)
    units = []
    for idx in member[1:]:
        unit = np.zeros(n)
        unit[idx] = _TAU
        units.append(solve(unit) - solve(np.zeros(n)))
    best, best_e = base, energy(base)
    for ks in itertools.product(range(-2, 3), repeat=len(units)):
        phi = base + sum((k * u for k, u in zip(ks, units, strict=True)), np.zeros(n))
        e = energy(phi)
        if e < best_e - 1e-12:
            best, best_e = phi, e
    return _wrap(S + best)


_RATES = np.linspace(0.0, 3.0, 301)  # candidate lss·dα/dd on a straight wall


def wall_profile(vt: float, vo: float, alpha_wall: float, need: float = 0.015,
                 pace: float = 1.0, steps: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """How fast the arcs may widen away from a straight wall, for ``lss`` = 1.

    Along a straight wall the arc's centre is the wall's inward normal ``n`` and only the
    half-width ``α`` changes, with gradient ``r·n`` (``r = dα/dd``): the ends ``∓α`` have
    gradients ``∓r·n``. At each of ``steps`` half-widths from ``alpha_wall`` to ``π`` the
    largest ``r`` (on a grid of 0.01) whose :func:`~tether.game.certificate.end_slack` at
    both ends is at least ``need`` is taken, times ``pace``; ``d(α) = ∫ dα / r``.

    Returns
    -------
    d, alpha : ndarray
        Distances from where the widening starts (units of ``lss``) and the half-widths there
        (radians, from ``alpha_wall`` to ``π``).

    Raises
    ------
    InvalidParameterError
        If some half-width admits no widening at all.
    """
    alpha = np.linspace(alpha_wall, math.pi, steps + 1)
    G = np.stack([_RATES, np.zeros_like(_RATES)], axis=1)
    rate = np.empty(len(alpha))
    for i, a in enumerate(alpha):
        s_lo = end_slack(-G, np.full(len(G), -a), np.full(len(G), -a), 1.0, vt, vo, False)
        s_hi = end_slack(G, np.full(len(G), a), np.full(len(G), a), 1.0, vt, vo, True)
        ok = _RATES[np.minimum(s_lo, s_hi) >= need]
        if not len(ok) or ok.max() <= 0:
            raise InvalidParameterError(f"the arcs cannot widen at half-width {a:.3f} rad "
                                        f"at vt/vo = {vt / vo:g}")
        rate[i] = pace * ok.max()
    # the slower of each step's two ends bounds the step
    slow = np.minimum(rate[:-1], rate[1:])
    d = np.concatenate([[0.0], np.cumsum(np.diff(alpha) / slow)])
    return d, alpha


def _round_corners(poly, radius: float, reach: float = 0.5):
    """``poly`` with each convex corner of its rings (interior angle below 179°) cut along
    the circle of radius ``radius`` (map units) tangent to its two sides (smaller where a side
    is short: the tangent points stay within half of each side)."""
    cuts = []
    rings = [poly.exterior, *poly.interiors] if poly.geom_type == "Polygon" else []
    for k, ring in enumerate(rings):
        c = np.asarray(ring.coords)[:-1]
        left = ring.is_ccw if k == 0 else not ring.is_ccw  # the polygon on the left
        for i in range(len(c)):
            v = c[i]
            e1, e2 = c[i - 1] - v, c[(i + 1) % len(c)] - v
            l1, l2 = float(np.hypot(*e1)), float(np.hypot(*e2))
            cross = e1[0] * e2[1] - e1[1] * e2[0]
            phi = math.acos(max(-1.0, min(1.0, float(e1 @ e2) / (l1 * l2))))
            if not ((cross < 0) if left else (cross > 0)) or phi > math.radians(179):
                continue
            t = min(radius / math.tan(phi / 2), reach * l1, reach * l2)  # to the tangent points
            r = t * math.tan(phi / 2)
            bis = e1 / l1 + e2 / l2
            centre = v + bis / np.hypot(*bis) * r / math.sin(phi / 2)
            wedge = shapely.Polygon([v, v + e1 / l1 * t, v + e2 / l2 * t])
            cuts.append(wedge.difference(shapely.Point(centre).buffer(r, quad_segs=_SEGS)))
    return poly.difference(shapely.union_all(cuts)) if cuts else poly


def rounded_core(env: Environment, depth: float, rounding: float, reach: float = 0.5):
    """The points at least ``depth`` (map units) from every wall (a shapely geometry), their
    convex corners cut along circles of radius ``rounding`` (map units; 0: none) as
    :func:`_round_corners` does, ``reach`` as there.

    Raises
    ------
    InvalidParameterError
        If no point lies ``depth`` from every wall.
    """
    core = env.polygon.buffer(-depth, quad_segs=_SEGS)
    if rounding > 0:
        parts = getattr(core, "geoms", [core])
        core = shapely.union_all([_round_corners(q, rounding, reach) for q in parts])
    if core.is_empty:
        raise InvalidParameterError(f"no point lies {depth:g} from every wall")
    return core


def core_direction(core, points: np.ndarray, inset: float) -> np.ndarray:
    """The direction (radians) from each point to its nearest point of ``core`` shrunk by
    ``inset`` (map units); 0 where the point lies in it (there the arcs are whole circles)."""
    inner = core.buffer(-inset, quad_segs=_SEGS)
    lines = shapely.shortest_line(shapely.points(points[:, 0], points[:, 1]), inner)
    xy = shapely.get_coordinates(lines).reshape(-1, 2, 2)
    d = xy[:, 1] - xy[:, 0]
    return np.where(np.hypot(d[:, 0], d[:, 1]) > 0, np.arctan2(d[:, 1], d[:, 0]), 0.0)


def band_depth(core, points: np.ndarray, depth: float) -> np.ndarray:
    """``depth − distance to core`` (map units) at each point, ``depth`` inside the core: the
    distance to the walls along a straight wall; at a rounded corner of the core, ``depth``
    less the distance to its circle."""
    return depth - shapely.distance(core, shapely.points(points[:, 0], points[:, 1]))


def arc_halfwidth(d: np.ndarray, profile: tuple[np.ndarray, np.ndarray], lss: float
                  ) -> np.ndarray:
    """Half-width (radians) of the arcs at depth ``d`` (map units, :func:`band_depth`): the
    ``profile`` of :func:`wall_profile` (depths in units of ``lss``), ``π`` (the whole
    circle) beyond its end."""
    dp, ap = profile
    return np.interp(d / lss, dp, ap)


def wall_band_field(env: Environment, lss: float, vt: float, vo: float, h: float,
                    direction: str = "core", profile: str = "wall",
                    alpha_wall: float = math.pi / 6,
                    pace: float = 0.6, rounding: float | None = None, reach: float = 0.5,
                    inset: float | None = None, z0: tuple[float, float] | None = None,
                    smooth: float = 0.0, tilt: float = 0.0, core_weight: float = 1e-3
                    ) -> CertifiedKernel:
    """The field of the module docstring on the mesh of spacing ``h``, checked.

    Parameters
    ----------
    env : Environment
        The map.
    lss, vt, vo : float
        Rod length (map units) and speeds (map units per second).
    h : float
        Mesh spacing (map units; :func:`~tether.game.certificate.free_mesh`).
    direction : {"core", "saddle"}
        The arcs' centre: toward the core (:func:`core_direction`) or the harmonic direction
        with one saddle at ``z0`` (:func:`saddle_direction`).
    profile : {"wall", "corner"}
        The half-width across the band: :func:`wall_profile` (a straight wall's), or the
        radial field's (:func:`~tether.game.radial.radial_profile` from ``ρ = rounding``
        outward: the core's rounded corners then turn as its centre does; slower, so the band
        is deeper).
    alpha_wall, pace : float
        As in :func:`wall_profile` (``pace``: ``profile="wall"`` only); the band's depth is
        the profile's.
    rounding : float, optional
        Radius (map units) of the core's rounded corners (default ``16·lss``).
    reach : float
        As in :func:`rounded_core`.
    inset : float, optional
        As in :func:`core_direction` (default ``lss``).
    z0, smooth, tilt : optional
        As in :func:`saddle_direction` (``direction="saddle"`` only; ``z0`` required there).
    core_weight : float
        The harmonic direction's weight on whole-circle triangles (``weight`` of
        :func:`saddle_direction`; 1 on the others): the direction turns in the core.

    Returns
    -------
    CertifiedKernel
        In the identity frame; ``certified`` says whether every check passed (only then is
        anything claimed). ``log`` holds ``{"wall_band": ...}`` with the parameters.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.game.wall_band import wall_band_field
    >>> room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])
    >>> wall_band_field(room, 0.15, 0.9, 1.0, h=0.075).certified  # doctest: +SKIP
    True
    """
    if not (math.isfinite(h) and h > 0):
        raise InvalidParameterError(f"the mesh spacing h must be a finite number > 0, got {h}")
    if direction not in ("core", "saddle") or (direction == "saddle" and z0 is None):
        raise InvalidParameterError("direction must be 'core', or 'saddle' with z0")
    if profile not in ("wall", "corner"):
        raise InvalidParameterError(f"profile must be 'wall' or 'corner', got {profile!r}")
    rounding = 16 * lss if rounding is None else rounding
    inset = lss if inset is None else inset
    t0 = time.perf_counter()
    x0, y0, x1, y1 = env.bounds
    xs, ys = np.arange(x0, x1 + h / 2, h), np.arange(y0, y1 + h / 2, h)
    lattice = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    pts, tri, _ = free_mesh(env, h, lattice)
    if profile == "corner":  # the radial field's, from the core's corners outward
        radii, halves = radial_profile(vt, vo, span=2 * h / lss, alpha_wall=alpha_wall,
                                       rho_start=rounding / lss)
        rounding = float(radii[0]) * lss  # where the whole circle may open
        prof = ((radii[-1] - radii)[::-1], halves[::-1])
    else:
        prof = wall_profile(vt, vo, alpha_wall, pace=pace)
    depth = float(prof[0][-1]) * lss
    core = rounded_core(env, depth, rounding, reach)
    alpha = arc_halfwidth(band_depth(core, pts, depth), prof, lss)
    whole = alpha >= math.pi
    if direction == "core":
        theta = core_direction(core, pts, inset)
    else:
        weight = np.where(whole[tri].all(axis=1), core_weight, 1.0)
        theta = saddle_direction(env, pts, tri, h, z0, smooth, tilt, weight)
    lo = np.where(whole, theta + math.pi, theta - alpha)  # whole circles: the gap centre
    w = np.where(whole, _TAU, 2 * alpha)
    f = ArcField(pts, tri, _wrap(lo), w)
    checks = certify(f, env, lss, vt, vo)
    log = [{"wall_band": {"direction": direction, "profile": profile,
                          "alpha_wall": alpha_wall, "pace": pace,
                          "depth": depth, "rounding": rounding, "reach": reach,
                          "inset": inset, "z0": None if z0 is None else [float(z0[0]),
                                                                          float(z0[1])],
                          "smooth": smooth, "tilt": tilt, "core_weight": core_weight}}]
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0)
