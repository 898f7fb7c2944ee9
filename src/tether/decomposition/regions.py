"""Regions from the arrangement's faces: faces adjacent across a part with equal structures
merged, faces below the resolution (and speck regions no boundary of which can be crossed)
absorbed by a neighbour, the regions numbered by representative point, and the
:class:`~tether.decomposition.model.Region` records and cells made."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import shapely

from tether._util.arrays import components, first_max_per_group, ragged_arange
from tether.arcs import feature_name
from tether.decomposition.arrangement import Arrangement, Chains
from tether.decomposition.frame import UserFrame
from tether.decomposition.model import Region, Regions, RegionTable
from tether.decomposition.pieces import (
    Candidates,
    crossing_candidates,
    make_chains,
    part_candidates,
)
from tether.decomposition.structure import FREE, Structures, feature_name_rank, feature_names
from tether.decomposition.views import (
    Cells,
    CellTable,
    PackedFaces,
    RegionShapes,
    cell_types,
    packed_geometries,
)
from tether.environment import Environment

__all__ = ["face_regions", "make_regions"]


def face_regions(arr: Arrangement, keep: np.ndarray, resolved: np.ndarray,
                 face_sid: np.ndarray, pts: np.ndarray, clear: np.ndarray, tol: float,
                 lss: float, report: Callable[[str, float], Any] | None = None
                 ) -> tuple[dict[str, Any], Chains, Candidates]:
    """The faces ``keep`` (in the free space; ``resolved`` flags those with a structure, of
    structure ids ``face_sid`` per face, -1: none; points ``pts`` and clearances ``clear``)
    grouped into numbered regions, with the chains between regions and their crossing
    candidates. Sub-resolution faces, then speck regions no chain of which has a candidate,
    join neighbours (``face_sid`` is updated: the structure taken). ``report``, if given,
    gets ``("chains", 0.75)`` once the regions are numbered, before the chains are made."""
    nf = len(arr.faces)
    kept = np.zeros(nf, bool)
    kept[keep] = True
    pa, pb = arr.part_faces[:, 0], arr.part_faces[:, 1]
    adj = np.flatnonzero((pa >= 0) & (pb >= 0) & (pa != pb) & kept[np.maximum(pa, 0)]
                         & kept[np.maximum(pb, 0)])
    adjacent = np.column_stack((pa[adj], pb[adj], adj))  # (face, face, part) rows
    # faces adjacent across a part with equal structures are one region (components)
    same = (face_sid[adjacent[:, 0]] >= 0) & (face_sid[adjacent[:, 0]]
                                              == face_sid[adjacent[:, 1]])
    uf = _UnionFind(nf)
    uf.parent = components(nf, adjacent[same, 0], adjacent[same, 1]).tolist()
    plen = arr.part_lengths()
    # sub-resolution faces join the neighbour they share most boundary with
    _absorb(keep[~resolved], adjacent, plen, uf, face_sid)
    for attempt in range(4):
        flat, size = _groups(uf, keep, face_sid)
        numbering = _number_regions(arr, flat, size, pts, clear)
        face_region = numbering["face_region"]
        # a region none of whose boundary is resolved (a speck at a tangency) would never
        # be crossed and its cells never eliminated: it is below resolution as a whole
        isolated = _isolated_regions(arr, face_region, len(size), tol, lss) \
            if len(size) > 1 and attempt < 3 else set()
        if not isolated:  # these are the regions
            break
        specks: dict[int, list[int]] = {}
        faces_in = np.flatnonzero(np.isin(face_region, list(isolated)))
        faces_in = faces_in[np.argsort(face_region[faces_in], kind="stable")]
        for f, r in zip(faces_in.tolist(), face_region[faces_in].tolist(), strict=True):
            specks.setdefault(r, []).append(f)
        face_sid[faces_in] = -1
        _absorb_groups(list(specks.values()), adjacent, plen, uf, face_sid)
    numbering["flat"], numbering["size"] = flat, size  # the last numbering's: the regions'
    if report is not None:
        report("chains", 0.75)
    chains = make_chains(arr, face_region)
    return numbering, chains, crossing_candidates(arr, chains, tol, lss)


def _isolated_regions(arr: Arrangement, face_region: np.ndarray, nreg: int, tol: float,
                      lss: float) -> set[int]:
    """The regions (of ``face_region``, ``nreg`` of them) no chain of which would have a
    crossing candidate (see :func:`crossing_candidates`): none of the parts between the
    region and another has a candidate point clear of the other parts by ``4 tol``. The
    parts' candidates only: no chains."""
    fr = np.append(face_region, -1)  # index -1 (no face) maps to the last slot, -1
    ra, rb = fr[arr.part_faces[:, 0]], fr[arr.part_faces[:, 1]]
    between = (ra >= 0) & (rb >= 0) & (ra != rb)
    _, mine, clear = part_candidates(arr, between, tol, lss)
    good = mine[clear >= 4 * tol]
    touched = np.zeros(nreg, bool)
    touched[ra[good]] = True
    touched[rb[good]] = True
    return set(np.flatnonzero(~touched).tolist())


class _UnionFind:
    def __init__(self, n: int) -> None:
        self.parent = list(range(n))

    def find(self, a: int) -> int:
        p = self.parent
        while p[a] != a:
            p[a] = p[p[a]]
            a = p[a]
        return a

    def union(self, a: int, b: int) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


def _absorb(pending: np.ndarray, adjacent: np.ndarray, plen: np.ndarray, uf: _UnionFind,
            face_sid: np.ndarray) -> None:
    """Merge each pending face (no structure of its own) into the resolved neighbour face it
    shares the longest arrangement part with (the first such pair in ``adjacent`` order among
    equals), taking that neighbour's structure id (``face_sid``, -1: none); repeated while
    faces are taken (vectorized)."""
    nf = len(uf.parent)
    todo = np.zeros(nf, bool)
    todo[np.asarray(pending, dtype=np.int64)] = True
    has = face_sid >= 0
    # both directions of every pair, in the order a loop over the pairs would meet them
    f = adjacent[:, :2].ravel()
    g = adjacent[:, 1::-1].ravel()
    length = plen[np.repeat(adjacent[:, 2], 2)]
    for _ in range(16):
        if not todo.any():
            return
        rows = np.flatnonzero(todo[f] & ~todo[g] & has[g])
        if len(rows) == 0:
            return
        rows = rows[np.lexsort((rows, -length[rows], f[rows]))]
        rows = rows[np.r_[True, f[rows][1:] != f[rows][:-1]]]
        for a, b in zip(f[rows].tolist(), g[rows].tolist(), strict=True):
            uf.union(a, b)
        face_sid[f[rows]] = face_sid[g[rows]]  # the g are not pending: set before this round
        todo[f[rows]] = False
        has[f[rows]] = True


def _roots(uf: _UnionFind) -> np.ndarray:
    """The union-find root of every element (pointer jumping, vectorized)."""
    par = np.asarray(uf.parent, dtype=np.int64)
    while True:
        nxt = par[par]
        if np.array_equal(nxt, par):
            return par
        par = nxt


def _absorb_groups(pending: list[list[int]], adjacent: np.ndarray, plen: np.ndarray,
                   uf: _UnionFind, face_sid: np.ndarray) -> None:
    """Merge each pending group of faces (a speck region, its faces already united) as a whole
    into the neighbour region it shares the most arrangement boundary with, taking that
    region's structure id (``face_sid``, -1: none).

    Absorbing the faces one by one, as :func:`_absorb` does for single faces, would let two
    faces of one speck join two different neighbours and so unite those two regions, whatever
    their structures (issue #9: half of R59 of ``tests/data/random_incomplete.json`` showed
    another structure)."""
    todo = {f: i for i, faces in enumerate(pending) for f in faces}
    mark = np.zeros(len(uf.parent), bool)
    mark[list(todo)] = True
    # only the pairs touching a pending face matter (in their order)
    near = adjacent[mark[adjacent[:, 0]] | mark[adjacent[:, 1]]].tolist()
    for _ in range(16):
        if not todo:
            return
        has = face_sid >= 0
        shared: dict[int, dict[int, tuple[float, int]]] = {}
        for a, b, k in near:
            for f, g in ((a, b), (b, a)):
                if f in todo and g not in todo and has[g]:
                    per = shared.setdefault(todo[f], {})
                    root = uf.find(g)
                    total, _ = per.get(root, (0.0, g))
                    per[root] = (total + float(plen[k]), g)
        if not shared:
            return
        for i, per in shared.items():
            _, g = max(per.values())
            for f in pending[i]:
                uf.union(f, g)
                face_sid[f] = face_sid[g]
                del todo[f]


def _groups(uf: _UnionFind, keep: np.ndarray, face_sid: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """The faces of ``keep`` having a structure (``face_sid >= 0``), grouped by union-find
    root: groups in the order of their first face in ``keep``, faces in ``keep`` order within
    a group. Returns the faces group after group and each group's size."""
    par = _roots(uf)  # every face to its root
    fs = keep[face_sid[keep] >= 0]
    _, first, inv = np.unique(par[fs], return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    g = rank[inv.ravel()]
    order = np.argsort(g, kind="stable")
    return fs[order], np.bincount(g, minlength=len(first))


def _number_regions(arr: Arrangement, flat: np.ndarray, size: np.ndarray, pts: np.ndarray,
                    clear: np.ndarray) -> dict[str, Any]:
    """Regions from groups of faces (``flat``: the faces group after group, ``size``: each
    group's count), numbered by representative point (x, then y): the point of the group's
    face farthest from its boundary. Returns the groups' best faces, areas and points, the
    group of each region id (``rank``) and the region of every face (-1: none); the groups'
    faces (``flat`` and ``size``, for the regions made) are added by :func:`face_regions`."""
    face_area = arr.memo.get("face_area")
    if face_area is None:
        face_area = arr.memo["face_area"] = shapely.area(arr.faces)
    group = np.repeat(np.arange(len(size)), size)
    best = flat[_best_per_group(clear[flat], group)]
    # numpy sums 8 or more values pairwise: those few groups are summed as before, bit for bit
    area = np.bincount(group, weights=face_area[flat], minlength=len(size))
    starts = np.cumsum(size) - size
    for g in np.flatnonzero(size >= 8).tolist():
        area[g] = face_area[flat[starts[g]:starts[g] + size[g]]].sum()
    point = np.round(pts[best], 9)
    rank = np.lexsort((point[:, 1], point[:, 0]))  # stable: ties keep the groups' order
    face_region = np.full(len(arr.faces), -1, dtype=np.int64)
    region_of_group = np.empty(len(size), np.int64)
    region_of_group[rank] = np.arange(len(size))
    face_region[flat] = region_of_group[group]
    return {"best": best, "area": area, "point": point, "rank": rank,
            "face_region": face_region}


def _best_per_group(value: np.ndarray, group: np.ndarray) -> np.ndarray:
    """For ``group`` sorted (runs from 0, none empty), the index of each run's first largest
    ``value``: the first row per run of ``np.lexsort((-value, group))`` (no sort unless a
    value is NaN)."""
    if np.isnan(value).any():
        order = np.lexsort((-value, group))
        return order[np.r_[True, group[order][1:] != group[order][:-1]]]
    return first_max_per_group(value, group)


def make_regions(env: Environment, arr: Arrangement, numbering: dict[str, Any],
                 face_sid: np.ndarray, structs: Structures, out: UserFrame | None = None
                 ) -> tuple[list[Region], Cells, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The :class:`Region` objects of a numbering (:func:`_number_regions`): polygon (the
    union of the faces, made on the first read: :class:`RegionShapes`), area, point,
    structure and cells; the cells (a :class:`Cells` over int columns, region by region,
    each region's in the order of :func:`structure_names`); and the cells' ``(region, start
    code, end code)`` columns (:meth:`Decomposition.cell_codes`, the file's codes). The
    structures are ids into one shared :class:`Structures` (``structs``, of the faces'
    ids ``face_sid``; the faces' structures are nearly all some region's), frozensets made
    when read. With
    ``out``, area, point, cell names and polygons are the user's (converted before the
    regions are made, the polygons on their first read); the structure is converted once the
    pieces are made (:meth:`UserFrame.regions`: the pieces compare the structures with
    internal ones)."""
    best, area, point = (numbering[k] for k in ("best", "area", "point"))
    rank = numbering["rank"].tolist()
    polys = _region_shapes(arr, numbering["flat"], numbering["size"], numbering["rank"], out)
    if out is not None:  # all at once, before any region is made
        area = area / (out.scale * out.scale)
        point = out.points(point)
    sid = face_sid[best[numbering["rank"]]]
    structs.region = sid  # region i's structure id
    # the cells' columns made in the table's int types (:func:`cell_types`): no 24 bytes
    # a cell of int64 columns, then copied (~1 GB at 4,000 map vertices)
    names = [FREE] + feature_names(env)
    region_t, code_t = cell_types(len(names), len(rank))
    region, start, end = _structure_cells(env, structs, sid, region_t, code_t)
    if out is not None:  # the file's codes and names
        names = [FREE] + [feature_name(out.env, c) for c in range(2 * out.env.n)]
        code_t = cell_types(len(names), len(rank))[1]
        cm = np.append(np.asarray(out.code_map, dtype=np.int64), -1)  # index -1: stays -1
        cm = cm.astype(code_t)
        start, end = cm[start], cm[end]
    table = CellTable(region, start, end, names, len(rank))
    del region, start, end
    g = numbering["rank"]  # region rid is the group g[rid]: its records made when read
    regions = Regions(RegionTable(area[g], np.asarray(point).reshape(-1, 2)[g], polys,
                                  structs, table))
    return regions, Cells(table), (table.region, table.start, table.end)


def _region_shapes(arr: Arrangement, flat: np.ndarray, size: np.ndarray, rank: np.ndarray,
                   out: UserFrame | None) -> RegionShapes:
    """The regions' polygons (region ``i`` is the group ``rank[i]`` of the faces ``flat``,
    group after group, ``size`` faces each), held packed as WKB (:func:`packed_geometries`,
    made and encoded a batch of faces at a time: no shapely object kept): single faces as
    they are, unions of several made on the first read from their faces
    (:class:`PackedFaces`)."""
    first = (np.cumsum(size) - size)[rank]  # each region's first face, in ``flat``
    count = size[rank]
    faces = arr.faces  # made here from ragged arrays (FaceRings), or an object array

    def make(ids: np.ndarray) -> np.ndarray:
        return faces[ids]

    polys = packed_geometries(make, flat[first])
    multi = np.flatnonzero(count > 1)
    k = count[multi]
    members = packed_geometries(make, flat[ragged_arange(first[multi], k)])
    unions = PackedFaces(multi, np.r_[0, np.cumsum(k)], *members)
    return RegionShapes(None, unions, None if out is None else out.frame, wkb=polys)


def _structure_cells(env: Environment, structs: Structures, sid: np.ndarray,
                     region_t: type = np.int64, code_t: type = np.int64
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cells of regions of structure ids ``sid`` (of ``structs``): ``(region, start code,
    end code)`` int columns (of types ``region_t`` and ``code_t``, which must hold them),
    region by region, each region's cells sorted by (start name, end name) as
    :func:`structure_codes` sorts them (one sort on name ranks over every distinct
    structure; a FULL region's cell is ``(-1, -1)``, an EMPTY one has none)."""
    n = len(sid)
    if n == 0:
        return np.zeros(0, region_t), np.zeros(0, code_t), np.zeros(0, code_t)
    ids, inv = np.unique(sid, return_inverse=True)
    npairs = structs.ptr[ids + 1] - structs.ptr[ids]
    size = npairs + (ids == 1)  # FULL: one cell, no pairs
    starts = np.cumsum(size) - size
    a = np.full(int(size.sum()), -1, dtype=np.int64)
    b = a.copy()
    at = ragged_arange(starts, npairs)
    a[at], b[at] = np.divmod(structs.pairs[ragged_arange(structs.ptr[ids], npairs)],
                             structs.base)
    name_rank = feature_name_rank(env)
    row = np.repeat(np.arange(len(ids)), size)
    ra, rb = name_rank[a + 1], name_rank[b + 1]
    m = len(name_rank)
    if (len(ids) + 1) * m * m < 2**62:  # one exact integer key: ~10 times faster
        order = np.argsort((row * m + ra) * m + rb, kind="stable")
    else:
        order = np.lexsort((rb, ra, row))
    a, b = a[order].astype(code_t), b[order].astype(code_t)
    del order, row, ra, rb
    inv = inv.ravel()
    count, first = size[inv], starts[inv]
    del inv
    # the cells filled a run of regions at a time (about CELL_CHUNK cells): the rows'
    # int64 index and its temporaries bounded (~32 bytes a cell at once, 0.6 GB at
    # 4,000 map vertices), the columns made in their own types
    ends = np.cumsum(count)
    total = int(ends[-1])
    region = np.empty(total, region_t)
    start, end = np.empty(total, code_t), np.empty(total, code_t)
    cuts = np.searchsorted(ends, np.arange(CELL_CHUNK, total, CELL_CHUNK), side="right")
    bounds = np.unique(np.r_[0, cuts, n]).tolist()
    for r0, r1 in zip(bounds[:-1], bounds[1:], strict=True):
        c0, c1 = int(ends[r0] - count[r0]), int(ends[r1 - 1])
        rows = ragged_arange(first[r0:r1], count[r0:r1])
        start[c0:c1], end[c0:c1] = a[rows], b[rows]
        region[c0:c1] = np.repeat(np.arange(r0, r1, dtype=region_t), count[r0:r1])
        del rows
    return region, start, end


#: Cells made per run by :func:`_structure_cells` (about; whole regions): bounds the
#: temporaries of the cells' rows.
CELL_CHUNK = 1 << 20
