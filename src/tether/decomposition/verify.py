"""Verification of a decomposition against the exact free arcs: random points in the regions,
both sides of every piece's crossing, and random lines scanned (:mod:`tether.decomposition.scan`);
:func:`self_check` is the cheap one the analysis runs by default."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from tether.arcs import free_arcs_many
from tether.decomposition.model import Decomposition, shared_holder
from tether.decomposition.scan import scan
from tether.decomposition.structure import structure_names, structures, structures_across
from tether.decomposition.views import Piece, Pieces, Shapes
from tether.tolerances import CHECK_LINES, SELF_CHECK_LINES

__all__ = ["SELF_CHECK_REGIONS", "UNRESOLVED_MAX_ROOT", "UNRESOLVED_MAX_TOLS", "CheckReport",
           "check", "sample_in_regions", "self_check"]


#: A boundary stretch between two regions that has no crossing sample (no point clear of the
#: other curves by 4 tolerances, :func:`.pieces.crossing_candidates`) is below resolution where two
#: curves run within a few tolerances of each other: near a tangency, or where two curves
#: cross at a shallow angle (a lens thinner than the resolution). Curves of radius about
#: ``lss`` stay that close over about ``sqrt(32 lss tol)``; the longest such stretches
#: measured on 80 random maps and floor plans were ``5.3 sqrt(lss tol)``. A stretch longer
#: than ``UNRESOLVED_MAX_ROOT * sqrt(lss tol)`` (and ``UNRESOLVED_MAX_TOLS`` tolerances) is
#: two curves nearly coincident along a whole boundary (lss within the resolution of a
#: critical length): G would miss the crossings over it, and the self-check fails.
UNRESOLVED_MAX_ROOT = 30.0


UNRESOLVED_MAX_TOLS = 8.0


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check`: sampled points whose exact structure disagrees with their
    region's, and pieces whose two sides do not show the two regions' structures."""

    samples: int
    point_disagreements: tuple[dict, ...]
    piece_disagreements: tuple[dict, ...]
    #: random lines scanned (:mod:`tether.decomposition.scan`), points evaluated along them, and the
    #: disagreements found there (kinds ``point``, ``change``, ``boundary``, ``uncovered``)
    lines: int = 0
    line_points: int = 0
    line_disagreements: tuple[dict, ...] = ()

    @property
    def ok(self) -> bool:
        """Whether no disagreement was found."""
        return not (self.point_disagreements or self.piece_disagreements
                    or self.line_disagreements)

    def to_dict(self) -> dict:
        """The report as JSON-ready values."""
        return {"ok": self.ok, "samples": self.samples,
                "point_disagreements": list(self.point_disagreements),
                "piece_disagreements": list(self.piece_disagreements),
                "lines": self.lines, "line_points": self.line_points,
                "line_disagreements": list(self.line_disagreements)}


def sample_in_regions(dec: Decomposition, per_region: int, seed: int = 0,
                      margin: float | None = None, regions: Any = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Random points inside each region (or each of the region indices ``regions``), farther
    than ``margin`` (default ``10 * curve_tol``) from its boundary. Returns (points, region
    index of each).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.decomposition import decompose, sample_in_regions
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> dec = decompose(room, 1.0)
    >>> points, owner = sample_in_regions(dec, 3)
    >>> points.shape, bool((dec.region_at(points) == owner).all())
    ((57, 2), True)
    """
    rng = np.random.default_rng(seed)
    margin = 10 * dec.curve_tol if margin is None else margin
    pts, owner = [], []
    chosen = dec.regions if regions is None else [dec.regions[int(i)] for i in regions]
    for r, poly in zip(chosen, _polygons(chosen), strict=True):
        inner = poly.buffer(-margin)
        if inner.is_empty:
            continue
        x0, y0, x1, y1 = inner.bounds
        got = np.zeros((0, 2))
        for _ in range(50):
            cand = rng.uniform([x0, y0], [x1, y1], size=(4 * per_region, 2))
            cand = cand[shapely.contains_xy(inner, cand[:, 0], cand[:, 1])]
            got = np.vstack((got, cand))
            if len(got) >= per_region:
                break
        got = got[:per_region]
        pts.append(got)
        owner.append(np.full(len(got), r.id))
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    return np.vstack(pts), np.concatenate(owner)


def _polygons(regions: Any) -> list:
    """The polygons of some regions of a decomposition: of a few regions whose polygons are
    not converted to the map's frame yet, only theirs converted (the self-check reads 200 of
    100k), else read as usual (all converted at once on the first read)."""
    shapes = shared_holder(regions, "_polygon")
    if not isinstance(shapes, Shapes) or shapes.converted or 4 * len(regions) > len(shapes):
        return [r.polygon for r in regions]
    return shapes.some([r.id for r in regions]).tolist()


def check(dec: Decomposition, per_region: int = 20, seed: int = 0, lines: int = CHECK_LINES
          ) -> CheckReport:
    """Verify a decomposition by sampling: every sampled point's exact structure must equal its
    region's, across every piece the two sides must show the two regions' structures, and
    along ``lines`` random lines (:func:`tether.decomposition.scan.scan`) every change of the exact
    structure must be a region boundary and nothing else.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.decomposition import check, decompose
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> report = check(decompose(room, 1.0), per_region=2, lines=2)
    >>> report.ok, report.samples
    (True, 38)
    """
    pts, owner = sample_in_regions(dec, per_region, seed)
    npts, bad_lines = scan(dec, lines, seed)
    return CheckReport(len(pts), _point_disagreements(dec, pts, owner),
                       _piece_disagreements(dec) + _unresolved_disagreement(dec), lines, npts,
                       bad_lines)


def _unresolved_disagreement(dec: Decomposition) -> tuple[dict, ...]:
    """The longest region boundary left without a piece, if longer than the resolution
    (``UNRESOLVED_MAX_ROOT``): G would miss the crossings over it."""
    longest = dec.unresolved_longest
    limit = max(UNRESOLVED_MAX_TOLS * dec.curve_tol,
                UNRESOLVED_MAX_ROOT * math.sqrt(dec.lss * dec.curve_tol))
    if longest is None or longest["length"] <= limit:
        return ()
    return ({"piece": "unresolved", "regions": longest["regions"],
             "point": list(longest["point"]), "length": longest["length"]},)


#: Regions sampled by :func:`self_check` (one point each, chosen at random).
SELF_CHECK_REGIONS = 200


def self_check(dec: Decomposition, regions: int = SELF_CHECK_REGIONS, seed: int = 0,
               lines: int | None = None) -> CheckReport:
    """The cheap check :func:`tether.analysis.analyze` runs by default: one random point in
    each of up to ``regions`` random regions against its region's structure, every piece's
    crossing as verified when the decomposition was built (no recomputation), and a scan of
    ``lines`` random lines (default :data:`tether.tolerances.SELF_CHECK_LINES`; see
    :func:`tether.decomposition.scan.scan`).

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.decomposition import decompose, self_check
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> self_check(decompose(room, 1.0)).ok
    True
    """
    lines = SELF_CHECK_LINES if lines is None else lines
    rng = np.random.default_rng(seed)
    chosen = np.arange(len(dec.regions))
    if len(chosen) > regions:
        chosen = np.sort(rng.choice(chosen, regions, replace=False))
    pts, owner = sample_in_regions(dec, 1, seed, regions=chosen)
    bad_pieces = tuple({"piece": p.name, "regions": [f"R{r}" for r in p.regions],
                        "point": list(p.sample)} for p in _unverified(dec.pieces))
    bad_pieces += _unresolved_disagreement(dec)
    npts, bad_lines = scan(dec, lines, seed)
    return CheckReport(len(pts), _point_disagreements(dec, pts, owner), bad_pieces, lines,
                       npts, bad_lines)


def _unverified(pieces: Sequence[Piece]) -> list[Piece]:
    """The pieces not verified when the decomposition was built (read from the columns: only
    those made)."""
    if type(pieces) is Pieces:
        t = pieces._table
        return [t.piece(i) for i in np.flatnonzero(~t.ok).tolist()]
    return [p for p in pieces if not p.verified]


def _point_disagreements(dec: Decomposition, pts: np.ndarray, owner: np.ndarray
                         ) -> tuple[dict, ...]:
    """Sampled points whose exact structure differs from their region's."""
    env = dec.env
    bad_pts = []
    if len(pts):
        st = structures(env, free_arcs_many(env, pts, dec.lss, check=False), len(pts))
        for p, r, s in zip(pts, owner, st, strict=True):
            if s != dec.regions[r].structure:
                bad_pts.append({"region": f"R{r}", "point": [float(p[0]), float(p[1])],
                                "found": [list(x) for x in structure_names(env, s)],
                                "expected": list(dec.regions[r].cells)})
    return tuple(bad_pts)


def _piece_disagreements(dec: Decomposition) -> tuple[dict, ...]:
    """Pieces whose two crossing sides do not show their two regions' structures (exact)."""
    env = dec.env
    bad_pieces = []
    if dec.pieces:
        plus, minus = structures_across(env, dec.lss, *dec.piece_crossings())
        for i, p in enumerate(dec.pieces):
            ra, rb = (dec.regions[r] for r in p.regions)
            if plus[i] != ra.structure or minus[i] != rb.structure:
                bad_pieces.append({"piece": p.name, "regions": [ra.name, rb.name],
                                   "point": list(p.sample)})
    return tuple(bad_pieces)
