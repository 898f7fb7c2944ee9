"""Segment scans: a decomposition checked against the exact free arcs along straight lines.

Point samples per region miss what lies between them: a pocket of real area merged into a
neighbour, or a region boundary drawn where the structure does not change. A scan walks along a
segment of the free space instead. The regions cut the segment into intervals (exact polygon
intersections); along it the exact structure (:func:`tether.arcs.free_arcs_many`) is evaluated
at evenly spaced points and at the middle of every interval, and each change of the exact
structure between two consecutive points is located by bisection. The decomposition passes a
line when

* every point farther than ``margin`` from its region's boundary has its region's structure
  (kind ``"point"``; a point of the free space in no region at all is kind ``"uncovered"``),
* every change of the exact structure lies within ``margin`` of a region boundary
  (kind ``"change"``: a change inside a region, where no critical curve was drawn), and
* two consecutive intervals of different regions have different structures (kind
  ``"boundary"``: a region boundary where nothing changes).

``margin`` is ``10 x`` the decomposition's curve tolerance, as for point samples (curves are
drawn to within one tolerance of the exact ones). A pocket narrower than the spacing of the
points along a line can still be missed by that line; more lines (``tether check --lines N``)
lower the odds.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

from tether.arcs import feature_name, free_arcs_many
from tether.decomposition.model import region_rows, shared_holder
from tether.decomposition.structure import FREE, Structures, rows_equal, table_rows
from tether.tolerances import SCAN_POINTS_PER_DIAMETER

__all__ = ["free_pieces", "random_chords", "scan", "scan_segments"]

#: Bisection stops when a change is bracketed to this fraction of the margin.
_BRACKET = 0.25


def random_chords(env: Any, lines: int, seed: int = 0) -> np.ndarray:
    """``lines`` random segments across the map's bounding box (a uniform point of the box and
    a uniform direction, extended to the box's diagonal both ways), shape (lines, 2, 2)."""
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = env.bounds
    mid = rng.uniform([x0, y0], [x1, y1], size=(lines, 2))
    ang = rng.uniform(0.0, np.pi, size=lines)
    half = np.hypot(x1 - x0, y1 - y0)
    d = half * np.column_stack((np.cos(ang), np.sin(ang)))
    return np.stack((mid - d, mid + d), axis=1)


def free_pieces(env: Any, chords: np.ndarray, min_length: float) -> np.ndarray:
    """The pieces of the chords (k, 2, 2) inside the free space, as segments (m, 2, 2),
    longer than ``min_length``."""
    out = []
    cut = shapely.intersection(shapely.linestrings(chords), env.polygon)
    for part in shapely.get_parts(shapely.get_parts(cut)):
        if shapely.get_type_id(part) != 1 or part.length <= min_length:
            continue
        xy = shapely.get_coordinates(part)
        out.append((xy[0], xy[-1]))  # collinear pieces: the ends are the segment
    return np.array(out, dtype=float).reshape(-1, 2, 2)


class _RegionShapes:
    """The polygons and boundaries of the regions a scan meets, made once each (map units)."""

    def __init__(self, dec: Any) -> None:
        self.dec = dec
        self._polys: dict[int, Any] = {}
        self._rings: dict[int, Any] = {}

    def polygons(self, ids: np.ndarray) -> np.ndarray:
        new = [i for i in dict.fromkeys(ids.tolist()) if i not in self._polys]
        if new:
            self._polys.update(zip(new, self.dec.region_polygons(new), strict=True))
        return np.fromiter((self._polys[i] for i in ids.tolist()), dtype=object,
                           count=len(ids))

    def boundaries(self, ids: np.ndarray) -> np.ndarray:
        new = [i for i in dict.fromkeys(ids.tolist()) if i not in self._rings]
        if new:
            rings = shapely.boundary(self.polygons(np.array(new)))
            shapely.prepare(rings)
            self._rings.update(zip(new, rings, strict=True))
        return np.fromiter((self._rings[i] for i in ids.tolist()), dtype=object,
                           count=len(ids))


def _intervals(dec: Any, segments: np.ndarray, shapes: _RegionShapes
               ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The regions along each segment ``[a, b]`` of ``segments`` (m, 2, 2): sorted intervals
    of the parameter ``t`` in ``[0, 1]`` (k, 2) and their region indices (k,), per segment.
    All segments at once: one tree query, one vectorized intersection."""
    segs = shapely.linestrings(segments)
    gi, ri = dec.regions_crossing(segs)
    cuts = shapely.intersection(segs[gi], shapes.polygons(ri))
    parts, pidx = shapely.get_parts(cuts, return_index=True)
    lines = shapely.get_type_id(parts) == 1  # points: a segment touching a region
    parts, pidx = parts[lines], pidx[lines]
    xy, cidx = shapely.get_coordinates(parts, return_index=True)
    seg = gi[pidx][cidx]  # the segment of each coordinate
    a, d = segments[:, 0], segments[:, 1] - segments[:, 0]
    t = np.einsum("ij,ij->i", xy - a[seg], d[seg]) / np.einsum("ij,ij->i", d[seg], d[seg])
    lo = np.full(len(parts), np.inf)
    hi = np.full(len(parts), -np.inf)
    np.minimum.at(lo, cidx, t)
    np.maximum.at(hi, cidx, t)
    owner, which = ri[pidx], gi[pidx]
    order = np.lexsort((lo, which))
    lo, hi, owner, which = lo[order], hi[order], owner[order], which[order]
    cut = np.searchsorted(which, np.arange(len(segments) + 1))
    return [(np.column_stack((lo[i:j], hi[i:j])), owner[i:j])
            for i, j in zip(cut[:-1].tolist(), cut[1:].tolist(), strict=True)]


class _Exact:
    """Exact structures at points as integer rows (no frozenset per point), comparable with
    the regions' own rows: in the internal frame and codes when the regions share the
    decomposition's structure table (as :func:`~tether.decomposition.decompose` makes them),
    else in the map's codes from the regions' structures."""

    def __init__(self, dec: Any) -> None:
        self.dec = dec
        env = dec.env
        held = shared_holder(dec.regions, "_structure")
        inner = env.internal
        self.fast = type(held) is Structures and held.base == 2 * inner.n + 1
        if self.fast:
            self.env, self.frame, self.lss = inner, env.frame, dec.lss * env.frame.scale
            self.regions, self.row_of = held.rows(), held.region
            self.codes = env.code_map if inner is not env else None
        else:
            self.env, self.frame, self.lss = env, None, dec.lss
            self.regions, self.row_of = region_rows(list(dec.regions), 2 * env.n + 1)
            self.codes = None

    def rows(self, pts: np.ndarray) -> Any:
        """The exact structures at ``pts`` (map units, (m, 2)) as rows."""
        q = pts if self.frame is None else self.frame.to_internal(pts)
        table = free_arcs_many(self.env, q, self.lss, check=False)
        return table_rows(self.env, table, len(pts))

    def equal(self, a: Any, i: np.ndarray, b: Any, j: np.ndarray) -> np.ndarray:
        return rows_equal(a, np.asarray(i, np.int64), b, np.asarray(j, np.int64))

    def is_region(self, rows: Any, i: np.ndarray, region: np.ndarray) -> np.ndarray:
        """Whether structure ``i[k]`` of ``rows`` is region ``region[k]``'s."""
        return self.equal(rows, i, self.regions, self.row_of[np.asarray(region, np.int64)])

    def same_regions(self, r: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Whether regions ``r[k]`` and ``s[k]`` have equal structures."""
        return self.equal(self.regions, self.row_of[r], self.regions, self.row_of[s])

    def names(self, rows: Any, i: int) -> list:
        """Structure ``i`` of ``rows`` as ``[start, end]`` feature names (the map's)."""
        if rows.kind[i] < 2:
            return [[FREE, FREE]] if rows.kind[i] == 1 else []
        base = 2 * self.env.n + 1
        a, b = np.divmod(rows.pairs[rows.ptr[i]:rows.ptr[i + 1]], base)
        if self.codes is not None:
            a, b = self.codes[a], self.codes[b]
        env = self.dec.env
        return sorted([feature_name(env, x), feature_name(env, y)]
                      for x, y in zip(a.tolist(), b.tolist(), strict=True))


def _far_from_boundary(pts: np.ndarray, region: np.ndarray, shapes: _RegionShapes,
                       margin: float) -> np.ndarray:
    """Whether each point lies farther than ``margin`` from the boundary of its region
    (False where ``region`` is -1)."""
    out = np.zeros(len(pts), dtype=bool)
    sel = np.flatnonzero(region >= 0)
    if len(sel):
        rings = shapes.boundaries(region[sel])
        out[sel] = ~shapely.dwithin(shapely.points(pts[sel]), rings, margin)
    return out


def scan_segments(dec: Any, segments: np.ndarray, spacing: float,
                  margin: float | None = None) -> tuple[int, tuple[dict, ...]]:
    """Scan a decomposition along segments of the free space (m, 2, 2), map units: points
    every ``spacing`` and at every region interval's middle, changes bisected to a quarter of
    ``margin`` (default ``10 x`` the curve tolerance). Returns the number of points evaluated
    and the disagreements (dicts with ``kind``, ``line``, ``point``, and the regions and
    structures involved; see the module's docstring)."""
    margin = 10 * dec.curve_tol if margin is None else margin
    env = dec.env
    shapes = _RegionShapes(dec)
    spans = _intervals(dec, segments, shapes) if len(segments) else []
    lines = [_line_samples(k, a, b, spacing, *spans[k]) for k, (a, b) in enumerate(segments)]
    if not lines:
        return 0, ()
    exact = _Exact(dec)
    line = np.concatenate([np.full(len(x["t"]), x["k"]) for x in lines])
    pts = np.concatenate([x["points"] for x in lines])
    region = np.concatenate([x["region"] for x in lines])
    t_all = np.concatenate([x["t"] for x in lines])
    st = exact.rows(pts)
    bad: list[dict] = []
    for i in np.flatnonzero(region < 0).tolist():  # in no region's interval
        x = lines[line[i]]
        if _gap_width(t_all[i], x["spans"], x["length"]) > 2 * margin and \
                env.boundary_distance(pts[i, :1], pts[i, 1:])[0] > margin:
            bad.append({"kind": "uncovered", "line": int(line[i]), "point": _xy(pts[i]),
                        "found": exact.names(st, i)})
    # points whose exact structure is not their region's: wrong unless near its boundary
    # (distances measured for those few only)
    placed = np.flatnonzero(region >= 0)
    wrong = placed[~exact.is_region(st, placed, region[placed])]
    wrong = wrong[_far_from_boundary(pts[wrong], region[wrong], shapes, margin)]
    for i in wrong.tolist():
        bad.append({"kind": "point", "line": int(line[i]), "point": _xy(pts[i]),
                    "region": f"R{region[i]}", "found": exact.names(st, i),
                    "expected": list(dec.regions[region[i]].cells)})
    for x in lines:  # consecutive intervals of different regions: different structures
        sp, owner = x["spans"], x["owner"]
        nxt = np.flatnonzero((owner[1:] != owner[:-1])
                             & ((sp[1:, 0] - sp[:-1, 1]) * x["length"] < margin))
        for j in nxt[exact.same_regions(owner[nxt], owner[nxt + 1])].tolist():
            bad.append({"kind": "boundary", "line": x["k"],
                        "point": _xy(x["a"] + sp[j, 1] * (x["b"] - x["a"])),
                        "regions": [f"R{owner[j]}", f"R{owner[j + 1]}"]})
    # changes of the exact structure between consecutive points of a line, bisected
    i = np.arange(len(pts) - 1)
    step = np.flatnonzero((line[1:] == line[:-1]) & ~exact.equal(st, i, st, i + 1))
    a = np.array([lines[k]["a"] for k in line[step]]).reshape(-1, 2)
    d = np.array([lines[k]["b"] - lines[k]["a"] for k in line[step]]).reshape(-1, 2)
    tc, evaluated = _bisect(exact, st, step, a, d, t_all[step], t_all[step + 1], margin)
    q = a + tc[:, None] * d
    at = np.array([_interval_region(lines[k], t) for k, t in
                   zip(line[step].tolist(), tc.tolist(), strict=True)], dtype=np.int64)
    # a change next to an end of its interval is on a region boundary (the end is); the
    # others (a line running along a boundary, or a change inside a region) are measured
    ends = np.array([_to_interval_end(lines[k], t) for k, t in
                     zip(line[step].tolist(), tc.tolist(), strict=True)]).reshape(-1)
    odd = np.flatnonzero((at >= 0) & (ends > margin))
    inside = odd[_far_from_boundary(q[odd], at[odd], shapes, margin)]
    for k in inside.tolist():
        ring = shapes.boundaries(at[k:k + 1])[0]
        bad.append({"kind": "change", "line": int(line[step[k]]), "point": _xy(q[k]),
                    "region": f"R{at[k]}",
                    "distance": float(shapely.distance(shapely.points(q[k]), ring))})
    return len(pts) + evaluated, tuple(bad)


def _line_samples(k: int, a: np.ndarray, b: np.ndarray, spacing: float, spans: np.ndarray,
                  owner: np.ndarray) -> dict[str, Any]:
    """Segment ``k``'s points: every ``spacing`` and each region interval's middle (intervals
    ``spans`` of regions ``owner``), with the region of each (-1: in no interval)."""
    length = float(np.hypot(*(b - a)))
    n = max(2, int(np.ceil(length / spacing)) + 1)
    t = np.unique(np.concatenate((np.linspace(0.0, 1.0, n), spans.mean(axis=1))))
    region = np.full(len(t), -1, dtype=np.int64)
    if len(spans):
        pos = np.searchsorted(spans[:, 0], t, side="right") - 1
        inside = (pos >= 0) & (t <= spans[np.maximum(pos, 0), 1])
        region[inside] = owner[pos[inside]]
    return {"k": k, "a": a, "b": b, "length": length, "spans": spans, "owner": owner,
            "t": t, "points": a + t[:, None] * (b - a), "region": region}


def _region_in(spans: np.ndarray, owner: np.ndarray, t: float) -> int:
    """The region whose interval holds ``t`` (-1: none)."""
    if len(spans) == 0:
        return -1
    pos = int(np.searchsorted(spans[:, 0], t, side="right")) - 1
    return int(owner[pos]) if pos >= 0 and t <= spans[pos, 1] else -1


def _interval_region(x: dict[str, Any], t: float) -> int:
    return _region_in(x["spans"], x["owner"], t)


def _to_interval_end(x: dict[str, Any], t: float) -> float:
    """Distance (map units, along the line) from ``t`` to the nearest end of a region interval
    of line ``x`` (infinite if it has none)."""
    sp = x["spans"]
    if len(sp) == 0:
        return float("inf")
    return float(np.abs(sp - t).min() * x["length"])


def _xy(p: np.ndarray) -> list[float]:
    return [float(p[0]), float(p[1])]


def _gap_width(t: float, spans: np.ndarray, length: float) -> float:
    """Length (map units) of the gap between region intervals that contains ``t``."""
    lo = spans[spans[:, 1] <= t, 1].max(initial=0.0) if len(spans) else 0.0
    hi = spans[spans[:, 0] >= t, 0].min(initial=1.0) if len(spans) else 1.0
    return float((hi - lo) * length)


def _bisect(exact: _Exact, rows: Any, lo_row: np.ndarray, a: np.ndarray, d: np.ndarray,
            lo: np.ndarray, hi: np.ndarray, margin: float) -> tuple[np.ndarray, int]:
    """The change of structure between ``a + lo d`` (structure ``lo_row`` of ``rows``) and
    ``a + hi d``, located by bisection (all at once, one exact evaluation per round) to a
    bracket below ``_BRACKET * margin``. Returns the middles of the final brackets and the
    number of points evaluated."""
    lo, hi = lo.astype(float), hi.astype(float)
    length = np.hypot(d[:, 0], d[:, 1])
    evaluated = 0
    for _ in range(64):
        todo = np.flatnonzero((hi - lo) * length > _BRACKET * margin)
        if len(todo) == 0:
            break
        mid = 0.5 * (lo[todo] + hi[todo])
        got = exact.rows(a[todo] + mid[:, None] * d[todo])
        evaluated += len(todo)
        same = exact.equal(got, np.arange(len(todo)), rows, lo_row[todo])
        lo[todo[same]] = mid[same]
        hi[todo[~same]] = mid[~same]
    return 0.5 * (lo + hi), evaluated


def scan(dec: Any, lines: int, seed: int = 0,
         points_per_diameter: int = SCAN_POINTS_PER_DIAMETER) -> tuple[int, tuple[dict, ...]]:
    """Scan ``lines`` random lines of the map (seeded) with points every
    ``diameter / points_per_diameter``: see :func:`scan_segments`."""
    if lines <= 0:
        return 0, ()
    spacing = dec.env.diameter / points_per_diameter
    segs = free_pieces(dec.env, random_chords(dec.env, lines, seed), 20 * dec.curve_tol)
    return scan_segments(dec, segs, spacing)

