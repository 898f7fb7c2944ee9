"""Escape points: where a surviving cell's target can cross toward eliminated cells, and the
sweep the observer needs before it gets there (``docs/formulas.md``, "The verdict";
``docs/strategy.md``).

**Escape table.** For a surviving cell ``K`` over ``R`` and a piece ``γ`` of ``R`` toward
``R'``, the continuation set ``C_γ(K)`` is the part of ``K``'s arc that continues into
*surviving* partners across ``γ``. Where some partner of ``K`` across ``γ`` was eliminated,
``C_γ(K)`` is not all of ``K``'s arc: ``γ`` is an *escape piece* of ``K`` and ``C_γ(K)`` its
goal. The table samples every escape piece (points ``q`` just inside ``R``, with ``K``'s arc
there and the goal arcs just across). Reflex vertices are listed with their no-pivot radius
``Lss·vt/(vo+vt)``.

**For an orientation a** an escape sample ``q`` concerns the rod when ``a`` lies in ``K``'s arc
at ``q`` but not in the goal: the observer must sweep ``Δ`` (inside ``K``'s arc, in the sense
``σ`` that reaches the goal first) before the target gets there. The sweep takes at most
``T_g = Lss·Δ/(vo − vt)``, the target covers ``L_g = vt·T_g`` meanwhile (:func:`l_safe`); the
paper's ``L`` (straight dash, R3) is :func:`l_paper`. Lengths in map units, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tether._util.vocabulary import Vocabulary
from tether.analysis.elimination import Verdict
from tether.arcs import feature_name, free_arcs_many, wedge_columns
from tether.bounds import distance_bound
from tether.decomposition import FREE, cell_name

__all__ = [
    "EscapeRows",
    "SAMPLES_PER_PIECE", "VERTEX_GOAL_MARGIN", "WALL_CODE", "EscapeTable", "escape_table",
    "escape_table_of", "l_paper", "l_safe", "sweep_row", "sweeps", "wall_contact_points",
    "wall_rows",
]

#: Samples per escape piece (at most; short pieces get fewer).
SAMPLES_PER_PIECE = 24


class EscapeRows(Vocabulary):
    """Which rows of an :class:`EscapeTable` a controller weighs (:meth:`EscapeTable.subset`):
    the pieces' escape samples only, those and the reflex vertices, or every row (the steep
    wall contacts too). The plain strings are accepted as well."""

    PIECES = "pieces"
    PIECES_VERTICES = "pieces+vertices"
    ALL = "all"


@dataclass(frozen=True, eq=False)
class EscapeTable:
    """Escape samples of every surviving cell (vectorized rows) and the reflex vertices.

    Row ``i``: point ``q[i]`` on piece ``piece[i]`` just inside the region of cell
    ``cell[i]``; ``(k_start[i], k_end[i])`` (CCW; equal ends: the full circle) is that cell's
    arc there widened over the blocked gaps on both sides (:func:`_widened`): the orientations
    the row concerns; the goal is the union of CCW arcs ``(g_start[i, j], g_end[i, j])``
    (NaN padded).
    """

    verdict: Verdict = field(repr=False)
    q: np.ndarray
    cell: tuple[str, ...]
    piece: np.ndarray
    k_start: np.ndarray
    k_end: np.ndarray
    g_start: np.ndarray
    g_end: np.ndarray
    reflex: np.ndarray  # indices of reflex vertices
    reflex_xy: np.ndarray

    def __len__(self) -> int:
        return len(self.q)

    @property
    def is_vertex(self) -> np.ndarray:
        """Rows that stand for a reflex vertex (``piece`` holds ``−1 − j`` there)."""
        return (self.piece < 0) & (self.piece > WALL_CODE)

    @property
    def is_wall(self) -> np.ndarray:
        """Rows that stand for a steep wall contact (``piece`` holds ``WALL_CODE − i``)."""
        return self.piece <= WALL_CODE

    def subset(self, kinds: EscapeRows | str) -> EscapeTable:
        """The rows of some kinds only (an :class:`EscapeRows` or its value)."""
        kinds = EscapeRows(kinds)
        keep = self.piece >= 0
        if kinds == EscapeRows.PIECES_VERTICES:
            keep = keep | self.is_vertex
        if kinds == EscapeRows.ALL:
            keep = np.ones(len(self), dtype=bool)
        return EscapeTable(self.verdict, self.q[keep], tuple(np.array(self.cell, dtype=object)
                                                              [keep].tolist()),
                           self.piece[keep], self.k_start[keep], self.k_end[keep],
                           self.g_start[keep], self.g_end[keep], self.reflex, self.reflex_xy)

    def offsets(self, vt: float, vo: float) -> np.ndarray:
        """Extra distance per row: the no-pivot radius ``Lss·vt/(vo+vt)`` at vertex rows."""
        return np.where(self.is_vertex, self.verdict.dec.lss * vt / (vo + vt), 0.0)

    def margins(self, p: Any, a: float, vt: float, vo: float,
                arc: tuple[float, float] | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(concern, Δ, σ, margin)`` per row for the rod ``(p, a)`` (in free ``arc``, see
        :meth:`sweeps`): ``margin = |p − q| − L_g(Δ) − offset`` (``inf`` where the row does
        not concern the rod)."""
        concern, delta, sense = self.sweeps(a, arc)
        q = self.points_for(p, a)
        d = np.hypot(q[:, 0] - p[0], q[:, 1] - p[1])
        m = d - l_safe(delta, vt, vo, self.verdict.dec.lss) - self.offsets(vt, vo)
        return concern, delta, sense, np.where(concern, m, np.inf)

    def points_for(self, p: Any, a: float) -> np.ndarray:
        """The escape point of each row for the rod ``(p, a)`` (m, 2): ``q`` itself, except at
        a steep-wall row, where it is the point nearest ``p`` of the wall translated by
        ``−lss·u(a)``: every target position from which rod ``a`` touches the wall (the wall
        row's ``q`` is only the perpendicular contact at the wall's middle)."""
        q = self.q
        wall = self.is_wall
        if not wall.any():
            return q
        q = q.copy()
        edges = WALL_CODE - self.piece[wall]
        q[wall] = wall_contact_points(self.verdict.dec.env, edges, self.verdict.dec.lss,
                                      np.asarray(p, float).reshape(1, 2), a)[:, 0]
        return q

    @property
    def pieces(self) -> list[str]:
        """Names ``P<k>`` of the pieces holding escape samples, in piece order."""
        return [f"P{k}" for k in sorted({k for k in self.piece.tolist() if k >= 0})]

    def sweeps(self, a: float, arc: tuple[float, float] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For orientation ``a``: which rows concern the rod (``a`` in the cell's arc, not in
        the goal), the sweep ``Δ`` to the goal (rad) and its sense ``σ`` (+1 CCW, −1 CW).

        ``arc``: the rod's current free arc ``(start, end)`` (CCW). Vertex rows (whose cell
        arc is the whole circle) then sweep only inside it, since the rod cannot turn through
        an obstacle."""
        ks, ke = self.k_start, self.k_end
        anywhere = self.piece < 0
        if arc is not None and anywhere.any():
            ks = np.where(anywhere, arc[0], ks)
            ke = np.where(anywhere, arc[1], ke)
        return sweeps(ks, ke, self.g_start, self.g_end, a)

    def to_dict(self) -> dict:
        """The table as JSON-ready values, one entry per row (map units, radians)."""
        rows = []
        for i in range(len(self.q)):
            goal = [[float(s), float(e)] for s, e in zip(self.g_start[i], self.g_end[i],
                                                          strict=True) if np.isfinite(s)]
            rows.append({"point": self.q[i].tolist(), "cell": self.cell[i],
                         "piece": row_name(int(self.piece[i])),
                         "cell_arc": [float(self.k_start[i]), float(self.k_end[i])],
                         "goal": goal})
        env = self.verdict.dec.env
        return {"escape_samples": rows,
                "reflex_vertices": [{"vertex": env.vertex_name(int(j)),
                                     "point": env.vertices[int(j)].tolist()}
                                    for j in self.reflex]}


#: Piece code of wall rows: ``WALL_CODE − i`` for edge ``E<i>``.
WALL_CODE = -1_000_000


def row_name(k: int) -> str:
    if k >= 0:
        return f"P{k}"
    return f"V{-1 - k}" if k > WALL_CODE else f"E{WALL_CODE - k}"


def sweeps(ks: Any, ke: Any, gs: Any, ge: Any, a: Any
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorized core of :meth:`EscapeTable.sweeps` (``gs``, ``ge`` of shape (m, G))."""
    ks, ke = np.asarray(ks, float), np.asarray(ke, float)
    gs, ge = np.asarray(gs, float), np.asarray(ge, float)
    klen = np.mod(ke - ks, math.tau)
    klen = np.where(klen == 0.0, math.tau, klen)
    in_k = np.mod(a - ks, math.tau) <= klen
    glen = np.mod(ge - gs, math.tau)
    glen = np.where(glen == 0.0, math.tau, glen)
    valid = np.isfinite(gs)
    in_g = np.any(valid & (np.mod(a - gs[...], math.tau) <= np.where(valid, glen, -1.0)), axis=1)
    ahead = np.mod(ke - a, math.tau)[:, None]  # room CCW inside K's arc
    behind = np.mod(a - ks, math.tau)[:, None]  # room CW
    full = (klen >= math.tau)[:, None]
    raw_ccw = np.where(valid, np.mod(gs - a, math.tau), np.inf)
    raw_cw = np.where(valid, np.mod(a - ge, math.tau), np.inf)
    d_ccw = np.where(full | (raw_ccw <= ahead), raw_ccw, np.inf)
    d_cw = np.where(full | (raw_cw <= behind), raw_cw, np.inf)
    best_ccw, best_cw = d_ccw.min(axis=1), d_cw.min(axis=1)
    # a goal the rod cannot reach inside its arc now (an obstacle in the way): count the
    # unconstrained sweep, since the arc may open as the target moves; never ignore the row
    stuck = ~np.isfinite(np.minimum(best_ccw, best_cw))
    best_ccw = np.where(stuck, raw_ccw.min(axis=1), best_ccw)
    best_cw = np.where(stuck, raw_cw.min(axis=1), best_cw)
    delta = np.minimum(best_ccw, best_cw)
    sense = np.where(best_ccw <= best_cw, 1, -1)
    concern = in_k & ~in_g & np.isfinite(delta)
    return concern, np.where(concern, delta, 0.0), sense


def sweep_row(ks: float, ke: float, gs: Any, ge: Any, a: float) -> tuple[bool, float, int]:
    """:func:`sweeps` for one row, in scalar arithmetic (the controller's per-step check of its
    committed row: a few µs instead of a dozen numpy calls). ``gs``, ``ge``: the row's goal
    arcs (NaN-padded). Returns ``(concern, Δ, σ)``."""
    klen = (ke - ks) % math.tau or math.tau
    in_k = (a - ks) % math.tau <= klen
    full = klen >= math.tau
    ahead, behind = (ke - a) % math.tau, (a - ks) % math.tau
    in_g = False
    best = [math.inf, math.inf]  # CCW, CW inside the arc
    raw = [math.inf, math.inf]  # CCW, CW unconstrained
    for s, e in zip(gs, ge, strict=True):
        s, e = float(s), float(e)
        if not math.isfinite(s):
            continue
        if (a - s) % math.tau <= ((e - s) % math.tau or math.tau):
            in_g = True
        r_ccw, r_cw = (s - a) % math.tau, (a - e) % math.tau
        raw[0], raw[1] = min(raw[0], r_ccw), min(raw[1], r_cw)
        if full or r_ccw <= ahead:
            best[0] = min(best[0], r_ccw)
        if full or r_cw <= behind:
            best[1] = min(best[1], r_cw)
    if not math.isfinite(min(best)):
        best = raw
    delta = min(best)
    sense = 1 if best[0] <= best[1] else -1
    concern = in_k and not in_g and math.isfinite(delta)
    return concern, (delta if concern else 0.0), sense


def _piece_samples(piece: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points along a piece and unit normals there (map units)."""
    geom = piece.geometry
    lines = list(getattr(geom, "geoms", [geom]))
    pts, nrm = [], []
    total = sum(g.length for g in lines)
    for g in lines:
        if g.length <= 0:
            continue
        k = max(1, int(round(n * g.length / total)))
        for s in (np.arange(k) + 0.5) / k:
            d = s * g.length
            a = np.asarray(g.interpolate(max(d - 1e-6 * g.length, 0.0)).coords[0])
            b = np.asarray(g.interpolate(min(d + 1e-6 * g.length, g.length)).coords[0])
            t = b - a
            tn = float(np.hypot(*t))
            if tn == 0:
                continue
            pts.append(np.asarray(g.interpolate(d).coords[0]))
            nrm.append(np.array([-t[1], t[0]]) / tn)
    if not pts:
        return np.asarray([piece.sample]), np.asarray([piece.normal])
    return np.array(pts), np.array(nrm)


def _arc_of(table: Any, env: Any, i: int, region: int, wanted: set[str]
            ) -> list[tuple[float, float, str]]:
    """Arcs of point ``i`` of an arc table whose cell name (in ``region``) is in ``wanted``."""
    if table.full[i]:
        cid = cell_name(region, FREE, FREE)
        return [(0.0, 0.0, cid)] if cid in wanted else []
    out = []
    rows = table.rows_of(i)
    for s, e, sc, ec in zip(table.start[rows], table.end[rows], table.start_code[rows],
                            table.end_code[rows], strict=True):
        cid = cell_name(region, feature_name(env, sc), feature_name(env, ec))
        if cid in wanted:
            out.append((float(s), float(e), cid))
    return out


def _widened(table: Any, i: int, s: float, e: float) -> tuple[float, float]:
    """Arc ``(s, e)`` of point ``i`` widened over the blocked gaps on both sides, up to the
    neighbouring free arcs (``(0, 0)``, the full circle, when it is the only arc).

    A rod that is blocked at the escape sample ``q`` (free where the target is now) is pushed
    into one of the two arcs bounding its gap by the time the target reaches ``q``, so the
    escape rows of both concern it: a rod pointing into the gap next to ``K`` must count the
    sweep to ``K``'s goal as well (otherwise a start a few degrees outside ``K``'s arc at ``q``
    is called safe while the follow law turns it into ``K`` right at the escape piece)."""
    if table.full[i]:
        return (0.0, 0.0)
    rows = table.rows_of(i)
    starts, ends = table.start[rows], table.end[rows]
    if len(starts) <= 1:
        return (0.0, 0.0)
    before = np.mod(s - ends, math.tau)  # CW distance from each arc's end to K's start
    after = np.mod(starts - e, math.tau)  # CCW distance from K's end to each arc's start
    before = np.where(before == 0.0, math.tau, before)
    after = np.where(after == 0.0, math.tau, after)
    return (float(ends[int(np.argmin(before))]), float(starts[int(np.argmin(after))]))


def escape_table(verdict: Verdict, samples: int = SAMPLES_PER_PIECE) -> EscapeTable:
    """The escape samples of every surviving cell and the reflex vertices (see the module
    docstring).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.analysis import analyze, escape_table
    >>> from tether.decomposition import decompose
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> table = escape_table(analyze(decompose(ell, 0.5)), samples=4)
    >>> len(table.q), table.reflex.tolist()  # escape samples, and the reflex vertex V3
    (41, [3])
    """
    dec, graph, surv = verdict.dec, verdict.graph, verdict.surviving
    env = dec.env
    rows_q, rows_cell, rows_piece, rows_k, rows_g = [], [], [], [], []
    for (cid, k), parts in sorted(graph.partners.items()):
        if cid not in surv:
            continue
        good = [c for c in parts if c in surv]
        if len(good) == len(parts) or not good:
            continue
        piece = dec.pieces[k]
        region = dec.cell(cid).region
        other = piece.regions[1] if piece.regions[0] == region else piece.regions[0]
        q, n = _piece_samples(piece, samples)
        eps = piece.eps
        side = np.vstack((q + eps * n, q - eps * n))
        reg = dec.region_at(side)
        m = len(q)
        here = np.where(reg[:m] == region, 0, np.where(reg[m:] == region, 1, -1))
        inside = np.where(here == 0, np.arange(m), np.arange(m) + m)
        across = np.where(here == 0, np.arange(m) + m, np.arange(m))
        ok = (here >= 0) & (reg[across] == other)
        if not ok.any():
            continue
        idx = np.flatnonzero(ok)
        table = free_arcs_many(env, side, dec.lss, check=False)
        for i in idx:
            karc = _arc_of(table, env, int(inside[i]), region, {cid})
            goals = _arc_of(table, env, int(across[i]), other, set(good))
            if len(karc) != 1 or not goals:
                continue
            rows_q.append(side[inside[i]])
            rows_cell.append(cid)
            rows_piece.append(k)
            rows_k.append(_widened(table, int(inside[i]), karc[0][0], karc[0][1]))
            rows_g.append([g[:2] for g in goals])
    refl = _pivot_vertices(env)
    vq, vgoal = _vertex_goals(env, dec.lss, refl)
    n_piece_rows = len(rows_q)
    for j, q, goals in zip(refl, vq, vgoal, strict=True):
        if not goals:
            continue
        rows_q.append(q)
        rows_cell.append(env.vertex_name(int(j)))
        rows_piece.append(-1 - int(j))
        rows_k.append((0.0, 0.0))
        rows_g.append(goals)
    width = max((len(g) for g in rows_g), default=1)
    gs = np.full((len(rows_g), width), np.nan)
    ge = np.full((len(rows_g), width), np.nan)
    for i, g in enumerate(rows_g):
        for j, (s, e) in enumerate(g):
            gs[i, j], ge[i, j] = s, e
    kk = np.array(rows_k, dtype=float).reshape(-1, 2)
    piece = np.array(rows_piece, dtype=int)
    del n_piece_rows
    return EscapeTable(verdict, np.array(rows_q, dtype=float).reshape(-1, 2), tuple(rows_cell),
                       piece, kk[:, 0], kk[:, 1], gs, ge, refl,
                       env.vertices[refl].reshape(-1, 2))


def _pivot_vertices(env: Any) -> np.ndarray:
    """The reflex vertices a target can round. Where rings touch, a vertex's own cone holds
    the other ring's obstacle: what matters is the free wedge that follows the vertex's
    obstacle (:func:`tether.arcs.wedge_columns`, one per touching vertex), kept when that
    wedge is reflex."""
    refl = np.asarray(env.reflex_indices, dtype=int)
    _, _, _, kind = wedge_columns(env)
    touch = env.touching[refl]
    return refl[~touch | (kind[refl] < 0)]


def _vertex_goals(env: Any, lss: float, refl: np.ndarray, n_dir: int = 720
                  ) -> tuple[np.ndarray, list[list[tuple[float, float]]]]:
    """For each reflex vertex: a point just off it inside its free cone, and the goal there:
    the orientations free at *every* sample point around the vertex (radii up to ``lss/2``,
    across the free cone), so that a rod held in them needs no pivot about the vertex however
    the target rounds it. Falls back to the free arcs at the point when that set is empty."""
    if not len(refl):
        return np.zeros((0, 2)), []
    _, d_out, d_in, _ = wedge_columns(env)  # the free cone; at a touching vertex, its wedge
    a_out = np.arctan2(d_out[refl, 1], d_out[refl, 0])
    width = np.mod(np.arctan2(d_in[refl, 1], d_in[refl, 0]) - a_out, math.tau)
    mid = a_out + 0.5 * width
    q = env.vertices[refl] + 1e-4 * lss * np.column_stack((np.cos(mid), np.sin(mid)))
    dirs = (np.arange(n_dir) + 0.5) * (math.tau / n_dir)
    goals = []
    table = free_arcs_many(env, q, lss, check=False)
    for i, j in enumerate(refl):
        phis = a_out[i] + width[i] * (np.arange(9) + 0.5) / 9
        radii = lss * np.array([0.02, 0.15, 0.5])
        pts = (env.vertices[j] + radii[:, None, None]
               * np.stack((np.cos(phis), np.sin(phis)), axis=-1)[None]).reshape(-1, 2)
        pts = pts[np.asarray(env.contains(pts[:, 0], pts[:, 1]), dtype=bool)]
        ok = np.ones(n_dir, dtype=bool)
        for pt in pts:
            ok &= rod_free_fan(env, pt, dirs, lss)
        arcs = _shrunk(_runs(ok, dirs, math.tau / n_dir), VERTEX_GOAL_MARGIN) \
            or _runs(ok, dirs, math.tau / n_dir)
        if not arcs:
            rows = table.rows_of(i)
            arcs = [(float(s), float(e)) for s, e in zip(table.start[rows], table.end[rows],
                                                         strict=True)]
        goals.append(arcs)
    return q, goals


#: Angle (rad) by which a reflex vertex's goal arcs are shrunk at each end. The goal is the
#: set free at sampled target positions around the vertex; between the samples the contact
#: orientation reaches past it (on the gallery a rod 0.05 rad inside the goal's edge was
#: caught by the vertex's arc end, 0.06 rad past the edge, while the target pulled away at
#: 0.1 from the vertex: `unforeseen` losses of ``docs/strategy.md``). Arcs narrower than
#: twice this are kept whole.
VERTEX_GOAL_MARGIN = 0.1


def _shrunk(arcs: list[tuple[float, float]], margin: float) -> list[tuple[float, float]]:
    """CCW arcs shrunk by ``margin`` rad at each end, those narrower than ``2·margin``
    dropped (the full circle ``(s, s)`` kept as it is)."""
    out = []
    for s, e in arcs:
        width = (e - s) % math.tau
        if width == 0.0:
            out.append((s, e))
        elif width > 2.0 * margin:
            out.append(((s + margin) % math.tau, (e - margin) % math.tau))
    return out


def rod_free_fan(env: Any, point: np.ndarray, dirs: np.ndarray, lss: float) -> np.ndarray:
    """Whether the rods from ``point`` in each direction are free (independent test)."""
    from tether.arcs import rod_is_free_many

    return rod_is_free_many(env, np.repeat(point[None], len(dirs), axis=0), dirs, lss)


def _runs(ok: np.ndarray, dirs: np.ndarray, step: float) -> list[tuple[float, float]]:
    """CCW arcs ``(start, end)`` covering the runs of ``True`` in a circular mask, shrunk by
    half a step at each end (so that they lie inside the true free set)."""
    if ok.all():
        return [(0.0, 0.0)]
    if not ok.any():
        return []
    k = int(np.argmin(ok))  # start scanning at a blocked direction
    order = np.roll(np.arange(len(ok)), -k)
    out, start = [], None
    for idx in list(order) + [order[0]]:
        if ok[idx] and start is None:
            start = idx
        elif not ok[idx] and start is not None:
            last = (idx - 1) % len(ok)
            if last != start:
                out.append((float(dirs[start]) % math.tau, float(dirs[last]) % math.tau))
            start = None
    return out


def escape_table_of(verdict: Verdict, ratio: float | None = None) -> EscapeTable:
    """:func:`escape_table`, cached on the verdict; with ``ratio = vt/vo`` the steep-wall rows
    of :func:`wall_rows` are added (cached per ratio)."""
    cache = verdict.memo.setdefault("escape_tables", {})
    t = cache.get(None)
    if t is None:
        t = escape_table(verdict)
        cache[None] = t
    if ratio is None:
        return t
    key = round(float(ratio), 12)
    w = cache.get(key)
    if w is None:
        w = _with_walls(t, float(ratio))
        cache[key] = w
    return w


def wall_rows(env: Any, lss: float, ratio: float
              ) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
    """Steep wall contacts (§5a): a rod whose tip meets edge ``E_i`` within ``δ0 =
    arcsin(vt/vo)`` of the wall's normal cannot slide for every target heading. One row per
    edge: a display point ``q`` (the perpendicular contact at the edge's middle, at distance
    ``lss``), the edge index, and the goal arc: every orientation at least ``δ0`` away from
    pointing straight at the wall. The escape point a rod ``a`` actually meets is the nearest
    point of the edge translated by ``−lss·u(a)`` (:func:`wall_contact_points`), wherever
    along the edge and at whatever inclination the contact happens."""
    d0 = math.asin(min(max(ratio, 0.0), 1.0))
    A, B, _, _ = env.oriented_edges
    nrm = env.free_normals
    qs, edges, goals = [], [], []
    for i in range(len(A)):
        at_wall = math.atan2(-nrm[i, 1], -nrm[i, 0])
        qs.append(0.5 * (A[i] + B[i]) + lss * nrm[i])
        edges.append(i)
        goals.append(((at_wall + d0) % math.tau, (at_wall - d0) % math.tau))
    return np.array(qs).reshape(-1, 2), np.array(edges, dtype=int), goals


def wall_contact_points(env: Any, edges: np.ndarray, lss: float, pts: np.ndarray, a: float
                        ) -> np.ndarray:
    """For each edge in ``edges`` and each point in ``pts`` (n, 2): the point nearest it of the
    edge translated by ``−lss·u(a)``, the target positions from which rod ``a`` has its tip on
    the edge. Shape (len(edges), n, 2), map units."""
    A, B, _, _ = env.oriented_edges
    shift = lss * np.array([math.cos(a), math.sin(a)])
    a0 = A[edges] - shift
    e = B[edges] - A[edges]
    ee = np.einsum("ij,ij->i", e, e)
    rel = pts[None, :, :] - a0[:, None, :]
    t = np.clip(np.einsum("enk,ek->en", rel, e) / ee[:, None], 0.0, 1.0)
    return a0[:, None, :] + t[..., None] * e[:, None, :]


def _with_walls(t: EscapeTable, ratio: float) -> EscapeTable:
    env, lss = t.verdict.dec.env, t.verdict.dec.lss
    q, edges, goals = wall_rows(env, lss, ratio)
    m = len(q)
    width = t.g_start.shape[1] if t.g_start.ndim == 2 and t.g_start.shape[1] else 1
    gs = np.full((m, width), np.nan)
    ge = np.full((m, width), np.nan)
    for i, (s, e) in enumerate(goals):
        gs[i, 0], ge[i, 0] = s, e
    g_start = np.vstack((t.g_start.reshape(len(t), -1) if len(t) else np.zeros((0, width)), gs))
    g_end = np.vstack((t.g_end.reshape(len(t), -1) if len(t) else np.zeros((0, width)), ge))
    return EscapeTable(t.verdict, np.vstack((t.q, q)),
                       t.cell + tuple(env.edge_name(int(i)) for i in edges),
                       np.concatenate((t.piece, WALL_CODE - edges)),
                       np.concatenate((t.k_start, np.zeros(m))),
                       np.concatenate((t.k_end, np.zeros(m))), g_start, g_end, t.reflex,
                       t.reflex_xy)


def l_safe(delta: Any, vt: float, vo: float, lss: float) -> np.ndarray:
    """``L_g = vt·Lss·Δ/(vo − vt)``: the target's travel bound during a sweep ``Δ`` (rad)."""
    return vt * lss * np.abs(np.asarray(delta, float)) / (vo - vt)


def l_paper(delta: Any, vt: float, vo: float, lss: float) -> np.ndarray:
    """The paper's ``L`` for a sweep ``Δ`` against the worst straight heading (R3)."""
    d = np.abs(np.asarray(delta, float))
    return np.asarray(distance_bound(-d / 2, d / 2, vt, vo, lss), float)
