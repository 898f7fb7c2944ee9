"""Drawing the critical parts: each interval overshot by a margin at its open ends (so that
curves meeting there cross), then approximated by a polyline within the curve tolerance that
contains the curve's exact marks; and the estimate of how many vertices that takes, checked
against the memory bound before anything is drawn."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from tether._util.arrays import ragged_arange
from tether.curves.critical import insert_after
from tether.curves.families import Family, take

__all__ = ["DRAW_BLOCK", "draw_all", "overshoot_family", "vertex_estimates"]


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


def overshoot_family(fam: Family, intervals: list[list[tuple[float, float]]], margin: float
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
    Q = take(fam.w, c) + t[:, None] * take(fam.d, c)
    r = take(fam.p, c) - Q
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


#: Polyline vertices (estimated, :func:`vertex_estimates`) drawn at once by
#: :func:`draw_all`: its temporaries are ~120 bytes a vertex (125 MB for the 1.1 million
#: vertices of 2,000 map vertices drawn at once); the polylines are the same in any blocks
DRAW_BLOCK = 250_000


def draw_all(found: list[tuple[Family, int, list[tuple[float, float]]]], tol: float,
             estimates: list[float] | None = None
             ) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """:func:`_polyline` of every interval of ``found``: straight curves and circles in one
    vectorized pass per family (then their marks inserted curve by curve), conchoids one by
    one (adaptive); in blocks of about :data:`DRAW_BLOCK` estimated vertices (``estimates``:
    :func:`vertex_estimates` of ``found``, computed here if not given)."""
    if estimates is None:
        estimates = vertex_estimates(found, tol)
    out: list[list[tuple[np.ndarray, np.ndarray]]] = []
    at = 0
    for fam, group in _family_runs(found):
        for a, b in _blocks(estimates[at:at + len(group)], DRAW_BLOCK):
            if fam.kind == "E":
                out += _draw_conchoids(fam, group[a:b], tol)
            else:
                out += _draw_simple(fam, group[a:b], tol)
        at += len(group)
    return out


def _blocks(sizes: list[float], limit: float) -> list[tuple[int, int]]:
    """Consecutive ``(start, stop)`` blocks of the items of ``sizes``, each of total size at
    most ``limit`` or a single item."""
    ends = np.cumsum(np.asarray(sizes, dtype=float))
    out, a = [], 0
    while a < len(sizes):
        base = ends[a - 1] if a else 0.0
        b = max(int(np.searchsorted(ends, base + limit, side="right")), a + 1)
        out.append((a, b))
        a = b
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
        iv, ts = insert_after(iv, ts, rows[pair[split]], mid_t[split])
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


def vertex_estimates(found: list[tuple[Family, int, list[tuple[float, float]]]], tol: float
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
