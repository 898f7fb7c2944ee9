"""Critical curves (``math.md`` §7): exact parametric objects and their polyline approximation.

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
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely

from tether._util.arrays import first_nearest, first_per_group, ragged_arange
from tether.arcs import rod_is_free_many, rod_is_free_rows, rod_rows
from tether.environment import Environment
from tether.errors import ResourceLimitError
from tether.tolerances import REL_CURVE_TOL

KINDS = ("A", "B", "C", "D", "E")
KIND_NAMES = {
    "A": "edge offset",
    "B": "vertex circle",
    "C": "edge extension",
    "D": "two reflex vertices",
    "E": "conchoid",
}
#: Uniform semi-free test samples per curve (the domain's ends and middle) besides the samples
#: at the exact breakpoints; the breakpoints are where freeness can change, so these only
#: catch a curve without breakpoints. (Before, 96 uniform samples per rod length of curve were
#: taken, ~740,000 at 400 map vertices; :func:`_critical_intervals` still takes them with
#: ``per_lss``, which the tests use as an independent check.)
_BASE_SAMPLES = 2
#: Where between two consecutive samples the extra one goes (not the middle: on maps with
#: symmetric features the middle of two breakpoints is often a degenerate parameter, e.g. a rod
#: lying along a wall, semi-free at that one parameter only).
_SPLIT = 0.3819660112501051
_BISECTIONS = 30


@dataclass(frozen=True, eq=False)
class Family:
    """All candidate curves of one kind, as arrays (vectorized evaluation).

    ``p`` and ``d`` hold per-curve points and vectors whose meaning depends on the kind (see
    :meth:`points`); ``lo``/``hi`` the parameter domain; ``features`` the defining features.
    """

    kind: str
    lss: float
    p: np.ndarray
    d: np.ndarray
    w: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    features: list[tuple[str, ...]]
    #: per curve, exact special points ``(parameter, point)`` that the polyline must contain as
    #: vertices: where an edge offset touches a vertex circle tangentially (``V + lss n``). Both
    #: curves get the very same floating-point coordinates so that the noder joins them there;
    #: overshooting cannot close a tangential meeting.
    marks: list[list[tuple[float, np.ndarray]]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.lo)

    def points(self, c: np.ndarray | None, t: np.ndarray) -> np.ndarray:
        """Points ``q(t)`` of curves ``c`` (arrays of equal length; ``None``: every curve in
        order, one parameter each), map units."""
        L = self.lss
        if self.kind == "A":  # p = A + L n, d = B - A
            return _take(self.p, c) + t[:, None] * _take(self.d, c)
        if self.kind == "B":  # p = vertex
            return _take(self.p, c) + L * np.column_stack((np.cos(t), np.sin(t)))
        if self.kind in "CD":  # p = ray origin (vertex), d = unit direction away from it
            return _take(self.p, c) + t[:, None] * _take(self.d, c)
        # E: p = pole, w = edge start, d = edge vector (columns apart: the same numbers as
        # with (k, 2) rows and np.linalg.norm, fewer temporaries)
        w, d, p = _take(self.w, c), _take(self.d, c), _take(self.p, c)
        qx = w[:, 0] + t * d[:, 0]
        qy = w[:, 1] + t * d[:, 1]
        rx, ry = p[:, 0] - qx, p[:, 1] - qy
        norm = np.sqrt(rx * rx + ry * ry)
        out = np.empty((len(t), 2))
        out[:, 0] = qx + L * rx / norm
        out[:, 1] = qy + L * ry / norm
        return out

    def rod_angles(self, c: np.ndarray | None, t: np.ndarray) -> np.ndarray:
        """Orientations ``a*`` of the event rods at ``q(t)``, radians (``c`` as in
        :meth:`points`)."""
        if self.kind == "A":  # toward the edge: -n
            n = _take(self.w, c)
            return np.arctan2(-n[:, 1], -n[:, 0])
        if self.kind == "B":
            return t + math.pi
        if self.kind in "CD":
            d = _take(self.d, c)
            return np.arctan2(-d[:, 1], -d[:, 0])
        Q = _take(self.w, c) + t[:, None] * _take(self.d, c)
        r = Q - _take(self.p, c)
        return np.arctan2(r[:, 1], r[:, 0])

    def rows(self, c: np.ndarray) -> Family:
        """The curves ``c`` (repeats allowed) as a family of their own, without features or
        marks: for loops evaluating the same rows many times (``points(None, t)``)."""
        return Family(self.kind, self.lss, _take(self.p, c), _take(self.d, c), _take(self.w, c),
                      self.lo[c], self.hi[c], [])

    def motion_bound(self, ta: np.ndarray, tb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on how far the event rods of every curve in order (one interval each, as
        ``points(None, t)``) move over ``t`` in ``[ta, tb]`` from the rod at ``ta``: of the
        target end (map units) and of the direction (radians; ``inf`` when unbounded)."""
        span = np.abs(tb - ta)
        if self.kind == "B":  # the target end on a circle of radius lss, the rod along its radius
            return self.lss * span, span
        step = span * np.hypot(self.d[:, 0], self.d[:, 1])  # the motion of q (A, C, D) or Q (E)
        if self.kind in "ACD":  # fixed direction
            return step, np.zeros(len(span))
        # E: the rod from q to Q = w + t d points away from the pole p; seen from p, Q sweeps
        # at most step / (least distance from p to Q) radians
        near = np.minimum(np.hypot(*(self.w + ta[:, None] * self.d - self.p).T),
                          np.hypot(*(self.w + tb[:, None] * self.d - self.p).T)) - step
        with np.errstate(divide="ignore"):
            du = np.where(near > 0, step / np.maximum(near, 0.0), np.inf)
        return step + self.lss * du, du

    def length_scale(self, c: np.ndarray) -> np.ndarray:
        """Rough length of each curve's domain, map units (for sample counts)."""
        span = self.hi[c] - self.lo[c]
        if self.kind == "A":
            return span * np.linalg.norm(self.d[c], axis=1)
        if self.kind == "B":
            return span * self.lss
        if self.kind in "CD":
            return span
        return np.full(len(c), 2.0 * self.lss)


def _take(a: np.ndarray, c: np.ndarray | None) -> np.ndarray:
    """Rows ``c`` (integers) of ``a`` (all of them for ``None``). ``np.take`` gives the rows
    of ``a[c]`` many times faster on (k, 2) arrays."""
    return a if c is None else np.take(a, c, axis=0)


@dataclass(frozen=True, eq=False)
class Curve:
    """One candidate critical curve and its critical part.

    ``intervals`` are the parameter intervals where the event rod is semi-free (slightly
    overshooting, see the module notes); ``polylines`` approximate the curve over each interval
    within ``tol`` map units.
    """

    id: int
    kind: str
    features: tuple[str, ...]
    domain: tuple[float, float]
    intervals: tuple[tuple[float, float], ...]
    polylines: tuple[np.ndarray, ...] = field(repr=False)
    params: tuple[np.ndarray, ...] = field(repr=False)
    family: Family = field(repr=False)
    index: int = field(repr=False)
    #: the map's :class:`~tether.environment.Frame` when this curve reports in user coordinates
    #: (polylines, points and length parameters of C and D in map units); ``None`` when it is
    #: the internal curve the computation used
    frame: Any = field(default=None, repr=False)

    @property
    def name(self) -> str:
        """E.g. ``"C(V6,E5)"``."""
        return f"{self.kind}({','.join(self.features)})"

    def _param_scale(self) -> float:
        """Internal parameter per reported parameter (C and D are parametrized by length)."""
        return self.frame.scale if self.frame is not None and self.kind in "CD" else 1.0

    def point(self, t: float) -> np.ndarray:
        """Exact point at parameter ``t``."""
        q = self._point(float(t) * self._param_scale())
        return q if self.frame is None else self.frame.to_user(q)

    def _point(self, t: float) -> np.ndarray:
        return self.family.points(np.array([self.index]), np.array([float(t)]))[0]

    def rod_angle(self, t: float) -> float:
        """Exact event rod orientation at parameter ``t``, radians."""
        t = float(t) * self._param_scale()
        return float(self.family.rod_angles(np.array([self.index]), np.array([t]))[0])

    def project(self, q: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Nearest point of the critical part to ``q``: ``(t, point, unit normal)``, exact."""
        if self.frame is None:
            return self._project(np.asarray(q, dtype=float))
        t, p, n = self._project(self.frame.to_internal(q))
        return t / self._param_scale(), self.frame.to_user(p), n

    def to_user(self, frame: Any, names: dict[str, str]) -> Curve:
        """This internal curve reported in user coordinates, its features renamed."""
        k = frame.scale if self.kind in "CD" else 1.0
        return Curve(self.id, self.kind, tuple(names.get(f, f) for f in self.features),
                     (self.domain[0] / k, self.domain[1] / k),
                     tuple((a / k, b / k) for a, b in self.intervals),
                     tuple(frame.to_user(p) for p in self.polylines),
                     tuple(t / k for t in self.params), self.family, self.index, frame)

    def _project(self, q: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        fam, c = self.family, self.index
        if self.kind in "ACD":  # a straight line: q(t) = p + t d
            d = fam.d[c]
            t = float((q - fam.p[c]) @ d / (d @ d))
            n = np.array([-d[1], d[0]]) / math.hypot(d[0], d[1])
            return t, fam.p[c] + t * d, n
        if self.kind == "B":
            r = q - fam.p[c]
            t = math.atan2(r[1], r[0])
            u = np.array([math.cos(t), math.sin(t)])
            return t, fam.p[c] + fam.lss * u, u
        best = None
        for ts, pts in zip(*self._internal_polylines(), strict=True):
            # the nearest polyline segment brackets the answer (a vertex would be ambiguous:
            # a conchoid's loop starts and ends at its pole)
            a, b = pts[:-1], pts[1:]
            ab = b - a
            u = np.clip(np.einsum("ij,ij->i", q - a, ab)
                        / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
            k = int(np.argmin(np.hypot(*(a + u[:, None] * ab - q).T)))
            lo, hi = float(ts[k]), float(ts[k + 1])
            t = lo + float(u[k]) * (hi - lo)
            for _ in range(12):  # Gauss-Newton on (q(t) - q)·q'(t) = 0, inside the bracket
                tangent = self._tangent(t)
                tt = float(tangent @ tangent)
                if tt == 0:
                    break
                t_new = min(max(t - float((self._point(t) - q) @ tangent) / tt, lo), hi)
                if abs(t_new - t) <= 1e-15 * max(1.0, abs(t)):
                    break
                t = t_new
            d = float(np.hypot(*(self._point(t) - q)))
            if best is None or d < best[0]:
                best = (d, t)
        t = best[1]
        tangent = self._tangent(t)
        tangent = tangent / max(float(np.hypot(*tangent)), 1e-300)
        return t, self._point(t), np.array([-tangent[1], tangent[0]])

    def _internal_polylines(self) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """Parameters and polylines in the internal frame."""
        if self.frame is None:
            return self.params, self.polylines
        k = self._param_scale()
        return (tuple(t * k for t in self.params),
                tuple(self.frame.to_internal(p) for p in self.polylines))

    def _tangent(self, t: float) -> np.ndarray:
        """dq/dt by finite differences taken inside the domain (a conchoid folds back at its
        pole, so a difference straddling a domain end would be meaningless)."""
        lo, hi = (x * self._param_scale() for x in self.domain)
        h = 1e-7 * max(1.0, abs(t), hi - lo)
        a, b = (t - h, t + h) if self.kind in "ABCD" else (max(t - h, lo), min(t + h, hi))
        return (self._point(b) - self._point(a)) / (b - a)

    def to_dict(self) -> dict:
        return {
            "id": self.id,
            "type": self.kind,
            "type_name": KIND_NAMES[self.kind],
            "features": list(self.features),
            "domain": list(self.domain),
            "critical_intervals": [list(iv) for iv in self.intervals],
        }


# ---------------------------------------------------------------------- candidates
def _tangent_points(env: Environment, L: float) -> tuple[np.ndarray, np.ndarray]:
    """For each oriented edge, the exact points ``A + L n`` and ``B + L n`` where its offset
    touches the circles of its end vertices."""
    A, B, _, _ = env.oriented_edges
    n = env.free_normals
    return A + L * n, B + L * n


def _family_a(env: Environment, L: float) -> Family:
    A, B, _, _ = env.oriented_edges
    n = env.free_normals
    m = env.n
    t0, t1 = _tangent_points(env, L)
    marks = [[(0.0, t0[i]), (1.0, t1[i])] for i in range(m)]
    return Family("A", L, A + L * n, B - A, n, np.zeros(m), np.ones(m),
                  [(f"E{i}",) for i in range(m)], marks)


def _family_b(env: Environment, L: float) -> Family:
    m = env.n
    z = np.zeros((m, 2))
    _, _, tag_a, tag_b = env.oriented_edges
    t0, t1 = _tangent_points(env, L)
    n = env.free_normals
    marks: list[list[tuple[float, np.ndarray]]] = [[] for _ in range(m)]
    # where rings touch, the circles of the coincident vertices are one curve: the first
    # vertex's (the others are dropped in :func:`critical_curves`), which takes the tangent
    # points of every edge meeting there
    first = env.coincident
    for i in range(m):
        phi = math.atan2(n[i, 1], n[i, 0]) % (2 * math.pi)
        marks[first[tag_a[i]]].append((phi, t0[i]))
        marks[first[tag_b[i]]].append((phi, t1[i]))
    return Family("B", L, env.vertices.copy(), z, z, np.zeros(m), np.full(m, 2 * math.pi),
                  [(f"V{j}",) for j in range(m)], marks)


def _family_c(env: Environment, L: float) -> Family:
    """Extensions of the edges through each reflex vertex. Where rings touch, an extension
    that runs along an edge of another ring from the same point is left out: it lies on that
    wall (the obstacle on one side, so it separates no two faces), and where it goes on past
    the wall's far end it is that end's own extension (the same event rods)."""
    V = env.vertices
    p, d, feats = [], [], []
    along = _touching_directions(env)
    for j in env.reflex_indices:
        for k, edge in ((env.next_vertex[j], j), (env.prev_vertex[j], env.prev_vertex[j])):
            u = V[j] - V[k]
            u = u / np.linalg.norm(u)
            if any(abs(u[0] * w[1] - u[1] * w[0]) <= 1e-12 and u @ w > 0
                   for w in along.get(j, ())):
                continue
            p.append(V[j])
            d.append(u)
            feats.append((f"V{j}", f"E{edge}"))
    m = len(p)
    p_ = np.array(p).reshape(m, 2)
    d_ = np.array(d).reshape(m, 2)
    return Family("C", L, p_, d_, np.zeros((m, 2)), np.zeros(m), np.full(m, L), feats)


def _family_d(env: Environment, L: float) -> Family:
    """Lines through two reflex vertices ``V1``, ``V2`` closer than ``L`` (by more than the
    length tolerance), not adjacent: the rod on the line beyond ``V2``, ``τ`` in
    ``[0, L - |V1 V2|]`` (vectorized over the pairs, in row-major order)."""
    V = env.vertices
    R = _poles(env)
    a = b = np.zeros(0, np.int64)
    diff, dist = np.zeros((0, 0, 2)), np.zeros((0, 0))
    if len(R) > 1:
        diff = V[R][:, None, :] - V[R][None, :, :]
        dist = np.linalg.norm(diff, axis=2)
        # the two vertices must be within lss by more than the tolerance; dist > 0: no pair
        # of coincident vertices (touching rings: |V1 V2| = 0 has no line; :func:`_poles`
        # keeps one vertex per point anyway)
        a, b = np.nonzero((dist < L - env.length_tol) & (dist > 0))
        v1, v2 = R[a], R[b]
        # adjacent: that line is an edge, its extension is type C (an edge of any ring
        # through the point, where rings touch)
        first, nxt = env.coincident, env.next_vertex
        n = env.n
        edges = np.concatenate((first * n + first[nxt], first[nxt] * n + first))
        keep = ~np.isin(first[v1] * n + first[v2], edges)
        a, b = a[keep], b[keep]
    d = diff[a, b] / dist[a, b][:, None]
    feats = [(f"V{x}", f"V{y}") for x, y in zip(R[a].tolist(), R[b].tolist(), strict=True)]
    m = len(a)
    return Family("D", L, V[R[a]].reshape(m, 2), d.reshape(m, 2), np.zeros((m, 2)),
                  np.zeros(m), (L - dist[a, b]).astype(float), feats)


def _family_e(env: Environment, L: float) -> Family:
    """Conchoids: pole a reflex vertex ``V_j``, base an edge ``E_i`` within ``L`` of it, ``V_j``
    strictly on the edge's free side; parameter ``s`` along the edge where ``|V_j - Q(s)| < L``
    (vectorized over the (pole, edge) pairs, in the order of the edge index's query)."""
    A, B, tag_a, tag_b = env.oriented_edges
    R = _poles(env)
    V = env.vertices
    tol = env.length_tol
    first = env.coincident
    pidx, eidx = env.edge_index(L).query(V[R]) if len(R) else (np.zeros(0, int),) * 2
    j, i = np.asarray(R)[pidx].astype(np.int64), np.asarray(eidx, dtype=np.int64)
    a, e = A[i], B[i] - A[i]
    rel = V[j] - a
    ex, ey, rx, ry = e[:, 0], e[:, 1], rel[:, 0], rel[:, 1]

    def dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # row-wise, the very bits of x @ y
        return (x[:, None, :] @ y[:, :, None])[:, 0, 0]

    ee, b = dot(e, e), dot(e, rel)
    disc = b * b - ee * (dot(rel, rel) - L * L)
    foot = np.clip(b / ee, 0.0, 1.0)
    sq = np.sqrt(np.maximum(disc, 0.0))
    s0 = np.maximum(0.0, (b - sq) / ee)
    s1 = np.minimum(1.0, (b + sq) / ee)
    keep = ((j != tag_a[i]) & (j != tag_b[i])
            # nor at an end of it through touching rings: the pole on the base's line (c = 0),
            # the conchoid degenerates to that line (the edge and the C extension through
            # the point); the side test below drops it too, this says why
            & (first[j] != first[tag_a[i]]) & (first[j] != first[tag_b[i]])
            # the pole strictly on the free side of the base edge
            & (ex * ry - ey * rx > tol * np.sqrt(ee))
            # within lss of the edge by more than the tolerance
            & (disc > 0) & (np.hypot(rx - foot * ex, ry - foot * ey) < L - tol)
            & (s1 - s0 > 1e-12))
    k = np.flatnonzero(keep)
    feats = [(f"V{jj}", f"E{ii}") for jj, ii in zip(j[k].tolist(), i[k].tolist(), strict=True)]
    return Family("E", L, V[j[k]].reshape(-1, 2), e[k].reshape(-1, 2), a[k].reshape(-1, 2),
                  s0[k].astype(float), s1[k].astype(float), feats)


def _poles(env: Environment) -> np.ndarray:
    """The reflex vertices that D lines and E conchoids start from: one per point. Where
    rings touch, the coincident vertices give the very same curves; only the first one's are
    made. (If the first one is not reflex for its ring, no free wedge at the point is reflex,
    no rod grazes it there, and its curves would have no critical part.)"""
    R = np.asarray(env.reflex_indices, dtype=np.int64)
    return R[env.coincident[R] == R]


def _touching_directions(env: Environment) -> dict[int, list[np.ndarray]]:
    """For each vertex where rings touch, the unit directions of the edges leaving that
    point from the other coincident vertices (the other rings' walls)."""
    V = env.vertices
    first = env.coincident
    out: dict[int, list[np.ndarray]] = {}
    touch = np.flatnonzero(env.touching).tolist()
    for j in touch:
        dirs = []
        for k in touch:
            if k != j and first[k] == first[j]:
                for w in (env.next_vertex[k], env.prev_vertex[k]):
                    u = V[w] - V[k]
                    dirs.append(u / np.linalg.norm(u))
        out[j] = dirs
    return out


def curves_to_user(curves: list[Curve], frame: Any, names: dict[str, str]) -> list[Curve]:
    """:meth:`Curve.to_user` of every curve, the polylines and parameters of all of them
    converted at once (the same numbers: one element-wise operation each)."""
    if not curves:
        return []
    lines = [p for c in curves for p in c.polylines]
    params = [t for c in curves for t in c.params]
    pts = frame.to_user(np.concatenate(lines)) if lines else np.zeros((0, 2))
    k = [frame.scale if c.kind in "CD" else 1.0 for c in curves]
    per = np.repeat(k, [len(c.params) for c in curves])
    ts = (np.concatenate(params) / np.repeat(per, [len(t) for t in params]) if params
          else np.zeros(0))
    pts_each, ts_each = _pieces(pts, lines), _pieces(ts, params)
    out, i = [], 0
    for c, kc in zip(curves, k, strict=True):
        n = len(c.polylines)
        out.append(Curve(c.id, c.kind, tuple(names.get(f, f) for f in c.features),
                         (c.domain[0] / kc, c.domain[1] / kc),
                         tuple((a / kc, b / kc) for a, b in c.intervals),
                         tuple(pts_each[i:i + n]), tuple(ts_each[i:i + n]), c.family,
                         c.index, frame))
        i += n
    return out


def _pieces(joined: np.ndarray, parts: list[np.ndarray]) -> list[np.ndarray]:
    """``joined`` (the concatenation of arrays like ``parts``) cut back into pieces of their
    lengths (views; ``np.split`` costs more per piece)."""
    ends = np.cumsum([len(p) for p in parts]).tolist()
    return [joined[a:b] for a, b in zip([0] + ends[:-1], ends, strict=True)]


def candidate_families(env: Environment, lss: float) -> list[Family]:
    """All candidate curves of the five kinds for rod length ``lss`` (map units)."""
    fa, fe = _family_a(env, lss), _family_e(env, lss)
    _mark_apexes(fa, fe)
    return [fa, _family_b(env, lss), _family_c(env, lss), _family_d(env, lss), fe]


def _mark_apexes(fa: Family, fe: Family) -> None:
    """A conchoid with base ``Ei`` touches the offset of ``Ei`` tangentially at its apex, where
    the rod is perpendicular to the edge: mark that point, exactly, on both curves."""
    fe.marks.extend([] for _ in range(len(fe)))
    if len(fe) == 0:
        return
    # the apex parameter s = (p - w)·d / d·d of every conchoid, roughly (the products of
    # ``@`` may round otherwise): only the conchoids with s near their domain are computed
    # as before (rounding moves s by about 1e-16 |p - w| / |d|: the margin is ample)
    r, d = fe.p - fe.w, fe.d
    dd = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
    s = (r[:, 0] * d[:, 0] + r[:, 1] * d[:, 1]) / dd
    slack = 1e-9 * (1.0 + np.hypot(r[:, 0], r[:, 1]) / np.sqrt(dd))
    for c in np.flatnonzero((fe.lo - slack < s) & (s < fe.hi + slack)).tolist():
        i = int(fe.features[c][1][1:])
        dc = fe.d[c]
        sc = float((fe.p[c] - fe.w[c]) @ dc / (dc @ dc))
        if fe.lo[c] < sc < fe.hi[c]:
            q = fa.p[i] + sc * fa.d[i]
            fa.marks[i].append((sc, q))
            fe.marks[c].append((sc, q))


# ---------------------------------------------------------------------- critical parts
def _critical_intervals(env: Environment, fam: Family, per_lss: float = 0.0
                        ) -> list[list[tuple[float, float]]]:
    """Parameter intervals of each curve where its event rod is semi-free.

    Freeness is constant between consecutive exact breakpoints (:func:`_breakpoints`): each
    curve is tested just either side of every breakpoint, inside every longer stretch between
    two consecutive samples, and at its domain's ends (``_BASE_SAMPLES``; at least
    24 and ``per_lss`` per rod length of curve when ``per_lss`` > 0: the former dense
    sampling, kept as an independent check)."""
    m = len(fam)
    out: list[list[tuple[float, float]]] = [[] for _ in range(m)]
    if m == 0:
        return out
    L = fam.lss
    cidx = np.arange(m)
    if per_lss > 0:
        counts = np.maximum(24, np.ceil(fam.length_scale(cidx) / L * per_lss)).astype(int)
    else:
        counts = np.full(m, _BASE_SAMPLES)
    c = np.repeat(cidx, counts)
    k = np.arange(len(c)) - np.repeat(np.cumsum(counts) - counts, counts)
    frac = k / np.repeat(counts - 1, counts)
    t = fam.lo[c] + frac * (fam.hi[c] - fam.lo[c])
    # samples just either side of every exact breakpoint: freeness is constant between them,
    # so no free stretch, however short, falls between two samples
    bc, bt = _breakpoints(env, fam)
    span = (fam.hi - fam.lo)[bc]
    extra_c = np.repeat(bc, 4)
    extra_t = (bt[:, None] + span[:, None] * np.array([-1e-5, -1e-8, 1e-8, 1e-5])).ravel()
    inside = (extra_t > fam.lo[extra_c]) & (extra_t < fam.hi[extra_c])
    c = np.concatenate((c, extra_c[inside]))
    t = np.concatenate((t, extra_t[inside]))
    order = np.lexsort((t, c))
    c, t = c[order], t[order]
    # and one inside every stretch between two consecutive samples of a curve (not between
    # the close samples around one breakpoint: their transition is pinned as is)
    gap = 1e-4 * (fam.hi - fam.lo)[c[:-1]]
    mid = np.flatnonzero((c[1:] == c[:-1]) & (t[1:] - t[:-1] > gap))
    c, t = _insert_after(c, t, mid, t[mid] + _SPLIT * (t[mid + 1] - t[mid]))
    counts = np.bincount(c, minlength=m)
    first = np.cumsum(counts) - counts
    if fam.kind in "CDE":  # open ends at the vertex / domain ends: sample just inside
        eps = 1e-9 * (fam.hi[c] - fam.lo[c])
        t = np.clip(t, fam.lo[c] + eps, fam.hi[c] - eps)
    free = _semi_free(env, fam, c, t)
    # transitions between consecutive samples of the same curve: pin them by bisection
    same = c[1:] == c[:-1]
    trans = np.flatnonzero(same & (free[1:] != free[:-1]))
    fa = free[trans]
    edge_t = _bisect(env, fam.rows(c[trans]), t[trans], t[trans + 1], fa)
    # runs of free samples: a run starts at a curve's first sample or after a transition and
    # ends at a curve's last sample or before one; transitions give the exact ends
    bound = np.full(len(c), np.nan)
    bound[trans] = edge_t
    is_first = np.zeros(len(c), bool)
    is_first[first[counts > 0]] = True
    is_last = np.r_[is_first[1:], True]
    starts = np.flatnonzero(free & (is_first | ~np.r_[True, free[:-1]]))
    ends = np.flatnonzero(free & (is_last | ~np.r_[free[1:], True]))
    lo_t = np.where(is_first[starts], fam.lo[c[starts]], bound[np.maximum(starts - 1, 0)])
    hi_t = np.where(is_last[ends], fam.hi[c[ends]], bound[ends])
    for cr, a, b in zip(c[starts].tolist(), lo_t.tolist(), hi_t.tolist(), strict=True):
        out[cr].append((a, b))
    if fam.kind == "B":  # the circle is closed: join a run through angle 0
        for ivs in out:
            if len(ivs) > 1 and ivs[0][0] == fam.lo[0] and ivs[-1][1] == fam.hi[0]:
                ivs[0] = (ivs[-1][0] - 2 * math.pi, ivs[0][1])
                ivs.pop()
    return out


def _bisect(env: Environment, sub: Family, ta: np.ndarray, tb: np.ndarray, fa: np.ndarray
            ) -> np.ndarray:
    """The last free parameter of each transition ``k`` of curve ``k`` of ``sub`` between
    ``ta[k]`` (free iff ``fa[k]``) and ``tb[k]``, by ``_BISECTIONS`` halvings. Every round
    tests rods within the interval: their candidate edges are found once, for every rod of
    the interval (:func:`tether.arcs.rod_rows`; the rods moving too far keep the plain test),
    and the targets that stay inside the free space: the same booleans as
    :func:`rod_is_free_many` every round."""
    L = sub.lss
    dp, du = sub.motion_bound(ta, tb)
    q = sub.points(None, ta)
    pidx, eidx, ok, inside = rod_rows(env, q, sub.rod_angles(None, ta), L, dp, du)
    far = np.flatnonzero(~ok)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (ta + tb)
        pts, ang = sub.points(None, mid), sub.rod_angles(None, mid)
        fm = rod_is_free_rows(env, pts, ang, L, pidx, eidx, inside)
        if len(far):
            fm[far] = rod_is_free_many(env, pts[far], ang[far], L)
        move_a = fm == fa
        ta = np.where(move_a, mid, ta)
        tb = np.where(move_a, tb, mid)
    return np.where(fa, ta, tb)


def _semi_free(env: Environment, fam: Family, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Whether the event rod of curve ``c[k]`` at ``t[k]`` is semi-free, for samples sorted by
    (curve, parameter); equal samples (a breakpoint found twice: a line through a vertex
    crosses both of its edges) are tested once (the test is row by row: the same answers)."""
    is_new = np.r_[True, (c[1:] != c[:-1]) | (t[1:] != t[:-1])]
    cn, tn = c[is_new], t[is_new]
    free = rod_is_free_many(env, fam.points(cn, tn), fam.rod_angles(cn, tn), fam.lss)
    return free[np.cumsum(is_new) - 1]


def _insert_after(c: np.ndarray, t: np.ndarray, at: np.ndarray, t_new: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Samples ``(c, t)`` sorted by (curve, parameter) with a sample ``(c[at[k]], t_new[k])``
    inserted after each sample ``at[k]`` (increasing, distinct; ``t[at[k]] <= t_new[k] <=
    t[at[k] + 1]``, same curve): the arrays a stable sort of all of them gives, without the
    sort."""
    n = len(c) + len(at)
    pos = np.arange(len(c)) + np.searchsorted(at, np.arange(len(c)))  # earlier insertions
    new = at + 1 + np.arange(len(at))
    c2, t2 = np.empty(n, c.dtype), np.empty(n, t.dtype)
    c2[pos], t2[pos] = c, t
    c2[new], t2[new] = c[at], t_new
    return c2, t2


def _breakpoints(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """Parameters where a curve's event rod can start or stop being semi-free.

    A, B, E: where the event rod passes through a vertex (the rod sweeps across it); C, D
    (rods on a fixed line): where the rod's target end or tip crosses an edge. Returns
    (curve index, parameter) arrays (E: the edge crossings, then the vertices; the samples
    placed at them are sorted, so only the set of breakpoints matters).
    """
    V = env.vertices
    L = fam.lss
    m = len(fam)
    if m == 0:
        return np.zeros(0, int), np.zeros(0)
    cs, ts = [], []
    pair_c, pair_v = _breakpoint_pairs(env, fam)
    for lo in range(0, len(pair_c), 200_000):  # bounded memory
        cc, vk = pair_c[lo:lo + 200_000], pair_v[lo:lo + 200_000]
        if fam.kind == "A":  # rod = foot + λ n, foot = A + s d
            a0 = _take(fam.p, cc) - L * _take(fam.w, cc)
            rel = _take(V, vk) - a0
            lam = np.einsum("ij,ij->i", rel, _take(fam.w, cc))
            d = _take(fam.d, cc)
            t = np.einsum("ij,ij->i", rel, d) / np.einsum("ij,ij->i", d, d)
            ok = (lam > 0) & (lam <= L)
            # and where the target end q(s) = p + s d crosses an edge
            e = _take(V, env.next_vertex[vk]) - _take(V, vk)
            rel_q = _take(V, vk) - _take(fam.p, cc)
            den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                sq = (rel_q[:, 0] * e[:, 1] - rel_q[:, 1] * e[:, 0]) / den
                uq = (rel_q[:, 0] * d[:, 1] - rel_q[:, 1] * d[:, 0]) / den
            hit = (np.abs(den) > 1e-300) & (uq >= 0) & (uq <= 1)
            cs.append(cc[hit])
            ts.append(sq[hit])
        elif fam.kind == "B":  # rod from V_j + L u(φ) to V_j
            rel = _take(V, vk) - _take(fam.p, cc)
            r = np.hypot(rel[:, 0], rel[:, 1])
            t = np.mod(np.arctan2(rel[:, 1], rel[:, 0]), 2 * math.pi)
            ok = (r > 0) & (r <= L)
            # and where the target end crosses an edge: |V_k + u e - V_j| = L
            e = _take(V, env.next_vertex[vk]) - _take(V, vk)
            ee = np.einsum("ij,ij->i", e, e)
            b = np.einsum("ij,ij->i", e, rel)
            disc = b * b - ee * (np.einsum("ij,ij->i", rel, rel) - L * L)
            root = np.sqrt(np.maximum(disc, 0.0))
            for sign in (-1.0, 1.0):
                u = (-b + sign * root) / ee
                hit = (disc > 0) & (u >= 0) & (u <= 1)
                x = rel[hit] + u[hit, None] * e[hit]
                cs.append(cc[hit])
                ts.append(np.mod(np.arctan2(x[:, 1], x[:, 0]), 2 * math.pi))
        elif fam.kind == "E":  # where the target end crosses the line of edge vk
            ec, et = _conchoid_edge_crossings(env, fam, cc, vk)
            cs.append(ec)
            ts.append(et)
            continue
        else:  # C, D: the line o + τ w crosses edge (V_k, next) at τ; breakpoints τ and τ + L
            nk = env.next_vertex[vk]
            e = _take(V, nk) - _take(V, vk)
            w = _take(fam.d, cc)
            rel = _take(V, vk) - _take(fam.p, cc)
            den = w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                tau = (rel[:, 0] * e[:, 1] - rel[:, 1] * e[:, 0]) / den
                u = (rel[:, 0] * w[:, 1] - rel[:, 1] * w[:, 0]) / den
            ok = (np.abs(den) > 1e-300) & (u >= 0) & (u <= 1)
            cs += [cc[ok], cc[ok]]
            ts += [tau[ok], tau[ok] + L]
            continue
        cs.append(cc[ok])
        ts.append(t[ok])
    if fam.kind == "E":  # and where the event rod passes through a vertex
        pair_c, pair_v = _conchoid_vertex_pairs(env, fam)
        for lo in range(0, len(pair_c), 200_000):  # bounded memory
            cc, vk = pair_c[lo:lo + 200_000], pair_v[lo:lo + 200_000]
            # the line through V_k and the pole meets the base edge at Q(t)
            rel = _take(V, vk) - _take(fam.p, cc)
            a_rel = _take(fam.w, cc) - _take(fam.p, cc)
            d = _take(fam.d, cc)
            den = rel[:, 0] * d[:, 1] - rel[:, 1] * d[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (a_rel[:, 0] * rel[:, 1] - a_rel[:, 1] * rel[:, 0]) / den
            ok = (np.abs(den) > 1e-300) & (np.hypot(rel[:, 0], rel[:, 1]) <= 2 * L)
            cs.append(cc[ok])
            ts.append(t[ok])
    c, t = np.concatenate(cs), np.concatenate(ts)
    # only breakpoints within 1e-5 of its span of a curve's domain place samples in it (most
    # conchoid ones fall outside: a tenth are kept at 1,000 map vertices); 2e-5 to spare
    span = (fam.hi - fam.lo)[c]
    near = (t > fam.lo[c] - 2e-5 * span) & (t < fam.hi[c] + 2e-5 * span)
    return c[near], t[near]


def _breakpoint_pairs(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """The (curve, vertex) pairs :func:`_breakpoints` must test: vertex ``k`` and its edge
    ``(V_k, V_next)`` near the curve. Every breakpoint within ``1e-4`` of its domain's span of
    the domain (the only ones whose samples fall inside it) comes from a pair whose edge's
    bounding box meets the curve's box: A, the target segment padded by ``lss`` (a vertex on
    the rod is within ``lss`` of the target); B, the vertex's box padded by ``lss``; C, D, the
    line's stretch ``[lo - lss, hi]`` (breakpoints ``τ`` and ``τ + lss``); E, the pole's box
    padded by ``lss`` (the edge crossings, of edges within ``lss`` of the pole; the vertices
    are :func:`_conchoid_vertex_pairs`'). The test was of every curve against every vertex
    (quadratic)."""
    V = env.vertices
    L = fam.lss
    m = len(fam)
    span = fam.hi - fam.lo
    tiny = 1e-9 * env.diameter
    if fam.kind in "ACD":
        lo_t = fam.lo - 1e-4 * span - (L if fam.kind in "CD" else 0.0)
        hi_t = fam.hi + 1e-4 * span
        a = fam.p + lo_t[:, None] * fam.d
        b = fam.p + hi_t[:, None] * fam.d
        pad = (L if fam.kind == "A" else 0.0) + tiny
        x0, y0 = np.minimum(a, b).T - pad
        x1, y1 = np.maximum(a, b).T + pad
    else:  # B: vertex circle of radius lss; E: edges within lss of the pole
        pad = L + tiny
        x0, y0 = fam.p.T - pad
        x1, y1 = fam.p.T + pad
    tree = env.__dict__.get("_edge_box_tree")
    if tree is None:
        seg = np.stack((V, V[env.next_vertex]), axis=1)
        tree = env.__dict__["_edge_box_tree"] = shapely.STRtree(shapely.linestrings(seg))
    if m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ci, vi = tree.query(shapely.box(x0, y0, x1, y1))
    order = np.lexsort((vi, ci))
    return ci[order].astype(np.int64), vi[order].astype(np.int64)


def _conchoid_vertex_pairs(env: Environment, fam: Family) -> tuple[np.ndarray, np.ndarray]:
    """The (conchoid, vertex) pairs :func:`_breakpoints` must test for an event rod through a
    vertex, in (curve, vertex) order: a breakpoint ``t`` is where the line through the pole
    and ``Q(t)`` passes through a vertex within ``2 lss`` of the pole, so a vertex of a
    breakpoint in the domain (padded by ``1e-3`` of its span, 50 times the margin the samples
    need) lies in the double sector of radius ``2 lss`` about the pole spanned by the
    directions to ``Q(t)`` (under 4 % of the pole's box at 1,000 map vertices, against about
    a quarter for these sectors' boxes, which are queried)."""
    V = env.vertices
    m = len(fam)
    if m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    x0, y0, x1, y1 = _sector_boxes(fam, 1e-3)
    tiny = 1e-9 * env.diameter
    px, py = fam.p[:, 0], fam.p[:, 1]
    tree = env.__dict__.get("_vertex_tree")
    if tree is None:
        tree = env.__dict__["_vertex_tree"] = shapely.STRtree(shapely.points(V))
    # the sector toward the base edge and the opposite one (the event rod's far side)
    ca, va = tree.query(shapely.box(px + x0 - tiny, py + y0 - tiny, px + x1 + tiny,
                                    py + y1 + tiny))
    cb, vb = tree.query(shapely.box(px - x1 - tiny, py - y1 - tiny, px - x0 + tiny,
                                    py - y0 + tiny))
    key = np.concatenate((ca, cb)).astype(np.int64) * len(V) + np.concatenate((va, vb))
    key.sort()
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # in both: once
    return np.divmod(key, len(V))


def _sector_boxes(fam: Family, pad: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bounding boxes (x0, y0, x1, y1, relative to the pole) of each conchoid's sector of
    radius ``2 lss`` spanned by the directions from the pole to ``Q(t)``, ``t`` over the
    domain padded by ``pad`` of its span: the pole, the two end directions and the axis
    directions between them. A sector of 90 degrees or more (the base line close to the
    pole) gets the whole box ``[-2 lss, 2 lss]^2``."""
    R = 2 * fam.lss
    span = fam.hi - fam.lo
    q1 = fam.w + (fam.lo - pad * span)[:, None] * fam.d - fam.p
    q2 = fam.w + (fam.hi + pad * span)[:, None] * fam.d - fam.p
    with np.errstate(divide="ignore", invalid="ignore"):
        u1 = q1 / np.hypot(q1[:, 0], q1[:, 1])[:, None]
        u2 = q2 / np.hypot(q2[:, 0], q2[:, 1])[:, None]
    turn = np.sign(u1[:, 0] * u2[:, 1] - u1[:, 1] * u2[:, 0])
    zero = np.zeros(len(fam))
    xs, ys = [zero, R * u1[:, 0], R * u2[:, 0]], [zero, R * u1[:, 1], R * u2[:, 1]]
    for ex, ey in ((1, 0), (0, 1), (-1, 0), (0, -1)):
        # the axis direction lies between u1 and u2 (rounding: a slack, and a sector of no
        # turn at all takes every axis)
        between = ((turn * (u1[:, 0] * ey - u1[:, 1] * ex) >= -1e-9)
                   & (turn * (ex * u2[:, 1] - ey * u2[:, 0]) >= -1e-9))
        xs.append(np.where(between, R * ex, 0.0))
        ys.append(np.where(between, R * ey, 0.0))
    x0, y0 = np.minimum.reduce(xs), np.minimum.reduce(ys)
    x1, y1 = np.maximum.reduce(xs), np.maximum.reduce(ys)
    wide = ~(np.einsum("ij,ij->i", u1, u2) > 0)  # also nan directions
    x0[wide], y0[wide], x1[wide], y1[wide] = -R, -R, R, R
    return x0, y0, x1, y1


def _conchoid_edge_crossings(env: Environment, fam: Family, cc: np.ndarray, vk: np.ndarray,
                             grid: int = 33) -> tuple[np.ndarray, np.ndarray]:
    """Parameters where a conchoid's target end q(s) crosses the line of edge ``vk`` (only
    edges within lss of the pole: the conchoid stays within lss of it). Sign changes of the
    side function on a grid, refined by bisection."""
    V = env.vertices
    c, a, e = cc, _take(V, vk), _take(V, env.next_vertex[vk]) - _take(V, vk)
    frac = np.linspace(0.0, 1.0, grid)
    # a pair whose edge line leaves the whole grid of its conchoid strictly on one side (by a
    # margin above rounding) shows no sign change on it: dropped before the grid (most pairs;
    # before the distance test, which then measures a tenth of them)
    x0, y0, x1, y1 = _conchoid_grid_boxes(fam, frac)
    side = [e[:, 0] * (y - a[:, 1]) - e[:, 1] * (x - a[:, 0])
            for x, y in ((x0[c], y0[c]), (x0[c], y1[c]), (x1[c], y0[c]), (x1[c], y1[c]))]
    margin = 1e-9 * np.hypot(e[:, 0], e[:, 1]) * (np.abs(a).max(axis=1) + fam.lss)
    low, high = np.minimum.reduce(side), np.maximum.reduce(side)
    keep = ~((low > margin) | (high < -margin))
    c, a, e = c[keep], a[keep], e[keep]
    rel = _take(fam.p, c) - a
    u = np.clip(np.einsum("ij,ij->i", rel, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    near = np.hypot(*(rel - u[:, None] * e).T) <= fam.lss
    c, a, e = c[near], a[near], e[near]
    if len(c) == 0:
        return np.zeros(0, int), np.zeros(0)
    lo, hi = fam.lo[c], fam.hi[c]

    t = lo[:, None] + frac[None, :] * (hi - lo)[:, None]
    # the side function on the grid, each pair's rows broadcast (Family.points' arithmetic)
    w, d, p = _take(fam.w, c), _take(fam.d, c), _take(fam.p, c)
    qx = w[:, :1] + t * d[:, :1]
    qy = w[:, 1:] + t * d[:, 1:]
    rx, ry = p[:, :1] - qx, p[:, 1:] - qy
    norm = np.sqrt(rx * rx + ry * ry)
    qx, qy = qx + fam.lss * rx / norm, qy + fam.lss * ry / norm
    f = e[:, :1] * (qy - a[:, 1:]) - e[:, 1:] * (qx - a[:, :1])
    r, k = np.nonzero(np.sign(f[:, :-1]) * np.sign(f[:, 1:]) < 0)
    ta = lo[r] + frac[k] * (hi - lo)[r]
    tb = lo[r] + frac[k + 1] * (hi - lo)[r]
    fa = np.sign(f[r, k])
    sub, ar, er = fam.rows(c[r]), a[r], e[r]  # the same rows every round: gathered once
    for _ in range(_BISECTIONS):
        mid = 0.5 * (ta + tb)
        q = sub.points(None, mid)
        same = np.sign(er[:, 0] * (q[:, 1] - ar[:, 1]) - er[:, 1] * (q[:, 0] - ar[:, 0])) == fa
        ta = np.where(same, mid, ta)
        tb = np.where(same, tb, mid)
    return c[r], 0.5 * (ta + tb)


def _conchoid_grid_boxes(fam: Family, frac: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each conchoid's target-end points at the grid ``lo + frac (hi - lo)`` (the arithmetic
    of :func:`_conchoid_edge_crossings`), reduced to their bounding box (x0, y0, x1, y1)."""
    lo, hi = fam.lo, fam.hi
    t = lo[:, None] + frac[None, :] * (hi - lo)[:, None]
    w, d, p = fam.w, fam.d, fam.p
    qx = w[:, :1] + t * d[:, :1]
    qy = w[:, 1:] + t * d[:, 1:]
    rx, ry = p[:, :1] - qx, p[:, 1:] - qy
    norm = np.sqrt(rx * rx + ry * ry)
    qx, qy = qx + fam.lss * rx / norm, qy + fam.lss * ry / norm
    return qx.min(axis=1), qy.min(axis=1), qx.max(axis=1), qy.max(axis=1)


def _overshoot(fam: Family, c: int, iv: tuple[float, float], margin: float
               ) -> tuple[float, float]:
    """Extend an interval by about ``margin`` map units at ends that are not domain ends
    where the curve meets the boundary (C and D at the vertex, E at the pole)."""
    lo, hi = iv
    if fam.kind == "B":
        if hi - lo >= 2 * math.pi - 1e-12:
            return lo, hi
        dt = margin / fam.lss
        return lo - dt, hi + dt
    speed = fam.length_scale(np.array([c]))[0] / max(fam.hi[c] - fam.lo[c], 1e-300)
    if fam.kind == "E":
        q = fam.points(np.array([c, c]), np.array([fam.lo[c], fam.hi[c]]))
        speed = max(speed, np.linalg.norm(q[1] - q[0]) / max(fam.hi[c] - fam.lo[c], 1e-300))
    dt = margin / max(speed, 1e-300)
    if fam.kind in "CD":  # t = 0 is the vertex itself, on the boundary: never extend below
        return max(lo - dt, 0.0), hi + dt
    if fam.kind == "E":  # never beyond the pole (the curve ends there, on the boundary)
        lo = lo if lo <= fam.lo[c] and _pole_end(fam, c, fam.lo[c]) \
            else lo - _reach(fam, c, lo, -dt, margin)
        hi = hi if hi >= fam.hi[c] and _pole_end(fam, c, fam.hi[c]) \
            else hi + _reach(fam, c, hi, dt, margin)
        return lo, hi
    return lo - dt, hi + dt


def _overshoot_family(fam: Family, intervals: list[list[tuple[float, float]]], margin: float
                      ) -> list[tuple[Family, int, list[tuple[float, float]]]]:
    """:func:`_overshoot` of every interval of every curve of a family, as ``(family, curve,
    intervals)`` for the curves with a critical part; vectorized except for conchoids (the
    same numbers as interval by interval)."""
    cs = [c for c, ivs in enumerate(intervals) if ivs]
    if not cs:
        return []
    count = [len(intervals[c]) for c in cs]
    c = np.repeat(np.array(cs, dtype=np.int64), count)
    lo, hi = np.array([iv for k in cs for iv in intervals[k]], dtype=float).reshape(-1, 2).T
    if fam.kind == "E":
        lo2, hi2 = _overshoot_conchoids(fam, c, lo, hi, margin)
    elif fam.kind == "B":
        full = hi - lo >= 2 * math.pi - 1e-12
        dt = margin / fam.lss
        lo2, hi2 = np.where(full, lo, lo - dt), np.where(full, hi, hi + dt)
    else:
        speed = fam.length_scale(c) / np.maximum(fam.hi[c] - fam.lo[c], 1e-300)
        dt = margin / np.maximum(speed, 1e-300)
        lo2 = np.maximum(lo - dt, 0.0) if fam.kind in "CD" else lo - dt
        hi2 = hi + dt
    pairs = list(zip(lo2.tolist(), hi2.tolist(), strict=True))
    stops = np.cumsum(count).tolist()
    return [(fam, k, pairs[b - n:b]) for k, n, b in zip(cs, count, stops, strict=True)]


def _overshoot_conchoids(fam: Family, c: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                         margin: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_overshoot` of conchoid intervals ``(lo, hi)`` of curves ``c``, vectorized (the
    same numbers: one-vector norms as :func:`_norms`, not the row-wise norm, whose rounding
    differs)."""
    dlo, dhi = fam.lo[c], fam.hi[c]
    width = np.maximum(dhi - dlo, 1e-300)
    speed = fam.length_scale(c) / width
    q = fam.points(np.concatenate((c, c)), np.concatenate((dlo, dhi)))
    chord = _norms(q[len(c):] - q[: len(c)])
    speed = np.maximum(speed, chord / width)
    dt = margin / np.maximum(speed, 1e-300)
    keep_lo = (lo <= dlo) & _pole_ends(fam, c, dlo)
    keep_hi = (hi >= dhi) & _pole_ends(fam, c, dhi)
    out_lo, out_hi = lo.copy(), hi.copy()
    k = np.flatnonzero(~keep_lo)
    out_lo[k] = lo[k] - _reach_many(fam, c[k], lo[k], -dt[k], margin)
    k = np.flatnonzero(~keep_hi)
    out_hi[k] = hi[k] + _reach_many(fam, c[k], hi[k], dt[k], margin)
    return out_lo, out_hi


def _norms(v: np.ndarray) -> np.ndarray:
    """``np.linalg.norm`` of each row of ``v`` (k, 2), bit for bit: it is ``sqrt(x @ x)``,
    and a batched matmul gives the bits of ``x @ x`` (``np.linalg.norm(v, axis=1)`` does not)."""
    return np.sqrt((v[:, None, :] @ v[:, :, None])[:, 0, 0]).reshape(-1)


def _pole_ends(fam: Family, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """:func:`_pole_end` for many (curve, parameter) pairs."""
    Q = _take(fam.w, c) + t[:, None] * _take(fam.d, c)
    r = _take(fam.p, c) - Q
    dist = _norms(r)
    return np.abs(dist - fam.lss) <= 1e-9 * fam.lss


def _reach_many(fam: Family, c: np.ndarray, t: np.ndarray, dt: np.ndarray, margin: float
                ) -> np.ndarray:
    """:func:`_reach` for many (curve, parameter, step) rows at once (the same numbers)."""
    m = len(c)
    if m == 0:
        return np.zeros(0)
    q0 = fam.points(c, t)
    span = np.maximum(fam.hi[c] - fam.lo[c], np.abs(dt))
    steps = dt[:, None] * 2.0 ** np.arange(_REACH_DOUBLINGS + 1)[None, :]
    nvalid = np.sum(np.abs(steps) < span[:, None], axis=1)  # a prefix: |steps| doubles
    steps = np.column_stack((steps, np.zeros(m)))
    col = np.arange(_REACH_DOUBLINGS + 2)[None, :]
    steps[np.arange(m), nvalid] = np.copysign(span, dt)
    present = col <= nvalid[:, None]
    steps = np.where(present, steps, 0.0)
    rows = np.repeat(np.arange(m), _REACH_DOUBLINGS + 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        pts = fam.points(c[rows], t[rows] + steps.ravel())
        moved = np.hypot(*(pts - q0[rows]).T).reshape(m, -1)
    ok = np.cumprod(np.isfinite(moved) & present, axis=1).astype(bool)
    hit = ok & (moved >= margin)
    any_hit = hit.any(axis=1)
    first_hit = np.argmax(hit, axis=1)
    last_ok = np.sum(ok, axis=1) - 1
    out = np.abs(dt).astype(float)
    r = np.arange(m)
    out = np.where(any_hit, np.abs(steps[r, first_hit]),
                   np.where(last_ok >= 0, np.abs(steps[r, np.maximum(last_ok, 0)]), out))
    return out


def _draw_all(found: list[tuple[Family, int, list[tuple[float, float]]]], tol: float
              ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`_polyline` of every interval of ``found``: straight curves and circles in one
    vectorized pass per family (then their marks inserted curve by curve), conchoids one by
    one (adaptive)."""
    out: list[list[tuple[np.ndarray, np.ndarray]]] = []
    for fam, group in _family_runs(found):
        if fam.kind == "E":
            out += _draw_conchoids(fam, group, tol)
        else:
            out += _draw_simple(fam, group, tol)
    return out


_Found = list[tuple["Family", int, list[tuple[float, float]]]]


def _family_runs(found: _Found) -> Iterator[tuple[Family, _Found]]:
    """The runs of consecutive items of ``found`` of one family: ``(family, its items)``."""
    k = 0
    while k < len(found):
        fam = found[k][0]
        j = k
        while j < len(found) and found[j][0] is fam:
            j += 1
        yield fam, found[k:j]
        k = j


def _draw_conchoids(fam: Family, group: list[tuple[Family, int, list[tuple[float, float]]]],
                    tol: float) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`_polyline` for conchoids, all intervals at once: 17 parameters each, chords
    split at their middle while the middle deviates more than ``tol`` (at most 24 rounds, each
    interval evolving as it would alone), then the marks and the pole ends."""
    count = [len(ivs) for _, _, ivs in group]
    c = np.repeat(np.array([g[1] for g in group], dtype=np.int64), count)
    lo, hi = np.array([iv for g in group for iv in g[2]], dtype=float).reshape(-1, 2).T
    m = len(lo)
    iv, ts = _linspace_many(lo, hi, np.full(m, 17, dtype=np.int64))
    active = np.ones(m, bool)
    for _ in range(24):
        rows = np.flatnonzero(active[iv])
        if len(rows) == 0:
            break
        v, t = iv[rows], ts[rows]
        pts = fam.points(c[v], t)
        pair = np.flatnonzero(v[1:] == v[:-1])  # consecutive parameters of one interval
        mid_t = 0.5 * (t[pair + 1] + t[pair])
        mid = fam.points(c[v[pair]], mid_t)
        a, b = pts[pair], pts[pair + 1]
        ab = b - a
        lab = np.maximum(np.linalg.norm(ab, axis=1), 1e-300)
        dev = np.abs(ab[:, 0] * (mid[:, 1] - a[:, 1]) - ab[:, 1] * (mid[:, 0] - a[:, 0])) / lab
        split = dev > tol
        active[:] = False
        active[v[pair[split]]] = True
        if not split.any():
            break
        # each middle right after its chord's first parameter (all rows of an active
        # interval are among ``rows``, so the next row is the chord's other end)
        iv, ts = _insert_after(iv, ts, rows[pair[split]], mid_t[split])
    pts = fam.points(c[iv], ts)
    n = np.bincount(iv, minlength=m)
    ts, pts, first, n = _with_marks_many(fam, c, np.cumsum(n) - n, n, ts, pts)
    at_lo = np.flatnonzero((lo == fam.lo[c]) & _pole_ends(fam, c, lo))
    at_hi = np.flatnonzero((hi == fam.hi[c]) & _pole_ends(fam, c, hi))
    pts[(first + n - 1)[at_hi]] = fam.p[c[at_hi]]
    pts[first[at_lo]] = fam.p[c[at_lo]]
    stops = (first + n).tolist()
    drawn = [(ts[a:b], pts[a:b]) for a, b in zip(first.tolist(), stops, strict=True)]
    ends = np.cumsum(count).tolist()
    return [drawn[e - q:e] for q, e in zip(count, ends, strict=True)]


def _linspace_many(lo: np.ndarray, hi: np.ndarray, n: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``np.linspace(lo[k], hi[k], n[k])`` for every ``k`` at once (its arithmetic: ``i *
    step + lo``, the last value ``hi`` exactly): (interval index, parameter) rows."""
    iv = np.repeat(np.arange(len(lo)), n)
    first = np.cumsum(n) - n
    kk = (np.arange(len(iv)) - np.repeat(first, n)).astype(float)
    delta = hi - lo
    stepv = delta / (n - 1)
    zero = stepv == 0
    ts = np.where(zero[iv], kk / (n - 1)[iv] * delta[iv], kk * stepv[iv]) + lo[iv]
    ts[first + n - 1] = hi
    return iv, ts


def _draw_simple(fam: Family, group: list[tuple[Family, int, list[tuple[float, float]]]],
                 tol: float) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`_polyline` for the lines (A, C, D) and circles (B) of one family, vectorized:
    the same parameters (``np.linspace``'s arithmetic) and points."""
    count = [len(ivs) for _, _, ivs in group]
    c = np.repeat(np.array([g[1] for g in group], dtype=np.int64), count)
    lo, hi = np.array([iv for g in group for iv in g[2]], dtype=float).reshape(-1, 2).T
    if fam.kind == "B":
        step = math.sqrt(8.0 * tol / fam.lss)
        n = np.maximum(2, np.ceil((hi - lo) / step).astype(np.int64) + 1)
    else:
        n = np.full(len(lo), 2, dtype=np.int64)
    iv, ts = _linspace_many(lo, hi, n)
    first = np.cumsum(n) - n
    pts = fam.points(c[iv], ts)
    ts, pts, first, n = _with_marks_many(fam, c, first, n, ts, pts)
    stops = (first + n).tolist()
    drawn = [(ts[a:b], pts[a:b]) for a, b in zip(first.tolist(), stops, strict=True)]
    ends = np.cumsum(count).tolist()
    return [drawn[e - m:e] for m, e in zip(count, ends, strict=True)]


#: At most this many doublings of a conchoid's overshoot step (a factor ~1e6 on its mean speed).
_REACH_DOUBLINGS = 20


def _reach(fam: Family, c: int, t: float, dt: float, margin: float) -> float:
    """``|dt'|`` with ``dt'`` a multiple ``2**k dt`` of the parameter step ``dt`` that moves
    the point of curve ``c`` from ``q(t)`` at least ``margin`` map units (a conchoid's speed
    varies along it: near a stationary point it can be 1000 times below its mean, and an
    overshoot sized by the mean then stays short of the curves meeting it there, leaving an
    unclosed dangle inside a face, issue #9)."""
    q0 = fam.points(np.array([c]), np.array([t]))[0]
    span = max(float(fam.hi[c] - fam.lo[c]), abs(dt))  # never more than the domain's length
    steps = dt * 2.0 ** np.arange(_REACH_DOUBLINGS + 1)
    steps = np.append(steps[np.abs(steps) < span], math.copysign(span, dt))
    with np.errstate(invalid="ignore", divide="ignore"):
        moved = np.hypot(*(fam.points(np.full(len(steps), c), t + steps) - q0).T)
    ok = np.cumprod(np.isfinite(moved)).astype(bool)  # stop before any undefined point
    far = np.flatnonzero(ok & (moved >= margin))
    if len(far):
        return float(abs(steps[far[0]]))
    return float(abs(steps[np.flatnonzero(ok)[-1]])) if ok.any() else abs(dt)


def _polyline(fam: Family, c: int, lo: float, hi: float, tol: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Parameters and points along curve ``c`` from ``lo`` to ``hi``, chord deviation below
    ``tol``."""
    if fam.kind in "ACD":
        ts = np.array([lo, hi])
        return _with_marks(fam, c, ts, fam.points(np.array([c, c]), ts))
    if fam.kind == "B":
        step = math.sqrt(8.0 * tol / fam.lss)
        n = max(2, math.ceil((hi - lo) / step) + 1)
        ts = np.linspace(lo, hi, n)
        return _with_marks(fam, c, ts, fam.points(np.full(n, c), ts))
    ts = np.linspace(lo, hi, 17)
    for _ in range(24):
        cc = np.full(len(ts), c)
        pts = fam.points(cc, ts)
        mid_t = 0.5 * (ts[1:] + ts[:-1])
        mid = fam.points(cc[1:], mid_t)
        a, b = pts[:-1], pts[1:]
        ab = b - a
        lab = np.maximum(np.linalg.norm(ab, axis=1), 1e-300)
        dev = np.abs(ab[:, 0] * (mid[:, 1] - a[:, 1]) - ab[:, 1] * (mid[:, 0] - a[:, 0])) / lab
        split = dev > tol
        if not split.any():
            break
        ts = np.sort(np.concatenate((ts, mid_t[split])))
    pts = fam.points(np.full(len(ts), c), ts)
    ts, pts = _with_marks(fam, c, ts, pts)
    if fam.kind == "E" and hi == fam.hi[c] and _pole_end(fam, c, hi):
        pts[-1] = fam.p[c]
    if fam.kind == "E" and lo == fam.lo[c] and _pole_end(fam, c, lo):
        pts[0] = fam.p[c]
    return ts, pts


def _with_marks(fam: Family, c: int, ts: np.ndarray, pts: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Insert the curve's exact marks lying strictly inside ``(ts[0], ts[-1])``."""
    if not fam.marks:
        return ts, pts
    lo, hi = ts[0], ts[-1]
    add_t, add_p = [], []
    for t, p in fam.marks[c]:
        for shift in ((-2 * math.pi, 0.0, 2 * math.pi) if fam.kind == "B" else (0.0,)):
            if lo < t + shift < hi:
                add_t.append(t + shift)
                add_p.append(p)
    if not add_t:
        return ts, pts
    keep = np.ones(len(ts), bool)
    for t in add_t:  # a mark replaces a sample at the same parameter
        keep &= np.abs(ts - t) > 1e-15 * max(1.0, abs(t))
    ts, pts = ts[keep], pts[keep]
    ts = np.concatenate((ts, add_t))
    pts = np.vstack((pts, add_p))
    order = np.argsort(ts, kind="stable")
    return ts[order], pts[order]


def _with_marks_many(fam: Family, c: np.ndarray, first: np.ndarray, n: np.ndarray,
                     ts: np.ndarray, pts: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_with_marks` of many polylines at once: polyline ``k`` of curve ``c[k]`` is
    rows ``first[k]:first[k] + n[k]`` of ``ts``, ``pts`` (consecutive). Returns the new
    ``ts, pts, first, n`` (the same numbers and order, polyline by polyline)."""
    size = np.array([len(mk) for mk in fam.marks], dtype=np.int64)
    if len(size) == 0 or size.sum() == 0:
        return ts, pts, first, n
    mark_t = np.array([t for mk in fam.marks for t, _ in mk], dtype=float)
    mark_p = np.array([p for mk in fam.marks for _, p in mk], dtype=float).reshape(-1, 2)
    shifts = np.array((-2 * math.pi, 0.0, 2 * math.pi) if fam.kind == "B" else (0.0,))
    # (polyline, mark, shift) rows, mark-major as the loops of _with_marks
    per = size[c]
    row = np.repeat(np.repeat(np.arange(len(c)), per), len(shifts))
    mark = np.repeat(ragged_arange((np.cumsum(size) - size)[c], per), len(shifts))
    add_t = mark_t[mark] + np.tile(shifts, int(per.sum()))
    inside = (ts[first][row] < add_t) & (add_t < ts[first + n - 1][row])
    row, mark, add_t = row[inside], mark[inside], add_t[inside]
    if len(row) == 0:
        return ts, pts, first, n
    # a mark replaces the samples of its polyline at the same parameter
    near = ragged_arange(first[row], n[row])
    thr = np.repeat(1e-15 * np.maximum(1.0, np.abs(add_t)), n[row])
    keep = np.ones(len(ts), bool)
    keep[near[~(np.abs(ts[near] - np.repeat(add_t, n[row])) > thr)]] = False
    line = np.repeat(np.arange(len(c)), n)
    kept = np.flatnonzero(keep)
    all_line = np.concatenate((line[kept], row))
    all_t = np.concatenate((ts[kept], add_t))
    all_p = np.vstack((pts[kept], mark_p[mark]))
    # polylines with marks sorted by parameter (stable: samples, then marks in order); the
    # others keep their order
    marked = np.zeros(len(c), bool)
    marked[row] = True
    key = np.where(marked[all_line], all_t, np.arange(len(all_t), dtype=float))
    order = np.lexsort((key, all_line))
    n2 = np.bincount(all_line, minlength=len(c))
    return all_t[order], all_p[order], np.cumsum(n2) - n2, n2


def _pole_end(fam: Family, c: int, t: float) -> bool:
    """Whether a conchoid's domain end ``t`` is where it reaches its pole (|V - Q| = lss)."""
    Q = fam.w[c] + t * fam.d[c]
    return abs(np.linalg.norm(fam.p[c] - Q) - fam.lss) <= 1e-9 * fam.lss


def critical_curves(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL
                    ) -> list[Curve]:
    """All candidate curves with a critical part, each with its polylines.

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units.
    rel_tol : float
        Polyline approximation tolerance relative to the map diameter.

    Returns
    -------
    list of Curve
        In the order A, B, C, D, E, then by feature; curves with no critical part are dropped.
    """
    if not env.is_internal:  # computed in the normalized frame, reported in the user's
        names = env.feature_names_map()
        return curves_to_user(critical_curves(env.internal, lss * env.frame.scale, rel_tol),
                              env.frame, names)
    tol = rel_tol * env.diameter
    margin = 20 * tol
    curves: list[Curve] = []
    found = []
    first = env.coincident
    walls = None
    for fam in candidate_families(env, lss):
        ivs = _critical_intervals(env, fam)
        if fam.kind == "B":  # touching rings: one circle per point (see :func:`_family_b`)
            ivs = [iv if first[c] == c else [] for c, iv in enumerate(ivs)]
        if fam.kind in "ACD":
            walls = _wall_band(env) if walls is None else walls
            ivs = _off_walls(fam, ivs, walls)
        found += _overshoot_family(fam, ivs, margin)
    check_vertex_budget(sum(_vertex_estimates(found, tol)), lss)
    drawn_all = _draw_all(found, tol)
    domains = {id(fam): (fam.lo.tolist(), fam.hi.tolist())
               for fam in {id(f): f for f, _, _ in found}.values()}
    for (fam, c, ivs), drawn in zip(found, drawn_all, strict=True):
        lo, hi = domains[id(fam)]
        # ``ivs`` are pairs of floats already (:func:`_overshoot_family`)
        curves.append(Curve(len(curves), fam.kind, fam.features[c], (lo[c], hi[c]),
                            tuple(ivs), tuple(p for _, p in drawn),
                            tuple(t for t, _ in drawn), fam, c))
    return _share_lines(curves, env.length_tol)


#: A straight curve's critical part within this many point tolerances of the walls all
#: along lies on a wall (see :func:`_off_walls`).
ON_WALL_TOLS = 4.0


def _wall_band(env: Environment) -> Any:
    """The walls grown by ``ON_WALL_TOLS`` point tolerances (a prepared polygon)."""
    band = shapely.buffer(shapely.boundary(env.polygon), ON_WALL_TOLS * env.length_tol)
    shapely.prepare(band)
    return band


def _off_walls(fam: Family, intervals: list[list[tuple[float, float]]], band: Any
               ) -> list[list[tuple[float, float]]]:
    """The critical intervals of straight curves without those lying on a wall all along.

    An offset exactly ``lss`` from a wall facing its edge, or an extension along a collinear
    wall, runs on the wall itself: it bounds no region (the free space is on one side only),
    but whether the exact rod test calls it critical is decided by rounding (its event rod
    touches a wall all along), so the map moved or scaled showed one curve more or less.
    Such intervals are dropped; any stretch of the curve off the walls is kept whole."""
    rows = [(c, k) for c, ivs in enumerate(intervals) for k in range(len(ivs))]
    if not rows:
        return intervals
    c = np.array([r[0] for r in rows], dtype=np.int64)
    lo, hi = np.array([intervals[a][k] for a, k in rows], dtype=float).T
    ends = np.stack((fam.points(c, lo), fam.points(c, hi)), axis=1)
    # both ends in the band first (points: cheap), then the whole segment
    on = (shapely.contains_xy(band, ends[:, 0, 0], ends[:, 0, 1])
          & shapely.contains_xy(band, ends[:, 1, 0], ends[:, 1, 1]))
    k = np.flatnonzero(on)
    on[k] = np.asarray(shapely.within(shapely.linestrings(ends[k]), band), dtype=bool)
    if not on.any():
        return intervals
    out = [list(ivs) for ivs in intervals]
    for a, k in sorted((rows[i] for i in np.flatnonzero(on).tolist()), reverse=True):
        del out[a][k]
    return out


def _share_lines(curves: list[Curve], tol: float) -> list[Curve]:
    """Make straight curves (A, C, D) on one supporting line share their vertices.

    Offsets of parallel edges at the same distance, an edge's extension and a line through two
    reflex vertices on it, ...: such curves coincide, but computed separately they differ in
    the last bits, and how the noder splits two almost coincident segments depends on the map's
    position and rotation. Here every polyline of a line gets all the vertices of the line's
    other curves that lie within its span (the very same coordinates), so that the overlapping
    stretches are identical segments, which the noder merges exactly. ``tol`` (map units) is how
    far apart two lines may be and still be one line, and two vertices along it one vertex.
    """
    straight = [k for k, c in enumerate(curves) if c.kind in "ACD"]
    if len(straight) < 2:
        return curves
    fam_d = np.array([curves[k].family.d[curves[k].index] for k in straight])
    fam_p = np.array([curves[k].family.p[curves[k].index] for k in straight])
    u = fam_d / np.linalg.norm(fam_d, axis=1)[:, None]
    flip = (u[:, 0] < 0) | ((u[:, 0] == 0) & (u[:, 1] < 0))
    u[flip] *= -1
    theta = np.arctan2(u[:, 1], u[:, 0])  # in (-pi/2, pi/2]
    offset = u[:, 0] * fam_p[:, 1] - u[:, 1] * fam_p[:, 0]  # signed distance of the line to 0
    groups = [g for g in _line_groups(theta, offset, tol) if len(g) >= 2]
    if not groups:
        return curves
    members = [straight[g] for group in groups for g in group]  # curve numbers, by group
    polys = [p for k in members for p in curves[k].polylines]
    npoly = np.array([len(curves[k].polylines) for k in members], dtype=np.int64)
    gsize = np.array([len(g) for g in groups], dtype=np.int64)
    poly_group = np.repeat(np.repeat(np.arange(len(groups)), gsize), npoly)
    size = np.array([len(p) for p in polys], dtype=np.int64)
    pstart = np.cumsum(size) - size
    pts = np.vstack(polys)
    # every vertex's position along its group's line: the products of the former loops, one
    # per group (its vertices) and one per polyline (its ends), so the very same bits
    # whatever the BLAS kernel (a row's bits could depend on the matrix's size)
    along = np.empty(len(pts))
    a_poly = np.empty(len(pts))
    gstop = np.cumsum(np.bincount(poly_group, weights=size, minlength=len(groups))
                      ).astype(np.int64).tolist()
    pstop = (pstart + size).tolist()
    j = 0
    for group, r0, r1 in zip(groups, [0] + gstop[:-1], gstop, strict=True):
        base, uu = fam_p[group[0]], u[group[0]]
        along[r0:r1] = (pts[r0:r1] - base) @ uu
        while j < len(polys) and pstop[j] <= r1:
            a_poly[pstop[j] - len(polys[j]):pstop[j]] = (polys[j] - base) @ uu
            j += 1
    row_poly = np.repeat(np.arange(len(polys)), size)
    row_group = poly_group[row_poly]
    # each group's vertices by position along the line (stable), one per tol
    order = np.lexsort((along, row_group))
    s_along, s_group = along[order], row_group[order]
    distinct = np.r_[True, (np.diff(s_along) > tol) | (s_group[1:] != s_group[:-1])]
    order = order[distinct]
    d_along, d_group = along[order], row_group[order]
    # each polyline's extreme vertices (the first of equals) and the group's vertices
    # strictly inside (lo + tol, hi - tol)
    lo = np.minimum.reduceat(a_poly, pstart)
    hi = np.maximum.reduceat(a_poly, pstart)
    first_lo = first_per_group(np.flatnonzero(a_poly == lo[row_poly]), row_poly)
    first_hi = first_per_group(np.flatnonzero(a_poly == hi[row_poly]), row_poly)
    i0 = _grouped_searchsorted(d_group, d_along, poly_group, lo + tol, "right")
    i1 = np.maximum(i0, _grouped_searchsorted(d_group, d_along, poly_group, hi - tol, "left"))
    count = i1 - i0 + 2
    cstart = np.cumsum(count) - count
    k = np.arange(int(count.sum())) - np.repeat(cstart, count)
    backward = a_poly[pstart] > a_poly[pstart + size - 1]
    k = np.where(np.repeat(backward, count), np.repeat(count - 1, count) - k, k)
    src = np.where(k == 0, np.repeat(first_lo, count),
                   np.where(k == np.repeat(count - 1, count), np.repeat(first_hi, count),
                            order[np.minimum(np.repeat(i0 - 1, count) + k, len(order) - 1)]))
    merged = pts[src]
    stops = np.cumsum(count).tolist()
    out = list(curves)
    j = 0  # polyline number
    for kk, n in zip(members, npoly.tolist(), strict=True):
        c = curves[kk]
        fam, i = c.family, c.index
        dd, p = fam.d[i], fam.p[i]
        den = dd @ dd
        cuts = [stops[j - 1] if j else 0] + stops[j:j + n]
        lines = [merged[x:y] for x, y in zip(cuts[:-1], cuts[1:], strict=True)]
        out[kk] = Curve(c.id, c.kind, c.features, c.domain, c.intervals, tuple(lines),
                        tuple((line - p) @ dd / den for line in lines), fam, i, c.frame)
        j += n
    return out


def _grouped_searchsorted(dg: np.ndarray, dv: np.ndarray, qg: np.ndarray, qv: np.ndarray,
                          side: str) -> np.ndarray:
    """``np.searchsorted`` of each ``qv[k]`` among the values of group ``qg[k]``, for values
    ``dv`` sorted by (group ``dg``, value), as an index into ``dv``: the number of values of
    earlier groups and of the group's values below (``left``) or not above (``right``) it.
    One merged sort, exact comparisons."""
    nd = len(dv)
    data_first = side == "right"  # ties: a value equal to the query counts as below it
    tie = np.r_[np.full(nd, not data_first), np.full(len(qv), data_first)]
    order = np.lexsort((tie, np.r_[dv, qv], np.r_[dg, qg]))
    is_data = order < nd
    before = np.cumsum(is_data) - is_data
    out = np.empty(len(qv), np.int64)
    out[order[~is_data] - nd] = before[~is_data]
    return out


def _line_groups(theta: np.ndarray, offset: np.ndarray, tol: float) -> list[list[int]]:
    """Groups of lines (direction angle in (-pi/2, pi/2], signed offset, map units) that are
    one line: angles within ``ANGLE_TOL``-ish of each other and offsets within ``tol``."""
    from tether.tolerances import ANGLE_TOL

    # directions near +-pi/2 are the same direction: fold them together
    th = np.where(theta > np.pi / 2 - 1e-9, theta - np.pi, theta)
    off = np.where(theta > np.pi / 2 - 1e-9, -offset, offset)
    order = np.argsort(th, kind="stable")
    run = np.r_[0, np.cumsum(np.diff(th[order]) > ANGLE_TOL)]  # runs of close angles
    by_off = np.lexsort((off[order], run))  # each run by offset (stable)
    idx, run = order[by_off], run[by_off]
    cut = np.flatnonzero((np.diff(off[idx]) > tol) | (run[1:] != run[:-1])) + 1
    flat = idx.tolist()
    bounds = [0] + cut.tolist() + [len(flat)]
    return [flat[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


#: Refuse decompositions whose curves would need more polyline vertices (estimated) than
#: this: the peak memory is about 1.2 kB per estimated vertex on floor plans (noded parts,
#: faces, region polygons, cells and G; measured 1.25 M -> 1.53 GB at 1,000 map vertices,
#: decompose + analyze; it was 2.5 kB before the freed C heap was returned between stages),
#: so the default bounds a decomposition near 2 GB. Raise it on a machine with more memory.
MAX_CURVE_VERTICES = 1_500_000


def check_vertex_budget(vertices: float, lss: float) -> None:
    """Raise :class:`ResourceLimitError` (one line) if ``vertices`` exceeds the bound."""
    if vertices > MAX_CURVE_VERTICES:
        raise ResourceLimitError(
            f"the critical curves at lss {lss:g} (internal units) would need about "
            f"{vertices:,.0f} polyline vertices, more than the limit {MAX_CURVE_VERTICES:,} "
            "(tether.curves.MAX_CURVE_VERTICES, about 2 GB of memory): use a smaller lss, "
            "a coarser curve tolerance, or split the map")


def _vertex_estimate(fam: Family, c: int, ivs: list[tuple[float, float]], tol: float
                     ) -> float:
    """Polyline vertices the intervals of curve ``c`` will need (an estimate: exact for lines
    and circles, by length over the chord step for conchoids)."""
    if fam.kind in "ACD":
        return 2.0 * len(ivs) + len(fam.marks[c]) if fam.marks else 2.0 * len(ivs)
    step = math.sqrt(8.0 * tol / fam.lss)  # radians per chord on a circle of radius lss
    span = sum(hi - lo for lo, hi in ivs)
    if fam.kind == "B":
        return span / step + 2 * len(ivs)
    per_param = fam.length_scale(np.array([c]))[0] / max(fam.hi[c] - fam.lo[c], 1e-300)
    return span * per_param / (fam.lss * step) + 17 * len(ivs)


def _vertex_estimates(found: list[tuple[Family, int, list[tuple[float, float]]]], tol: float
                      ) -> list[float]:
    """:func:`_vertex_estimate` of every ``(family, curve, intervals)`` of ``found`` (the same
    numbers: the same operations, by family)."""
    out: list[float] = []
    for fam, group in _family_runs(found):
        c = np.array([g[1] for g in group], dtype=np.int64)
        count = np.array([len(g[2]) for g in group], dtype=float)
        if fam.kind in "ACD":
            est = 2.0 * count
            if fam.marks:
                est = est + np.array([len(fam.marks[i]) for i in c.tolist()], dtype=float)
        else:
            step = math.sqrt(8.0 * tol / fam.lss)
            span = np.array([sum(hi - lo for lo, hi in g[2]) for g in group], dtype=float)
            if fam.kind == "B":
                est = span / step + 2 * count
            else:
                per_param = fam.length_scale(c) / np.maximum(fam.hi[c] - fam.lo[c], 1e-300)
                est = span * per_param / (fam.lss * step) + 17 * count
        out += est.tolist()
    return out


def project_many(curves: list[Curve], cid: np.ndarray, q: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorized :meth:`Curve.project`: for each row ``k`` the nearest point of the critical
    part of ``curves[cid[k]]`` to ``q[k]`` (shape (m, 2), map units). Returns parameters (m,),
    points (m, 2) and unit normals (m, 2), exact up to the Gauss-Newton convergence of the
    conchoids (12 steps from the nearest polyline segment, as :meth:`Curve.project`)."""
    cid = np.asarray(cid, dtype=int)
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    t = np.zeros(len(cid))
    pts = np.zeros((len(cid), 2))
    nrm = np.zeros((len(cid), 2))
    kinds = np.array([c.kind for c in curves])[cid] if len(cid) else np.zeros(0, str)
    index = np.array([c.index for c in curves], dtype=int)
    fams = {c.kind: c.family for c in curves}
    for kind, fam in fams.items():
        rows = np.flatnonzero(kinds == kind)
        if len(rows) == 0:
            continue
        c = index[cid[rows]]
        if kind in "ACD":
            d = _take(fam.d, c)
            tt = np.einsum("ij,ij->i", q[rows] - _take(fam.p, c), d) / np.einsum("ij,ij->i", d, d)
            t[rows] = tt
            pts[rows] = _take(fam.p, c) + tt[:, None] * d
            nrm[rows] = np.column_stack((-d[:, 1], d[:, 0])) / np.hypot(d[:, 0], d[:, 1])[:, None]
        elif kind == "B":
            r = q[rows] - _take(fam.p, c)
            tt = np.arctan2(r[:, 1], r[:, 0])
            u = np.column_stack((np.cos(tt), np.sin(tt)))
            t[rows], pts[rows], nrm[rows] = tt, _take(fam.p, c) + fam.lss * u, u
        else:
            t[rows], pts[rows], nrm[rows] = _project_conchoids(curves, cid[rows], q[rows])
    return t, pts, nrm


def _project_conchoids(curves: list[Curve], cid: np.ndarray, q: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`project_many` for conchoid rows: the nearest polyline segment of each row's curve
    brackets the answer, then Gauss-Newton on ``(q(t) - q)·q'(t) = 0`` inside the bracket."""
    uc, inv = np.unique(cid, return_inverse=True)
    # every polyline segment of the involved curves, grouped by curve
    seg_a, seg_b, seg_lo, seg_hi, seg_c = [], [], [], [], []
    for k, c in enumerate(uc.tolist()):
        for ts, p in zip(curves[c].params, curves[c].polylines, strict=True):
            seg_a.append(p[:-1])
            seg_b.append(p[1:])
            seg_lo.append(ts[:-1])
            seg_hi.append(ts[1:])
            seg_c.append(np.full(len(p) - 1, k))
    a, b = np.vstack(seg_a), np.vstack(seg_b)
    lo_all, hi_all, sc = map(np.concatenate, (seg_lo, seg_hi, seg_c))
    row, seg = _near_segment_pairs(a, b, sc, len(uc), inv, q)
    ab = b[seg] - a[seg]
    u = np.clip(np.einsum("ij,ij->i", q[row] - a[seg], ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    dist = np.hypot(*(a[seg] + u[:, None] * ab - q[row]).T)
    best = first_nearest(row, dist)  # nearest segment per row
    s = seg[best]
    lo, hi = lo_all[s], hi_all[s]
    t = lo + u[best] * (hi - lo)
    fam = curves[int(cid[0])].family
    c = np.array([curves[k].index for k in cid.tolist()], dtype=int)
    dlo = fam.lo[c]
    dhi = fam.hi[c]
    sub = fam.rows(c)  # the same rows every step: gathered once
    for _ in range(12):
        tangent = _tangents(sub, None, t, dlo, dhi)
        tt = np.einsum("ij,ij->i", tangent, tangent)
        step = np.where(tt > 0, np.einsum("ij,ij->i", sub.points(None, t) - q, tangent)
                        / np.maximum(tt, 1e-300), 0.0)
        t_new = np.clip(t - step, lo, hi)
        done = np.abs(t_new - t) <= 1e-15 * np.maximum(1.0, np.abs(t))
        t = t_new
        if done.all():
            break
    tangent = _tangents(sub, None, t, dlo, dhi)
    tangent = tangent / np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-300)[:, None]
    return t, sub.points(None, t), np.column_stack((-tangent[:, 1], tangent[:, 0]))


#: Consecutive polyline segments per block in the pruned nearest-segment search.
_SEG_BLOCK = 16


def _near_segment_pairs(a: np.ndarray, b: np.ndarray, sc: np.ndarray, ncurves: int,
                        inv: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (row, segment) pairs among which each point ``q[row]`` finds its nearest segment
    of curve ``inv[row]`` (segments ``a[k]-b[k]`` grouped by curve ``sc[k]``), in (row,
    segment) order: every segment of the blocks of ``_SEG_BLOCK`` consecutive segments whose
    bounding box is not farther from the point than some block's first vertex (an upper bound
    of the nearest distance). Every segment at the nearest distance is kept, so the nearest
    one, and the first among equals, are those of the search over all segments."""
    count = np.bincount(sc, minlength=ncurves)
    first = np.cumsum(count) - count
    nblk = -(-count // _SEG_BLOCK)  # blocks per curve
    bfirst = np.cumsum(nblk) - nblk
    bcurve = np.repeat(np.arange(ncurves), nblk)
    bstart = first[bcurve] + _SEG_BLOCK * (np.arange(len(bcurve)) - bfirst[bcurve])
    bstop = np.minimum(bstart + _SEG_BLOCK, (first + count)[bcurve])
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    bx0, by0 = (np.minimum.reduceat(lo[:, j], bstart) for j in (0, 1))
    bx1, by1 = (np.maximum.reduceat(hi[:, j], bstart) for j in (0, 1))
    nb = nblk[inv]
    rowb = np.repeat(np.arange(len(inv)), nb)
    blk = ragged_arange(bfirst[inv], nb)
    qx, qy = q[rowb, 0], q[rowb, 1]
    gap = np.hypot(np.maximum(np.maximum(bx0[blk] - qx, qx - bx1[blk]), 0.0),
                   np.maximum(np.maximum(by0[blk] - qy, qy - by1[blk]), 0.0))
    vertex = a[bstart[blk]]
    ub = np.full(len(inv), np.inf)
    np.minimum.at(ub, rowb, np.hypot(vertex[:, 0] - qx, vertex[:, 1] - qy))
    slack = 1e-9 * ub + 1e-12  # rounding of the bounds against the distances
    keep = np.flatnonzero(gap <= (ub + slack)[rowb])
    rowb, blk = rowb[keep], blk[keep]
    size = bstop[blk] - bstart[blk]
    return np.repeat(rowb, size), ragged_arange(bstart[blk], size)


def _tangents(fam: Family, c: np.ndarray | None, t: np.ndarray, dlo: np.ndarray,
              dhi: np.ndarray) -> np.ndarray:
    """dq/dt of conchoids by finite differences inside the domain (as ``Curve._tangent``;
    ``c`` as in :meth:`Family.points`)."""
    h = 1e-7 * np.maximum(np.maximum(1.0, np.abs(t)), dhi - dlo)
    a, b = np.maximum(t - h, dlo), np.minimum(t + h, dhi)
    return (fam.points(c, b) - fam.points(c, a)) / (b - a)[:, None]
