"""Structures: the labelled free-arc structure of a point or a region, as frozensets (``"FULL"``,
``"EMPTY"`` or the set of its cells' ``(start_code, end_code)`` feature-code pairs), as integer
ids (:class:`Structures`, shared by the points or regions having them) and as integer rows
(:class:`StructureRows`, compared exactly and vectorized); their cells' feature names and
codes."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from tether._util.arrays import ragged_arange, row_ids
from tether._util.vocabulary import Vocabulary
from tether.arcs import ArcTable, feature_name, free_arcs_many, near_edge_lines
from tether.decomposition.faces import face_points
from tether.environment import Environment

__all__ = ["FREE", "FaceArcs", "Structure", "StructureRows", "Structures", "crossing_points",
           "face_arcs", "feature_name_rank", "feature_names", "join_rows", "rows_equal",
           "set_rows", "structure_codes", "structure_ids", "structure_ids_of",
           "structure_names", "structures", "structures_across", "table_rows"]


class Structure(Vocabulary):
    """The two structures that are not sets of cells: every orientation free (one cell, its
    ends :data:`FREE`) or none. A structure is one of these or a frozenset of the cells'
    ``(start_code, end_code)`` pairs; the values are the strings the output prints (plain
    ``"FULL"`` / ``"EMPTY"`` compare equal)."""

    FULL = "FULL"
    EMPTY = "EMPTY"


FREE = "*"  # feature name of both ends of the single cell of a FULL region


def structures(env: Environment, table: ArcTable, npts: int) -> list[Structure]:
    """Structure key of each point of an :class:`ArcTable`: a frozenset of
    ``(start_code, end_code)`` pairs, or ``"FULL"`` / ``"EMPTY"``. Points with equal
    structures share one object."""
    ids, table_ = structure_ids(env, table, npts)
    uniq, inv = np.unique(ids, return_inverse=True)  # each distinct structure made once
    made = [table_.structure(i) for i in uniq.tolist()]
    return [made[j] for j in inv.ravel().tolist()]


def structure_ids(env: Environment, table: ArcTable, npts: int
                  ) -> tuple[np.ndarray, Structures]:
    """An integer id per point of an :class:`ArcTable`, equal for equal structures (and only
    for them), and the structures of the ids as integer rows (:class:`Structures`: no
    frozenset is made here)."""
    return structure_ids_of(env.n, table.full, table.point, table.start_code, table.end_code,
                            npts)


def structure_ids_of(nvertices: int, full: np.ndarray, point: np.ndarray,
                     start_code: np.ndarray, end_code: np.ndarray, npts: int
                     ) -> tuple[np.ndarray, Structures]:
    """:func:`structure_ids` from an :class:`ArcTable`'s columns ``full``, ``point``,
    ``start_code``, ``end_code`` (a map of ``nvertices`` vertices): the arcs' angles are not
    needed (the tiles' face tasks send these columns only)."""
    ids = np.zeros(npts, dtype=np.int64)  # id 0: EMPTY
    ids[np.asarray(full, dtype=bool)] = 1
    base = 2 * nvertices + 1
    if len(point) == 0:
        return ids, Structures(base, np.zeros(3, np.int64), np.zeros(0, np.int64))
    table = _Codes(point, start_code, end_code)
    pair = table.start_code.astype(np.int64) * base + table.end_code
    # np.lexsort((pair, point)) on one exact integer key (pair < base**2), several times faster
    if (npts + 1) * base * base < 2**62:
        order = np.argsort(table.point.astype(np.int64) * (base * base) + pair, kind="stable")
    else:  # the key would overflow
        order = np.lexsort((pair, table.point))
    point, pair = table.point[order], pair[order]
    new = np.r_[True, (point[1:] != point[:-1]) | (pair[1:] != pair[:-1])]
    if not new.all():  # a set holds each pair once
        point, pair = point[new], pair[new]
    counts = np.bincount(point, minlength=npts)
    first = np.cumsum(counts) - counts
    rows = np.flatnonzero(counts)
    got = _ragged_row_ids(pair, first[rows], counts[rows])
    if got is None:  # two distinct rows of one hash: the rows padded into a grid, sorted
        got = _grid_row_ids(pair, first[rows], counts[rows])
    inv, first_row = got
    ids[rows] = inv + 2
    vals = pair[ragged_arange(first[rows][first_row], counts[rows][first_row])]
    valid = vals >= 0  # as the grid's rows: each row's pairs (sorted), then -1 padding
    size = np.bincount(np.repeat(np.arange(len(first_row)), counts[rows][first_row])[valid],
                       minlength=len(first_row))
    ptr = np.r_[0, 0, 0, np.cumsum(size)]  # ids 0 and 1 have no pairs
    return ids, Structures(base, ptr, vals[valid])


def _row_hashes(pair: np.ndarray, start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The 64-bit hash :func:`tether._util.arrays.row_ids` gives each row of the grid
    (:func:`_grid`), made one column at a time from the ragged rows."""
    h = np.zeros(len(start), np.uint64)
    last = np.maximum(length - 1, 0)
    with np.errstate(over="ignore"):
        for j in range(int(length.max())):
            col = np.where(length > j, pair[start + np.minimum(j, last)], -1)
            h = (h ^ col.astype(np.int64).view(np.uint64)) * np.uint64(0x9E3779B97F4A7C15)
            h ^= h >> np.uint64(29)
    return h


def _grid(pair: np.ndarray, start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The ragged rows ``pair[start[i]:start[i] + length[i]]`` padded with -1 into a grid
    (one row each, as wide as the longest)."""
    grid = np.full((len(start), int(length.max())), -1, dtype=np.int64)
    row = np.repeat(np.arange(len(start)), length)
    grid[row, ragged_arange(np.zeros(len(start), np.int64), length)] = \
        pair[ragged_arange(start, length)]
    return grid


def _grid_row_ids(pair: np.ndarray, start: np.ndarray, length: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`tether._util.arrays.row_ids` of the ragged rows padded into a grid
    (:func:`_grid`): the ids and each id's first row."""
    return row_ids(_grid(pair, start, length))


def _ragged_row_ids(pair: np.ndarray, start: np.ndarray, length: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`_grid_row_ids` without the grid (its memory: rows times the longest row, ~1 GB
    at 4,000 map vertices): the same 64-bit hash of each padded row, made column by column,
    the same stable sort on it; the rows of equal hash compared as ragged rows. None if two
    distinct rows share a hash (the grid's exact sort decides then)."""
    n = len(start)
    h = _row_hashes(pair, start, length)
    order = np.argsort(h, kind="stable")
    sh = h[order]
    new = np.r_[True, sh[1:] != sh[:-1]]
    same = np.flatnonzero(~new[1:])  # sorted rows k and k + 1 of one hash: equal rows?
    a, b = order[same], order[same + 1]
    if np.any(length[a] != length[b]):
        return None
    c = length[a]
    if np.any(pair[ragged_arange(start[a], c)] != pair[ragged_arange(start[b], c)]):
        return None
    ids = np.empty(n, np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


@dataclass(frozen=True)
class _Codes:
    """An arc table's point and feature code columns."""

    point: np.ndarray
    start_code: np.ndarray
    end_code: np.ndarray


@dataclass(frozen=True)
class FaceArcs:
    """The faces' points and free arcs (:func:`face_arcs`): a point well inside each face and
    its clearance (map units), the faces in the free space (``keep``, increasing) and which
    of them are resolved (clear of their boundary by ``2 tol``), and the free arcs' columns
    of the resolved ones (``keep[resolved]``, in that order): ``full``, ``point``,
    ``start_code``, ``end_code`` (:class:`tether.arcs.ArcTable`)."""

    pts: np.ndarray
    clear: np.ndarray
    keep: np.ndarray
    resolved: np.ndarray
    full: np.ndarray
    point: np.ndarray
    start_code: np.ndarray
    end_code: np.ndarray


def face_arcs(env: Environment, faces: np.ndarray, tol: float, grid: float, lss: float
              ) -> FaceArcs:
    """The free arcs of the faces ``faces`` (polygons, internal frame): each face's point
    (:func:`tether.decomposition.faces.face_points`), whether it is in the free space, and
    the free arcs at the points of those resolved, face by face (the same for a face
    wherever the other faces are: the tiles' face tasks compute them for their faces).
    ``tol``: the curve tolerance, ``grid``: the noding's snap grid (map units)."""
    pts, clear = face_points(faces, tol, grid)
    inside = np.asarray(env.contains(pts[:, 0], pts[:, 1]), dtype=bool)
    # and not on a wall: walls are arrangement parts (moved at most 0.71 grid by snapping),
    # so a point farther than tol + grid from its face's boundary is off every wall
    near = np.flatnonzero(inside & (clear < tol + grid))
    inside[near] = np.asarray(env.boundary_distance(pts[near, 0], pts[near, 1]) > 0)
    # a face belongs to the free space iff its interior point does (faces inside holes, or
    # between an overshooting curve end and an obstacle, are dropped)
    keep = np.flatnonzero(inside)
    resolved = clear[keep] >= 2 * tol
    ok = keep[resolved]
    _off_edge_lines(env, pts, ok, lss)
    table = free_arcs_many(env, np.take(pts, ok, axis=0), lss, check=False)
    return FaceArcs(pts, clear, keep, resolved, np.asarray(table.full, dtype=bool),
                    table.point, table.start_code, table.end_code)


#: Directions in which a face's point is moved off an edge's supporting line (tried in
#: turn; neither along the lattice's axes nor its diagonals), and by how many length
#: tolerances: far past the band where the edge is skipped, far inside a resolved face.
_OFF_LINE_STEPS = ((0.6, 0.8), (0.8, -0.6), (-0.28, 0.96), (0.96, 0.28))


_OFF_LINE_TOLS = 64.0


def _off_edge_lines(env: Environment, pts: np.ndarray, rows: np.ndarray, lss: float) -> None:
    """Move the points ``pts[rows]`` (faces' points, each at least ``2 tol`` inside its face)
    that lie within ``length_tol`` of an edge's supporting line, on its free side
    (:func:`tether.arcs.near_edge_lines`), by ``_OFF_LINE_TOLS`` length tolerances: a face's
    structure is read at its point alone, and on such a line the free arcs can show a sliver
    arc that neither side of the line has (a symmetric face whose axis carries a wall)."""
    todo = rows
    for step in _OFF_LINE_STEPS:
        todo = todo[near_edge_lines(env, np.take(pts, todo, axis=0), lss)]
        if len(todo) == 0:
            return
        pts[todo] += _OFF_LINE_TOLS * env.length_tol * np.asarray(step)


class Structures:
    """Distinct structures as integer rows, shared by the points (or regions) having them:
    id 0 is ``"EMPTY"``, id 1 ``"FULL"``, id ``i >= 2`` the set of ``(start_code,
    end_code)`` pairs (internal codes) encoded ``start_code * base + end_code``, sorted, in
    ``pairs[ptr[i]:ptr[i + 1]]``. ``region`` (when the regions hold it): the id of each
    region's structure. The frozenset of an id is made on its first read and kept, in the
    file's codes once :meth:`to_file` is called (the rows stay internal)."""

    __slots__ = ("base", "ptr", "pairs", "region", "_code_map", "_sets")

    def __init__(self, base: int, ptr: np.ndarray, pairs: np.ndarray,
                 region: np.ndarray | None = None) -> None:
        self.base = base
        self.ptr = ptr
        self.pairs = pairs
        self.region = region
        self._code_map: np.ndarray | None = None
        self._sets: dict[int, Structure] = {}

    def __len__(self) -> int:
        return len(self.ptr) - 1

    def __getstate__(self) -> tuple:
        return self.base, self.ptr, self.pairs, self.region, self._code_map, self._sets

    def __setstate__(self, state: tuple) -> None:
        self.base, self.ptr, self.pairs, self.region, self._code_map, self._sets = state

    def structure(self, i: int) -> Structure:
        """The structure of id ``i`` (``"EMPTY"``, ``"FULL"`` or a frozenset, one object
        per id)."""
        if i < 2:
            return Structure.FULL if i == 1 else Structure.EMPTY
        got = self._sets.get(i)
        if got is None:
            a, b = np.divmod(self.pairs[self.ptr[i]:self.ptr[i + 1]], self.base)
            if self._code_map is not None:
                a, b = self._code_map[a], self._code_map[b]
            got = self._sets[i] = frozenset(zip(a.tolist(), b.tolist(), strict=True))
        return got

    def of_region(self, rid: int) -> Structure:
        """The structure of region ``rid``."""
        return self.structure(int(self.region[rid]))

    def rows(self) -> StructureRows:
        """Every id's structure as :class:`StructureRows` (internal codes)."""
        kind = np.minimum(np.arange(len(self), dtype=np.int64), 2)
        return StructureRows(kind, self.ptr, self.pairs)

    def to_file(self, code_map: np.ndarray) -> None:
        """Make the structures in the file's feature codes from now on (``code_map``:
        internal code -> the file's; any made before are dropped, to be made again)."""
        self._code_map = np.asarray(code_map, dtype=np.int64)
        self._sets = {}


def structure_names(env: Environment, s: Structure) -> list[tuple[str, str]]:
    """The cells' ``(start_feature, end_feature)`` names of a structure, sorted."""
    if s == Structure.FULL:
        return [(FREE, FREE)]
    if s == Structure.EMPTY:
        return []
    memo = env.memo.setdefault("structure_names", {})  # many regions share structures
    got = memo.get(s)
    if got is None:
        names = feature_names(env)
        got = memo[s] = sorted((names[a], names[b]) for a, b in s)
    return list(got)


def structure_codes(env: Environment, s: Structure) -> np.ndarray:
    """The cells' ``(start, end)`` feature codes of a structure as a ``(k, 2)`` int array, in
    the order of :func:`structure_names` (by name); a FULL structure's cell is ``(-1, -1)``."""
    if s == Structure.FULL:
        return np.full((1, 2), -1, dtype=np.int64)
    if s == Structure.EMPTY:
        return np.zeros((0, 2), dtype=np.int64)
    memo = env.memo.setdefault("structure_codes", {})
    got = memo.get(s)
    if got is None:
        names = feature_names(env)
        pairs = sorted(s, key=lambda p: (names[p[0]], names[p[1]]))
        got = memo[s] = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    return got


def feature_names(env: Environment) -> list[str]:
    """Every feature code's name (``feature_name``), computed once per map."""
    got = env.memo.get("feature_names")
    if got is None:
        got = env.memo["feature_names"] = [feature_name(env, c) for c in range(2 * env.n)]
    return got


def feature_name_rank(env: Environment) -> np.ndarray:
    """``rank[code + 1]``: the position of feature ``code``'s name (``FREE`` for -1) among all
    of them sorted as strings, cached per map."""
    got = env.memo.get("feature_name_rank")
    if got is None:
        names = [FREE] + feature_names(env)
        got = np.empty(len(names), dtype=np.int64)
        got[sorted(range(len(names)), key=names.__getitem__)] = np.arange(len(names))
        env.memo["feature_name_rank"] = got
    return got


@dataclass
class StructureRows:
    """Structures as integer rows (CSR), compared exactly and vectorized
    (:func:`rows_equal`) instead of as frozensets: structure ``i`` is ``kind[i]`` (0:
    ``"EMPTY"``, 1: ``"FULL"``, 2: a set of ``(start_code, end_code)`` pairs), the set's
    pairs encoded ``start_code * base + end_code``, sorted and distinct, in
    ``pairs[ptr[i]:ptr[i + 1]]``."""

    kind: np.ndarray
    ptr: np.ndarray
    pairs: np.ndarray


def table_rows(env: Environment, table: ArcTable, npts: int) -> StructureRows:
    """The structure of each point of an :class:`ArcTable` as integer rows (the structures of
    :func:`structures`, without building a frozenset per point)."""
    base = 2 * env.n + 1
    point = table.point.astype(np.int64)
    pair = table.start_code.astype(np.int64) * base + table.end_code
    if len(point) and (npts + 1) * base * base < 2**62:  # one exact integer key
        order = np.argsort(point * (base * base) + pair, kind="stable")
    else:
        order = np.lexsort((pair, point))
    point, pair = point[order], pair[order]
    new = np.r_[True, (point[1:] != point[:-1]) | (pair[1:] != pair[:-1])] if len(point) \
        else np.zeros(0, bool)
    point, pair = point[new], pair[new]
    size = np.bincount(point, minlength=npts)
    kind = np.where(size > 0, 2, np.asarray(table.full, dtype=bool).astype(np.int64))
    return StructureRows(kind, np.r_[0, np.cumsum(size)], pair)


def set_rows(structs: list[Structure], base: int) -> tuple[StructureRows, np.ndarray]:
    """The distinct structure objects of ``structs`` as integer rows (pairs encoded with
    ``base``, see :class:`StructureRows`) and the row of each item. Equal structures are
    mostly one shared object: each distinct object is read once."""
    if not structs:
        return StructureRows(np.zeros(0, np.int64), np.zeros(1, np.int64),
                             np.zeros(0, np.int64)), np.zeros(0, np.int64)
    obj = np.fromiter(map(id, structs), np.int64, len(structs))
    _, first, inv = np.unique(obj, return_index=True, return_inverse=True)
    objs = [structs[i] for i in first.tolist()]
    full, empty = Structure.FULL, Structure.EMPTY
    kind = np.fromiter((0 if s == empty else 1 if s == full else 2 for s in objs),
                       np.int64, len(objs))
    sets = [s if k == 2 else () for s, k in zip(objs, kind.tolist(), strict=True)]
    size = np.fromiter(map(len, sets), np.int64, len(sets))
    flat = np.fromiter(itertools.chain.from_iterable(itertools.chain.from_iterable(sets)),
                       np.int64, 2 * int(size.sum()))
    code = flat[0::2] * base + flat[1::2]
    row = np.repeat(np.arange(len(objs)), size)
    code = code[np.lexsort((code, row))]  # frozensets hold distinct pairs
    return StructureRows(kind, np.r_[0, np.cumsum(size)], code), inv.ravel()


def rows_equal(a: StructureRows, i: np.ndarray, b: StructureRows, j: np.ndarray
               ) -> np.ndarray:
    """Whether structure ``i[k]`` of ``a`` equals structure ``j[k]`` of ``b``, for every ``k``
    (exact: same kind, same pairs)."""
    na, nb = a.ptr[i + 1] - a.ptr[i], b.ptr[j + 1] - b.ptr[j]
    eq = (a.kind[i] == b.kind[j]) & (na == nb)
    k = np.flatnonzero(eq & (na > 0))
    c = na[k]
    diff = a.pairs[ragged_arange(a.ptr[i[k]], c)] != b.pairs[ragged_arange(b.ptr[j[k]], c)]
    bad = np.bincount(np.repeat(np.arange(len(k)), c)[diff], minlength=len(k)) > 0
    eq[k[bad]] = False
    return eq


def join_rows(parts: list[StructureRows]) -> StructureRows:
    """The structure rows of consecutive batches of points as one (see :func:`join_tables`)."""
    if len(parts) == 1:
        return parts[0]
    ends = np.cumsum([int(r.ptr[-1]) for r in parts])
    ptr = np.concatenate([[0]] + [r.ptr[1:] + (ends[i - 1] if i else 0)
                                  for i, r in enumerate(parts)])
    return StructureRows(np.concatenate([r.kind for r in parts]), ptr,
                         np.concatenate([r.pairs for r in parts]))


def crossing_points(q: np.ndarray, n: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Both sides of crossings: rows ``0..k-1`` are ``q + eps n``, rows ``k..2k-1`` are
    ``q - eps n`` (``q``, ``n`` of shape (k, 2), ``eps`` of shape (k,))."""
    e = np.asarray(eps, dtype=float)[:, None]
    return np.vstack((q + e * n, q - e * n))


def structures_across(env: Environment, lss: float, q: np.ndarray, n: np.ndarray,
                      eps: np.ndarray) -> tuple[list[Structure], list[Structure]]:
    """Exact structures on the ``+n`` and ``-n`` sides of crossings at ``q``."""
    pts = crossing_points(q, n, eps)
    st = structures(env, free_arcs_many(env, pts, lss, check=False), len(pts))
    return st[: len(q)], st[len(q):]
