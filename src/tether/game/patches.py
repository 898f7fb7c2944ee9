"""The certified field on big maps: coarse to fine, then repair in patches
(``docs/certified.md``, "Big maps").

**Coarse to fine** (:func:`coarse_to_fine`). The search of :func:`~tether.game.field_lp.
solve_field` on a coarse mesh (spacing ``coarse_h``: few vertices, a small LP) gives a field
that is interpolated (:func:`~tether.game.certificate.interpolate_field`) onto the fine mesh
(:func:`~tether.game.certificate.free_mesh` at ``h`` on the lattice of
:func:`~tether.game.grid.lattice`). A fine triangle inside one coarse triangle carries the
coarse triangle's linear ends on a smaller range, so it passes every check the coarse one
passes; the fine checks fail only where fine triangles straddle coarse edges or the coarse
field failed. The fine grid kernel is not needed: the fine mesh comes from the lattice's
points alone.

**Patches** (:func:`repair_patches`). The checks of :func:`~tether.game.certificate.certify`
are per triangle, and a triangle's checks read its three vertices' arcs only; so a vertex's
arc enters the checks of its star and nothing else. The failing triangles are grouped by
square tiles of the map (side ``tile`` mesh spacings, by centroid), each tile's group grown
by ``ring`` rings of triangles: its vertices are the patch's free vertices. The LP of
:func:`~tether.game.field_lp.lp_field` runs on the patch's triangles (those with a free
vertex) with their other vertices fixed (the ring of fixed vertices around the patch), so it
changes nothing outside; the patch's triangles are checked again (exactly, by ``certify`` on
the sub-mesh), and the new arcs are kept only when fewer of them fail. Tiles go worst first
(most failing triangles); a pass over every tile is followed by another with the tiles moved
by half a side (patches overlap from pass to pass), until every triangle passes, a pass
repairs nothing, or a budget (passes, seconds) is spent. ``certify`` on the whole field has
the last word.

Soundness does not depend on any of this: the search only proposes fields, and a field is
certified by ``certify`` or not at all.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game.certificate import (
    ArcField,
    Checks,
    certify,
    free_mesh,
    interpolate_field,
)
from tether.game.field_lp import lp_field, solve_field, triangle_spans, windows_of_spans
from tether.game.grid import lattice

__all__ = ["PATCH_RING", "PATCH_TILE", "clip_to_free", "coarse_to_fine", "lattice_points",
           "patch_vertices", "repair_patches", "solve_patch"]

_TAU = math.tau
#: Side of a patch's tile, in mean edge lengths of the mesh.
PATCH_TILE = 12
#: Rings of triangles around a tile's failing triangles whose vertices the patch's LP may move.
PATCH_RING = 2
#: Candidate orientations per arc (and around the circle) where :func:`clip_to_free` looks
#: for its star's common free window.
_CLIP_REFS = 16
#: Distance (radians) a clipped arc keeps from the ends of its star's free window.
_CLIP_GAP = 1e-3


def lattice_points(env: Environment, h: float) -> np.ndarray:
    """The lattice points (map units, (n, 2)) of :func:`~tether.game.grid.build_grid` at
    spacing ``h`` (those inside the map and off its walls), without the grid's free states:
    what :func:`~tether.game.certificate.free_mesh` needs.

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.game import build_grid
    >>> room = Environment([(0, 0), (2, 0), (2, 1), (0, 1)])
    >>> lattice_points(room, 0.5)[:5].tolist()
    [[0.25, 0.25], [0.75, 0.25], [1.25, 0.25], [1.75, 0.25], [0.25, 0.75]]
    >>> np.array_equal(lattice_points(room, 0.5), build_grid(room, 0.5, 0.5, 8).points)
    True
    """
    origin, nx, ny = lattice(env, float(h))
    gx, gy = np.meshgrid(origin[0] + h * np.arange(nx), origin[1] + h * np.arange(ny))
    inside = env.contains(gx, gy) & (env.boundary_distance(gx, gy) > 10 * env.length_tol)
    iy, ix = np.nonzero(inside)
    return np.column_stack([gx[iy, ix], gy[iy, ix]])


def patch_vertices(tri: np.ndarray, seeds: np.ndarray, ring: int = PATCH_RING) -> np.ndarray:
    """The free vertices (bool mask over ``tri.max() + 1`` vertices) of a patch: those of the
    ``seeds`` triangles (mask or indices) and of ``ring`` rings of triangles around them (each
    ring: every triangle with a free vertex frees its other two).

    Examples
    --------
    >>> import numpy as np
    >>> tri = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 5, 6]])
    >>> np.flatnonzero(patch_vertices(tri, [0], ring=0)).tolist()
    [0, 1, 2]
    >>> np.flatnonzero(patch_vertices(tri, [0], ring=1)).tolist()
    [0, 1, 2, 3, 4]
    """
    tri = np.asarray(tri)
    free = np.zeros(int(tri.max()) + 1 if len(tri) else 0, dtype=bool)
    seeds = np.asarray(seeds)
    sel = np.zeros(len(tri), dtype=bool)
    sel[seeds if seeds.dtype == bool else seeds.astype(np.int64)] = True
    free[tri[sel].ravel()] = True
    for _ in range(ring):
        free[tri[free[tri].any(axis=1)].ravel()] = True
    return free


def clip_to_free(env: Environment, field: ArcField, which: np.ndarray, lss: float,
                 grow: float = 0.0) -> ArcField:
    """``field`` with the arcs of the vertices ``which`` (bool mask) cut to the orientations
    free from every point of their star (check 1 of
    :func:`~tether.game.certificate.certify` on each triangle at the vertex, whatever the
    other vertices hold): the part of the arc inside the star's common free window
    (:func:`~tether.game.field_lp.windows_of_spans`, each of its ends :data:`_CLIP_GAP` in),
    the widest such part over :data:`_CLIP_REFS` candidate orientations inside the arc; where
    no part is free, the star's widest free window among candidates around the circle. A
    vertex whose star has no free window keeps its arc.

    Why: the LP of :func:`~tether.game.field_lp.lp_field` moves each end by at most its
    trust region per round and holds a vertex whose reference arc is blocked from its star
    (an arc interpolated from a coarse field over a wall's corner can be); cut first, the
    vertex is free to move again.
    """
    which = np.asarray(which, dtype=bool)
    stars = np.flatnonzero(which[field.tri].any(axis=1))
    if not len(stars):
        return field
    tri = field.tri[stars]
    spans = triangle_spans(env, field.points[tri], lss, grow)
    nv = len(field.points)
    lo, w = field.lo, field.w
    best_lo, best_hi = lo.copy(), lo + w
    best_w = np.full(nv, -np.inf)
    k = (np.arange(_CLIP_REFS) + 0.5) / _CLIP_REFS
    for inside, frac in ((True, k), (False, k)):
        for f in frac:
            ref = lo + f * (w if inside else _TAU)  # per vertex
            f_lo = np.full(nv, -np.inf)
            f_hi = np.full(nv, np.inf)
            for j in range(3):
                r = ref[tri[:, j]]
                a, b = windows_of_spans(spans, r, len(tri))
                np.maximum.at(f_lo, tri[:, j], a - r)
                np.minimum.at(f_hi, tri[:, j], b - r)
            a_lo, a_hi = ref + f_lo + _CLIP_GAP, ref + f_hi - _CLIP_GAP
            if inside:  # the part of the arc in the window around ref
                a_lo, a_hi = np.maximum(a_lo, ref - f * w), np.minimum(a_hi, ref + (1 - f) * w)
            else:  # an open side of the window (nothing blocked there): a whole turn from
                # its other end (a blocked ref has a_lo = +inf, a_hi = -inf: no width)
                lo_open, hi_open = a_lo == -np.inf, a_hi == np.inf
                a_lo = np.where(lo_open & hi_open, ref - math.pi,
                                np.where(lo_open, a_hi - _TAU, a_lo))
                a_hi = np.where(lo_open & hi_open, ref + math.pi,
                                np.where(hi_open, a_lo + _TAU, a_hi))
            a_hi = np.minimum(a_hi, a_lo + _TAU)
            width = a_hi - a_lo
            take = which & (width > best_w) & (width > 0)
            if not inside:
                take &= best_w <= 0  # around the circle only where the arc has no free part
            best_lo[take], best_hi[take], best_w[take] = a_lo[take], a_hi[take], width[take]
    new_w = np.minimum(best_hi - best_lo, _TAU)
    keep = ~(which & (best_w > 0))
    return ArcField(field.points, field.tri, np.where(keep, lo, best_lo),
                    np.where(keep, w, np.where(new_w >= _TAU - 1e-9, _TAU, new_w)))


def solve_patch(env: Environment, field: ArcField, free: np.ndarray, lss: float, vt: float,
                vo: float, grow: float = 0.0, rounds: int = 20, clip: bool = True
                ) -> tuple[ArcField, np.ndarray, int, int]:
    """One patch: the LP of :func:`~tether.game.field_lp.lp_field` on the triangles of
    ``field`` with a vertex in ``free`` (bool per vertex), every other vertex of them fixed.

    Returns ``(new, sub, before, after)``: ``new`` is ``field`` with the free vertices' arcs
    replaced by the LP's when that makes fewer of the patch's triangles ``sub`` (indices)
    fail :func:`~tether.game.certificate.certify` (``after < before``), else ``field``
    itself; a vertex outside ``free`` keeps its arc bit for bit either way. ``before`` and
    ``after`` count the patch's failing triangles. A patch with no free vertex is returned
    as it is (``sub`` empty, 0 and 0). ``clip``: the free vertices of triangles that fail
    check 1 are cut to their star's free orientations first (:func:`clip_to_free`). The
    patch's LP runs its ``rounds`` without the plateau rule (``plateau=0``: it stops at a
    stall only): a patch's few rounds are cheap, and stopping them at a plateau left
    triangles failing that the full rounds repair (``tests/game/test_patches.py``).
    """
    free = np.asarray(free, dtype=bool)
    if free.shape != (len(field.points),):
        raise InvalidParameterError(f"free must be a bool mask of the {len(field.points)} "
                                    f"vertices, got shape {free.shape}")
    sub = np.flatnonzero(free[field.tri].any(axis=1))
    if not len(sub):
        return field, sub, 0, 0
    verts, local = np.unique(field.tri[sub], return_inverse=True)
    tri = local.reshape(-1, 3)
    pts = field.points[verts]
    part = ArcField(pts, tri, field.lo[verts], field.w[verts])
    checks = certify(part, env, lss, vt, vo, grow)
    before = int(checks.bad.sum())
    if before == 0:
        return field, sub, 0, 0
    move = free[verts]
    ref = part
    if clip and checks.free.any():  # blocked arcs cut first: the LP cannot move them
        blocked = np.zeros(len(pts), bool)
        blocked[tri[checks.free].ravel()] = True
        ref = clip_to_free(env, part, blocked & move, lss, grow)
    res = lp_field(env, pts, tri, ref.lo, ref.w, lss, vt, vo, rounds=rounds, grow=grow,
                   fixed=~move, plateau=0)
    lo = np.where(move, res.lo, part.lo)
    w = np.where(move, np.minimum(res.hi - res.lo, _TAU), part.w)
    after = int(certify(ArcField(pts, tri, lo, w), env, lss, vt, vo, grow).bad.sum())
    if after >= before:
        return field, sub, before, before
    new_lo, new_w = field.lo.copy(), field.w.copy()
    new_lo[verts[move]], new_w[verts[move]] = lo[move], w[move]
    return ArcField(field.points, field.tri, new_lo, new_w), sub, before, after


def _tiles(field: ArcField, bad: np.ndarray, side: float, shift: float) -> list[np.ndarray]:
    """The failing triangles (indices) grouped by square tiles of ``side`` (map units, the
    grid moved by ``shift``) by centroid, the tile with most first."""
    idx = np.flatnonzero(bad)
    if not len(idx):
        return []
    cen = field.points[field.tri[idx]].mean(axis=1)
    key = np.floor((cen + shift) / side).astype(np.int64)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    order = np.argsort(-counts, kind="stable")
    groups = np.split(idx[np.argsort(inv, kind="stable")], np.cumsum(counts)[:-1])
    return [groups[g] for g in order]


def repair_patches(env: Environment, field: ArcField, lss: float, vt: float, vo: float,
                   grow: float = 0.0, tile: float = PATCH_TILE, ring: int = PATCH_RING,
                   passes: int = 4, lp_rounds: int = 20, seconds: float | None = None,
                   progress: Callable[[dict], Any] | None = None
                   ) -> tuple[ArcField, Checks, list]:
    """Repair ``field`` where :func:`~tether.game.certificate.certify` fails it, patch by
    patch (module docstring).

    Parameters
    ----------
    env : Environment
    field : ArcField
        The field to repair (on a mesh of ``env``'s free space).
    lss, vt, vo : float
        The game (map units, map units per second).
    grow : float
        ``vt·d`` for a sensing delay ``d`` (map units), as in ``certify``.
    tile : float
        Side of a patch's tile, in mean edge lengths.
    ring : int
        Rings of triangles around a tile's failing triangles that the LP may move.
    passes : int
        At most this many passes over the tiles.
    lp_rounds : int
        LP rounds per patch.
    seconds : float, optional
        Start no patch after this many seconds.
    progress : callable, optional
        Gets each pass's record.

    Returns
    -------
    (field, checks, log)
        The repaired field, ``certify`` of it on the whole mesh, and one record per pass
        (``failing`` before it, ``patches``, ``repaired`` triangles, ``seconds``).
    """
    if not (isinstance(ring, (int, np.integer)) and ring >= 0):
        raise InvalidParameterError(f"ring must be an integer >= 0, got {ring!r}")
    if not (math.isfinite(tile) and tile > 0):
        raise InvalidParameterError(f"tile must be a finite number > 0, got {tile!r}")
    t0 = time.perf_counter()
    xy = field.points[field.tri]
    side = tile * float(np.mean(np.hypot(*(xy[:, 1] - xy[:, 0]).T)))
    checks = certify(field, env, lss, vt, vo, grow)
    bad = checks.bad.copy()
    log: list = []
    idle = 0  # passes in a row that repaired nothing
    for p in range(passes):
        if not bad.any() or (seconds is not None and time.perf_counter() - t0 > seconds):
            break
        rec = {"pass": p + 1, "failing": int(bad.sum()), "patches": 0, "repaired": 0}
        for seeds in _tiles(field, bad, side, side / 2 * (p % 2)):
            if seconds is not None and time.perf_counter() - t0 > seconds:
                break
            if not bad[seeds].any():  # repaired by an earlier patch of this pass
                continue
            free = patch_vertices(field.tri, seeds[bad[seeds]], ring)
            free = np.pad(free, (0, len(field.points) - len(free)))
            field, sub, before, after = solve_patch(env, field, free, lss, vt, vo, grow,
                                                    lp_rounds)
            rec["patches"] += 1
            if after < before:
                part = ArcField(field.points, field.tri[sub], field.lo, field.w)
                bad[sub] = certify(part, env, lss, vt, vo, grow).bad
                rec["repaired"] += before - after
        rec["seconds"] = time.perf_counter() - t0
        log.append(rec)
        if progress is not None:
            progress(rec)
        idle = idle + 1 if rec["repaired"] == 0 else 0
        if idle >= 2:  # neither tiling repairs anything more
            break
    checks = certify(field, env, lss, vt, vo, grow)
    return field, checks, log


def coarse_to_fine(env: Environment, lss: float, vt: float, vo: float, h: float,
                   coarse_h: float, orientations: int = 180, grow: float = 0.0,
                   passes: int = 4, seconds: float | None = None,
                   progress: Callable[[dict], Any] | None = None, plateau: int = 0
                   ) -> tuple[ArcField, Checks, list]:
    """A field on the mesh of spacing ``h`` (map units) from one searched at ``coarse_h``
    (module docstring): the coarse search
    (:func:`~tether.game.field_lp.solve_field` from the conservative grid kernel at
    ``coarse_h`` and ``orientations`` bins), its field interpolated onto
    :func:`~tether.game.certificate.free_mesh` at ``h``, then :func:`repair_patches`
    (``passes``, ``seconds``). Returns ``(field, checks, log)``: the fine field, ``certify``
    of it, and the records: ``{"coarse": ...}`` (the coarse mesh's vertices, whether its
    field is certified and its failing triangles, the fine field's failing triangles before
    the patches ``fine_failing``, and seconds: ``t_kernel``, ``t_search``, ``t_mesh``), then
    one per pass of :func:`repair_patches`. ``plateau``: the coarse search's plateau rule
    (:func:`~tether.game.field_lp.lp_field`; 0, the default: a try stops only at a stall, as
    when the figures of ``docs/certified.md``, "Big maps", were measured).

    Raises
    ------
    ValueError
        If a mesh cannot follow the walls (:func:`~tether.game.certificate.free_mesh`).

    Examples
    --------
    >>> from tether import Environment
    >>> room = Environment([(0, 0), (4, 0), (4, 3), (0, 3)])
    >>> f, checks, log = coarse_to_fine(room, 1.0, 0.3, 1.0, h=0.25, coarse_h=0.5,
    ...                                 orientations=36)  # doctest: +SKIP
    >>> checks.passed  # doctest: +SKIP
    True
    """
    from tether.game.kernel import surveillance_kernel

    t0 = time.perf_counter()
    kern = surveillance_kernel(env, lss, vt, vo, h=coarse_h, orientations=orientations)
    t_kernel = time.perf_counter() - t0
    fc, cc, clog = solve_field(env, kern, lss, vt, vo, grow=grow, progress=progress,
                             plateau=plateau)
    t_coarse = time.perf_counter() - t0
    pts, tri, _ = free_mesh(env, h, lattice_points(env, h))
    f0 = interpolate_field(fc, pts, tri)
    t_mesh = time.perf_counter() - t0
    log: list = [{"coarse": {"h": coarse_h, "vertices": int(len(fc.points)),
                             "certified": bool(cc is not None and cc.passed),
                             "failing": None if cc is None else int(cc.bad.sum()),
                             "t_kernel": t_kernel, "t_search": t_coarse - t_kernel,
                             "t_mesh": t_mesh - t_coarse, "log": clog}}]
    f, checks, plog = repair_patches(env, f0, lss, vt, vo, grow, passes=passes,
                                     seconds=seconds, progress=progress)
    log[0]["coarse"]["fine_failing"] = plog[0]["failing"] if plog else int(checks.bad.sum())
    log += plog
    return f, checks, log
