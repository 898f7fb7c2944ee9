"""The candidate critical curves: :class:`Family` (all curves of one kind as arrays, evaluated
vectorized), :class:`Curve` (one curve's critical part, its polylines and exact projection) and
the candidates of the five kinds A-E for a rod length (the table in :mod:`tether.curves`;
``docs/formulas.md``, "Critical curves")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tether.environment import Environment

__all__ = ["KINDS", "KIND_NAMES", "Curve", "Family", "candidate_families", "curves_to_user",
           "take"]


KINDS = ("A", "B", "C", "D", "E")
KIND_NAMES = {
    "A": "edge offset",
    "B": "vertex circle",
    "C": "edge extension",
    "D": "two reflex vertices",
    "E": "conchoid",
}


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
            return take(self.p, c) + t[:, None] * take(self.d, c)
        if self.kind == "B":  # p = vertex
            return take(self.p, c) + L * np.column_stack((np.cos(t), np.sin(t)))
        if self.kind in "CD":  # p = ray origin (vertex), d = unit direction away from it
            return take(self.p, c) + t[:, None] * take(self.d, c)
        # E: p = pole, w = edge start, d = edge vector (columns apart: the same numbers as
        # with (k, 2) rows and np.linalg.norm, fewer temporaries)
        w, d, p = take(self.w, c), take(self.d, c), take(self.p, c)
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
            n = take(self.w, c)
            return np.arctan2(-n[:, 1], -n[:, 0])
        if self.kind == "B":
            return t + math.pi
        if self.kind in "CD":
            d = take(self.d, c)
            return np.arctan2(-d[:, 1], -d[:, 0])
        Q = take(self.w, c) + t[:, None] * take(self.d, c)
        r = Q - take(self.p, c)
        return np.arctan2(r[:, 1], r[:, 0])

    def rows(self, c: np.ndarray) -> Family:
        """The curves ``c`` (repeats allowed) as a family of their own, without features or
        marks: for loops evaluating the same rows many times (``points(None, t)``)."""
        return Family(self.kind, self.lss, take(self.p, c), take(self.d, c), take(self.w, c),
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


def take(a: np.ndarray, c: np.ndarray | None) -> np.ndarray:
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
        """The curve reported in user coordinates (from the internal frame), features renamed."""
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
        """The curve as JSON-ready values (domain and intervals in map units)."""
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
    # vertex's (the others are dropped in :func:`~tether.curves.critical_curves`), which takes
    # the tangent points of every edge meeting there
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
    a, b, d, dist = _reflex_pairs(env, R, L)
    feats = [(f"V{x}", f"V{y}") for x, y in zip(R[a].tolist(), R[b].tolist(), strict=True)]
    m = len(a)
    return Family("D", L, V[R[a]].reshape(m, 2), d.reshape(m, 2), np.zeros((m, 2)),
                  np.zeros(m), (L - dist).astype(float), feats)


#: Pairs of poles compared at once by :func:`_reflex_pairs` (its memory: ~40 bytes a pair;
#: all pairs at once took 180 MB at 2,000 map vertices, ~4 times that at 4,000)
_PAIR_BLOCK = 1 << 20


def _reflex_pairs(env: Environment, R: np.ndarray, L: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``(a, b)`` of poles ``R[a]``, ``R[b]`` of the D lines, in row-major order,
    with the unit direction ``d`` from ``R[b]`` to ``R[a]`` and their distance ``dist``
    (map units): closer than ``L`` by more than the length tolerance, apart (``dist > 0``:
    touching rings' coincident vertices have no line; :func:`_poles` keeps one vertex per
    point anyway) and not the ends of one edge (that line is an edge, its extension is type
    C, for an edge of any ring through the point where rings touch). Rows of the distance
    matrix in blocks of about :data:`_PAIR_BLOCK` pairs (the same numbers as the whole
    matrix: each entry is computed alone)."""
    V = env.vertices
    first, nxt = env.coincident, env.next_vertex
    n = env.n
    edges = np.concatenate((first * n + first[nxt], first[nxt] * n + first))
    VR = V[R]
    rows = max(1, _PAIR_BLOCK // max(len(R), 1))
    out: list[tuple[np.ndarray, ...]] = []
    for r0 in range(0, len(R) if len(R) > 1 else 0, rows):
        diff = VR[r0:r0 + rows, None, :] - VR[None, :, :]
        dist = np.linalg.norm(diff, axis=2)
        a, b = np.nonzero((dist < L - env.length_tol) & (dist > 0))
        keep = ~np.isin(first[R[a + r0]] * n + first[R[b]], edges)
        a, b = a[keep], b[keep]
        out.append((a + r0, b, diff[a, b] / dist[a, b][:, None], dist[a, b]))
    if not out:
        return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0))
    return tuple(np.concatenate(x) for x in zip(*out, strict=True))  # type: ignore[return-value]


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
    made: if the first one is not reflex for its ring, no free wedge at the point is reflex,
    no rod grazes it there, and its curves would have no critical part."""
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
