"""The search for a certified arc field by sequential linear programming: every check of
:func:`tether.game.certificate.certify` is linear in the field's vertex values once the
orientation range of each triangle is fixed, so the widest field within a trust region around a
reference is one LP (HiGHS); the reference then moves to the solution and the LP is solved again.

The LP is only a search: what it returns is certified (or not) by
:func:`~tether.game.certificate.certify`, whose checks are exact.

**Variables.** Per mesh vertex ``i``: ``lo_i = L_i + x_i`` and ``hi_i = H_i + y_i`` (radians;
``L``, ``H`` the reference ends, ``|x|, |y| <= rho``), and per triangle and end an elastic slack
``s >= 0`` priced :data:`PENALTY` (the LP is always feasible; a field is found when every slack
is zero).

**Constraints.**

- *Free*: ``lo_i >= f_lo(T)`` and ``hi_i <= f_hi(T)`` for every triangle ``T`` at ``i``, where
  ``[f_lo, f_hi]`` is the free window of ``T`` (exact blocked spans of every wall from every
  point of ``T``) that holds the reference arc: variable bounds.
- *Width*: ``W_MIN <= hi_i − lo_i <= 2π``.
- *Ends*: on every triangle not inside the *core* (whole-circle vertices none of whose
  neighbours has a gap: the vortex every room has), for each heading ``θ`` of a set grown by
  cutting planes, ``lss·vt·G_lo·u(θ) <= S_lo(θ) − m`` and ``−lss·vt·G_hi·u(θ) <= S_hi(θ) − m``,
  where ``G`` is the (linear) gradient and ``S(θ)`` the smallest of ``sqrt(vo² − vt²cos²(θ − a))
  ∓ vt·sin(θ − a)`` over the orientations ``a`` the end can take on ``T`` within the trust
  region (sampled, minus its Lipschitz bound). The headings: :data:`BASE_HEADINGS` evenly
  spaced ones on every *steep* triangle (:data:`BASE_STEEP`: one whose end some heading
  can violate, at the reference or a later round's field), and per round and end the one
  that violates most (a cutting plane; by default its rows are added for both ends).

**Objective.** The largest area-weighted width ``Σ area_i·(hi_i − lo_i)``, minus the slacks
and a small proximal price of the moves ``|x|``, ``|y|`` (:data:`PROXIMAL`).

**Solver.** One HiGHS model (``highspy``) per search, kept across the rounds and the
releases of core vertices: the columns and most rows are the same every round; the trust
region, the free windows, the widths and the end rows' bounds move, cutting planes add end
rows, and a release frees core rows and adds the end rows of the triangles it makes
end-checked, so each round re-solves from the last basis instead of from scratch. The
blocked spans behind the free windows depend on the mesh only and are computed once.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import highspy
import numpy as np
from scipy import sparse

from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game.cells import (
    ANGLE_MARGIN,
    blocked_spans,
    convex_pieces_of,
    grow_triangles,
    walls_near,
)
from tether.game.certificate import (
    FULL,
    W_MIN,
    ArcField,
    Checks,
    certify,
    first_field,
    hat_gradients,
    heading_window_min,
    lifted_ends,
    sight_widening,
    window_floor,
    window_min_at,
)

__all__ = ["BASE_HEADINGS", "BASE_STEEP", "CORE_TRIES", "LPResult", "PLATEAU_REL", "PLATEAU_ROUNDS",
           "RELEASE_CUTS", "RELEASE_REL", "RELEASE_ROUNDS", "SEARCH_ROUNDS", "SETTLED",
           "STALL_MOVE", "WIDTH_REL",
           "aligned_radius", "free_windows", "initial_core", "lp_field", "lp_rounds",
           "solve_field", "triangle_spans", "vortex_radius", "windows_of_spans"]

#: The search's core sizes, in units of :func:`vortex_radius`, tried in this order (0: every
#: whole-circle vertex in the core, released where needed)
CORE_TRIES = (0.0, 2 / 3, 1.0)
#: LP rounds of one try of the search
SEARCH_ROUNDS = 60
#: Rounds without progress after which a search with slack counts as stuck (a *plateau*):
#: its elastic slack has not fallen below ``(1 − PLATEAU_REL)`` times its best within this
#: many rounds. A stuck search can also cycle (the slack alternating between two values,
#: the ends moving back and forth by more than the stall's move), so waiting for the ends
#: to stop moving is not enough (``docs/certified.md``, "How the field is found").
PLATEAU_ROUNDS = 5
#: Relative fall of the slack that counts as progress for :data:`PLATEAU_ROUNDS`
PLATEAU_REL = 1e-3
#: Rounds after a release of core vertices within which the slack must have fallen by
#: :data:`RELEASE_REL` of its best before the release, else, while the search is still far
#: from settled (:data:`RELEASE_CUTS`), the try ends (``"stuck": "release"``). A release
#: that frees what held the slack pays at once: in every recorded search that certifies
#: (gallery 0.3 at N = 64 and 100, the room at 0.3 and 0.6) the slack fell by 44 % to 100 %
#: within three rounds of each release. Where none is found (the room at 0.9) it fell by
#: 11 %, while the LP, with thousands of new end rows a round, grew slower each round (0.5 s
#: before the release, 45 s six rounds after): that try ran for over ten CPU minutes without
#: this rule (``docs/kernel.md``, "The certified kernel's search").
RELEASE_ROUNDS = 3
#: Relative fall of the slack (against its best before the release) that a release must
#: bring within :data:`RELEASE_ROUNDS` rounds
RELEASE_REL = 0.25
#: A release that has not paid ends the try only if the round that judges it added cutting
#: planes for more than this share of the LP's rows (counted as the end rows plus six per
#: vertex, the LP's rows before ``x`` and ``y`` were split, which the rule was tuned on;
#: the LP still growing: the room at 0.9 added 3 % at round 9). A try that is settling goes
#: on to its stall: the 6 x 6 room at 0.3, ``h`` 0.5, whose release did not pay (slack 2.8)
#: and which then added 0.1 %, is certified four rounds later, and would not be if it ended
#: there (counted against the split LP's own rows, it did end there: not certified).
RELEASE_CUTS = 0.01
#: With the plateau rule, a round that adds no cutting plane and does not improve on the
#: best (the slack, or the mean width once the slack is zero) ends the wait at once
#: (``"stuck": "settled"``): it solved the LP with every row the search has, and the next LP
#: has the same rows. The gallery at N = 100 (core 2/3) then takes 15 rounds instead of 21,
#: N = 64 (core 0) 16 instead of 19, the same fields' widths (``docs/kernel.md``). False: wait
#: out :data:`PLATEAU_ROUNDS` as before (``tests/game/test_field_lp_order.py`` compares).
SETTLED = True
#: Relative growth of the mean width that counts as progress once the slack is zero: a
#: search without slack whose mean width has not grown by this much within
#: :data:`PLATEAU_ROUNDS` rounds has converged (it can cycle there too, by a little more than
#: the stall's move)
WIDTH_REL = 1e-4
#: Evenly spaced headings whose end rows every steep end-checked triangle has
#: (:data:`BASE_STEEP`), per end (the rest are cutting planes). Fewer make each LP smaller
#: but the search slower to converge or stuck (``docs/kernel.md``, "The certified kernel's
#: search": with 2, or with unpaired ends, the gallery at N = 100 needs a second core size or
#: is not certified).
BASE_HEADINGS = 8
#: A triangle gets the end rows of its base headings once the gradient ``G`` of one of its
#: ends asks for this share of the least bound any heading can have: ``lss·vt·|G| >=
#: BASE_STEEP·(window_floor − margin/2)`` (at the reference, or at any later round's field;
#: they are kept from then on). A gentler triangle's rows cannot bind while its gradient
#: stays below the floor (no heading violates); the cutting planes of every round catch one
#: that grows steeper within a trust region. 0: every end-checked triangle from the start.
BASE_STEEP = 1.0
#: Price of one unit of elastic slack (per triangle end) against one radian of width at a
#: vertex of mean area (the widths are priced by area relative to the mean, times
#: :data:`WIDTH_PRICE`: scale-free, so that a map scaled or normalized gets the same LP).
PENALTY = 1e4
#: Price of one radian of width at a vertex of mean area (the regime in which the search was
#: tuned: meshes of spacing 0.25 to 0.5 in units where lss = vo = 1).
WIDTH_PRICE = 0.1
#: Distance (radians) the field keeps from the ends of every free window (the exact check
#: counts a touching end as blocked).
WINDOW_GAP = 1e-6
#: Price of moving an end by one radian, per unit area, against widening it (a small fraction
#: of the width's price of 1: moves happen only where they widen the field or relieve a slack).
PROXIMAL = 0.01
#: Widening (radians) of each triangle's orientation range where the end conditions' bound
#: ``S`` is taken: the range of the reference, not of the trust region (which would make ``S``
#: its worst value over a wide range); a move that leaves the range is corrected in the next
#: round, and :func:`~tether.game.certificate.certify` has the last word.
A_WIDEN = 0.02
#: A round that adds no cutting plane and moves no end by this much (radians) is a *stall*.
#: Not more: with ``A_WIDEN`` (0.02 rad, the range the end rows' bound ``S`` holds on) the
#: gallery's search at N = 100 ran 16 rounds instead of 21, but the coarse search and the
#: patches of ``tests/game/test_patches.py`` (a 6 x 5 room) stopped early, and the room was
#: no longer certified: small moves still repair there.
STALL_MOVE = 1e-3
_TAU = math.tau
#: HiGHS's default primal feasibility tolerance (radians here): bounds violated by less are
#: met for the solver
_FEASIBILITY = 1e-7


@dataclass(eq=False)
class LPResult:
    """What :func:`lp_field` returns: the field's ends per vertex and the search's record."""

    lo: np.ndarray
    hi: np.ndarray
    slack: float
    rounds: int
    log: list
    core: np.ndarray


def _wrap(x: np.ndarray) -> np.ndarray:
    return np.mod(x + math.pi, _TAU) - math.pi


def free_windows(env: Environment, xy: np.ndarray, ref: np.ndarray, lss: float,
                 grow: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle ``xy`` (n, 3, 2), the free window ``[f_lo, f_hi]`` (lifted near ``ref``,
    radians) of orientations free from every point of the triangle's free part that holds
    ``ref``; ``(-inf, inf)`` where nothing is blocked, ``f_lo > f_hi`` where ``ref`` itself is
    blocked. Blocked spans are exact (:func:`tether.game.cells.blocked_spans`) and widened by
    :data:`~tether.game.cells.ANGLE_MARGIN`. With a sensing delay (``grow = vt·d > 0``, map
    units) the window is that of check 1 with the delay: the triangle grown by ``grow``, rods
    ``lss + grow`` long, each blocked span widened by
    :func:`~tether.game.certificate.sight_widening` more. The same as
    :func:`triangle_spans` then :func:`windows_of_spans` (which a search repeats for new
    ``ref`` without recomputing the spans)."""
    return windows_of_spans(triangle_spans(env, xy, lss, grow), ref, len(xy))


def triangle_spans(env: Environment, xy: np.ndarray, lss: float, grow: float = 0.0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every blocked span of every triangle ``xy`` (n, 3, 2) of :func:`free_windows`:
    ``(t, b0, b1)``, the triangle of each span and its ends (radians, widened as there),
    sorted by ``t``. They depend on the geometry only, not on the field."""
    widen = ANGLE_MARGIN + sight_widening(grow, lss)
    if grow > 0:
        xy, lss = grow_triangles(xy, grow), lss + grow
    quads = np.concatenate([xy, xy[:, 2:3]], axis=1)
    owner, verts = convex_pieces_of(env, quads)
    ts, b0s, b1s = [np.zeros(0, np.int64)], [np.zeros(0)], [np.zeros(0)]
    if len(owner):
        piece, wall, walls = walls_near(env, verts, lss)
        for s in range(0, len(piece), 200_000):
            pc, wl = piece[s:s + 200_000], wall[s:s + 200_000]
            b0, b1, hit = blocked_spans(verts[pc], walls[wl], lss, env.length_tol)
            ts.append(owner[pc][hit])
            b0s.append(b0[hit] - widen)
            b1s.append(b1[hit] + widen)
    t, b0, b1 = np.concatenate(ts), np.concatenate(b0s), np.concatenate(b1s)
    order = np.argsort(t, kind="stable")
    return t[order], b0[order], b1[order]


def windows_of_spans(spans: tuple[np.ndarray, np.ndarray, np.ndarray], ref: np.ndarray,
                     n: int) -> tuple[np.ndarray, np.ndarray]:
    """The free windows ``(f_lo, f_hi)`` of :func:`free_windows` around ``ref`` (radians, per
    triangle, ``n`` triangles) from the ``spans`` of :func:`triangle_spans`: each span is
    shifted to start within ``[ref, ref + 2π)``; one that holds ``ref`` (or is the whole
    circle) closes the window, else it bounds it above at its start and below at its end
    minus ``2π``."""
    t, b0, b1 = spans
    f_lo = np.full(n, -np.inf)
    f_hi = np.full(n, np.inf)
    if not len(t):
        return f_lo, f_hi
    r = ref[t]
    whole = (b1 - b0) >= _TAU
    k = np.floor((b0 - r) / _TAU)  # b0 shifted into [r, r + 2π)
    b0, b1 = b0 - k * _TAU, b1 - k * _TAU
    holds = whole | (b0 <= r) | (b1 - _TAU >= r)
    first = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    f_hi[t[first]] = np.minimum.reduceat(np.where(holds, -np.inf, b0), first)
    f_lo[t[first]] = np.maximum.reduceat(np.where(holds, np.inf, b1 - _TAU), first)
    return f_lo, f_hi


def _vortex_vertices(points: np.ndarray, lo: np.ndarray, w: np.ndarray, tri: np.ndarray,
                     core: np.ndarray, r: float) -> np.ndarray:
    """Core vertices that must keep the whole circle: those within ``r`` (map units) of a
    whole-circle triangle whose gap centres wind (a vortex); none where ``r < 0``.
    :func:`vortex_radius` is the radius for every alignment of the gap, :func:`aligned_radius`
    the one for a gap that points at the vortex."""
    _, _, winds = lifted_ends(lo, w, tri)
    hot = winds & core[tri].all(axis=1)
    out = np.zeros(len(lo), bool)
    if hot.any() and r >= 0:
        from scipy.spatial import cKDTree
        near = cKDTree(points[tri[hot]].mean(axis=1)).query(points, distance_upper_bound=r)[0]
        out = np.isfinite(near)
    return out & core


def _unmovable(x_lb: np.ndarray, x_ub: np.ndarray, y_lb: np.ndarray, y_ub: np.ndarray,
               core: np.ndarray) -> np.ndarray:
    """The vertices whose bounds leave no move (radians, per vertex): an empty box for ``x``
    or ``y``, or, at a core vertex (``x = y``, the whole circle kept), boxes that do not
    meet (a triangle at it blocks orientations just after the gap place: its window bounds
    ``x`` from below above ``y``'s upper bound). The search holds them at their reference;
    an LP with them would be infeasible, slacks or not. Boxes apart by at most
    :data:`_FEASIBILITY` meet for HiGHS (its primal feasibility tolerance) and are kept."""
    bad = (x_lb > x_ub) | (y_lb > y_ub)
    apart = np.maximum(x_lb, y_lb) - np.minimum(x_ub, y_ub)
    return bad | (core & (apart > _FEASIBILITY))


class _RoundLP:
    """The LP of :func:`lp_field`'s rounds, kept in one HiGHS model for the whole search: the
    columns and the width and proximal rows are the same every round, only bounds move (the
    trust region, the free windows, the widths, the end rows' right-hand sides), the end rows
    of new cutting planes are added, and a release of core vertices turns their core rows
    into free rows and adds the end rows of the triangles it makes end-checked; HiGHS
    re-solves from the last basis (dual simplex: a bound change keeps the basis dual
    feasible; a new row's slack is basic), never from scratch after the first round.

    Columns: ``x⁺``, ``x⁻``, ``y⁺``, ``y⁻`` (nv each; ``x = x⁺ − x⁻``, ``y = y⁺ − y⁻``), the
    slacks (2 per mesh triangle: lower end, upper end; a triangle without end rows leaves its
    slack columns empty, hence at 0). The proximal price of ``|x|`` and ``|y|`` is that of
    ``x⁺ + x⁻`` and ``y⁺ + y⁻``: at an optimum one of each pair is 0 (raising both by the
    same amount only adds their positive price), so the optimum is that of the module
    docstring's LP with ``p >= ±x``, ``q >= ±y`` rows, without its 4 rows per vertex (the
    gallery at N = 100: a cold first round of 2,400 dual simplex iterations instead of
    11,300; ``tests/game/test_field_lp_split.py`` compares the two). Rows: widths (2 per live
    vertex), core (``x = y`` on live core vertices; free once released), then the end rows in
    the order they were added. The *live* vertices (``live``, indices; default all) are
    those the LP may move: a vertex held at its reference (``x``, ``y`` bounded to 0 by
    :meth:`solve`) needs no width or core row and no proximal price, its columns only enter
    the end rows of the triangles it shares with live vertices. :meth:`solve` returns
    ``x``, ``y`` and the slacks."""

    def __init__(self, tri: np.ndarray, hat: np.ndarray, core: np.ndarray,
                 area_v: np.ndarray, k: float, headings: int,
                 live: np.ndarray | None = None) -> None:
        nv, nt = len(area_v), len(tri)
        self.nv, self.tri, self.hat, self.k = nv, tri, hat, k
        iv = np.arange(nv) if live is None else np.asarray(live, np.int64)
        nl = len(iv)
        self.live = iv
        self.nx = 4 * nv + 2 * nt
        ncol = self.nx
        rows, cols, vals = [], [], []
        # x = x⁺ − x⁻ and y = y⁺ − y⁻ (columns x⁺, x⁻, y⁺, y⁻): u = x − y has the columns
        # +x⁺, −x⁻, −y⁺, +y⁻
        pm = np.array([1.0, -1.0, -1.0, 1.0])
        # widths: x − y <= W − W_MIN ; y − x <= 2π − W (right-hand sides set every round)
        for r0, sx in ((0, 1.0), (nl, -1.0)):
            for j in range(4):
                rows.append(r0 + np.arange(nl))
                cols.append(j * nv + iv)
                vals.append(np.full(nl, sx * pm[j]))
        r0 = 2 * nl
        # core vertices keep the whole circle: x − y = 0 (row core_row[i] of vertex i)
        on = np.zeros(nv, bool)
        on[iv] = True
        ci = np.flatnonzero(core & on)
        self.core_row = np.full(nv, -1, np.int64)
        self.core_row[ci] = r0 + np.arange(len(ci))
        for j in range(4):
            rows.append(r0 + np.arange(len(ci)))
            cols.append(j * nv + ci)
            vals.append(np.full(len(ci), pm[j]))
        self.n_fixed = r0 + len(ci)
        a = sparse.csc_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                      np.concatenate(cols))),
                              shape=(self.n_fixed, ncol))
        row_lo = np.full(self.n_fixed, -np.inf)
        row_hi = np.zeros(self.n_fixed)
        row_lo[r0:] = 0.0
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = ncol, self.n_fixed
        prox = np.zeros(nv)  # |x| and |y| priced PROXIMAL·area at live vertices
        prox[iv] = PROXIMAL * area_v[iv]
        lp.col_cost_ = np.concatenate([area_v + prox, -area_v + prox, -area_v + prox,
                                       area_v + prox, np.full(2 * nt, PENALTY)])
        lp.col_lower_ = np.zeros(ncol)
        lp.col_upper_ = np.full(ncol, np.inf)
        lp.row_lower_, lp.row_upper_ = row_lo, row_hi
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = a.indptr.astype(np.int32)
        lp.a_matrix_.index_ = a.indices.astype(np.int32)
        lp.a_matrix_.value_ = a.data.astype(float)
        self.h = _highs()
        self.h.passModel(lp)
        self.have = np.zeros((nt, headings, 2), bool)  # end rows in the model
        self.row_t = np.zeros(0, np.int64)  # per end row: triangle,
        self.row_h = np.zeros(0, np.int64)  # heading,
        self.row_s = np.zeros(0)  # and end (-1 lower, +1 upper)
        self.rhs = np.zeros(0)  # the end rows' right-hand sides in the model
        self.ends = np.full((nt, 6), np.nan)  # the lifted ends they were set for

    def release(self, freed: np.ndarray) -> None:
        """Vertices ``freed`` (indices) leave the core: their ``x = y`` rows become free."""
        r = self.core_row[freed]
        r = r[r >= 0]
        self.core_row[freed] = -1
        if len(r):
            self.h.changeRowsBounds(len(r), r.astype(np.int32), np.full(len(r), -np.inf),
                                    np.full(len(r), np.inf))

    def add_cuts(self, cut: np.ndarray, u_all: np.ndarray,
                 among: np.ndarray | None = None) -> None:
        """Add the end rows of the (triangle, heading, end) triples of ``cut``
        (``(triangles, headings, 2)`` over the mesh's triangles, end 0 the lower, 1 the upper)
        not in the model yet, of the triangles ``among`` only (indices; default all)."""
        sub = cut if among is None else cut[among]
        have = self.have if among is None else self.have[among]
        ti, hs, end = np.nonzero(sub & ~have)
        self.add_rows(ti if among is None else np.asarray(among)[ti], hs, end, u_all)

    def add_rows(self, ti: np.ndarray, hs: np.ndarray, end: np.ndarray,
                 u_all: np.ndarray) -> None:
        """Add the end rows of the triples ``(ti, hs, end)`` (triangle, heading, end 0 the
        lower or 1 the upper) not in the model yet (``u_all``: the headings' unit vectors):
        per triple, ``−sgn·k·Σ_j (∇φ_j·u)·z_j − s <= rhs`` (the right-hand side set by
        :meth:`solve`)."""
        new = ~self.have[ti, hs, end]
        ti, hs, end = ti[new], hs[new], end[new]
        nt, nh = self.have.shape[:2]  # duplicates once; the lower ends' rows first
        key = np.unique((end * nt + ti) * nh + hs)
        end, ti, hs = key // (nt * nh), (key // nh) % nt, key % nh
        if not len(ti):
            return
        self.have[ti, hs, end] = True
        sgn = np.where(end == 1, 1.0, -1.0)
        coef = np.einsum("rvk,rk->rv", self.hat[ti], u_all[hs])
        off = 2 * end[:, None] * self.nv  # x⁺ (lower end) or y⁺ (upper end), then x⁻, y⁻
        cols = np.column_stack([off + self.tri[ti], off + self.nv + self.tri[ti],
                                4 * self.nv + 2 * ti + end])
        c = -sgn[:, None] * self.k * coef
        vals = np.column_stack([c, -c, np.full(len(ti), -1.0)])
        self.h.addRows(len(ti), np.full(len(ti), -np.inf), np.full(len(ti), np.inf),
                       cols.size, (7 * np.arange(len(ti))).astype(np.int32),
                       cols.ravel().astype(np.int32), vals.ravel())
        self.row_t = np.concatenate([self.row_t, ti])
        self.row_h = np.concatenate([self.row_h, hs])
        self.row_s = np.concatenate([self.row_s, sgn])

    def solve(self, x_b: tuple[np.ndarray, np.ndarray], y_b: tuple[np.ndarray, np.ndarray],
              width: np.ndarray, end_rhs: np.ndarray) -> tuple[str | None, np.ndarray]:
        """Set the bounds of ``x`` and ``y`` (``(lower, upper)`` each), the widths ``W``
        and the end rows' right-hand sides, and re-solve. Returns ``(None, z)`` (the
        columns' values) when optimal, else ``(status, empty)``."""
        nv, h, iv = self.nv, self.h, self.live
        idx = np.arange(4 * nv, dtype=np.int32)
        lo, hi = [], []
        for lb, ub in (x_b, y_b):  # z in [lb, ub]: z⁺ in [lb⁺, ub⁺], z⁻ in [ub⁻, lb⁻]
            lo += [np.maximum(lb, 0.0), np.maximum(-ub, 0.0)]
            hi += [np.maximum(ub, 0.0), np.maximum(-lb, 0.0)]
        h.changeColsBounds(4 * nv, idx, np.concatenate(lo), np.concatenate(hi))
        nw = 2 * len(iv)
        h.changeRowsBounds(nw, np.arange(nw, dtype=np.int32), np.full(nw, -np.inf),
                           np.concatenate([width[iv] - W_MIN, _TAU - width[iv]]))
        # the end rows whose right-hand side changed (those of triangles whose ends moved,
        # and the new rows): HiGHS's update costs per row given
        old = np.full(len(end_rhs), np.nan)
        old[:len(self.rhs)] = self.rhs
        ch = np.flatnonzero(end_rhs != old)
        h.changeRowsBounds(len(ch), (self.n_fixed + ch).astype(np.int32),
                           np.full(len(ch), -np.inf), end_rhs[ch])
        self.rhs = end_rhs.copy()
        h.run()
        status = h.getModelStatus()
        if status != highspy.HighsModelStatus.kOptimal:
            return h.modelStatusToString(status), np.zeros(0)
        z = np.asarray(h.getSolution().col_value)
        return None, np.concatenate([z[:nv] - z[nv:2 * nv], z[2 * nv:3 * nv] - z[3 * nv:4 * nv],
                                     z[4 * nv:]])


def _highs() -> Any:
    """A silent HiGHS instance: highspy's bare binding where it exports one (its ``Highs``
    subclass installs a logging callback that prints a banner on stdout)."""
    h = getattr(highspy, "_Highs", highspy.Highs)()
    h.setOptionValue("output_flag", False)
    return h


def lp_field(env: Environment, points: np.ndarray, tri: np.ndarray, lo: np.ndarray,
             w: np.ndarray, lss: float, vt: float, vo: float, **options: Any) -> LPResult:
    """The widest arc field near the reference ``(lo, w)`` (radians per vertex) on the mesh
    ``(points, tri)`` by sequential LP (see the module docstring), :func:`lp_rounds` run to
    its end; ``options`` are its keywords (defaults there): at most ``rounds`` LPs,
    each move within ``rho`` radians, the end rows kept ``margin`` (``lss·rate``, map units
    per second) inside their bound, over ``headings`` target headings. ``core_radius`` (map
    units): whole-circle vertices at least this far from every gap start in the core (or
    ``core``, a mask); ``release`` (map units, default three mean edge lengths): how near to a
    stuck slack a core vertex is released; ``protect`` (map units, default
    :func:`vortex_radius`): core vertices this near a vortex (a whole-circle triangle whose
    gap centres wind) are never released (none if negative). ``progress`` gets each round's
    record. ``grow`` (map units): ``vt·d`` for a sensing delay ``d`` (the free windows of
    :func:`free_windows`). Returns the ends per vertex (radians) and the search's record
    (per round: ``t_windows``, ``t_lp``, ``t_ends``, the seconds spent on the free windows,
    the LP, and the end rows' bounds with the cutting planes).

    The blocked spans of the free windows are computed once (:func:`triangle_spans`, or
    ``spans``, those of every triangle of this mesh, given: a caller running several searches
    on one mesh computes them once); the LP is one HiGHS model re-solved from its last basis
    (:class:`_RoundLP`); the cutting-plane search looks again only at the triangles whose
    ends moved (the others' worst heading is already a row or not violated), and there only
    at those whose gradient is steep enough for some heading to violate
    (:func:`~tether.game.certificate.window_floor`).

    ``base_headings``: the evenly spaced headings whose end rows every steep end-checked
    triangle has, per end (:data:`BASE_HEADINGS`; the other rows are cutting planes,
    one heading per triangle, end and round at most, the one that violates most).
    ``base_steep``: the share of :func:`~tether.game.certificate.window_floor` (less half
    the margin) that ``lss·vt·|G|`` of one end must reach for its triangle to be steep and
    get the base rows, from the reference or the first round's field that steep on
    (:data:`BASE_STEEP`; 0: every end-checked triangle from the start, as before).
    ``seed_cuts``: add the reference field's own cutting planes before the first LP (else
    the first LP sees the base headings only). ``paired_ends``: a cutting plane found for
    one end adds the rows of its heading for both ends (the search as tuned; False: only for
    that end, half the rows).

    The search is *stuck* when a round adds no cutting plane and moves no end by
    :data:`STALL_MOVE` or more (a stall), or when its slack has not fallen by
    :data:`PLATEAU_REL` of its best within ``plateau`` rounds (a plateau,
    :data:`PLATEAU_ROUNDS`; 0: never; a search that cycles between two fields never stalls), or,
    with the plateau rule, when a round adds no cutting plane and does not improve on the best
    (:data:`SETTLED`, ``"stuck": "settled"``). Stuck with slack, it releases the core vertices
    near the slack (below) and goes on; with none to release, it stops. The round's record then
    says ``"stuck": "stall"`` or ``"plateau"``. Without slack it stops at a stall, or
    (``"stuck": "widths"``) when its mean width has not grown by :data:`WIDTH_REL` of itself
    within ``plateau`` rounds. A release must pay: when the slack has not fallen by
    :data:`RELEASE_REL` of its best before the release within ``release_rounds`` rounds of it
    (:data:`RELEASE_ROUNDS`; 0: no such limit), and that round added cutting planes for more
    than :data:`RELEASE_CUTS` of the LP's rows, the try ends there (``"stuck": "release"``).
    The record of a round that released says how many vertices (``"released"``); the LP
    keeps its model and basis across a release (:meth:`_RoundLP.release`).

    ``fixed`` (bool per vertex, optional): vertices that keep their reference ends, for a
    search local to the rest (:func:`tether.game.refine.refine_certified` frees only where it
    split the mesh). They stay columns of the LP, bounded to 0, rather than being moved to
    the right-hand sides: the end rows of a triangle with fixed and free vertices are then
    the same rows as without ``fixed`` (one code path, and the same field when ``fixed`` is
    None or all False), and a column fixed by its bounds is never basic, so it costs the
    simplex nothing. What scales with the mesh is dropped instead: the width, proximal and
    core rows and the proximal columns of fixed vertices (:class:`_RoundLP`'s live
    vertices), the end rows and the cutting-plane search of triangles whose three vertices
    are fixed (their ends do not move; :func:`~tether.game.certificate.certify` checks
    them), and the blocked spans of those triangles (their free windows bound fixed
    vertices only). A fixed core vertex is never released. Soundness does not depend on
    ``fixed``: the field is certified by ``certify`` or not at all.

    Examples
    --------
    >>> import numpy as np
    >>> from tether import Environment
    >>> from tether.game.certificate import free_mesh
    >>> env = Environment([(0, 0), (4, 0), (4, 4), (0, 4)])
    >>> lattice = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
    >>> pts, tri, _ = free_mesh(env, 1.0, lattice)
    >>> lo, w = np.full(len(pts), 1.0), np.full(len(pts), 2.0)  # rods from 1 to 3 rad
    >>> fixed = np.ones(len(pts), bool)
    >>> fixed[1] = False  # the vertex at (2, 1): only its ends may move
    >>> r = lp_field(env, pts, tri, lo, w, 1.0, 0.3, 1.0, rounds=2, fixed=fixed)
    >>> np.flatnonzero((r.lo != lo) | (r.hi != lo + w)).tolist()
    [1]
    """
    return _finish(lp_rounds(env, points, tri, lo, w, lss, vt, vo, **options))


def _finish(gen: Any) -> LPResult:
    """Run the rounds of :func:`lp_rounds` ``gen`` to the end: its result."""
    while True:
        try:
            next(gen)
        except StopIteration as stop:
            return stop.value


def initial_core(points: np.ndarray, w: np.ndarray, core_radius: float) -> np.ndarray:
    """The core :func:`lp_field` starts from: the whole-circle vertices (``w`` radians per
    vertex) at least ``core_radius`` (map units) from every vertex with a gap."""
    full0 = w >= FULL
    core = full0.copy()
    if (~full0).any() and full0.any():
        from scipy.spatial import cKDTree
        dist, _ = cKDTree(points[~full0]).query(points[full0])
        core[full0] = dist >= core_radius
    return core


def lp_rounds(env: Environment, points: np.ndarray, tri: np.ndarray, lo: np.ndarray,
              w: np.ndarray, lss: float, vt: float, vo: float, rho: float = 0.25,
              margin: float = 0.03, rounds: int = 20, headings: int = 256,
              core_radius: float = 0.0, core: np.ndarray | None = None,
              release: float | None = None,
              progress: Callable[[dict], Any] | None = None, grow: float = 0.0,
              fixed: np.ndarray | None = None, base_headings: int = BASE_HEADINGS,
              seed_cuts: bool = False, paired_ends: bool = True,
              plateau: int = PLATEAU_ROUNDS, protect: float | None = None,
              release_rounds: int = RELEASE_ROUNDS, spans: tuple | None = None,
              base_steep: float = BASE_STEEP) -> Any:
    """:func:`lp_field` (whose docstring describes the keywords) one round at a time: a
    generator that yields each LP round's record (the dict ``progress`` gets) and returns the
    :class:`LPResult` (``StopIteration.value``). A caller may run several searches a round at
    a time (:func:`solve_field` runs the first round of each core size before it chooses
    which to finish first)."""
    nv, nt = len(points), len(tri)
    xy = points[tri]
    if fixed is not None:
        fixed = np.asarray(fixed)
        if fixed.shape != (nv,) or fixed.dtype != bool:
            raise InvalidParameterError(
                f"fixed must be a bool mask of the {nv} vertices, got dtype {fixed.dtype} "
                f"and shape {fixed.shape}")
        if not fixed.any():
            fixed = None  # nothing held: the search over the whole mesh
    if release is None:  # by default three mean edge lengths
        release = 3 * float(np.mean(np.hypot(*(xy[:, 1] - xy[:, 0]).T)))
    e1, e2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    hat = hat_gradients(xy)  # (nt, 3, 2)
    area_v = np.zeros(nv)
    np.add.at(area_v, tri.ravel(), np.repeat(np.abs(det) / 6, 3))
    area_v *= WIDTH_PRICE / area_v.mean()  # the widths' prices, scale-free
    th_all = np.linspace(0, _TAU, headings, endpoint=False)
    U_all = np.stack([np.cos(th_all), np.sin(th_all)], 1)
    k = lss * vt
    L = lo.astype(float).copy()
    H = L + w
    core = initial_core(points, w, core_radius) if core is None else core.copy()
    if protect is None:
        protect = vortex_radius(lss, vt, vo)
    protected = _vortex_vertices(points, L, H - L, tri, core, protect)
    cen = xy.mean(axis=1)
    # the (heading, end) pairs whose end rows each triangle has: base_headings evenly
    # spaced ones from the start, and the cutting planes (end 0 the lower, 1 the upper)
    cut = np.zeros((nt, headings, 2), bool)
    base = np.zeros(headings, bool)  # the base headings
    if base_headings:
        base[::max(headings // base_headings, 1)] = True
    based = np.zeros(nt, bool)  # triangles whose base headings' rows are in ``cut``
    seen = np.full((nt, 6), np.nan)  # the ends each triangle's cut search last saw
    # no heading can violate an end whose smallest bound over every window, less the largest
    # rate its gradient asks for, keeps half the margin (window_floor)
    floor = {sgn: window_floor(vt, vo, sgn) - margin / 2 for sgn in (-1.0, 1.0)}

    def steep(ts: np.ndarray, Lt: np.ndarray, Ht: np.ndarray) -> np.ndarray:
        """Those of the triangles ``ts`` (indices) not yet based whose lower or upper end
        (lifted ends ``Lt``, ``Ht``) has a gradient that asks for at least ``base_steep``
        times the floor (``k·|G| >= base_steep·floor``): their base headings go into
        ``cut``; returned as new (triangle, heading, end) triples."""
        ts = ts[~based[ts]]
        go = np.zeros(len(ts), bool)
        for sgn, Z in ((-1.0, Lt), (1.0, Ht)):
            G = np.einsum("nvk,nv->nk", hat[ts], Z[ts])
            go |= k * np.hypot(G[:, 0], G[:, 1]) >= base_steep * floor[sgn]
        tn = ts[go]
        based[tn] = True
        fresh = cut[tn][:, base]
        cut[np.ix_(tn, np.flatnonzero(base))] = True
        ti, hi, ei = np.nonzero(~fresh)
        return tn[ti], np.flatnonzero(base)[hi], ei

    def search_cuts(L: np.ndarray, H: np.ndarray, et: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cutting planes for the field ``(L, H)``: per triangle of ``et`` whose ends moved
        since it was last searched, and per end, the heading that violates most (if it does
        and has no row yet). Returns the new (triangle, heading, end) triples."""
        Lt, Ht, _ = lifted_ends(L, H - L, tri)
        now = np.concatenate([Lt[et], Ht[et]], axis=1)
        moved = ~(now == seen[et]).all(axis=1)
        em = et[moved]
        seen[em] = now[moved]
        found = []
        for end, (sgn, Z) in enumerate(((-1.0, Lt), (1.0, Ht))):
            G = np.einsum("nvk,nv->nk", hat[em], Z[em])
            # F >= floor − k·|G| at every heading: only where that is below 0 can one violate
            can = floor[sgn] - k * (1 + 1e-9) * np.hypot(G[:, 0], G[:, 1]) < 1e-12
            ec, Gc = em[can], G[can]
            S = heading_window_min(Z[ec].min(1), Z[ec].max(1), headings, vt, vo, sgn)
            F = S + sgn * k * (Gc[:, 0:1] * U_all[:, 0] + Gc[:, 1:2] * U_all[:, 1]) \
                - margin / 2
            worst = np.argmin(F, axis=1)
            viol = F[np.arange(len(ec)), worst] < 0
            new = viol & ~cut[ec, worst, end]
            tn, hn = ec[new], worst[new]
            cut[tn, hn, slice(None) if paired_ends else end] = True
            found.append((tn, hn, np.full(len(tn), end)))
            if paired_ends:
                found.append((tn, hn, np.full(len(tn), 1 - end)))
        if base_steep > 0:  # triangles grown steep since: their base headings
            found.append(steep(em, Lt, Ht))
        return tuple(np.concatenate(x) for x in zip(*found, strict=True))

    # triangles with a vertex the LP may move (all without ``fixed``), and those vertices
    live_t = np.ones(nt, bool) if fixed is None else ~fixed[tri].all(axis=1)
    live = None if fixed is None else np.flatnonzero(~fixed)

    def ends_checked() -> tuple[np.ndarray, np.ndarray]:
        et = np.flatnonzero(~core[tri].all(axis=1) & live_t)  # triangles with end constraints
        idle = core.copy()  # vertices of no end-checked triangle: their gap place stays
        idle[tri[et].ravel()] = False
        if fixed is not None:
            idle |= fixed
        return et, idle

    et, idle = ends_checked()
    if base_steep > 0:  # the base headings of the triangles steep at the reference
        steep(et, *lifted_ends(L, H - L, tri)[:2])
    else:
        cut[:, base] = True
    model = _RoundLP(tri, hat, core, area_v, k, headings, live)
    model.add_cuts(cut, U_all, et)
    t_spans = time.perf_counter()
    if spans is not None:
        pass
    elif fixed is None:
        spans = triangle_spans(env, xy, lss, grow)
    else:  # the spans of triangles with a free vertex, numbered in the whole mesh
        at = np.flatnonzero(live_t)
        t_s, b0_s, b1_s = triangle_spans(env, xy[at], lss, grow)
        spans = (at[t_s], b0_s, b1_s)
    t_spans = time.perf_counter() - t_spans  # counted with the first round's windows
    log = []
    if seed_cuts:  # the reference's own violated headings, before the first LP
        model.add_rows(*search_cuts(L, H, et), U_all)
    slack_sum = np.inf
    best, best_round = np.inf, 0  # the plateau's reference: the best slack, and its round
    widest, widest_round = 0.0, 0  # without slack: the widest mean width, and its round
    released_at, before, since = 0, np.inf, np.inf  # the last release: its round, the best
    # slack before it, the least since
    r = 0
    for r in range(1, rounds + 1):
        t0 = time.perf_counter()
        Lt, Ht, _ = lifted_ends(L, H - L, tri)
        # free windows around the middle of the vertices' common arc (else vertex 0's middle)
        cmid = np.where(Lt.max(1) <= Ht.min(1), (Lt.max(1) + Ht.min(1)) / 2,
                        (Lt[:, 0] + Ht[:, 0]) / 2)
        f_lo, f_hi = windows_of_spans(spans, cmid, nt)
        x_lb = np.full(nv, -rho)
        y_ub = np.full(nv, rho)
        np.maximum.at(x_lb, tri.ravel(), (f_lo[:, None] + WINDOW_GAP - Lt).ravel())
        np.minimum.at(y_ub, tri.ravel(), (f_hi[:, None] - WINDOW_GAP - Ht).ravel())
        x_ub = np.full(nv, rho)
        y_lb = np.full(nv, -rho)
        x_lb[idle], x_ub[idle], y_lb[idle], y_ub[idle] = 0.0, 0.0, 0.0, 0.0
        bad = _unmovable(x_lb, x_ub, y_lb, y_ub, core)
        if bad.any():  # a vertex whose reference is blocked: kept, and reported
            x_lb[bad], x_ub[bad], y_lb[bad], y_ub[bad] = 0.0, 0.0, 0.0, 0.0
            log.append({"round": r, "blocked_reference": int(bad.sum())})
        t1 = time.perf_counter()
        # the end rows' right-hand sides: lower end k·(G + Σ x_j ∇φ_j)·u − s <= S − m,
        # upper end −k·(…)·u − s <= S − m, S at the row's triangle and heading
        # (recomputed only for the rows of triangles whose ends moved, and new rows)
        ti, hs, sg = model.row_t, model.row_h, model.row_s
        now = np.concatenate([Lt, Ht], axis=1)
        fresh = ~(now == model.ends).all(axis=1)
        model.ends = now
        rhs = np.empty(len(ti))
        rhs[:len(model.rhs)] = model.rhs
        redo = fresh[ti]
        redo[len(model.rhs):] = True
        for sgn, Z in ((-1.0, Lt), (1.0, Ht)):
            m = redo & (sg == sgn)
            tm, hm = ti[m], hs[m]
            amin, amax = Z.min(1) - A_WIDEN, Z.max(1) + A_WIDEN
            G = np.einsum("nvk,nv->nk", hat, Z)
            S = window_min_at(th_all[hm] - amax[tm], th_all[hm] - amin[tm], vt, vo, sgn)
            rhs[m] = S - margin + sgn * k * (G[tm] * U_all[hm]).sum(1)
        t2 = time.perf_counter()
        status, z = model.solve((x_lb, x_ub), (y_lb, y_ub), H - L, rhs)
        t3 = time.perf_counter()
        if status is not None:
            log.append({"round": r, "status": status})
            break
        nx_ = 2 * nv + 2 * nt
        x, y, s = z[:nv], z[nv:2 * nv], z[2 * nv:nx_]
        L = L + x
        H = H + y
        slack_sum = float(s.sum())
        # cutting planes: for the new field, the headings that violate most per triangle
        # and end (only where the ends moved since this triangle was last searched)
        new_cuts = search_cuts(L, H, et)
        added = len(new_cuts[0]) // (2 if paired_ends else 1)
        model.add_rows(*new_cuts, U_all)
        t4 = time.perf_counter()
        move = float(max(np.abs(x).max(), np.abs(y).max()))
        entry = {"round": r, "slack": slack_sum, "move": move, "cuts_added": added,
                 "mean_w": float(np.mean(H - L) / _TAU), "rows": model.h.getNumRow(),
                 "t_windows": t1 - t0 + (t_spans if r == 1 else 0.0), "t_lp": t3 - t2,
                 "t_ends": t2 - t1 + t4 - t3}
        entry["slack_at"] = [points[tri[j // 2]].mean(0).round(2).tolist()
                             for j in np.argsort(-s)[:5] if s[j] > 1e-9]
        log.append(entry)
        if progress is not None:
            progress(entry)
        if slack_sum < (1.0 - PLATEAU_REL) * best:
            best, best_round = slack_sum, r
        stalled = added == 0 and move < STALL_MOVE
        if slack_sum > 0.0:
            widest, widest_round = 0.0, r
        elif entry["mean_w"] > (1.0 + WIDTH_REL) * widest:
            widest, widest_round = entry["mean_w"], r
        # settled: a round that added no cutting plane solved the LP with every row the
        # search has, and did not improve on the best (slack, or width without slack): the
        # next LP has the same rows (only the trust region and the bounds S move); a
        # plateau without waiting out its rounds (with the plateau rule only)
        settled = SETTLED and 0 < plateau and added == 0 \
            and r > (best_round if slack_sum > 0.0 else widest_round)
        if slack_sum <= 0.0 and (stalled or settled or 0 < plateau <= r - widest_round):
            entry["stuck"] = "stall" if stalled else "settled" if settled else "widths"
            break
        since = min(since, slack_sum)
        if released_at and 0 < release_rounds == r - released_at \
                and since > (1.0 - RELEASE_REL) * before \
                and added > RELEASE_CUTS * (6 * nv + len(model.row_t)):
            entry["stuck"] = "release"  # the last release did not pay: the try ends
            break
        if slack_sum > 0.0 and (stalled or settled or 0 < plateau <= r - best_round):
            entry["stuck"] = "stall" if stalled else "settled" if settled else "plateau"
            # stuck with slack: the core vertices near the triangles that need it give up
            # the whole circle (their gap may open), and the search goes on
            hot = cen[np.flatnonzero(s.reshape(-1, 2).max(axis=1) > 1e-9)]
            from scipy.spatial import cKDTree
            near = cKDTree(hot).query_ball_point(points[core], release)
            freed = np.flatnonzero(core)[np.array([len(q) > 0 for q in near], bool)]
            freed = freed[~protected[freed]]
            if fixed is not None:
                freed = freed[~fixed[freed]]
            if not len(freed):
                break
            core[freed] = False
            et_before = et
            et, idle = ends_checked()
            if base_steep > 0:  # the steep ones of the triangles it makes end-checked
                steep(np.setdiff1d(et, et_before), *lifted_ends(L, H - L, tri)[:2])
            model.release(freed)  # the same model: the freed vertices' x = y rows go,
            model.add_cuts(cut, U_all, np.setdiff1d(et, et_before))  # new triangles' rows
            entry["released"] = int(len(freed))
            released_at, before, since = r, min(best, slack_sum), np.inf
            best, best_round = np.inf, r  # the slack is measured afresh after a release
        yield entry
    return LPResult(L, H, slack_sum, r, log, core)


def vortex_radius(lss: float, vt: float, vo: float) -> float:
    """The smallest radius (map units) of a whole-circle disc around a vortex of the gap
    place: ``lss·vt/(sqrt(vo² − vt²) − vt)``, where the turn rate ``1/r`` of a gap place
    winding once equals the fastest an end can follow in the worst heading."""
    return lss * vt / (math.sqrt(vo * vo - vt * vt) - vt)


def aligned_radius(lss: float, vt: float, vo: float) -> float:
    """The smallest radius (map units) of a whole-circle disc around a vortex whose gap points
    at its centre: ``lss·vt/(vo + vt)``. On the circle of radius ``ρ`` the ends ``lo = hi −
    2π = ψ + π`` (``ψ`` the polar angle) turn at ``1/ρ`` along it, and both end conditions
    hold for ``lss·vt/ρ <= vo + vt`` (``docs/certified.md``, "Where no field is certified";
    ``tests/game/test_certified_cores.py`` checks it with
    :func:`~tether.game.certificate.end_slack`). It exists at every speed ratio, where
    :func:`vortex_radius` (every alignment) does not above ``1/√2``."""
    return lss * vt / (vo + vt)


def solve_field(env: Environment, kern: Any, lss: float, vt: float, vo: float,
                tries: tuple[float, ...] = CORE_TRIES, rounds: int = SEARCH_ROUNDS,
                progress: Callable[[dict], Any] | None = None, grow: float = 0.0,
                start: ArcField | None = None, plateau: int = PLATEAU_ROUNDS,
                release_rounds: int = RELEASE_ROUNDS) -> tuple[ArcField, Checks | None, list]:
    """The best field the search finds, the first :func:`~tether.game.certificate.certify`
    passes if any, searched from
    :func:`~tether.game.certificate.first_field` of ``kern`` (a conservative grid kernel of
    the same game) with the core at each of ``tries`` times :func:`vortex_radius` from the
    gaps (0: every whole-circle vertex, released where needed; above ``vt/vo = 1/√2``, where
    :func:`vortex_radius` is negative, every size gives that same core and the same search,
    which runs once). Returns ``(field, checks,
    log)``: the best field tried (:func:`_best_try`: fewest failing triangles, then the
    widest; a certified one ends the search) and its checks (``checks.passed`` when
    certified; None when the first field already has a closed arc, which no search can open
    and nothing else was tried), and one record per try, the kept one marked ``"kept":
    True``.

    ``grow`` (map units, ``vt·d``): the sensing delay of :func:`certify`. ``start``: a field
    on the same mesh to try first (one certified at a shorter delay: it is checked at this
    one, kept if it passes, else the search starts from it with the first core size of
    ``tries``, and then from the first field as without it). ``plateau``: the rounds
    without progress after which a try counts as stuck, ``release_rounds``: those within which
    a release of core vertices must pay (:func:`lp_field`)."""
    log: list = []
    r_v = vortex_radius(lss, vt, vo)
    if r_v < 0:  # above vt/vo = 1/√2 every core size is the whole-circle set: one try
        tries = tries[:1]
    f = first_field(kern, grow)
    tried: list = []  # (field, checks, record) per field certify checked
    if start is not None and np.array_equal(start.points, f.points) \
            and np.array_equal(start.tri, f.tri):
        g = ArcField(f.points, f.tri, start.lo.copy(), start.w.copy())
        checks = certify(g, env, lss, vt, vo, grow)
        log.append({"start": "given", "failing": int(checks.bad.sum()),
                    "mean_w": float(np.mean(g.w) / _TAU)})
        tried.append((g, checks, log[-1]))
        if not checks.passed:
            tried += _search(env, g, lss, vt, vo, tries[:1], r_v, rounds, progress, grow,
                             log, plateau, release_rounds)
        if tried[-1][1].passed:
            return _best_try(tried) + (log,)
    if (f.w <= 0).any():
        log.append({"core": None, "closed_arcs": int((f.w <= 0).sum())})
        return _best_try(tried) + (log,) if tried else (f, None, log)
    tried += _search(env, f, lss, vt, vo, tries, r_v, rounds, progress, grow, log, plateau,
                     release_rounds)
    return _best_try(tried) + (log,)


def _best_try(tried: list) -> tuple[ArcField, Checks]:
    """Of ``tried`` (``(field, checks, record)`` per field checked), the one with the fewest
    failing triangles, then the widest (largest mean width, fraction of 2π, ``"mean_w"``),
    then the earliest; its record is marked ``"kept": True``."""
    i = min(range(len(tried)),
            key=lambda j: (int(tried[j][1].bad.sum()), -tried[j][2]["mean_w"], j))
    tried[i][2]["kept"] = True
    return tried[i][0], tried[i][1]


def _search(env: Environment, f: ArcField, lss: float, vt: float, vo: float,
            tries: tuple[float, ...], r_v: float, rounds: int,
            progress: Callable[[dict], Any] | None, grow: float, log: list,
            plateau: int = PLATEAU_ROUNDS, release_rounds: int = RELEASE_ROUNDS
            ) -> list:
    """The sequential LP from ``f`` with the core at each of ``tries`` times ``r_v``, until a
    field passes :func:`certify`: ``(field, checks, record)`` per try (records appended to
    ``log``, in the order the tries ran).

    A core size whose core is an earlier one's is the same search and is skipped. With more
    than one try, the first LP round of each runs first, and the tries are finished in the
    order of that round's slack, least first (ties in the order of ``tries``): the slack the
    first LP needs to move from ``f`` within one trust region is how far that core's problem
    is from a field, and the try that needs least is tried first (``docs/certified.md``, "How
    the field is found"). The first in that order goes on from its first round; the others'
    LP models are dropped as soon as a try with less slack is found (at most two models at a
    time: one model is the search's largest piece of memory), and a try run after a failing
    one starts again from its first round. Those that do not run leave a record
    ``{"probes_not_run": [...]}`` (core, first slack and seconds of each)."""
    t_spans = time.perf_counter()
    spans = triangle_spans(env, f.points[f.tri], lss, grow)
    t_spans = time.perf_counter() - t_spans  # counted with the first try's windows
    qs: list = []
    cores: list = []
    for q in tries:
        c = initial_core(f.points, f.w, q * r_v)
        if not any(np.array_equal(c, d) for d in cores):
            qs.append(q)
            cores.append(c)

    def start(i: int) -> Any:
        return lp_rounds(env, f.points, f.tri, f.lo.copy(), f.w.copy(), lss, vt, vo,
                         rounds=rounds, core_radius=qs[i] * r_v, core=cores[i],
                         progress=progress, grow=grow, plateau=plateau,
                         release_rounds=release_rounds, spans=spans)

    gens: list = [None] * len(qs)  # the tries under way (at most two LP models at a time)
    first: list = []  # per try: its first round's slack, its result if it ended there, and
    # the first round's record
    lead = None  # the try of least first slack so far: the only one kept under way
    for i in range(len(qs)) if len(qs) > 1 else ():
        gens[i] = start(i)
        try:
            e = next(gens[i])
            first.append((float(e["slack"]), None, e))
        except StopIteration as stop:
            first.append((float(stop.value.slack), stop.value, {}))
        drop = i
        if lead is None or first[i][0] < first[lead][0]:
            drop, lead = lead, i
        if drop is not None:  # not the lead: its model goes (restarted if it is run)
            gens[drop].close()
            gens[drop] = None
    order = sorted(range(len(qs)), key=lambda i: (first[i][0], i)) if first else [0]
    tried: list = []
    ran: list = []
    try:
        for i in order:
            ran.append(i)
            r = (first[i][1] if first else None) or _finish(gens[i] or start(i))
            g = ArcField(f.points, f.tri, r.lo, np.minimum(r.hi - r.lo, _TAU))
            t0 = time.perf_counter()
            checks = certify(g, env, lss, vt, vo, grow)
            rec = [e for e in r.log if "t_lp" in e]
            log.append({"core": qs[i], "rounds": r.rounds, "slack": r.slack,
                        **({"first_slack": first[i][0]} if first else {}),
                        "stuck": [(e["round"], e["stuck"]) for e in r.log if "stuck" in e],
                        "releases": sum(1 for e in r.log if "released" in e),
                        "failing": int(checks.bad.sum()),
                        "mean_w": float(np.mean(g.w) / _TAU),
                        "t_windows": sum(e["t_windows"] for e in rec)
                        + (t_spans if not tried else 0.0),
                        "t_lp": sum(e["t_lp"] for e in rec),
                        "t_ends": sum(e["t_ends"] for e in rec),
                        "t_certify": time.perf_counter() - t0})
            tried.append((g, checks, log[-1]))
            if checks.passed:
                break
    finally:
        for gen in gens:  # the tries not run to the end: their models go
            if gen is not None:
                gen.close()
    if len(ran) < len(first):  # the first rounds of tries not run: their slack and seconds
        log.append({"probes_not_run": [
            {"core": qs[i], "first_slack": first[i][0],
             **{key: first[i][2].get(key, 0.0) for key in ("t_windows", "t_lp", "t_ends")}}
            for i in range(len(first)) if i not in ran]})
    return tried
