"""Reporting in the user's frame: a decomposition computed on :attr:`Environment.internal`
(normalized frame, no straight vertices) converted back to the map's coordinates and feature
names (file numbering). Angles are unchanged by the frame; lengths scale by a power of two."""

from __future__ import annotations

import numpy as np
import shapely

from tether.decomposition import FREE, Cell, Decomposition, Piece, Region
from tether.environment import Environment


def decomposition_to_user(inner: Decomposition, env: Environment, lss: float) -> Decomposition:
    """The decomposition ``inner`` of ``env.internal`` as a decomposition of ``env`` for rod
    length ``lss`` (map units): regions, pieces and curves in map coordinates, features and
    cells named after the file, structures in the file's feature codes."""
    frame = env.frame
    names = env.feature_names_map()
    names[FREE] = FREE
    code_map = env.code_map
    k2 = frame.scale * frame.scale

    # every cell renamed at once (cells are listed region by region, in the regions' order)
    ids = [f"(R{c.region},{names[c.start_feature]},{names[c.end_feature]})"
           for c in inner.cells]
    first = np.concatenate(([0], np.cumsum([len(r.cells) for r in inner.regions]))).tolist()

    structures: dict = {}  # many regions share a structure: remap each once

    def structure(st):
        if isinstance(st, str):
            return st
        got = structures.get(st)
        if got is None:
            got = structures[st] = frozenset((int(code_map[a]), int(code_map[b]))
                                             for a, b in st)
        return got

    # all geometries transformed at once (one vectorized call, not one per region)
    polys = frame.geometry_to_user(np.array([r.polygon for r in inner.regions], dtype=object))
    shapely.prepare(polys)
    pts = frame.to_user(np.array([r.point for r in inner.regions]).reshape(-1, 2)).tolist()
    regions = [Region(r.id, poly, r.area / k2, (pt[0], pt[1]), structure(r.structure),
                      tuple(ids[first[i]:first[i + 1]]))
               for i, (r, poly, pt) in enumerate(zip(inner.regions, polys, pts, strict=True))]
    cells = tuple(Cell(cid, c.region, names[c.start_feature], names[c.end_feature])
                  for cid, c in zip(ids, inner.cells, strict=True))
    lines = frame.geometry_to_user(np.array([p.geometry for p in inner.pieces], dtype=object))
    qs = frame.to_user(np.array([p.sample for p in inner.pieces]).reshape(-1, 2)).tolist()
    pieces = [Piece(p.id, p.regions, p.curves, p.kind,
                    tuple(names.get(f, f) for f in p.features), line, (q[0], q[1]),
                    p.normal, p.eps / frame.scale, p.verified)
              for p, line, q in zip(inner.pieces, lines, qs, strict=True)]
    curves = tuple(c.to_user(frame, names) for c in inner.curves)
    return Decomposition(env, lss, curves, tuple(regions), cells, tuple(pieces),
                         inner.curve_tol / frame.scale, inner.unresolved_pieces)
