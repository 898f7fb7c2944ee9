"""Critical curves (``docs/formulas.md``, "Critical curves"): exact parametric objects and
their polyline approximation.

The labelled free-arc structure of a target point changes only across these curves. Each is
the locus of target points ``q`` whose *event rod* ``[q, q + lss u(a*)]`` touches features in a
special way:

====  ===============================  ===================================  ================
kind  curve                            parameter                            event rod
====  ===============================  ===================================  ================
A     offset of edge ``Ei`` at lss     ``s`` in (0, 1) along the edge       tip on ``Ei``
B     circle of radius lss about V_j   ``φ`` in [0, 2π), direction from V_j tip at ``V_j``
C     extension of an edge through a   ``t`` in (0, lss], distance from V_j along the edge,
      reflex vertex V_j                                                     grazes ``V_j``
D     line through reflex V1, V2       ``t`` in (0, lss - |V1V2|], beyond   grazes both
      (|V1V2| < lss), beyond V1        V1
E     conchoid: pole reflex V_j, base  ``s`` along ``Ei`` where |V_j-Q|<lss grazes ``V_j``,
      edge ``Ei``                                                           tip on ``Ei``
====  ===============================  ===================================  ================

A point of a candidate curve is critical iff its event rod is semi-free (in the closed free
space). Freeness can change along a candidate only at its exact breakpoints (the rod sweeping
across a vertex, an end of the rod crossing an edge): tether tests each candidate just either
side of every breakpoint and once between consecutive ones, keeps the runs of semi-free
samples, pins each run's ends by bisection and then lets them overshoot by a small margin
(an end of a critical
part lies on another curve; overshooting only adds a dangling bit, undershooting would leave a
gap between two regions). Including non-critical bits is harmless: faces with equal structure
are merged later.

The package, in pipeline order: :mod:`~tether.curves.families` (the candidate curves of the
five kinds, :class:`Family` and :class:`Curve`), :mod:`~tether.curves.critical` (their
critical parts: breakpoints, semi-free tests, bisection, the parts lying on walls),
:mod:`~tether.curves.draw` (overshoot, polylines with their exact marks, the vertex
estimate), :mod:`~tether.curves.share` (straight curves on one line made to share their
vertices) and :mod:`~tether.curves.project` (projection of points onto the curves).
:func:`critical_curves` runs them in that order; it and the vertex bound
:data:`MAX_CURVE_VERTICES` live here so that ``tether.curves.MAX_CURVE_VERTICES = ...`` keeps
taking effect. :mod:`~tether.curves.budget` estimates a decomposition's memory before any
curve is computed and refuses what does not fit the memory budget (the default ceiling).
"""

from __future__ import annotations

from concurrent.futures import Executor

from tether._util.memory import release_memory
from tether.curves.budget import check_exact
from tether.curves.critical import ON_WALL_TOLS as ON_WALL_TOLS
from tether.curves.critical import critical_intervals as critical_intervals
from tether.curves.critical import off_walls, wall_band
from tether.curves.draw import draw_all, overshoot_family, vertex_estimates
from tether.curves.families import (
    KIND_NAMES,
    KINDS,
    Curve,
    Family,
    candidate_families,
    curves_to_user,
)
from tether.curves.project import project_many
from tether.curves.share import share_lines
from tether.curves.tasks import family_intervals
from tether.environment import Environment
from tether.errors import ResourceLimitError
from tether.tolerances import REL_CURVE_TOL

__all__ = ["KINDS", "KIND_NAMES", "MAX_CURVE_VERTICES", "Curve", "Family", "ResourceLimitError",
           "candidate_families", "check_vertex_budget", "critical_curves", "curves_to_user",
           "project_many"]


#: Refuse decompositions whose curves would need more polyline vertices (estimated) than
#: this, when set to a number. The default ceiling is the memory budget instead
#: (:mod:`tether.curves.budget`: ``--memory-limit``, ``TETHER_MEMORY_LIMIT``, else what the
#: machine lets this process use); setting this adds a fixed ceiling of its own (until
#: 2026-11 it was 1,500,000, about 2 GB).
MAX_CURVE_VERTICES: int | None = None


def check_vertex_budget(vertices: float, lss: float) -> None:
    """Raise :class:`ResourceLimitError` (one line) if ``vertices`` (the exact estimate made
    after the critical intervals) exceeds :data:`MAX_CURVE_VERTICES`, when that is set (the
    memory budget is checked by :func:`tether.curves.budget.check_exact`)."""
    if MAX_CURVE_VERTICES is not None and vertices > MAX_CURVE_VERTICES:
        raise ResourceLimitError(
            f"the critical curves at lss {lss:g} (internal units) would need about "
            f"{vertices:,.0f} polyline vertices, more than the limit {MAX_CURVE_VERTICES:,} "
            "(tether.curves.MAX_CURVE_VERTICES): use a smaller lss, "
            "a coarser curve tolerance, or split the map")


def critical_curves(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL,
                    executor: Executor | None = None) -> list[Curve]:
    """All candidate curves with a critical part, each with its polylines.

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units.
    rel_tol : float
        Polyline approximation tolerance relative to the map diameter.
    executor : concurrent.futures.Executor, optional
        Computes the critical intervals in tasks (:mod:`tether.curves.tasks`: the same
        curves, bit for bit); None: in this process.

    Returns
    -------
    list of Curve
        In the order A, B, C, D, E, then by feature; curves with no critical part are dropped.

    Examples
    --------
    In a rectangle only walls and corners matter: one offset (A) per wall and one circle (B) per
    corner.

    >>> from tether import Environment
    >>> from tether.curves import critical_curves
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> [curve.kind for curve in critical_curves(room, 1.0)]
    ['A', 'A', 'A', 'A', 'B', 'B', 'B', 'B']
    """
    if not env.is_internal:  # computed in the normalized frame, reported in the user's
        names = env.feature_names_map()
        return curves_to_user(critical_curves(env.internal, lss * env.frame.scale, rel_tol,
                                              executor), env.frame, names)
    tol = rel_tol * env.diameter
    margin = 20 * tol
    curves: list[Curve] = []
    found = []
    first = env.coincident
    walls = None
    for fam, ivs in family_intervals(env, candidate_families(env, lss), executor):
        if fam.kind == "B":  # touching rings: one circle per point (see ``families._family_b``)
            ivs = [iv if first[c] == c else [] for c, iv in enumerate(ivs)]
        if fam.kind in "ACD":
            walls = wall_band(env) if walls is None else walls
            ivs = off_walls(fam, ivs, walls)
        found += overshoot_family(fam, ivs, margin)
        release_memory()  # the family's temporaries, returned before the next one's
    estimates = vertex_estimates(found, tol)
    vertices = sum(estimates)
    check_vertex_budget(vertices, lss)
    check_exact(env, lss, vertices)
    drawn_all = draw_all(found, tol, estimates)
    domains = {id(fam): (fam.lo.tolist(), fam.hi.tolist())
               for fam in {id(f): f for f, _, _ in found}.values()}
    for (fam, c, ivs), drawn in zip(found, drawn_all, strict=True):
        lo, hi = domains[id(fam)]
        # ``ivs`` are pairs of floats already (:func:`~tether.curves.draw.overshoot_family`)
        curves.append(Curve(len(curves), fam.kind, fam.features[c], (lo[c], hi[c]),
                            tuple(ivs), tuple(p for _, p in drawn),
                            tuple(t for t, _ in drawn), fam, c))
    return share_lines(curves, env.length_tol)
