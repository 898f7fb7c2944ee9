"""Adaptive refinement of the certified kernel (``docs/certified.md``, "Adaptive refinement"):
split the mesh's triangles only where the certified field and the optimistic grid kernel
disagree, carry the field over unchanged, and widen it again by the sequential LP.

**The split** (:func:`bisect`) is newest-vertex bisection with closure. Each triangle keeps
its *refinement edge* opposite its local vertex 0 (at the start, its longest edge:
:func:`longest_edge_first`). A marked triangle marks its refinement edge; every triangle with a
marked edge marks its own refinement edge too, until nothing changes (the closure). Then each
marked edge is cut at its midpoint, in both triangles that share it, so the mesh stays
conforming: no vertex lies inside another triangle's edge. A triangle ``[p1, p2, p3]`` whose
refinement edge ``p2p3`` is cut at ``m`` becomes ``[m, p1, p2]`` and ``[m, p3, p1]``, both
counter-clockwise with their refinement edge opposite the new vertex ``m``; a child whose
refinement edge is marked as well is cut once more. A wall piece is an edge of one triangle;
its midpoint lies on the wall (to rounding), so the refined mesh keeps every wall piece as an
edge or as a chain of edges.

**The field carried over** (:func:`refine_field`): a new vertex takes the arc interpolated
at the middle of its edge in the lifted coordinates of
:func:`~tether.game.certificate.lifted_ends` (the gap centres lifted along the edge by their
wrapped difference, the widths averaged). On every parent triangle whose lift exists the
refined field is then the same set-valued map as before, and a certified field stays certified
(the proof is in the docs).

**The loop** (:func:`refine_certified`): mark (:func:`mark_triangles`: the triangles that
hold an undecided lattice state of the band, or that fail the checks), split, carry the field
over, widen it by :func:`~tether.game.field_lp.lp_field`, and keep the widened field only if
:func:`~tether.game.certificate.certify` passes it; until the band's reach is below a given
width, or a budget of rounds or vertices is spent.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from tether.errors import InvalidParameterError
from tether.game.band import Band, lattice_classes, undecided_band
from tether.game.certificate import ArcField, bisect, certify, longest_edge_first
from tether.game.certified import CertifiedKernel
from tether.game.field_lp import CORE_TRIES, SEARCH_ROUNDS, lp_field, vortex_radius

__all__ = ["RING", "bisect", "free_near_split", "longest_edge_first", "mark_triangles",
           "refine_certified", "refine_field", "undecided_points"]

_TAU = math.tau
#: Rings of triangles around the split ones whose vertices the widening LP may move (the rest
#: keep the carried ends): :func:`free_near_split`.
RING = 1


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles into ``[-π, π)``."""
    return np.mod(x + math.pi, _TAU) - math.pi


def _midpoint_arcs(lo: np.ndarray, w: np.ndarray, edges: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The arcs ``(lo, w)`` (radians) at the middle of each edge ``(i, j)``: the gap centres
    ``c = lo − (2π − w)/2`` lifted along the edge by their wrapped difference (as
    :func:`~tether.game.certificate.lifted_ends` lifts them in both triangles of the edge) and
    averaged, and the widths averaged."""
    i, j = edges[:, 0], edges[:, 1]
    c = lo - (_TAU - w) / 2
    cm = c[i] + _wrap(c[j] - c[i]) / 2
    wm = (w[i] + w[j]) / 2
    return cm + (_TAU - wm) / 2, wm


def refine_field(field: ArcField, marked: np.ndarray) -> ArcField:
    """``field`` on the mesh :func:`bisect` makes of it (triangles ``marked`` split, with
    closure), each new vertex carrying its edge's interpolated arc (:func:`_midpoint_arcs`):
    the same set-valued map on every triangle whose lift exists, hence certified where
    ``field`` is (``docs/certified.md``, "Adaptive refinement").

    Examples
    --------
    >>> import numpy as np
    >>> from tether.game.certificate import ArcField
    >>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> f = ArcField(pts, np.array([[0, 1, 2]]), np.array([0.0, 0.2, 6.2]),
    ...              np.array([1.0, 1.0, 0.6]))
    >>> g = refine_field(f, [0])
    >>> len(g.tri), round(float(g.lo[3]), 6), round(float(g.w[3]), 6)  # mean of 0.2, 6.2 − 2π
    (2, 0.058407, 0.8)
    """
    pts, tri, edges = bisect(field.points, field.tri, marked)
    lo_m, w_m = _midpoint_arcs(field.lo, field.w, edges)
    return ArcField(pts, tri, np.concatenate([field.lo, lo_m]), np.concatenate([field.w, w_m]))


def _touching(f: ArcField, pts: np.ndarray) -> np.ndarray:
    """The triangles of ``f`` whose closure holds one of ``pts`` (bool mask; both in the
    field's frame)."""
    import shapely

    mark = np.zeros(len(f.tri), dtype=bool)
    if len(pts):
        tree = shapely.STRtree(shapely.polygons(f.points[f.tri]))
        _, hit = tree.query(shapely.points(pts), predicate="intersects")
        mark[hit] = True
    return mark


def undecided_points(ck: CertifiedKernel, optimistic: Any) -> np.ndarray:
    """The lattice points of ``optimistic`` (a grid kernel of scheme ``"outer"``) with an
    undecided state (in that kernel, free, and not certified by ``ck``:
    :func:`~tether.game.band.lattice_classes`), in the field's frame."""
    _, undecided = lattice_classes(ck, optimistic)
    return ck.frame.to_internal(optimistic.grid.points[undecided.any(axis=1)])


def mark_triangles(ck: CertifiedKernel, optimistic: Any) -> np.ndarray:
    """The triangles of ``ck``'s mesh to split (bool mask): those that fail its checks when
    ``ck`` is not certified (there the whole free space is undecided, and the failures are
    what a finer mesh may cure); else those whose closure holds a lattice point with an
    undecided state (:func:`undecided_points`)."""
    if not ck.certified:
        if ck.checks is None:  # no field to refine (a closed arc in the first field)
            return np.zeros(len(ck.field.tri), dtype=bool)
        return ck.checks.bad.copy()
    return _touching(ck.field, undecided_points(ck, optimistic))


def _split_round(ck: CertifiedKernel, optimistic: Any) -> tuple[ArcField, int]:
    """One round's split: the marked triangles bisected (:func:`refine_field`); for a certified
    field, the triangles of the result that still touch an undecided lattice point bisected
    once more, so that the star of such a point shrinks every round (newest-vertex bisection
    halves its edges every second split). Returns the field and the number of triangles marked
    first."""
    mark = mark_triangles(ck, optimistic)
    if not mark.any():
        return ck.field, 0
    g = refine_field(ck.field, mark)
    if ck.certified:
        again = _touching(g, undecided_points(ck, optimistic))
        if again.any():
            g = refine_field(g, again)
    return g, int(mark.sum())


def free_near_split(tri: np.ndarray, n_old: int, ring: int = RING) -> np.ndarray:
    """The vertices (bool mask) a round's widening may move on a mesh refined from one of
    ``n_old`` vertices (vertices ``>= n_old`` are the new midpoints): those of the split
    triangles' children (every child holds a new vertex) and of ``ring`` rings of triangles
    around them (each ring: every triangle with a vertex already free frees its other two).

    Why a ring: a vertex's ends enter the end rows of every triangle of its star, through
    the triangle's gradient. A free vertex whose star holds fixed vertices can widen only as
    far as the gradient towards them allows; with one ring, every triangle that touches a
    split triangle has its three vertices free, so the vertices where the free windows grew
    (the children's, whose smaller triangles see fewer blocked spans) are bounded by
    gradients the LP can shape on every side. Further out the carried field was already
    the LP's optimum on the coarser mesh (the previous round's), so a second ring buys
    little and costs a second shell of rows (on the room at vt/vo 0.3, three rounds: the
    same band with one ring or two).

    Examples
    --------
    >>> import numpy as np
    >>> tri = np.array([[0, 1, 2], [1, 7, 2], [7, 3, 2], [3, 4, 2], [4, 5, 6]])
    >>> np.flatnonzero(free_near_split(tri, 7, ring=0)).tolist()  # the children of vertex 7
    [1, 2, 3, 7]
    >>> np.flatnonzero(free_near_split(tri, 7, ring=1)).tolist()
    [0, 1, 2, 3, 4, 7]
    """
    tri = np.asarray(tri)
    nv = int(tri.max()) + 1 if len(tri) else 0
    free = np.zeros(nv, dtype=bool)
    free[tri[(tri >= n_old).any(axis=1)].ravel()] = True
    for _ in range(ring):
        free[tri[free[tri].any(axis=1)].ravel()] = True
    return free


def _check_budget(max_rounds: int, max_vertices: int | None, width: float | None,
                  ring: int | None = None) -> None:
    """One-line errors for a bad budget (or ring width)."""
    if ring is not None and not (isinstance(ring, (int, np.integer)) and ring >= 0):
        raise InvalidParameterError(f"ring must be None or an integer >= 0, got {ring!r}")
    if not (isinstance(max_rounds, (int, np.integer)) and max_rounds >= 0):
        raise InvalidParameterError(f"max_rounds must be an integer >= 0, got {max_rounds!r}")
    if max_vertices is not None and not max_vertices > 0:
        raise InvalidParameterError(f"max_vertices must be > 0, got {max_vertices!r}")
    if width is not None and not (math.isfinite(width) and width >= 0):
        raise InvalidParameterError(f"the band width must be a finite number >= 0, got {width}")


def _record(r: int, ck: CertifiedKernel, band: Band, t0: float, **extra: Any) -> dict:
    """One round's record (JSON-ready)."""
    return {"round": r, "vertices": int(len(ck.field.points)),
            "triangles": int(len(ck.field.tri)), "certified": ck.certified,
            "failing": None if ck.checks is None else int(ck.checks.bad.sum()),
            "undecided_share": band.share, "reach": band.reach, "reach_95": band.reach_95,
            "volume": band.volume, "contradictions": band.contradictions,
            "seconds": time.perf_counter() - t0, **extra}


def refine_certified(ck: CertifiedKernel, optimistic: Any, max_rounds: int = 3,
                     max_vertices: int | None = None, width: float | None = None,
                     lp_rounds: int = 20,
                     progress: Callable[[dict], Any] | None = None,
                     ring: int | None = RING,
                     search_ring: int | None = None) -> CertifiedKernel:
    """Refine ``ck``'s mesh where its band is (module docstring) and widen the field again.

    Parameters
    ----------
    ck : CertifiedKernel
        The field to refine (certified or not).
    optimistic : Kernel
        The optimistic grid kernel (scheme ``"outer"``) of the same game, on ``ck.h``'s lattice:
        it defines the band (:func:`~tether.game.band.undecided_band`), measured on that
        lattice every round.
    max_rounds : int
        At most this many rounds of marking, splitting and widening.
    max_vertices : int, optional
        Stop before a round whose mesh would exceed this many vertices.
    width : float, optional
        Stop once the band's reach (map units) is at most this (0: once nothing is undecided).
    lp_rounds : int
        LP rounds per widening (:func:`~tether.game.field_lp.lp_field`).
    progress : callable, optional
        Gets each round's record (a dict).
    ring : int or None
        The widening of a certified field moves only the vertices of the split triangles and
        of this many rings of triangles around them (:func:`free_near_split`); the others
        keep the carried ends. None: the LP over the whole mesh. :func:`certify` checks the
        whole field either way.
    search_ring : int or None
        The same for a field not certified yet (the search's three core sizes, from the
        carried field): None (the default) searches the whole mesh; an integer moves only the
        vertices of the split triangles (those that failed) and of this many rings around
        them, so that a field that fails in a few places is repaired there at the cost of a
        local LP (``docs/certified.md``, "Floor plans").

    Returns
    -------
    CertifiedKernel
        The refined kernel; its ``refine_log`` holds one record per round (round 0: ``ck``),
        and ``refined`` the number of rounds that split the mesh.

    A round whose widened field fails :func:`~tether.game.certificate.certify` keeps the
    field carried over without the LP (the previous field on the finer mesh, certified where
    the previous one was) and says so in its record (``"kept": "carried"``). Should the
    carried field fail too (possible with a sensing delay only, where check 1 runs on grown
    triangles), the previous field is kept and the refinement stops (``"stopped":
    "failed"``).
    """
    _check_budget(max_rounds, max_vertices, width, ring)
    _check_budget(max_rounds, max_vertices, width, search_ring)
    t0 = time.perf_counter()
    env, lss, vt, vo = ck.game
    grow = ck.grow
    f = ck.field
    if ck.refined == 0:
        f = ArcField(f.points, longest_edge_first(f.points, f.tri), f.lo, f.w)
    cur = _kernel_like(ck, f, ck.checks, ck.refined)
    band = undecided_band(cur, optimistic)
    log = [_record(0, cur, band, t0)]
    if progress is not None:
        progress(log[-1])
    for r in range(1, max_rounds + 1):
        if width is not None and band.reach <= width:
            break
        g, marked = _split_round(cur, optimistic)
        if not marked:
            break
        if max_vertices is not None and len(g.points) > max_vertices:
            log.append({"round": r, "stopped": "max_vertices", "would_have": int(len(g.points))})
            if progress is not None:
                progress(log[-1])
            break
        rings = ring if cur.certified else search_ring
        free = None if rings is None else free_near_split(g.tri, len(cur.field.points), rings)
        g, checks, how = _widen(env, g, lss, vt, vo, grow, cur.certified, lp_rounds, free)
        if how == "failed":  # neither the LP's field nor the carried one passes: keep cur
            log.append({"round": r, "stopped": "failed", "failing": int(checks.bad.sum())})
            if progress is not None:
                progress(log[-1])
            break
        cur = _kernel_like(ck, g, checks, cur.refined + 1)
        band = undecided_band(cur, optimistic)
        log.append(_record(r, cur, band, t0, marked=marked, kept=how))
        if progress is not None:
            progress(log[-1])
    cur.refine_log = log
    cur.seconds = ck.seconds + time.perf_counter() - t0
    return cur


def _widen(env: Any, g: ArcField, lss: float, vt: float, vo: float, grow: float,
           was_certified: bool, lp_rounds: int, free: np.ndarray | None = None
           ) -> tuple[ArcField, Any, str]:
    """The field carried over to the finer mesh, widened: ``(field, checks, how)``.

    From a certified field: the LP's field if :func:`~tether.game.certificate.certify` passes
    it (``how`` = ``"lp"``), else the carried field if it passes (``"carried"``; it does
    without a delay, ``docs/certified.md`` (R3)), else the carried field and its failing
    checks (``"failed"``: the caller keeps the previous field). Without a certified field
    yet: the search's three core sizes (as :func:`~tether.game.field_lp.solve_field`'s) from
    the carried field, the one with the fewest failing triangles kept (``"search"``, or
    ``"carried"`` when none has fewer than the carried field). ``free``: the vertices the
    LP may move (None: all)."""
    if was_certified:
        res = lp_field(env, g.points, g.tri, g.lo, g.w, lss, vt, vo, rounds=lp_rounds,
                       grow=grow, fixed=None if free is None else ~free)
        wide = ArcField(g.points, g.tri, res.lo, np.minimum(res.hi - res.lo, _TAU))
        checks = certify(wide, env, lss, vt, vo, grow)
        if checks.passed:
            return wide, checks, "lp"
        carried = certify(g, env, lss, vt, vo, grow)
        return g, carried, "carried" if carried.passed else "failed"
    best, best_checks = g, certify(g, env, lss, vt, vo, grow)
    for q in CORE_TRIES:
        res = lp_field(env, g.points, g.tri, g.lo, g.w, lss, vt, vo, rounds=SEARCH_ROUNDS,
                       core_radius=q * vortex_radius(lss, vt, vo), grow=grow,
                       fixed=None if free is None else ~free)
        found = ArcField(g.points, g.tri, res.lo, np.minimum(res.hi - res.lo, _TAU))
        checks = certify(found, env, lss, vt, vo, grow)
        if checks.bad.sum() < best_checks.bad.sum():
            best, best_checks = found, checks
        if checks.passed:
            break
    return best, best_checks, "search" if best is not g else "carried"


def _kernel_like(ck: CertifiedKernel, f: ArcField, checks: Any, refined: int
                 ) -> CertifiedKernel:
    """A :class:`CertifiedKernel` of ``ck``'s game on the field ``f``."""
    return CertifiedKernel(ck.env, ck.lss, ck.vt, ck.vo, ck.h, f, checks, ck.log, ck.seconds,
                           ck.frame, ck.space, ck.delay, refined=refined)
