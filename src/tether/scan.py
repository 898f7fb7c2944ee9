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

from tether.arcs import free_arcs_many
from tether.tolerances import SCAN_POINTS_PER_DIAMETER

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
            self._rings.update(zip(new, rings, strict=True))
        return np.fromiter((self._rings[i] for i in ids.tolist()), dtype=object,
                           count=len(ids))


def _intervals(dec: Any, a: np.ndarray, b: np.ndarray, shapes: _RegionShapes
               ) -> tuple[np.ndarray, np.ndarray]:
    """The regions along segment ``[a, b]``: sorted intervals of the parameter ``t`` in
    ``[0, 1]`` (k, 2) and their region indices (k,)."""
    seg = shapely.linestrings([a, b])
    cand = dec.regions_crossing(seg)
    polys = shapes.polygons(cand)
    cuts = shapely.intersection(seg, polys)
    d = b - a
    dd = float(d @ d)
    spans, owner = [], []
    for r, g in zip(cand.tolist(), cuts, strict=True):
        for part in shapely.get_parts(g):
            if shapely.get_type_id(part) != 1:  # points: the segment touches the region
                continue
            t = (shapely.get_coordinates(part) - a) @ d / dd
            spans.append((t.min(), t.max()))
            owner.append(r)
    if not spans:
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    spans_arr, owner_arr = np.array(spans), np.array(owner)
    order = np.argsort(spans_arr[:, 0], kind="stable")
    return spans_arr[order], owner_arr[order]


def _structures_at(dec: Any, pts: np.ndarray) -> list:
    from tether.decomposition import structures

    if len(pts) == 0:
        return []
    return structures(dec.env, free_arcs_many(dec.env, pts, dec.lss, check=False), len(pts))


def _boundary_distance(pts: np.ndarray, region: np.ndarray, shapes: _RegionShapes
                       ) -> np.ndarray:
    """Distance of each point to the boundary of its region (0 where ``region`` is -1)."""
    out = np.zeros(len(pts))
    sel = np.flatnonzero(region >= 0)
    if len(sel):
        rings = shapes.boundaries(region[sel])
        out[sel] = shapely.distance(shapely.points(pts[sel]), rings)
    return out


def scan_segments(dec: Any, segments: np.ndarray, spacing: float,
                  margin: float | None = None) -> tuple[int, tuple[dict, ...]]:
    """Scan a decomposition along segments of the free space (m, 2, 2), map units: points
    every ``spacing`` and at every region interval's middle, changes bisected to a quarter of
    ``margin`` (default ``10 x`` the curve tolerance). Returns the number of points evaluated
    and the disagreements (dicts with ``kind``, ``line``, ``point``, and the regions and
    structures involved; see the module's docstring)."""
    from tether.decomposition import structure_names

    margin = 10 * dec.curve_tol if margin is None else margin
    env = dec.env
    shapes = _RegionShapes(dec)
    lines = [_line_samples(dec, k, a, b, spacing, shapes) for k, (a, b) in enumerate(segments)]
    if not lines:
        return 0, ()
    line = np.concatenate([np.full(len(x["t"]), x["k"]) for x in lines])
    pts = np.concatenate([x["points"] for x in lines])
    region = np.concatenate([x["region"] for x in lines])
    t_all = np.concatenate([x["t"] for x in lines])
    st = _structures_at(dec, pts)
    expected = {r: dec.regions[r].structure for r in np.unique(region[region >= 0]).tolist()}
    dist = _boundary_distance(pts, region, shapes)
    bad: list[dict] = []
    for i in np.flatnonzero(region < 0).tolist():  # in no region's interval
        x = lines[line[i]]
        if _gap_width(t_all[i], x["spans"], x["length"]) > 2 * margin and \
                env.boundary_distance(pts[i, :1], pts[i, 1:])[0] > margin:
            bad.append({"kind": "uncovered", "line": int(line[i]), "point": _xy(pts[i]),
                        "found": _names(structure_names(env, st[i]))})
    far = np.flatnonzero((region >= 0) & (dist > margin)).tolist()
    for i in far:
        if st[i] != expected[region[i]]:
            bad.append({"kind": "point", "line": int(line[i]), "point": _xy(pts[i]),
                        "region": f"R{region[i]}",
                        "found": _names(structure_names(env, st[i])),
                        "expected": list(dec.regions[region[i]].cells)})
    for x in lines:  # consecutive intervals of different regions: different structures
        spans, owner = x["spans"], x["owner"]
        for j in range(len(owner) - 1):
            if owner[j] != owner[j + 1] and (spans[j + 1, 0] - spans[j, 1]) * x["length"] \
                    < margin and dec.regions[owner[j]].structure == \
                    dec.regions[owner[j + 1]].structure:
                bad.append({"kind": "boundary", "line": x["k"],
                            "point": _xy(x["a"] + spans[j, 1] * (x["b"] - x["a"])),
                            "regions": [f"R{owner[j]}", f"R{owner[j + 1]}"]})
    # changes of the exact structure between consecutive points of a line, bisected
    step = np.flatnonzero((line[1:] == line[:-1]) &
                          np.array([st[i] != st[i + 1] for i in range(len(st) - 1)], bool))
    a = np.array([lines[k]["a"] for k in line[step]]).reshape(-1, 2)
    d = np.array([lines[k]["b"] - lines[k]["a"] for k in line[step]]).reshape(-1, 2)
    tc, evaluated = _bisect(dec, a, d, t_all[step], t_all[step + 1], [st[i] for i in step],
                            margin)
    q = a + tc[:, None] * d
    at = np.array([_interval_region(lines[k], t) for k, t in
                   zip(line[step].tolist(), tc.tolist(), strict=True)], dtype=np.int64)
    dq = _boundary_distance(q, at, shapes)
    for k, i in enumerate(step.tolist()):
        if at[k] >= 0 and dq[k] > margin:
            bad.append({"kind": "change", "line": int(line[i]), "point": _xy(q[k]),
                        "region": f"R{at[k]}", "distance": float(dq[k])})
    return len(pts) + evaluated, tuple(bad)


def _line_samples(dec: Any, k: int, a: np.ndarray, b: np.ndarray, spacing: float,
                  shapes: _RegionShapes) -> dict[str, Any]:
    """One segment's region intervals and its points: every ``spacing`` and each interval's
    middle, with the region of each (-1: in no interval)."""
    spans, owner = _intervals(dec, a, b, shapes)
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


def _xy(p: np.ndarray) -> list[float]:
    return [float(p[0]), float(p[1])]


def _gap_width(t: float, spans: np.ndarray, length: float) -> float:
    """Length (map units) of the gap between region intervals that contains ``t``."""
    lo = spans[spans[:, 1] <= t, 1].max(initial=0.0) if len(spans) else 0.0
    hi = spans[spans[:, 0] >= t, 0].min(initial=1.0) if len(spans) else 1.0
    return float((hi - lo) * length)


def _bisect(dec: Any, a: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            s_lo: list, margin: float) -> tuple[np.ndarray, int]:
    """The change of structure between ``a + lo d`` (structure ``s_lo``) and ``a + hi d``,
    located by bisection (all at once, one exact evaluation per round) to a bracket below
    ``_BRACKET * margin``. Returns the middles of the final brackets and the number of
    points evaluated."""
    lo, hi = lo.astype(float), hi.astype(float)
    length = np.hypot(d[:, 0], d[:, 1])
    evaluated = 0
    for _ in range(64):
        todo = np.flatnonzero((hi - lo) * length > _BRACKET * margin)
        if len(todo) == 0:
            break
        mid = 0.5 * (lo[todo] + hi[todo])
        st = _structures_at(dec, a[todo] + mid[:, None] * d[todo])
        evaluated += len(todo)
        same = np.array([s == s_lo[i] for i, s in zip(todo.tolist(), st, strict=True)], bool)
        lo[todo[same]] = mid[same]
        hi[todo[~same]] = mid[~same]
    return 0.5 * (lo + hi), evaluated


def _names(pairs: Any) -> Any:
    return [list(x) for x in pairs] if isinstance(pairs, list) else pairs


def scan(dec: Any, lines: int, seed: int = 0,
         points_per_diameter: int = SCAN_POINTS_PER_DIAMETER) -> tuple[int, tuple[dict, ...]]:
    """Scan ``lines`` random lines of the map (seeded) with points every
    ``diameter / points_per_diameter``: see :func:`scan_segments`."""
    if lines <= 0:
        return 0, ()
    spacing = dec.env.diameter / points_per_diameter
    segs = free_pieces(dec.env, random_chords(dec.env, lines, seed), 20 * dec.curve_tol)
    return scan_segments(dec, segs, spacing)


__all__ = ["free_pieces", "random_chords", "scan", "scan_segments"]
