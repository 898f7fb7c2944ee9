"""The cell decomposition (``math.md`` §8): regions, cells and boundary pieces, point location.

Regions are the maximal connected open sets of target positions over which the labelled
free-arc structure stays the same. They are computed from the arrangement of the critical
curves, never from a grid: the curves' polylines and the map's rings are noded (shapely) and
the faces of the noded lines traced from their half-edges; each face's structure is evaluated
exactly at a point well inside it; faces adjacent across a curve piece with equal structure
are merged. Sampling is how :func:`check` verifies the result.

Tolerances: curves are drawn within ``curve_tol = REL_CURVE_TOL * diameter`` of their exact
shape. A face whose inscribed circle is smaller than ``2 * curve_tol`` is below that resolution:
it gets no structure of its own and joins the neighbour it shares most boundary with.
A target passing exactly through an arrangement vertex is not modelled (``math.md`` §8).
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.errors import GEOSException

from tether._util.arrays import first_nearest, ragged_arange
from tether._util.memory import gc_paused, release_memory
from tether._util.threads import in_background, map_batches, map_chunks
from tether.arcs import (
    TWO_PI,
    ArcTable,
    check_lss,
    feature_name,
    free_arcs_many,
    join_tables,
    near_edge_lines,
)
from tether.coincidence import merge_collinear, wall_stubs
from tether.curves import Curve, critical_curves, project_many
from tether.environment import Environment
from tether.noding import ArrangementError, geos_message, node_lines
from tether.spatial import SegmentGrid, z_order
from tether.tolerances import CHECK_LINES, REL_CURVE_TOL, SELF_CHECK_LINES

if TYPE_CHECKING:
    from tether.userframe import UserFrame


Structure = Any  # frozenset of (start_code, end_code) pairs, or "FULL" / "EMPTY"
FREE = "*"  # feature name of both ends of the single cell of a FULL region

#: A boundary stretch between two regions that has no crossing sample (no point clear of the
#: other curves by 4 tolerances, :func:`_crossing_candidates`) is below resolution where two
#: curves run within a few tolerances of each other: near a tangency, or where two curves
#: cross at a shallow angle (a lens thinner than the resolution). Curves of radius about
#: ``lss`` stay that close over about ``sqrt(32 lss tol)``; the longest such stretches
#: measured on 80 random maps and floor plans were ``5.3 sqrt(lss tol)``. A stretch longer
#: than ``UNRESOLVED_MAX_ROOT * sqrt(lss tol)`` (and ``UNRESOLVED_MAX_TOLS`` tolerances) is
#: two curves nearly coincident along a whole boundary (lss within the resolution of a
#: critical length): G would miss the crossings over it, and the self-check fails.
UNRESOLVED_MAX_ROOT = 30.0
UNRESOLVED_MAX_TOLS = 8.0


def structures(env: Environment, table: ArcTable, npts: int) -> list[Structure]:
    """Structure key of each point of an :class:`ArcTable`: a frozenset of
    ``(start_code, end_code)`` pairs, or ``"FULL"`` / ``"EMPTY"``. Points with equal
    structures share one object."""
    ids, table_ = structure_ids(env, table, npts)
    uniq, inv = np.unique(ids, return_inverse=True)  # each distinct structure made once
    made = [table_.structure(i) for i in uniq.tolist()]
    return [made[j] for j in inv.ravel().tolist()]


def structure_ids(env: Environment, table: ArcTable, npts: int
                  ) -> tuple[np.ndarray, _Structures]:
    """An integer id per point of an :class:`ArcTable`, equal for equal structures (and only
    for them), and the structures of the ids as integer rows (:class:`_Structures`: no
    frozenset is made here)."""
    ids = np.zeros(npts, dtype=np.int64)  # id 0: EMPTY
    ids[np.asarray(table.full, dtype=bool)] = 1
    base = 2 * env.n + 1
    if len(table.point) == 0:
        return ids, _Structures(base, np.zeros(3, np.int64), np.zeros(0, np.int64))
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
    width = int(counts.max())
    first = np.cumsum(counts) - counts
    rows = np.flatnonzero(counts)
    grid = np.full((len(rows), width), -1, dtype=np.int64)
    slot = np.arange(len(point)) - first[point]
    row_of = np.searchsorted(rows, point)
    grid[row_of, slot] = pair
    inv, first_row = _row_ids(grid)
    ids[rows] = inv + 2
    sub = grid[first_row]
    valid = sub >= 0  # each row's pairs come first (sorted), then -1 padding
    ptr = np.r_[0, 0, 0, np.cumsum(valid.sum(axis=1))]  # ids 0 and 1 have no pairs
    return ids, _Structures(base, ptr, sub[valid])


class _Structures:
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
            return "FULL" if i == 1 else "EMPTY"
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

    def rows(self) -> _StructureRows:
        """Every id's structure as :class:`_StructureRows` (internal codes)."""
        kind = np.minimum(np.arange(len(self), dtype=np.int64), 2)
        return _StructureRows(kind, self.ptr, self.pairs)

    def to_file(self, code_map: np.ndarray) -> None:
        """Make the structures in the file's feature codes from now on (``code_map``:
        internal code -> the file's; any made before are dropped, to be made again)."""
        self._code_map = np.asarray(code_map, dtype=np.int64)
        self._sets = {}


def structure_names(env: Environment, s: Structure) -> list[tuple[str, str]]:
    """The cells' ``(start_feature, end_feature)`` names of a structure, sorted."""
    if s == "FULL":
        return [(FREE, FREE)]
    if s == "EMPTY":
        return []
    memo = env.__dict__.setdefault("_structure_names", {})  # many regions share structures
    got = memo.get(s)
    if got is None:
        names = _feature_names(env)
        got = memo[s] = sorted((names[a], names[b]) for a, b in s)
    return list(got)


def structure_codes(env: Environment, s: Structure) -> np.ndarray:
    """The cells' ``(start, end)`` feature codes of a structure as a ``(k, 2)`` int array, in
    the order of :func:`structure_names` (by name); a FULL structure's cell is ``(-1, -1)``."""
    if s == "FULL":
        return np.full((1, 2), -1, dtype=np.int64)
    if s == "EMPTY":
        return np.zeros((0, 2), dtype=np.int64)
    memo = env.__dict__.setdefault("_structure_codes", {})
    got = memo.get(s)
    if got is None:
        names = _feature_names(env)
        pairs = sorted(s, key=lambda p: (names[p[0]], names[p[1]]))
        got = memo[s] = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    return got


def _feature_names(env: Environment) -> list[str]:
    """Every feature code's name (``feature_name``), computed once per map."""
    got = env.__dict__.get("_feature_names")
    if got is None:
        got = env.__dict__["_feature_names"] = [feature_name(env, c) for c in range(2 * env.n)]
    return got


@dataclass(frozen=True, slots=True)  # no __dict__: 624k cells at 1,000 map vertices
class Cell:
    """A connected component of free rod orientations above a region: ``(R, start, end)``."""

    id: str
    region: int
    start_feature: str
    end_feature: str

    def to_dict(self) -> dict:
        return {"id": self.id, "region": f"R{self.region}",
                "start_feature": self.start_feature, "end_feature": self.end_feature}


class _Shapes:
    """The geometries of a decomposition's regions (or of its pieces), shared by them: item
    ``i`` is the geometry of the object whose ``id`` is ``i``. Kept as made, in the internal
    frame, and converted to the map's frame all at once on the first read (one vectorized
    ``shapely.transform``, the very numbers an eager conversion gives, then cached; the
    internal ones are dropped): building the graph and analyzing read no geometry and never
    pay for it, and reading one region's polygon converts the batch once, never one by one.
    ``frame`` None: the geometries are the map's already."""

    __slots__ = ("_geoms", "_frame", "_prepare")

    def __init__(self, geoms: np.ndarray, frame: Any = None, prepare: bool = False) -> None:
        self._geoms = geoms  # object array of shapely geometries (None stays None)
        self._frame = frame  # tether.environment frame: internal -> map coordinates
        self._prepare = prepare  # shapely.prepare the converted geometries

    @property
    def converted(self) -> bool:
        """Whether the geometries are in the map's frame already (read or made so)."""
        return self._frame is None

    def all(self) -> np.ndarray:
        """Every geometry in map coordinates (an object array; converted on the first call)."""
        if self._frame is not None:
            geoms = self._to_user(self._geoms)
            if self._prepare:
                shapely.prepare(geoms)
            self._geoms, self._frame = geoms, None
        return self._geoms

    def __getitem__(self, i: int) -> Any:
        return self.all()[i]

    def some(self, ids: Any) -> np.ndarray:
        """The geometries ``ids`` in map coordinates, converting only those if the batch is
        not converted yet (not cached: the same numbers, the transform is pointwise; not
        prepared): a few reads need not convert them all."""
        if self._frame is None:
            return self._geoms[ids]
        return self._to_user(self._geoms[ids])

    def _to_user(self, geoms: np.ndarray) -> np.ndarray:
        """Geometries converted to the map's frame (:class:`_RegionShapes` also repairs
        polygons that rounding made invalid)."""
        return self._frame.geometry_to_user(geoms)

    def __len__(self) -> int:
        return len(self._geoms)


class _RegionShapes(_Shapes):
    """The regions' polygons (see :class:`_Shapes`), the unions of the multi-face regions made
    on the first read: ``unions[i]`` the faces (an object array) whose ``shapely.union_all``
    is item ``i``, all made at once on the first read of all (then prepared, converted),
    only those asked for by :meth:`some`. Building G and analyzing never pay for them."""

    __slots__ = ("_unions", "_face_tree", "_face_owner")

    def __init__(self, geoms: np.ndarray, unions: dict[int, np.ndarray], frame: Any = None,
                 prepare: bool = True) -> None:
        super().__init__(geoms, frame, prepare)
        self._unions = unions or None

    @property
    def converted(self) -> bool:
        """Whether the polygons are made and in the map's frame already (read or made so)."""
        return self._unions is None and self._frame is None

    def all(self) -> np.ndarray:
        if self._unions is not None:
            geoms = self._geoms.copy()  # never the caller's array
            for i, faces in self._unions.items():
                geoms[i] = shapely.union_all(faces)
            self._geoms, self._unions = geoms, None
            self._face_tree = None  # the faces' tree: no longer valid once converted
            if self._frame is None and self._prepare:
                shapely.prepare(geoms)
        return super().all()

    def crossing(self, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pairs ``(i, region)`` where region's polygon intersects ``geoms[i]`` (map
        coordinates), sorted, found over the faces as made (a face tree built once) without
        making or converting any region's polygon. Only while :attr:`converted` is False."""
        if self._frame is not None:
            geoms = shapely.transform(geoms, self._frame.to_internal)
        gi, hit = self._tree().query(geoms, predicate="intersects")
        return _unique_pairs(gi, self._face_owner[hit])

    def _tree(self) -> shapely.STRtree:
        """An STRtree of the single-face regions' polygons and the multi-face regions' faces
        (``_face_owner``: the region of each), built on the first call."""
        got = getattr(self, "_face_tree", None)
        if got is None:
            items, owner = [self._geoms], [np.arange(len(self._geoms))]
            if self._unions:
                items += list(self._unions.values())
                owner += [np.full(len(f), i) for i, f in self._unions.items()]
            geoms, owner_arr = np.concatenate(items), np.concatenate(owner)
            keep = ~shapely.is_missing(geoms)
            self._face_owner = owner_arr[keep]
            got = self._face_tree = shapely.STRtree(geoms[keep])
        return got

    def _to_user(self, geoms: np.ndarray) -> np.ndarray:
        return valid_polygons(self._frame.geometry_to_user(geoms))

    def some(self, ids: Any) -> np.ndarray:
        if self._unions is None:
            return super().some(ids)
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        geoms = self._geoms[ids]
        for k, i in enumerate(ids.tolist()):
            faces = self._unions.get(i)
            if faces is not None:
                geoms[k] = shapely.union_all(faces)
        return geoms if self._frame is None else self._to_user(geoms)


def _unique_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct pairs ``(a[k], b[k])`` of two int arrays, sorted by ``a`` then ``b``."""
    if len(a) == 0:
        return a.astype(np.int64), b.astype(np.int64)
    pairs = np.unique(np.column_stack((a, b)).astype(np.int64), axis=0)
    return pairs[:, 0], pairs[:, 1]


def valid_polygons(geoms: np.ndarray) -> np.ndarray:
    """The polygons ``geoms`` with those that are invalid repaired: a region's polygon is
    valid in the internal frame, but its conversion to the map's coordinates can round a
    cusp's tip (two circles, or a circle and a line, touching) or two nodes one unit in the
    last place apart into a collinear back-track, a self-touching ring. Such rings get
    ``make_valid``'s structure method without the collapsed parts (the same area to rounding).
    The array is changed in place and returned."""
    bad = np.flatnonzero(~shapely.is_valid(geoms) & ~shapely.is_missing(geoms))
    if len(bad):
        fixed = shapely.make_valid(geoms[bad], method="structure", keep_collapsed=False)
        geoms[bad] = fixed
    return geoms


class _CellTable:
    """The cells of a decomposition as int columns, in cell order (region by region):
    ``region``, ``start`` and ``end`` feature codes (the reported map's numbering, -1 for both
    ends of a FULL region's cell); ``names[code + 1]`` is a code's feature name (``FREE`` for
    -1); region ``r``'s cells are ``first[r]:first[r + 1]``. :class:`Cell` objects and id
    strings are made from it when read."""

    __slots__ = ("region", "start", "end", "names", "first", "_codes")

    def __init__(self, region: np.ndarray, start: np.ndarray, end: np.ndarray,
                 names: list[str], nregions: int) -> None:
        self.region, self.start, self.end, self.names = region, start, end, names
        count = np.bincount(region, minlength=nregions)
        self.first = np.concatenate(([0], np.cumsum(count))).astype(np.int64)
        self._codes: dict[str, int] | None = None

    def __len__(self) -> int:
        return len(self.region)

    def cell(self, i: int) -> Cell:
        r, s, e = int(self.region[i]), self.names[self.start[i] + 1], self.names[self.end[i] + 1]
        return Cell(f"(R{r},{s},{e})", r, s, e)

    def cells(self, lo: int = 0, hi: int | None = None) -> Iterator[Cell]:
        """The cells ``lo:hi``, made one by one."""
        names = self.names
        for r, s, e in zip(self.region[lo:hi].tolist(), self.start[lo:hi].tolist(),
                           self.end[lo:hi].tolist(), strict=True):
            a, b = names[s + 1], names[e + 1]
            yield Cell(f"(R{r},{a},{b})", r, a, b)

    def ids(self, which: Any = None) -> list[str]:
        """The ids of the cells ``which`` (indices; default all), in that order."""
        names = self.names
        reg, st, en = ((self.region, self.start, self.end) if which is None else
                       (self.region[which], self.start[which], self.end[which]))
        return [f"(R{r},{names[s + 1]},{names[e + 1]})" for r, s, e in zip(
            reg.tolist(), st.tolist(), en.tolist(), strict=True)]

    def dicts(self) -> list[dict]:
        """Every cell's :meth:`Cell.to_dict`, made from the columns."""
        names = self.names
        return [{"id": f"(R{r},{names[s + 1]},{names[e + 1]})", "region": f"R{r}",
                 "start_feature": names[s + 1], "end_feature": names[e + 1]}
                for r, s, e in zip(self.region.tolist(), self.start.tolist(),
                                   self.end.tolist(), strict=True)]

    def fill(self, regions: Any) -> None:
        """Make the cell ids of every region of ``regions`` still reading this table, in one
        pass (each region's :attr:`Region.cells`)."""
        todo = [r for r in regions if r._cells is self]
        if not todo:
            return
        ids, first = self.ids(), self.first.tolist()
        put = object.__setattr__
        for r in todo:
            put(r, "_cells", tuple(ids[first[r.id]:first[r.id + 1]]))

    def region_ids(self, r: int) -> tuple[str, ...]:
        """The ids of region ``r``'s cells."""
        names = self.names
        lo, hi = int(self.first[r]), int(self.first[r + 1])
        return tuple([f"(R{r},{names[s + 1]},{names[e + 1]})" for s, e in zip(
            self.start[lo:hi].tolist(), self.end[lo:hi].tolist(), strict=True)])

    def index(self, cell_id: Any) -> int:
        """The index of the cell named ``cell_id``, -1 if there is none."""
        if not isinstance(cell_id, str) or cell_id[:2] != "(R" or cell_id[-1:] != ")":
            return -1
        parts = cell_id[2:-1].split(",")
        if len(parts) != 3 or not parts[0].isdigit():
            return -1
        r = int(parts[0])
        if r >= len(self.first) - 1:
            return -1
        code = self._codes
        if code is None:
            code = self._codes = {n: c - 1 for c, n in enumerate(self.names) if n is not None}
        s, e = code.get(parts[1]), code.get(parts[2])
        if s is None or e is None:
            return -1
        lo, hi = int(self.first[r]), int(self.first[r + 1])
        hit = np.flatnonzero((self.start[lo:hi] == s) & (self.end[lo:hi] == e))
        if len(hit) == 0:
            return -1
        i = lo + int(hit[0])
        return i if self.cell(i).id == cell_id else -1  # the canonical spelling only


class _RowSequence(Sequence):
    """An immutable sequence over the rows of a column table, each item made when read (so
    ``seq[i] is seq[i]`` may be False; they are equal). Equal to the tuple of the same items,
    and hashed as it. Subclasses say how one item (``_one``) and a run (``_many``) are made."""

    __slots__ = ("_table",)
    _what = "item"

    def __init__(self, table: Any) -> None:
        self._table = table

    def _one(self, i: int) -> Any:
        raise NotImplementedError

    def _many(self, lo: int = 0, hi: int | None = None) -> Iterator[Any]:
        raise NotImplementedError

    def __len__(self) -> int:
        return len(self._table)

    def __getitem__(self, i: Any) -> Any:
        n = len(self._table)
        if isinstance(i, slice):
            lo, hi, step = i.indices(n)
            if step == 1:
                return tuple(self._many(lo, max(lo, hi)))
            return tuple(self._one(j) for j in range(lo, hi, step))
        j = operator.index(i)
        j = j + n if j < 0 else j
        if not 0 <= j < n:
            raise IndexError(f"{self._what} index out of range")
        return self._one(j)

    def __iter__(self) -> Iterator[Any]:
        return self._many()

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (tuple, type(self))):
            return len(self) == len(other) and tuple(self) == tuple(other)
        return NotImplemented

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        return repr(tuple(self))


class _Cells(_RowSequence):
    """:attr:`Decomposition.cells`: the :class:`Cell` s of a :class:`_CellTable`, each made
    when read (see :class:`_RowSequence`)."""

    __slots__ = ()
    _what = "cell"

    def _one(self, i: int) -> Cell:
        return self._table.cell(i)

    def _many(self, lo: int = 0, hi: int | None = None) -> Iterator[Cell]:
        return self._table.cells(lo, hi)

    def __contains__(self, x: object) -> bool:
        if not isinstance(x, Cell):
            return False
        i = self._table.index(x.id)
        return i >= 0 and self._table.cell(i) == x


class _CellsById(Mapping):
    """``dec.cell(id)``'s lookup over a :class:`_CellTable` (no dict of every cell)."""

    __slots__ = ("_table",)

    def __init__(self, table: _CellTable) -> None:
        self._table = table

    def __getitem__(self, cell_id: Any) -> Cell:
        i = self._table.index(cell_id)
        if i < 0:
            raise KeyError(cell_id)
        return self._table.cell(i)

    def __contains__(self, cell_id: object) -> bool:
        return self._table.index(cell_id) >= 0

    def __iter__(self) -> Iterator[str]:
        return iter(self._table.ids())

    def __len__(self) -> int:
        return len(self._table)


@dataclass(frozen=True, eq=False, slots=True)
class Region:
    """A noncritical region: polygon, area, a representative interior point, its structure.

    ``_polygon`` is the polygon, or the decomposition's :class:`_Shapes` holding it (item
    ``id``, converted to the map's frame on the first read of any region's polygon);
    ``_structure`` the structure, or the decomposition's :class:`_Structures` holding it
    (the frozenset made on the first read)."""

    id: int
    _polygon: Any = field(repr=False)
    area: float
    point: tuple[float, float]
    _structure: Any = field(repr=False)
    _cells: Any = field(repr=False)  # the ids, or the decomposition's _CellTable

    @property
    def name(self) -> str:
        return f"R{self.id}"

    @property
    def structure(self) -> Structure:
        """``"FULL"``, ``"EMPTY"`` or the frozenset of the cells' ``(start_code, end_code)``
        pairs (the file's feature codes)."""
        s = self._structure
        return s.of_region(self.id) if type(s) is _Structures else s

    @property
    def cells(self) -> tuple[str, ...]:
        """The ids of the region's cells (made from the cells' columns on the first read)."""
        c = self._cells
        if type(c) is _CellTable:
            c = c.region_ids(self.id)
            object.__setattr__(self, "_cells", c)
        return c

    def __repr__(self) -> str:
        return (f"Region(id={self.id!r}, area={self.area!r}, point={self.point!r}, "
                f"cells={self.cells!r})")

    @property
    def polygon(self) -> Any:
        """The region's polygon (a shapely Polygon or MultiPolygon, map units, prepared)."""
        g = self._polygon
        return g[self.id] if isinstance(g, _Shapes) else g

    def to_dict(self) -> dict:
        return {"id": self.name, "area": self.area, "point": list(self.point),
                "cells": list(self.cells)}


@dataclass(frozen=True, slots=True)
class Piece:
    """A maximal stretch of critical curve separating two regions (``math.md`` §8).

    ``sample`` is a point of the piece, ``normal`` the unit normal there pointing into
    ``regions[0]``, ``eps`` an offset small enough that ``sample ± eps * normal`` lie in the two
    regions (and on the right sides of the exact curve). Pieces compare (and hash) by value,
    their line aside: a decomposition's pieces are made when read (:class:`_Pieces`), so two
    reads of one piece are equal objects, not the same one.
    """

    id: int
    regions: tuple[int, int]
    curves: tuple[int, ...]
    kind: str
    features: tuple[str, ...]
    # the line, or a _Shapes holding it (item ``id``)
    _geometry: Any = field(repr=False, compare=False)
    sample: tuple[float, float]
    normal: tuple[float, float]
    eps: float
    #: whether the two sides of the crossing showed the two regions' structures when the
    #: decomposition was built (False: no candidate point did; ``check`` reports it)
    verified: bool = True

    @property
    def name(self) -> str:
        return f"P{self.id}"

    @property
    def geometry(self) -> Any:
        """The piece's line (a shapely LineString or MultiLineString, map units)."""
        g = self._geometry
        return g[self.id] if type(g) is _Shapes else g

    @property
    def length(self) -> float:
        return float(self.geometry.length)

    def to_dict(self) -> dict:
        return {"id": self.name, "regions": [f"R{r}" for r in self.regions],
                "type": self.kind, "features": list(self.features), "length": self.length,
                "point": list(self.sample)}


class _PieceTable:
    """The pieces of a decomposition as columns, in piece order (piece ``i`` is row ``i``):
    ``pair`` (m, 2) int64, the two regions (``regions[0]`` the side ``n`` points into);
    ``q`` (m, 2) crossing samples and ``n`` (m, 2) unit normals, ``eps`` (m,) offsets (map
    units once :meth:`tether.userframe.UserFrame.pieces` converted them); ``ok`` (m,) bool,
    verified; ``desc`` (m,) int ids into ``descs``, the distinct ``(curves, kind, features)``
    (many pieces share their curves); ``shapes`` the lines (a :class:`_Shapes`, item ``i``
    piece ``i``). :class:`Piece` objects are made from it when read."""

    __slots__ = ("pair", "q", "n", "eps", "ok", "desc", "descs", "shapes")

    def __init__(self, pair: np.ndarray, q: np.ndarray, n: np.ndarray, eps: np.ndarray,
                 ok: np.ndarray, desc: np.ndarray, descs: list[tuple], shapes: _Shapes) -> None:
        self.pair, self.q, self.n, self.eps, self.ok = pair, q, n, eps, ok
        self.desc, self.descs, self.shapes = desc, descs, shapes
        pair.flags.writeable = False  # G reads it as is (graph._piece_regions)

    def __len__(self) -> int:
        return len(self.pair)

    def piece(self, i: int) -> Piece:
        a, b = self.pair[i].tolist()
        qx, qy = self.q[i].tolist()
        nx, ny = self.n[i].tolist()
        curves, kind, feats = self.descs[self.desc[i]]
        return Piece(i, (a, b), curves, kind, feats, self.shapes, (qx, qy), (nx, ny),
                     float(self.eps[i]), bool(self.ok[i]))

    def pieces(self, lo: int = 0, hi: int | None = None) -> Iterator[Piece]:
        """The pieces ``lo:hi``, made one by one (the columns read a bounded batch at a
        time: the lists of a batch, not of all)."""
        hi = len(self) if hi is None else hi
        descs, shapes = self.descs, self.shapes
        for b in range(lo, hi, PIECE_BATCH):
            e = min(b + PIECE_BATCH, hi)
            q, n = self.q[b:e], self.n[b:e]
            for i, a, r, d, qx, qy, nx, ny, eps, ok in zip(
                    range(b, e), self.pair[b:e, 0].tolist(), self.pair[b:e, 1].tolist(),
                    self.desc[b:e].tolist(), q[:, 0].tolist(), q[:, 1].tolist(),
                    n[:, 0].tolist(), n[:, 1].tolist(), self.eps[b:e].tolist(),
                    self.ok[b:e].tolist(), strict=True):
                curves, kind, feats = descs[d]
                yield Piece(i, (a, r), curves, kind, feats, shapes, (qx, qy), (nx, ny), eps,
                            ok)

    def dicts(self) -> list[dict]:
        """Every piece's :meth:`Piece.to_dict`, made from the columns (lengths all at once,
        the same numbers as one by one)."""
        descs = self.descs
        length = shapely.length(self.shapes.all()).tolist()
        return [{"id": f"P{i}", "regions": [f"R{a}", f"R{b}"], "type": descs[d][1],
                 "features": list(descs[d][2]), "length": ln, "point": [qx, qy]}
                for i, (a, b, d, ln, qx, qy) in enumerate(zip(
                    self.pair[:, 0].tolist(), self.pair[:, 1].tolist(), self.desc.tolist(),
                    length, self.q[:, 0].tolist(), self.q[:, 1].tolist(), strict=True))]


#: Pieces made per batch when iterating: the batch's columns are Python lists, this bounds
#: their memory.
PIECE_BATCH = 16_384


class _Pieces(_RowSequence):
    """:attr:`Decomposition.pieces`: the :class:`Piece` s of a :class:`_PieceTable`, each
    made when read (see :class:`_RowSequence`)."""

    __slots__ = ()
    _what = "piece"

    def _one(self, i: int) -> Piece:
        return self._table.piece(i)

    def _many(self, lo: int = 0, hi: int | None = None) -> Iterator[Piece]:
        return self._table.pieces(lo, hi)

    def __contains__(self, x: object) -> bool:
        if not isinstance(x, Piece):
            return False
        try:
            i = operator.index(x.id)
        except TypeError:
            return False
        return 0 <= i < len(self) and self._table.piece(i) == x


@dataclass(frozen=True, eq=False)
class Decomposition:
    """The result of :func:`decompose`: curves, regions, cells, pieces and point location."""

    env: Environment = field(repr=False)
    lss: float
    curves: tuple[Curve, ...] = field(repr=False)
    regions: tuple[Region, ...] = field(repr=False)
    #: the cells, region by region (a tuple, or from :func:`decompose` an equal sequence
    #: making each :class:`Cell` when read: ``cells[i] is cells[i]`` may be False)
    cells: Sequence[Cell] = field(repr=False)
    #: the pieces, in piece order (a tuple, or from :func:`decompose` an equal sequence
    #: making each :class:`Piece` when read: ``pieces[i] is pieces[i]`` may be False)
    pieces: Sequence[Piece] = field(repr=False)
    curve_tol: float
    unresolved_pieces: int = 0  # boundary stretches below resolution (see _make_pieces)
    #: the longest of those stretches: ``{"length", "regions", "point"}`` (map units), or None;
    #: the self-check fails when it is longer than the resolution (``UNRESOLVED_MAX_ROOT``)
    unresolved_longest: dict | None = None

    def __repr__(self) -> str:
        return (f"Decomposition(map={self.env.name!r}, lss={self.lss:g}, "
                f"curves={len(self.curves)}, regions={len(self.regions)}, "
                f"cells={len(self.cells)}, pieces={len(self.pieces)})")

    @property
    def counts(self) -> dict:
        return {"curves": len(self.curves), "regions": len(self.regions),
                "cells": len(self.cells), "pieces": len(self.pieces)}

    def cell(self, cell_id: str) -> Cell:
        """The cell named ``cell_id`` (e.g. ``"(R1,E1,E2)"``)."""
        return self._cell_by_id[cell_id]

    def cell_codes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cells' ``(region, start code, end code)`` as three int arrays in the order of
        :attr:`cells` (feature codes in :attr:`env`'s numbering, -1 for both ends of a FULL
        region's cell), cached: recorded by :func:`decompose`, else read from the cells."""
        got = self.__dict__.get("_cell_codes")
        if got is None and type(self.cells) is _Cells:
            t = self.cells._table
            got = self.__dict__["_cell_codes"] = (t.region, t.start, t.end)
        if got is None:
            code = {feature_name(self.env, c): c for c in range(2 * self.env.n)}
            code[FREE] = -1
            n = len(self.cells)
            got = (np.fromiter((c.region for c in self.cells), np.int64, n),
                   np.fromiter((code[c.start_feature] for c in self.cells), np.int64, n),
                   np.fromiter((code[c.end_feature] for c in self.cells), np.int64, n))
            self.__dict__["_cell_codes"] = got
        return got

    @property
    def _cell_by_id(self) -> Mapping[str, Cell]:
        d = self.__dict__.get("_cells_by_id")
        if d is None:
            d = (_CellsById(self.cells._table) if type(self.cells) is _Cells else
                 {c.id: c for c in self.cells})
            self.__dict__["_cells_by_id"] = d
        return d

    @property
    def _tree(self) -> shapely.STRtree:
        t = self.__dict__.get("_region_tree")
        if t is None:
            t = shapely.STRtree([r.polygon for r in self.regions])
            self.__dict__["_region_tree"] = t
        return t

    def piece_crossings(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every piece's crossing sample: points (k, 2), unit normals into ``regions[0]``
        (k, 2), offsets (k,), map units."""
        if type(self.pieces) is _Pieces:  # copies of the columns
            t = self.pieces._table
            return t.q.copy(), t.n.copy(), t.eps.copy()
        return (np.array([p.sample for p in self.pieces]).reshape(-1, 2),
                np.array([p.normal for p in self.pieces]).reshape(-1, 2),
                np.array([p.eps for p in self.pieces], dtype=float))

    def crossing_arcs(self) -> ArcTable:
        """The exact free arcs at both sides of every piece's crossing (the points
        :func:`crossing_points` of :meth:`piece_crossings`: point ``k`` is ``sample + eps
        normal`` of piece ``k``, point ``m + k`` the other side), as found while the
        crossings were chosen (computed now if the decomposition was built otherwise)."""
        got = self.__dict__.get("_crossing_arcs")
        if got is None:
            got = free_arcs_many(self.env, crossing_points(*self.piece_crossings()), self.lss,
                                 check=False)
            self.__dict__["_crossing_arcs"] = got
        return got

    def regions_crossing(self, geoms: Any) -> tuple[np.ndarray, np.ndarray]:
        """The pairs ``(i, r)`` (two int arrays, sorted) such that region ``r``'s polygon
        intersects the shapely geometry ``geoms[i]`` (an array of them, map coordinates).
        Makes no region polygon that was not made yet."""
        geoms = np.asarray(geoms, dtype=object).reshape(-1)
        shapes = self.regions[0]._polygon if self.regions else None
        if type(shapes) is _RegionShapes and not shapes.converted:
            return shapes.crossing(geoms)
        gi, ri = self._tree.query(geoms, predicate="intersects")
        return _unique_pairs(gi, ri)

    def region_polygons(self, ids: Any) -> np.ndarray:
        """The polygons of the regions ``ids`` (map coordinates, an object array), making and
        converting only those if the regions' polygons were not read yet."""
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        shapes = self.regions[0]._polygon if self.regions else None
        if isinstance(shapes, _Shapes) and not shapes.converted:
            return shapes.some(ids)
        return np.fromiter((self.regions[i].polygon for i in ids.tolist()), dtype=object,
                           count=len(ids))

    def region_at(self, points: Any) -> np.ndarray:
        """Index of the region containing each point (``-1`` outside every region: outside the
        free space, or on a region boundary). Vectorized over points of shape (m, 2)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.full(len(pts), -1)
        pi, ri = self._tree.query(shapely.points(pts), predicate="within")
        out[pi] = ri
        return out

    def cell_at(self, points: Any, angles: Any) -> list[str | None]:
        """The cell containing each rod configuration ``(x, y, a)``: the region's cell whose
        labels match the exact free arc containing ``a`` (``None`` if the rod is not free or
        the point is on a region boundary)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        reg = self.region_at(pts)
        table = free_arcs_many(self.env, pts, self.lss, check=False)
        out: list[str | None] = [None] * len(pts)
        for i in range(len(pts)):
            if reg[i] < 0:
                continue
            region = self.regions[reg[i]]
            if table.full[i]:
                out[i] = region.cells[0] if region.structure == "FULL" else None
                continue
            rows = table.rows_of(i)
            for s, e, sc, ec in zip(table.start[rows], table.end[rows], table.start_code[rows],
                                    table.end_code[rows], strict=True):
                if (ang[i] - s) % TWO_PI <= (e - s) % TWO_PI:
                    cid = cell_name(region.id, feature_name(self.env, sc),
                                    feature_name(self.env, ec))
                    out[i] = cid if cid in self._cell_by_id else None
                    break
        return out

    def to_dict(self, geometry: bool = False) -> dict:
        """Counts, regions and cells; with ``geometry`` also the pieces, the curves and each
        region's polygon (WKT) and each piece's line (WKT), map units. The lean form stays
        small on large maps (the full one is tens of MB at a few hundred vertices)."""
        table = self.cells._table if type(self.cells) is _Cells else None
        if table is not None:
            table.fill(self.regions)
        out = {
            "map": self.env.name,
            "lss": self.lss,
            "curve_tolerance": self.curve_tol,
            "unresolved_pieces": self.unresolved_pieces,
            "counts": {k: v for k, v in self.counts.items() if k != "curves"},
            "regions": [r.to_dict() for r in self.regions],
            "cells": ([c.to_dict() for c in self.cells] if table is None else
                      table.dicts()),
        }
        if geometry:
            pieces = self.pieces._table if type(self.pieces) is _Pieces else None
            out["pieces"] = ([p.to_dict() for p in self.pieces] if pieces is None else
                             pieces.dicts())
            out["curves"] = [c.to_dict() for c in self.curves]
            wkt = shapely.to_wkt([r.polygon for r in self.regions], rounding_precision=-1)
            for d, w in zip(out["regions"], wkt, strict=True):
                d["polygon"] = w
            wkt = shapely.to_wkt([p.geometry for p in self.pieces] if pieces is None else
                                 pieces.shapes.all(), rounding_precision=-1)
            for d, w in zip(out["pieces"], wkt, strict=True):
                d["geometry"] = w
        return out

    def plot(self, ax: Any = None, **kw: Any) -> list:
        """Draw the decomposition (see :func:`tether.plot.plot_decomposition`)."""
        from tether.plot.decomposition import plot_decomposition

        return plot_decomposition(self, ax, **kw)


def cell_name(region: int, start: str, end: str) -> str:
    """The paper's cell name, e.g. ``(R1,E1,E2)``."""
    return f"(R{region},{start},{end})"


# ---------------------------------------------------------------------- arrangement
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


def _segment_ids(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """An integer id per undirected segment ``a[k]-b[k]``, equal for equal coordinates."""
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    lo = np.where(swap[:, None], b, a)
    hi = np.where(swap[:, None], a, b)
    return _row_ids(np.column_stack((lo, hi)))[0]


def _row_ids(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An integer id per row of ``key`` (shape (n, k), floats or integers), equal for equal
    rows (compared as numbers), and the first row of each id (ids are numbered in no
    particular order). One stable sort on a 64-bit hash of the rows, verified (rows of equal
    hash must be equal, else a lexsort): ``np.unique`` on rows viewed as bytes compares them
    as strings, several times slower, and a lexsort sorts once per column."""
    n = len(key)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if key.dtype.kind == "f":
        bits = np.ascontiguousarray(key + 0.0).view(np.uint64)  # + 0.0: -0.0 becomes 0.0
    else:
        bits = np.ascontiguousarray(key).astype(np.int64).view(np.uint64)
    h = np.zeros(n, np.uint64)
    with np.errstate(over="ignore"):
        for j in range(key.shape[1]):
            h = (h ^ bits[:, j]) * np.uint64(0x9E3779B97F4A7C15)
            h ^= h >> np.uint64(29)
    order = np.argsort(h, kind="stable")
    sh = h[order]
    sk = key[order]
    new = np.empty(n, bool)
    new[0] = True
    new[1:] = sh[1:] != sh[:-1]
    if np.any(~new[1:] & np.any(sk[1:] != sk[:-1], axis=1)):  # a collision: sort the rows
        order = np.lexsort(key.T[::-1])
        sk = key[order]
        new[1:] = np.any(sk[1:] != sk[:-1], axis=1)
    ids = np.empty(n, np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


def _ring_segments(geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All segments of the rings of polygons (or of linestrings): (a, b, owner index)."""
    rings = shapely.get_rings(geoms, return_index=True) if len(geoms) and \
        shapely.get_type_id(geoms[0]) == 3 else (geoms, np.arange(len(geoms)))
    lines, owner = rings
    coords, idx = shapely.get_coordinates(lines, return_index=True)
    same = idx[1:] == idx[:-1]
    k = np.flatnonzero(same)
    return np.take(coords, k, axis=0), np.take(coords, k + 1, axis=0), owner[idx[k]]


@dataclass
class _Arrangement:
    parts: np.ndarray  # noded linestrings
    part_faces: np.ndarray  # (nparts, 2) face ids, -1 for none
    #: curve ids (-1 = wall) of each part, CSR: part ``k``'s are
    #: ``source_ids[source_ptr[k]:source_ptr[k + 1]]`` (increasing)
    source_ptr: np.ndarray
    source_ids: np.ndarray
    faces: np.ndarray  # polygons
    grid: float = 0.0  # the snap-rounding grid of the noding (map units), 0: exact

    @property
    def part_sources(self) -> list[tuple[int, ...]]:
        """The curve ids (-1 = wall) of each part, as tuples."""
        flat = self.source_ids.tolist()
        ptr = self.source_ptr.tolist()
        return [tuple(flat[a:b]) for a, b in zip(ptr[:-1], ptr[1:], strict=True)]

    def segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, SegmentGrid]:
        """All segments of the parts (a, b, part index) and their grid (for
        :func:`_segments_near`), built once."""
        got = self.__dict__.get("_segments")
        if got is None:
            a, b, owner = self.__dict__.pop("_part_segments", None) or _ring_segments(self.parts)
            got = (a, b, owner, SegmentGrid(a, b))
            self.__dict__["_segments"] = got
        return got

    def end_ids(self) -> tuple[np.ndarray, np.ndarray]:
        """An id per end point of every part (first, last), equal for equal coordinates,
        built once."""
        got = self.__dict__.get("_end_ids")
        if got is None:
            ids = _part_ends(self.parts)[4]
            got = self.__dict__["_end_ids"] = (ids[: len(self.parts)], ids[len(self.parts):])
        return got

    def sources(self) -> tuple[np.ndarray, np.ndarray]:
        """The parts' sources as CSR arrays ``(ptr, src)``: part ``k``'s sources are
        ``src[ptr[k]:ptr[k + 1]]`` (increasing)."""
        return self.source_ptr, self.source_ids

    def chain_sources(self, chains: _Chains) -> tuple[np.ndarray, np.ndarray]:
        """The curves (no walls) of each chain, sorted, distinct, as CSR arrays ``(ptr,
        src)``: chain ``i``'s are ``src[ptr[i]:ptr[i + 1]]``; vectorized over all chains."""
        ptr, src = self.sources()
        parts = chains.parts
        chain = np.repeat(np.arange(len(chains), dtype=np.int64), chains.size)
        nsrc = ptr[parts + 1] - ptr[parts]
        rows = ragged_arange(ptr[parts], nsrc)
        base = int(src.max(initial=0)) + 2  # sources are -1 (wall) .. max
        key = np.sort(np.repeat(chain, nsrc) * base + src[rows] + 1)  # np.unique hashes: slow
        key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
        c, s = np.divmod(key, base)
        s = s - 1
        c, s = c[s >= 0], s[s >= 0]
        return np.searchsorted(c, np.arange(len(chains) + 1)), s


def _input_lines(env: Environment, curves: list[Curve], tol: float | None = None
                 ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """The arrangement's input: the map's rings (closed) and every curve polyline of at least
    two distinct points, as linestrings (built in one call), each line's source curve id
    (-1: a ring), and the lines' segments (as :func:`_ring_segments` of the lines). Collinear
    copies are made one (:func:`tether.coincidence.merge_collinear`); with the curve
    tolerance ``tol``, curve ends stopping just short of a wall get a stub to it
    (:func:`tether.coincidence.wall_stubs`), a line of their curve's."""
    polys = [np.vstack((r, r[:1])) for r in env.rings]
    src = [-1] * len(polys)
    straight = [True] * len(polys)  # rings and the straight kinds' polylines
    for c in curves:
        polys.extend(c.polylines)
        src.extend([c.id] * len(c.polylines))
        straight.extend([c.kind in "ACD"] * len(c.polylines))
    size = np.fromiter((len(p) for p in polys), np.int64, len(polys))
    coords = np.vstack(polys)
    line = np.repeat(np.arange(len(polys)), size)
    # a polyline is kept if some coordinate differs from its first point
    first = np.repeat(np.cumsum(size) - size, size)
    moves = np.bincount(line, weights=np.any(coords != coords[first], axis=1),
                        minlength=len(polys))
    ok = (size >= 2) & (moves > 0)
    rows = ok[line]
    new_index = np.cumsum(ok) - 1
    xy, idx = coords[rows], new_index[line[rows]]
    # coincident straight copies (exactly coincident curves, rounded apart) made one exactly
    xy, idx = merge_collinear(xy, idx, idx < len(env.rings),
                              np.asarray(straight)[ok][idx])
    source = np.asarray(src)[ok]
    if tol is not None:
        xy, idx, source = _with_wall_stubs(env, xy, idx, source, tol)
    lines = shapely.linestrings(xy, indices=idx)
    k = np.flatnonzero(idx[1:] == idx[:-1])
    return np.asarray(lines, dtype=object), source, (xy[k], xy[k + 1], idx[k])


def _with_wall_stubs(env: Environment, xy: np.ndarray, idx: np.ndarray, source: np.ndarray,
                     tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines (vertices ``xy`` of lines ``idx``, sources ``source``) with the stubs of
    :func:`tether.coincidence.wall_stubs` added as lines of their curves."""
    head = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    tail = np.r_[head[1:] - 1, len(idx) - 1]
    curve = source[idx[head]] >= 0
    ends = np.concatenate((xy[head[curve]], xy[tail[curve]]))
    owner = np.tile(source[idx[head[curve]]], 2)
    free = np.asarray(env.polygon.contains(shapely.points(ends)), dtype=bool) \
        if len(ends) else np.zeros(0, bool)
    nr = len(env.rings)
    wall = idx[:-1] == idx[1:]
    wall &= idx[:-1] < nr
    w = np.flatnonzero(wall)
    stubs = wall_stubs(ends, free, xy[w], xy[w + 1], tol,
                       lambda q: env.polygon.contains(shapely.points(q)))
    if len(stubs) == 0:
        return xy, idx, source
    # each stub's curve: the end it starts from
    at = {tuple(p): o for p, o in zip(ends.tolist(), owner.tolist(), strict=True)}
    new_src = np.array([at[tuple(p)] for p in stubs[:, 0].tolist()])
    base = int(idx.max()) + 1
    return (np.vstack((xy, stubs.reshape(-1, 2))),
            np.concatenate((idx, np.repeat(np.arange(base, base + len(stubs)), 2))),
            np.concatenate((source, new_src)))


def _arrangement(env: Environment, curves: list[Curve], tol: float) -> _Arrangement:
    lines, source, (la, lb, lowner) = _input_lines(env, curves, tol)
    # the sources' segment grid built while GEOS nodes (it releases the GIL); for the reach
    # of floating-point noding (snap rounding's wider reach builds its own blocks)
    tree = SegmentGrid(la, lb)
    ready = in_background(tree.prepare, max(1e-3 * tol, 1e-12)) if len(la) else (lambda: None)
    parts, grid = node_lines(lines, tol, len(la))
    ready()
    release_memory()  # the noder's temporaries (~0.5 GB at 1,000 map vertices), before tracing
    parts = parts[shapely.length(parts) > 0]
    ends = _part_ends(parts)
    pa, pb, powner = _part_segments(ends)
    seg_len = np.hypot(*(pb - pa).T)
    longest = _first_max_per_group(seg_len, powner)  # the longest segment of each part
    traced = _trace_faces(parts, ends)
    if traced is not None:
        faces, part_faces = traced
    else:
        faces, part_faces = _polygonize_faces(parts, pa, pb, powner, longest)
    # which input lines each part came from: input segments near the middle of its longest
    # segment (a segment grid: distances to whole long polylines would dominate the time)
    mid = 0.5 * (np.take(pa, longest, axis=0) + np.take(pb, longest, axis=0))
    source = np.asarray(source, dtype=np.int64)
    base = int(source.max(initial=0)) + 2  # sources are -1 (wall) .. max
    keys = []  # (part, source) pairs as one integer key; in batches: their candidate pairs
    for lo in range(0, len(mid), SOURCE_BATCH):  # (1.3 M at 1,000 v) set the stage's peak
        qi, si, _ = _segments_near(mid[lo:lo + SOURCE_BATCH], la, lb,
                                   max(1e-3 * tol + 2 * grid, 1e-12), tree)
        keys.append(powner[longest[qi + lo]].astype(np.int64) * base + source[lowner[si]] + 1)
    del tree
    # distinct (part, source) pairs in (part, source) order
    key = np.sort(np.concatenate(keys)) if keys else np.zeros(0, np.int64)
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # np.unique hashes: slow
    part_of, src = np.divmod(key, base)
    ptr = np.searchsorted(part_of, np.arange(len(parts) + 1))
    arr = _Arrangement(parts, part_faces, ptr, src - 1, faces, grid)
    arr.__dict__["_end_ids"] = (ends[4][: len(parts)], ends[4][len(parts):])  # as end_ids()
    arr.__dict__["_part_segments"] = (pa, pb, powner)  # for segments(): not made again
    return arr


#: Parts whose sources are looked up per batch (bounds the candidate pairs' memory).
SOURCE_BATCH = 65536


def _polygonize_faces(parts: np.ndarray, pa: np.ndarray, pb: np.ndarray, powner: np.ndarray,
                      longest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_trace_faces` by ``shapely.polygonize`` (the fallback): the faces, and which
    faces lie on the two sides of each part, by matching the part's longest segment
    (``longest``: its index in the parts' segments ``pa-pb`` of owner ``powner``) with the
    faces' ring segments (polygonize keeps the noded coordinates exactly)."""
    faces = shapely.get_parts(shapely.polygonize(parts))
    fa, fb, fowner = _ring_segments(faces)
    ids = _segment_ids(np.vstack((pa[longest], fa)), np.vstack((pb[longest], fb)))
    part_ids, face_ids = ids[: len(longest)], ids[len(longest):]
    part_faces = np.full((len(parts), 2), -1)
    # the first two faces (in face order) having each part's longest segment in their ring
    order = np.argsort(face_ids, kind="stable")
    sorted_ids, owner_sorted = face_ids[order], fowner[order]
    pos = np.searchsorted(sorted_ids, part_ids)
    for slot in (0, 1):
        at = np.minimum(pos + slot, max(len(sorted_ids) - 1, 0))
        hit = (pos + slot < len(sorted_ids)) & (sorted_ids[at] == part_ids) if len(
            sorted_ids) else np.zeros(len(part_ids), bool)
        part_faces[powner[longest[hit]], slot] = owner_sorted[at[hit]]
    return faces, part_faces


def _part_ends(parts: np.ndarray) -> tuple[np.ndarray, ...]:
    """The parts' coordinates, each part's number of points, index of its first and of its
    last point there, and an id per end point (first points, then last points), equal for
    equal coordinates."""
    coords, idx = shapely.get_coordinates(parts, return_index=True)
    count = np.bincount(idx, minlength=len(parts))
    start = np.cumsum(count) - count  # parts have 2 or more points
    last = start + count - 1
    return coords, count, start, last, _point_ids(np.take(coords, np.r_[start, last], axis=0))


def _part_segments(ends: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_ring_segments` of the parts from their :func:`_part_ends` (the same arrays,
    without reading the coordinates again)."""
    coords, count, start = ends[:3]
    i = ragged_arange(start, count - 1)
    return (np.take(coords, i, axis=0), np.take(coords, i + 1, axis=0),
            np.repeat(np.arange(len(count)), count - 1))


def _trace_faces(parts: np.ndarray, ends: tuple | None = None
                 ) -> tuple[np.ndarray, np.ndarray] | None:
    """The faces of the noded ``parts`` (polygons) and the faces on the two sides of every
    part (``(nparts, 2)``, the smaller face id first, -1 for none), traced on the planar
    graph of the parts' half-edges in numpy instead of ``shapely.polygonize`` and matching
    rings back to parts (several times slower). As polygonize: dangles and cut edges bound
    no face (their parts get ``(-1, -1)``), rings touching themselves at a node are split
    into simple rings, counter-clockwise rings are shells, clockwise rings holes of the
    smallest shell containing them, the unbounded face is none. Returns None where the
    tracing cannot decide (two half-edges leaving a node in exactly the same direction,
    which noding rules out, or a ring with no point off its cycle's other rings): the caller
    polygonizes then. ``ends``: :func:`_part_ends` of the parts, if already computed."""
    n = len(parts)
    coords, count, start, last, ends = ends if ends is not None else _part_ends(parts)
    origin = np.empty(2 * n, np.int64)  # half-edge 2k runs along part k, 2k + 1 against it
    origin[0::2], origin[1::2] = ends[:n], ends[n:]
    nodes = int(ends.max(initial=-1)) + 1
    alive = _drop_dangles(origin, nodes)
    step = np.empty((2 * n, 2))  # each half-edge's first step from its origin
    step[0::2] = coords[start + 1] - coords[start]
    step[1::2] = coords[last - 1] - coords[last]
    for h in np.flatnonzero(~step.any(axis=1)).tolist():  # a repeated point (none seen)
        k, sign = h // 2, 1 - 2 * (h % 2)
        at = start[k] if sign > 0 else last[k]
        j = at + sign
        while not (coords[j] != coords[at]).any():  # parts have length > 0
            j += sign
        step[h] = coords[j] - coords[at]
    angle = np.arctan2(step[:, 1], step[:, 0])
    label = off = None
    for _ in range(2):  # the second pass without the cut edges
        nxt = _next_half_edges(origin, angle, alive)
        if nxt is None:
            return None
        label, off = _cycle_labels(nxt, alive)
        cut = alive[0::2] & (label[0::2] == label[1::2])  # one face on both sides
        if not cut.any():
            break
        alive[0::2] &= ~cut
        alive[1::2] &= ~cut
        off = None  # the labels are not those of the half-edges left
    # alive half-edges, cycle after cycle, in order
    seq = _cycle_order(nxt, label, alive) if off is None else _cycles_laid_out(label, off,
                                                                                alive)
    at = np.where(np.arange(2 * n) % 2 == 0, np.repeat(start, 2), np.repeat(last, 2))
    inner = np.where(np.repeat(count, 2) > 2, np.repeat(start + 1, 2), -1)
    loop = _split_pinched(seq, label[seq], origin, at, inner)
    if loop is None:
        return None
    ring_of, test_pt = loop
    # each ring's coordinates: every half-edge's points but its last, then the first again
    fwd = seq % 2 == 0
    k = seq // 2
    m = count[k] - 1
    # a half-edge's j-th point: its first point's index, then forwards or backwards
    ci = ragged_arange(np.zeros(len(seq), np.int64), m)
    ci *= np.repeat(np.where(fwd, 1, -1), m)
    ci += np.repeat(np.where(fwd, start[k], last[k]), m)
    ring_pt = np.repeat(ring_of, m)
    if np.any(ring_pt[1:] < ring_pt[:-1]):  # rings split off pinched cycles: numbered last
        order = np.argsort(ring_pt, kind="stable")
        ci, ring_pt = ci[order], ring_pt[order]
    nring = int(ring_of.max(initial=-1)) + 1
    first = np.searchsorted(ring_pt, np.arange(nring))
    ci = np.insert(ci, np.r_[first[1:], len(ci)], ci[first])  # close each ring
    xy = coords[ci]
    size = np.bincount(ring_pt, minlength=nring) + 1
    ring_ptr = np.r_[0, np.cumsum(size)]
    ccw = _rings_ccw(xy, ring_ptr)
    shell = np.flatnonzero(ccw)
    hole = np.flatnonzero(~ccw)
    face_of_ring = np.full(nring, -1)
    face_of_ring[shell] = np.arange(len(shell))
    faces = _ragged_polygons(xy, ring_ptr, shell, np.ones(len(shell), np.int64))
    # holes: in the smallest shell whose interior holds a point of theirs off every pinch
    # (the faces have no holes yet: their polygons are their shells)
    pts = shapely.points(coords[test_pt[hole]])
    hi, si = shapely.STRtree(faces).query(pts, predicate="within")
    area = shapely.area(faces)
    pick = np.lexsort((area[si], hi))
    hi, si = hi[pick], si[pick]
    head = np.r_[True, hi[1:] != hi[:-1]] if len(hi) else np.zeros(0, bool)
    face_of_ring[hole[hi[head]]] = si[head]
    # the faces with holes again: each shell then its holes
    inner = hole[face_of_ring[hole] >= 0]
    if len(inner):
        with_holes = np.unique(face_of_ring[inner])
        rows = np.concatenate((shell[with_holes], inner))
        o = np.argsort(face_of_ring[rows], kind="stable")
        faces[with_holes] = _ragged_polygons(xy, ring_ptr, rows[o], np.bincount(
            face_of_ring[rows], minlength=len(shell))[with_holes])
    side = np.full(2 * n, -1)
    side[seq] = face_of_ring[ring_of]
    pf = np.sort(side.reshape(n, 2), axis=1)
    one = pf[:, 0] < 0  # -1 (none) goes second
    pf[one] = pf[one][:, ::-1]
    pf[pf[:, 0] == pf[:, 1]] = -1
    return faces, pf


def _rings_ccw(xy: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """Whether each closed ring ``xy[ptr[r]:ptr[r + 1]]`` runs counter-clockwise: the sign of
    its shoelace sum about its first point where that exceeds the sum's rounding bound
    (nearly all), GEOS's robust ``is_ccw`` for the others (specks of ~1e-16 map units)."""
    nring = len(ptr) - 1
    size = np.diff(ptr)
    ring = np.repeat(np.arange(nring), size)
    d = xy - np.repeat(np.take(xy, ptr[:-1], axis=0), size, axis=0)
    a = d[:-1, 0] * d[1:, 1]
    b = d[1:, 0] * d[:-1, 1]
    # pairs of consecutive points, each summed in its first point's ring: a ring's last
    # point (its first again: d = 0) and the next ring's first (d = 0) add 0 to its sums
    row = ring[:-1]
    total = np.bincount(row, weights=a - b, minlength=nring)
    bound = np.bincount(row, weights=np.abs(a) + np.abs(b), minlength=nring)
    ccw = total > 0
    unsure = np.flatnonzero(np.abs(total) <= 8 * np.diff(ptr) * np.finfo(float).eps * bound)
    if len(unsure):
        idx = ragged_arange(ptr[unsure], ptr[unsure + 1] - ptr[unsure])
        rings = shapely.linearrings(xy[idx], indices=np.repeat(np.arange(len(unsure)),
                                                                size[unsure]))
        ccw[unsure] = shapely.is_ccw(rings)
    return ccw


def _ragged_polygons(xy: np.ndarray, ptr: np.ndarray, rings: np.ndarray,
                     per_polygon: np.ndarray) -> np.ndarray:
    """Polygons from closed rings ``xy[ptr[r]:ptr[r + 1]]``: ``rings`` in order, the first
    ``per_polygon[0]`` of them the first polygon (shell, then holes), and so on; built in one
    call, without intermediate ring objects."""
    size = ptr[rings + 1] - ptr[rings]
    idx = ragged_arange(ptr[rings], size)
    offsets = (np.r_[0, np.cumsum(size)], np.r_[0, np.cumsum(per_polygon)])
    return np.asarray(shapely.from_ragged_array(shapely.GeometryType.POLYGON, xy[idx],
                                                offsets), dtype=object)


def _drop_dangles(origin: np.ndarray, nodes: int) -> np.ndarray:
    """Which half-edges (``origin``: each one's start node, twins ``2k``, ``2k + 1``) remain
    once dangles are removed: parts with an end of degree 1, repeatedly."""
    alive = np.ones(len(origin), bool)
    deg = np.bincount(origin, minlength=nodes)  # alive half-edges leaving each node
    # and the sum of their indices (exact in floats): at a tip, its one half-edge
    total = np.bincount(origin, weights=np.arange(len(origin), dtype=float), minlength=nodes)
    tip = np.flatnonzero(deg == 1)
    while len(tip):
        part = np.unique(total[tip].astype(np.int64) // 2)
        alive[2 * part] = alive[2 * part + 1] = False
        gone = np.concatenate((2 * part, 2 * part + 1))
        end = origin[gone]
        np.subtract.at(deg, end, 1)
        np.subtract.at(total, end, gone.astype(float))
        tip = np.unique(end[deg[end] == 1])
    return alive


def _next_half_edges(origin: np.ndarray, angle: np.ndarray, alive: np.ndarray
                     ) -> np.ndarray | None:
    """The next half-edge of each alive one along its face (the face on its left): at its end
    node, the outgoing half-edge just clockwise of its twin. None if two half-edges leave a
    node in exactly the same direction."""
    live = np.flatnonzero(alive)
    order = _by_origin_then_angle(origin, angle, live)
    o, a = origin[order], angle[order]
    if np.any((o[1:] == o[:-1]) & (a[1:] == a[:-1])):
        return None
    pos = np.empty(len(origin), np.int64)
    pos[order] = np.arange(len(order))
    gstart = np.flatnonzero(np.r_[True, o[1:] != o[:-1]])
    prev = np.arange(-1, len(order) - 1)  # the one before in the sorted order, cyclic per node
    prev[gstart] = np.r_[gstart[1:], len(order)] - 1
    nxt = np.full(len(origin), -1)
    nxt[live] = order[prev[pos[live ^ 1]]]  # from each half-edge's twin, in the sorted order
    return nxt


def _by_origin_then_angle(origin: np.ndarray, angle: np.ndarray, live: np.ndarray
                          ) -> np.ndarray:
    """``live[np.lexsort((angle[live], origin[live]))]`` (``origin``: integers from 0,
    ``angle``: radians in ``[-pi, pi]``), by one sort of ``origin + (angle + pi) / (4 pi)``:
    that key grows with the origin, then with the angle, but may round distinct angles of
    one origin to equal keys. The order is the lexsort's if the angles then strictly
    increase within each origin (no ties: the sorted order is unique), else the lexsort
    is made."""
    o, a = origin[live], angle[live]
    order = live[np.argsort(o + (a + np.pi) * (0.25 / np.pi))]
    o, a = origin[order], angle[order]
    if np.all(o[1:] >= o[:-1]) and not np.any((o[1:] == o[:-1]) & (a[1:] <= a[:-1])):
        return order
    return live[np.lexsort((angle[live], origin[live]))]


def _cycle_labels(nxt: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest half-edge of each alive half-edge's cycle under ``nxt`` (dead ones: their
    own index), and the steps from the half-edge to it along ``nxt`` (0 for itself).
    Pointer doubling: ``label[h]`` is the least of the ``2^k`` half-edges from ``h`` on,
    first met ``off[h]`` steps on, ``jump[h]`` the one after them; once a round changes no
    label, each label is its cycle's least (following ``jump`` from ``h`` the labels cannot
    decrease, so they are equal all around, and those windows cover the cycle)."""
    small = np.int32 if len(nxt) < 2**31 else np.int64  # less memory read per round
    label = np.arange(len(nxt), dtype=small)
    off = np.zeros(len(nxt), small)
    jump = np.where(alive, nxt, np.arange(len(nxt)))
    span = 1
    while True:
        ahead = label[jump]
        take = np.flatnonzero(ahead < label)  # the least only in the window's second half
        if len(take) == 0:
            return label.astype(np.int64), off.astype(np.int64)
        label[take] = ahead[take]
        off[take] = off[jump[take]] + span
        jump = jump[jump]
        span *= 2


def _cycles_laid_out(label: np.ndarray, off: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """:func:`_cycle_order` from the cycles' labels and each half-edge's steps to its label
    (:func:`_cycle_labels`): every half-edge put at its place, no sort."""
    live = np.flatnonzero(alive)
    lab = label[live]
    first = live[lab == live]  # the cycles' least half-edges, increasing
    cycle = np.empty(len(label), np.int64)
    cycle[first] = np.arange(len(first))
    c = cycle[lab]
    size = np.bincount(c, minlength=len(first))
    n = size[c]
    at = (n - off[live]) % np.maximum(n, 1)  # steps from the label to it
    seq = np.empty(len(live), np.int64)
    seq[(np.cumsum(size) - size)[c] + at] = live
    return seq


def _cycle_order(nxt: np.ndarray, label: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """The alive half-edges cycle after cycle (by smallest half-edge), each cycle from its
    smallest half-edge along ``nxt`` (list ranking by pointer doubling)."""
    live = np.flatnonzero(alive)
    succ = nxt.copy()
    tail = np.zeros(len(nxt), bool)
    tail[live] = nxt[live] == label[live]  # the last half-edge of its cycle
    succ[~alive | tail] = np.flatnonzero(~alive | tail)
    dist = np.where(alive & ~tail, 1, 0)  # steps to the cycle's last half-edge
    act = np.flatnonzero(succ[succ] != succ)  # not yet pointing at their cycle's last
    while len(act):  # pointer doubling on the half-edges still jumping (long cycles)
        s = succ[act]
        dist[act] += dist[s]
        succ[act] = succ[s]
        act = act[succ[succ[act]] != succ[act]]
    return live[np.lexsort((-dist[live], label[live]))]


def _split_pinched(seq: np.ndarray, lab: np.ndarray, origin: np.ndarray, at: np.ndarray,
                   inner: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Simple rings from the cycles ``seq`` (half-edges cycle after cycle, in order; ``lab``:
    their cycle): a cycle passing a node twice is cut there into rings (rare: a Python loop
    over those cycles only). Returns the ring of every position of ``seq`` and, per ring, the
    coordinate index of a point of it on no other ring of its cycle (a node passed once, or
    an inner point of a part: ``at`` and ``inner`` per half-edge, -1 for none), None if a
    ring has none."""
    new = np.r_[True, lab[1:] != lab[:-1]] if len(lab) else np.zeros(0, bool)
    ring = np.cumsum(new) - 1
    test = at[seq[new]]
    key = ring * (int(origin.max(initial=0)) + 1) + origin[seq]
    srt = np.sort(key)
    dup = srt[1:][srt[1:] == srt[:-1]]
    pinched = np.unique(dup // (int(origin.max(initial=0)) + 1))
    if len(pinched) == 0:
        return ring, test
    ring = ring.copy()
    tests = test.tolist()
    starts = np.flatnonzero(new)
    stops = np.r_[starts[1:], len(seq)]
    for c in pinched.tolist():
        a, b = int(starts[c]), int(stops[c])
        nodes = origin[seq[a:b]].tolist()
        seen: dict[int, int] = {}
        for v in nodes:
            seen[v] = seen.get(v, 0) + 1
        loops: list[list[int]] = []
        stack: list[int] = []  # positions in seq
        where: dict[int, int] = {}
        for p, v in zip(range(a, b), nodes, strict=True):
            if v in where:
                i = where[v]
                loops.append(stack[i:])
                for q in stack[i:]:
                    del where[int(origin[seq[q]])]
                del stack[i:]
            where[v] = len(stack)
            stack.append(p)
        loops.append(stack)
        for j, lp in enumerate(loops):
            free = [int(at[seq[q]]) for q in lp if seen[int(origin[seq[q]])] == 1]
            free += [int(inner[seq[q]]) for q in lp if inner[seq[q]] >= 0]
            if not free:
                return None
            r = c if j == 0 else len(tests)
            if j:
                tests.append(0)
            ring[lp] = r
            tests[r] = free[0]
    return ring, np.asarray(tests, dtype=np.int64)


def _first_max_per_group(value: np.ndarray, group: np.ndarray) -> np.ndarray:
    """For ``group`` sorted (runs of equal values, all present from 0), the index of the
    first largest ``value`` of each run: ``np.lexsort((-value, group))``'s first row per run,
    without the sort."""
    if len(value) == 0:
        return np.zeros(0, np.int64)
    start = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    top = np.maximum.reduceat(value, start)
    run = np.cumsum(np.r_[True, group[1:] != group[:-1]]) - 1
    hit = np.flatnonzero(value == top[run])
    return hit[np.r_[True, run[hit][1:] != run[hit][:-1]]]


def _segment_tree(a: np.ndarray, b: np.ndarray) -> shapely.STRtree:
    """An STRtree of the segments ``a[k]-b[k]``."""
    return shapely.STRtree(shapely.linestrings(np.stack((a, b), axis=1)))


def _segments_near(pts: np.ndarray, a: np.ndarray, b: np.ndarray, reach: float,
                   tree: shapely.STRtree | SegmentGrid
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs (point, segment) closer than ``reach`` (map units) for points (m, 2) and
    segments ``a[k]-b[k]`` indexed by ``tree`` (an STRtree or, faster, a
    :class:`SegmentGrid`; the same pairs): point indices, segment indices, distances."""
    if len(pts) == 0 or len(a) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    qi, si = _segment_pairs(pts, reach, tree)  # envelopes only; exact distances below
    if isinstance(tree, SegmentGrid):
        d = _pair_distances(pts[:, 0][qi], pts[:, 1][qi], tree, si)
    else:
        d = _point_segment_distance_xy(pts[:, 0][qi], pts[:, 1][qi], a[:, 0][si],
                                       a[:, 1][si], b[:, 0][si], b[:, 1][si])
    near = np.flatnonzero(d <= reach)
    return qi[near], si[near], d[near]


def _segment_pairs(pts: np.ndarray, reach: float, tree: shapely.STRtree | SegmentGrid
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (point, segment) of the points (m, 2) and the segments indexed by ``tree``
    whose bounding box meets the point's box ``[p - reach, p + reach]``: an STRtree's
    answer, or a :class:`SegmentGrid`'s (the same pairs, without making the boxes)."""
    if isinstance(tree, SegmentGrid):
        return tree.meeting(pts - reach, pts + reach)
    box = shapely.box(pts[:, 0] - reach, pts[:, 1] - reach, pts[:, 0] + reach,
                      pts[:, 1] + reach)
    qi, si = tree.query(box)
    return qi, si


def _pair_distances(px: np.ndarray, py: np.ndarray, grid: SegmentGrid, si: np.ndarray
                    ) -> np.ndarray:
    """:func:`_point_segment_distance_xy` from points ``(px[k], py[k])`` to the grid's
    segments ``si[k]`` (the same numbers: the segments' directions and squared lengths are
    the grid's, computed alike once per segment), in place on few temporaries."""
    ax, ay, ex, ey, den = grid.ax[si], grid.ay[si], grid.ex[si], grid.ey[si], grid.den[si]
    u = px - ax
    u *= ex
    t = py - ay
    t *= ey
    u += t
    with np.errstate(invalid="ignore", divide="ignore"):
        u /= den
    u[~(den > 0)] = 0.0
    np.clip(u, 0.0, 1.0, out=u)
    np.multiply(u, ey, out=t)
    t += ay
    t -= py
    u *= ex
    u += ax
    u -= px
    return np.hypot(u, t, out=u)


def _point_segment_distance_xy(px: np.ndarray, py: np.ndarray, ax: np.ndarray,
                               ay: np.ndarray, bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    """:func:`_point_segment_distance` on coordinate columns (the same numbers, without the
    (k, 2) temporaries)."""
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(den > 0, ((px - ax) * abx + (py - ay) * aby) / den, 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.hypot(ax + u * abx - px, ay + u * aby - py)


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise distance from points ``p`` to segments ``a-b`` (all shape (k, 2))."""
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(den > 0, np.einsum("ij,ij->i", p - a, ab) / den, 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.hypot(*(a + u[:, None] * ab - p).T)


def _face_points(faces: np.ndarray, tol: float, grid: float = 0.0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """A point well inside each face and its distance to the face's boundary (map units).

    ``point_on_surface`` first; faces where it lies closer than ``4 tol`` to the boundary get
    the centre of their maximum inscribed circle instead if that is farther. The circle (the
    costly step) is skipped where it cannot change a result: faces that cannot be resolved
    (:data:`MIC_MIN_BOUND`; :func:`_decompose` only compares clearances with ``2 tol`` and,
    among resolved faces, with each other) whose point is clear of the boundary by more than
    rounding and the noding ``grid`` (whether the face is in the free space is then the same
    at either point; specks of ~1e-16 map units, where it is not, get their circle: cheap)."""
    inside = map_chunks(shapely.point_on_surface, faces)  # element-wise: on every core
    pts = shapely.get_coordinates(inside)
    clear = map_chunks(_boundary_distance, np.arange(len(faces)), faces=faces, points=inside)
    thin = np.flatnonzero(clear < 4 * tol)
    speck = clear[thin] < 1e-6 * tol + 2 * grid
    thin = thin[speck | (_inradius_bound(faces[thin]) >= MIC_MIN_BOUND * tol)]
    if len(thin):
        # the costly step (long slivers), face by face: on every core
        circ = map_chunks(shapely.maximum_inscribed_circle, faces[thin], tolerance=0.1 * tol)
        c = shapely.get_coordinates(circ)[::2]
        r = shapely.length(circ)
        better = r > clear[thin]
        pts[thin[better]] = c[better]
        clear[thin[better]] = r[better]
    return pts, clear


def _boundary_distance(rows: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The distance from ``points[rows]`` to the boundaries of ``faces[rows]`` (map units)."""
    return shapely.distance(shapely.boundary(faces[rows]), points[rows])


#: Faces whose inradius bound (:func:`_inradius_bound`) is below this many curve tolerances
#: get no inscribed circle: their inradius is below ``2 tol`` with a margin of 4/3 (the bound
#: holds up to rounding: measured within 4e-8 relative on faces clear of specks, the faces
#: that get the circle anyway; specks of ~1e-16 map units exceed it by up to 2x).
MIC_MIN_BOUND = 1.5


def _inradius_bound(polys: np.ndarray) -> np.ndarray:
    """An upper bound of each polygon's inradius (map units): ``2 area / perimeter`` of its
    convex hull (a convex set containing a disc of radius ``r`` has area at least
    ``r * perimeter / 2``; the polygon's disc lies in its hull). Vectorized, cheap."""
    if len(polys) == 0:
        return np.zeros(0)
    hull = shapely.convex_hull(polys)
    with np.errstate(invalid="ignore", divide="ignore"):
        bound = 2 * shapely.area(hull) / shapely.length(hull)
    return np.nan_to_num(bound, nan=0.0)


def decompose(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL,
              progress: Any = None) -> Decomposition:
    """Decompose the free space for rod length ``lss`` into regions, cells and pieces.

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units, > 0.
    rel_tol : float
        Curve approximation tolerance relative to the map diameter.
    progress : callable, optional
        Called as ``progress(stage_name, fraction_done)``.

    Returns
    -------
    Decomposition

    Raises
    ------
    InvalidParameterError
        If ``lss`` is not a finite positive number within the range of
        :func:`tether.arcs.check_lss` relative to the map's diameter.
    ArrangementError
        If the geometry engine fails even with snap rounding (one line, no traceback).
    """
    lss = check_lss(lss, env)
    out, inner_lss = None, lss
    if not env.is_internal:  # computed in the normalized frame, reported in the user's
        from tether.userframe import UserFrame

        out = UserFrame(env, lss)
        inner_lss = check_lss(lss * env.frame.scale, env.internal)
    try:
        with gc_paused():
            dec = _decompose(env.internal, inner_lss, rel_tol, progress, out)
    except GEOSException as exc:  # never a traceback from the geometry engine
        raise ArrangementError(f"geometry engine failed on map {env.name!r} at lss {lss:g}: "
                               f"{geos_message(exc)}") from exc
    if out is not None:
        release_memory()  # the arrangement and the internal frame's geometries, freed
    return dec


def _face_regions(arr: _Arrangement, keep: np.ndarray, resolved: np.ndarray,
                  face_sid: np.ndarray, pts: np.ndarray, clear: np.ndarray, tol: float,
                  lss: float) -> tuple[dict[str, Any], _Chains, _Candidates]:
    """The faces ``keep`` (in the free space; ``resolved`` flags those with a structure, of
    structure ids ``face_sid`` per face, -1: none; points ``pts`` and clearances ``clear``)
    grouped into numbered regions, with the chains between regions and their crossing
    candidates. Sub-resolution faces, then speck regions no chain of which has a candidate,
    join neighbours (``face_sid`` is updated: the structure taken)."""
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
    uf.parent = _components(nf, adjacent[same, 0], adjacent[same, 1]).tolist()
    plen = shapely.length(arr.parts)
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
    chains = _chains(arr, face_region)
    return numbering, chains, _crossing_candidates(arr, chains, tol, lss)


def _decompose(env: Environment, lss: float, rel_tol: float, progress: Any,
               out: UserFrame | None = None) -> Decomposition:
    """The decomposition of the internal map ``env`` for rod length ``lss`` (internal units),
    reported as is, or in the user's frame of ``out`` (the result objects made once)."""
    tol = rel_tol * env.diameter
    report = progress or (lambda stage, frac: None)
    report("critical curves", 0.0)
    curves = critical_curves(env, lss, rel_tol)
    report("arrangement", 0.3)
    arr = _arrangement(env, curves, tol)
    release_memory()  # the noder's and the face tracing's temporaries
    report("face structures", 0.5)
    pts, clear = _face_points(arr.faces, tol, arr.grid)
    inside = np.asarray(env.contains(pts[:, 0], pts[:, 1]), dtype=bool)
    # and not on a wall: walls are arrangement parts (moved at most 0.71 grid by snapping),
    # so a point farther than tol + grid from its face's boundary is off every wall
    near = np.flatnonzero(inside & (clear < tol + arr.grid))
    inside[near] = np.asarray(env.boundary_distance(pts[near, 0], pts[near, 1]) > 0)
    # a face belongs to the free space iff its interior point does (faces inside holes, or
    # between an overshooting curve end and an obstacle, are dropped)
    keep = np.flatnonzero(inside)
    resolved = clear[keep] >= 2 * tol
    ok = keep[resolved]
    _off_edge_lines(env, pts, ok, lss)
    table = free_arcs_many(env, np.take(pts, ok, axis=0), lss, check=False)
    sid, structs = structure_ids(env, table, len(ok))
    del table
    face_sid = np.full(len(arr.faces), -1, dtype=np.int64)  # the structure id of each face
    face_sid[ok] = sid
    release_memory()
    report("regions", 0.7)
    numbering, chains, cands = _face_regions(arr, keep, resolved, face_sid, pts, clear, tol,
                                             lss)
    # the segments' grid and the candidates cache are no longer needed: freed before the
    # pieces allocate theirs (at 1,000 map vertices the grid is ~100 MB)
    arr.__dict__.pop("_segments", None)
    arr.__dict__.pop("_part_candidates", None)
    release_memory()
    # the regions made after that: their polygons and cells do not add to the grid's peak
    regions, cells, codes = _make_regions(env, arr, numbering, face_sid, structs, out)
    report("pieces", 0.85)
    pieces, unresolved_pieces, arcs = _make_pieces(env, arr, regions, chains, cands, curves,
                                                    lss)
    longest = _longest_unresolved(arr, chains, cands)
    report("done", 1.0)
    if out is None:
        dec = Decomposition(env, lss, tuple(curves), tuple(regions), cells, _Pieces(pieces),
                            tol, unresolved_pieces, longest)
    else:  # the regions' polygons and structures and the pieces to the user's frame
        del arr, chains, cands  # the arrangement, freed first
        out.regions(regions)
        out.pieces(pieces)
        if longest is not None:
            longest["length"] /= out.scale
            longest["point"] = out.points(longest["point"])[0].tolist()
        dec = Decomposition(out.env, out.lss, out.curves(curves), tuple(regions), cells,
                            _Pieces(pieces), tol / out.scale, unresolved_pieces, longest)
        arcs = out.crossing_arcs(arcs)
    dec.__dict__["_crossing_arcs"] = arcs  # computed while choosing the crossings
    dec.__dict__["_cell_codes"] = codes  # known when the cells were made
    return dec


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


def _isolated_regions(arr: _Arrangement, face_region: np.ndarray, nreg: int, tol: float,
                      lss: float) -> set[int]:
    """The regions (of ``face_region``, ``nreg`` of them) no chain of which would have a
    crossing candidate (see :func:`_crossing_candidates`): none of the parts between the
    region and another has a candidate point clear of the other parts by ``4 tol``. The
    parts' candidates only: no chains."""
    fr = np.append(face_region, -1)  # index -1 (no face) maps to the last slot, -1
    ra, rb = fr[arr.part_faces[:, 0]], fr[arr.part_faces[:, 1]]
    between = (ra >= 0) & (rb >= 0) & (ra != rb)
    _, mine, clear = _part_candidates(arr, between, tol, lss)
    good = mine[clear >= 4 * tol]
    touched = np.zeros(nreg, bool)
    touched[ra[good]] = True
    touched[rb[good]] = True
    return set(np.flatnonzero(~touched).tolist())


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


def _number_regions(arr: _Arrangement, flat: np.ndarray, size: np.ndarray, pts: np.ndarray,
                    clear: np.ndarray) -> dict[str, Any]:
    """Regions from groups of faces (``flat``: the faces group after group, ``size``: each
    group's count), numbered by representative point (x, then y): the point of the group's
    face farthest from its boundary. Returns the groups' best faces, areas and points, the
    group of each region id (``rank``) and the region of every face (-1: none); the groups'
    faces (``flat`` and ``size``, for the regions made) are added by :func:`_face_regions`."""
    face_area = arr.__dict__.get("_face_area")
    if face_area is None:
        face_area = arr.__dict__["_face_area"] = shapely.area(arr.faces)
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
    return _first_max_per_group(value, group)


def _make_regions(env: Environment, arr: _Arrangement, numbering: dict[str, Any],
                  face_sid: np.ndarray, structs: _Structures, out: UserFrame | None = None
                  ) -> tuple[list[Region], _Cells, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The :class:`Region` objects of a numbering (:func:`_number_regions`): polygon (the
    union of the faces, made on the first read: :class:`_RegionShapes`), area, point,
    structure and cells; the cells (a :class:`_Cells` over int columns, region by region,
    each region's in the order of :func:`structure_names`); and the cells' ``(region, start
    code, end code)`` columns (:meth:`Decomposition.cell_codes`, the file's codes). The
    structures are ids into one shared :class:`_Structures` (``structs``, of the faces'
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
    region, start, end = _structure_cells(env, structs, sid)
    if out is None:
        names = [FREE] + _feature_names(env)
    else:  # the file's codes and names
        cm = np.append(np.asarray(out.code_map, dtype=np.int64), -1)  # index -1: stays -1
        start, end = cm[start], cm[end]
        names = [FREE] + [feature_name(out.env, c) for c in range(2 * out.env.n)]
    table = _CellTable(region, start, end, names, len(rank))
    area_l = area.tolist()
    point_l = point.tolist()
    regions = [Region(rid, polys, area_l[g], (point_l[g][0], point_l[g][1]), structs, table)
               for rid, g in enumerate(rank)]
    return regions, _Cells(table), (region, start, end)


def _region_shapes(arr: _Arrangement, flat: np.ndarray, size: np.ndarray, rank: np.ndarray,
                   out: UserFrame | None) -> _RegionShapes:
    """The regions' polygons (region ``i`` is the group ``rank[i]`` of the faces ``flat``,
    group after group, ``size`` faces each): single faces as they are, unions of several
    made on the first read (their faces gathered at once, each region's a slice)."""
    first = (np.cumsum(size) - size)[rank]  # each region's first face, in ``flat``
    count = size[rank]
    polys = arr.faces[flat[first]]
    multi = np.flatnonzero(count > 1)
    k = count[multi]
    faces = arr.faces[flat[ragged_arange(first[multi], k)]]
    end = np.cumsum(k)
    unions = {rid: faces[a:b] for rid, a, b in zip(multi.tolist(), (end - k).tolist(),
                                                    end.tolist(), strict=True)}
    return _RegionShapes(polys, unions, None if out is None else out.frame)


def _structure_cells(env: Environment, structs: _Structures, sid: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cells of regions of structure ids ``sid`` (of ``structs``): ``(region, start code,
    end code)`` int columns, region by region, each region's cells sorted by (start name, end
    name) as :func:`structure_codes` sorts them (one sort on name ranks over every
    distinct structure; a FULL region's cell is ``(-1, -1)``, an EMPTY one has none)."""
    n = len(sid)
    if n == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
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
    a, b = a[order], b[order]
    count = size[inv.ravel()]
    rows = ragged_arange(starts[inv.ravel()], count)
    region = np.repeat(np.arange(n, dtype=np.int64), count)
    return region, a[rows], b[rows]


def feature_name_rank(env: Environment) -> np.ndarray:
    """``rank[code + 1]``: the position of feature ``code``'s name (``FREE`` for -1) among all
    of them sorted as strings, cached per map."""
    got = env.__dict__.get("_feature_name_rank")
    if got is None:
        names = [FREE] + _feature_names(env)
        got = np.empty(len(names), dtype=np.int64)
        got[sorted(range(len(names)), key=names.__getitem__)] = np.arange(len(names))
        env.__dict__["_feature_name_rank"] = got
    return got


@dataclass
class _Chains:
    """Chains of arrangement parts (CSR): chain ``i`` separates regions ``pair[i, 0] <
    pair[i, 1]`` and is made of the parts ``parts[ptr[i]:ptr[i + 1]]`` (increasing). Chains
    are sorted by region pair, then first part."""

    pair: np.ndarray
    ptr: np.ndarray
    parts: np.ndarray

    def __len__(self) -> int:
        return len(self.pair)

    @property
    def size(self) -> np.ndarray:
        """Number of parts of each chain."""
        return np.diff(self.ptr)


def _chains(arr: _Arrangement, face_region: np.ndarray) -> _Chains:
    """Arrangement parts separating two regions, grouped into chains: parts that meet end to
    end and share a source curve. Vectorized: parts sharing (region pair, end point, source)
    are linked, chains are the connected components."""
    fr = np.append(face_region, -1)  # index -1 (no face) maps to the last slot, -1
    ra, rb = fr[arr.part_faces[:, 0]], fr[arr.part_faces[:, 1]]
    parts = np.flatnonzero((ra >= 0) & (rb >= 0) & (ra != rb))
    if len(parts) == 0:
        return _Chains(np.zeros((0, 2), np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    first_id, last_id = arr.end_ids()
    end_id = np.concatenate((first_id[parts], last_id[parts]))
    sptr, sflat = arr.sources()
    nsrc = sptr[parts + 1] - sptr[parts]
    src = sflat[ragged_arange(sptr[parts], nsrc)]
    local = np.tile(np.repeat(np.arange(len(parts)), nsrc), 2)  # rows: (end, source)
    end_of_row = np.concatenate((np.repeat(end_id[: len(parts)], nsrc),
                                 np.repeat(end_id[len(parts):], nsrc)))
    src_row = np.tile(src, 2)
    # rows of one (region pair, end point, source) group are linked (any links connecting
    # the group: the components, labelled by their smallest part, do not depend on which)
    pair = np.unique(lo[parts] * (int(hi.max()) + 1) + hi[parts], return_inverse=True)[1]
    u, v = _equal_row_links((pair.ravel()[local], end_of_row, src_row + 1))
    comp = _components(len(parts), local[u], local[v])
    # chains sorted by (region pair, first part): parts in increasing order within each
    order = np.lexsort((parts, comp))
    comp_o, parts_o = comp[order], parts[order]
    starts = np.flatnonzero(np.r_[True, comp_o[1:] != comp_o[:-1]])
    stops = np.r_[starts[1:], len(parts_o)]
    head = parts_o[starts]
    rank = np.lexsort((head, hi[head], lo[head]))
    h = head[rank]
    size = (stops - starts)[rank]
    return _Chains(np.column_stack((lo[h], hi[h])), np.r_[0, np.cumsum(size)],
                   parts_o[ragged_arange(starts[rank], size)])


def _equal_row_links(cols: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Links ``(u[k], v[k])`` between rows (of the columns ``cols``, non-negative integers)
    connecting every group of equal rows: rows next to each other in sorted order. The
    columns are packed into one integer per row (one sort) when their ranges allow it, else
    each row is linked to its group's first (:func:`_row_ids`, hashed rows)."""
    n = len(cols[0])
    key = np.zeros(n, np.int64)
    size = 1
    for c in cols:
        span = int(c.max(initial=0)) + 1
        size *= span
        if size >= 2**62:
            group, first = _row_ids(np.column_stack(cols))
            return np.arange(n), first[group]
        key = key * span + c
    order = np.argsort(key)
    same = np.flatnonzero(key[order[1:]] == key[order[:-1]])
    return order[same], order[same + 1]


def _components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` nodes with edges ``u[k]-v[k]``: a label per
    node (the smallest node of its component). Min-label propagation with pointer jumping,
    in numpy (scipy.sparse would cost 0.2 s of import on every CLI call)."""
    label = np.arange(n)
    while True:
        m = np.minimum(label[u], label[v])
        new = label.copy()
        np.minimum.at(new, u, m)
        np.minimum.at(new, v, m)
        new = new[new]  # pointer jumping
        if np.array_equal(new, label):
            return label
        label = new


def _point_ids(pts: np.ndarray) -> np.ndarray:
    """An integer id per point, equal for equal coordinates."""
    return _row_ids(pts)[0]


def _make_pieces(env: Environment, arr: _Arrangement, regions: list[Region], chains: _Chains,
                 cands: _Candidates, curves: list[Curve], lss: float
                 ) -> tuple[_PieceTable, int, ArcTable]:
    """One piece per chain with a crossing sample. Returns the pieces (as columns), the
    number of chains dropped as below resolution (no candidate point clear of other curves by
    ``4 tol``: artefacts of the polyline approximation at tangencies, where the exact regions
    touch at a point only) and the exact arcs at both sides of every piece's crossing (see
    :meth:`Decomposition.crossing_arcs`)."""
    sptr, ssrc = arr.chain_sources(chains)
    got, tables = _pick_crossings(env, chains, cands, regions, curves, (sptr, ssrc), lss)
    kept = np.flatnonzero(cands.count > 0)  # the chains with a crossing sample
    # the pieces' arcs first, the rounds' tables freed before the pieces are made: a lower
    # peak (at 1,000 map vertices each table is ~100 MB)
    arcs = _crossing_table(tables, got["at"][kept])
    del tables
    release_memory()
    geoms = _chain_geometries(arr, chains, kept)
    desc, descs = _describe_chains(sptr, ssrc, kept, curves)
    table = _PieceTable(chains.pair[kept].astype(np.int64), got["q"][kept], got["n"][kept],
                        got["eps"][kept], got["ok"][kept], desc, descs, _Shapes(geoms))
    return table, len(chains) - len(kept), arcs


def _longest_unresolved(arr: _Arrangement, chains: _Chains, cands: _Candidates
                        ) -> dict | None:
    """The longest chain without a crossing sample (internal units): its length, regions and
    middle point; None if every chain has one."""
    dropped = np.flatnonzero(cands.count == 0)
    if len(dropped) == 0:
        return None
    geoms = _chain_geometries(arr, chains, dropped)
    length = shapely.length(geoms)
    i = int(np.argmax(length))
    mid = shapely.line_interpolate_point(shapely.line_merge(geoms[i]), 0.5, normalized=True) \
        if shapely.get_type_id(geoms[i]) in (1, 5) else shapely.centroid(geoms[i])
    return {"length": float(length[i]),
            "regions": [f"R{r}" for r in chains.pair[dropped[i]].tolist()],
            "point": shapely.get_coordinates(mid)[0].tolist()}


def _describe_chains(sptr: np.ndarray, ssrc: np.ndarray, which: np.ndarray,
                     curves: list[Curve]) -> tuple[np.ndarray, list[tuple]]:
    """The descriptions of the chains ``which``, whose curves are ``ssrc[sptr[i]:sptr[i +
    1]]`` (sorted, distinct): an id per chain into the returned list of distinct ``(curves,
    kinds, features)`` (the curves' tuple, their kind letters sorted, ``"?"`` for none, and
    their features in order, each once). Chains of equal curves share an id, found
    vectorized, size by size (:func:`_row_ids`); each distinct one is described once."""
    start = sptr[which]
    size = sptr[which + 1] - start
    desc = np.zeros(len(which), np.int64)
    descs: list[tuple] = []
    for s in np.unique(size).tolist():
        rows = np.flatnonzero(size == s)
        keys = ssrc[start[rows, None] + np.arange(s)]  # (k, s): each chain's curves
        ids, first = _row_ids(keys) if s else (np.zeros(len(rows), np.int64), [0])
        desc[rows] = ids + len(descs)
        for key in keys[first].tolist():
            kinds = "".join(sorted({curves[c].kind for c in key})) or "?"
            feats = tuple(dict.fromkeys(f for c in key for f in curves[c].features))
            descs.append((tuple(key), kinds, feats))
    return desc, descs


def _chain_geometries(arr: _Arrangement, chains: _Chains, which: np.ndarray) -> np.ndarray:
    """The lines of the chains ``which`` (an object array): a chain's part, or its parts
    merged into as few lines as they form (all multi-part chains at once)."""
    size = chains.size[which]
    out = arr.parts[chains.parts[chains.ptr[which]]]  # single parts as they are
    multi = np.flatnonzero(size > 1)
    if len(multi):
        rows = ragged_arange(chains.ptr[which[multi]], size[multi])
        lines = shapely.multilinestrings(arr.parts[chains.parts[rows]],
                                         indices=np.repeat(np.arange(len(multi)), size[multi]))
        out[multi] = shapely.line_merge(lines)
    return out


@dataclass
class _Candidates:
    """Candidate crossing points of every chain (CSR): chain ``i``'s candidates, best first,
    are rows ``ptr[i]:ptr[i + 1]`` of ``q`` (points, map units) and ``eps`` (offsets)."""

    ptr: np.ndarray
    q: np.ndarray
    eps: np.ndarray

    @property
    def count(self) -> np.ndarray:
        """Number of candidates of each chain."""
        return np.diff(self.ptr)


def _crossing_candidates(arr: _Arrangement, chains: _Chains, tol: float, lss: float
                         ) -> _Candidates:
    """For every chain, candidate crossing points (midpoints of the 6 longest segments of
    each of its parts) with their offsets ``eps``, best clearance first (up to 8; among equals
    in part order); only points clear of every other part by ``4 tol``. All chains are
    handled in one vectorized pass."""
    need = np.zeros(len(arr.parts), bool)
    need[chains.parts] = True
    Q, mine, clear = _part_candidates(arr, need, tol, lss)  # in (part, rank) order
    # the rows chain after chain (a chain's parts in increasing order), then by clearance
    first = np.searchsorted(mine, np.arange(len(arr.parts) + 1))
    per_part = first[chains.parts + 1] - first[chains.parts]
    rows = ragged_arange(first[chains.parts], per_part)
    chain = np.repeat(np.repeat(np.arange(len(chains)), chains.size), per_part)
    ok = np.flatnonzero(clear[rows] >= 4 * tol)
    rows, chain = rows[ok], chain[ok]
    count = np.bincount(chain, minlength=len(chains))
    start = np.cumsum(count) - count
    rows = rows[_descending_within_runs(clear[rows], start, count)]
    # the best 8 of each chain (rank within the chain's run)
    rank = np.arange(len(rows)) - np.repeat(start, count)
    rows = rows[rank < 8]
    cap = max(50 * tol, 1e-4 * lss)
    eps = np.minimum(0.25 * (clear[rows] - tol), cap)
    ptr = np.r_[0, np.cumsum(np.minimum(count, 8))]
    return _Candidates(ptr, np.take(Q, rows, axis=0).reshape(-1, 2), eps)


def _descending_within_runs(value: np.ndarray, start: np.ndarray, count: np.ndarray,
                            width: int = 8) -> np.ndarray:
    """The order of rows sorting each run ``start[i]:start[i] + count[i]`` (runs one after
    the other, covering the rows) by ``value``, largest first, equals in row order: that of
    ``np.lexsort((-value, run))``. Runs of up to ``width`` rows are sorted as the rows of one
    padded matrix (no sort of all the rows), longer ones by a lexsort of their rows."""
    n = len(value)
    order = np.arange(n)
    if n == 0:
        return order
    if np.isnan(value).any():
        run = np.repeat(np.arange(len(count)), count)
        return np.lexsort((-value, run))
    short = np.flatnonzero((count > 1) & (count <= width))
    if len(short):
        idx = start[short][:, None] + np.arange(width)
        real = np.arange(width) < count[short][:, None]
        idx = np.where(real, idx, n - 1)
        neg = np.where(real, -value[idx], np.inf)  # padding after every value, -inf too
        srt = np.take_along_axis(idx, np.argsort(neg, axis=1, kind="stable"), axis=1)
        order[idx[real]] = srt[real]
    long = np.flatnonzero(count > width)
    if len(long):
        rows = ragged_arange(start[long], count[long])
        run = np.repeat(np.arange(len(long)), count[long])
        order[rows] = rows[np.lexsort((-value[rows], run))]
    return order


#: Candidate points handled per batch when measuring their clearance: each brings one row per
#: segment near it, so this bounds the working memory (not the speed; one batch per thread).
CLEARANCE_BATCH = 10_000


#: The clearance search's radii, as fractions of its reach: a point is searched again within
#: the next radius only if nothing of another part was found within the previous one (a
#: first radius of 1/3: the fastest of 1/6 to 1/2, measured with the points in Z order).
CLEARANCE_STAGES = (1 / 3, 1.0)

#: The cells of the clearance's Z order of the points, in reaches (4 to 16 alike, measured).
CLEARANCE_Z_CELL = 8.0


def _clearance(pts: np.ndarray, owner: np.ndarray, sa: np.ndarray, sb: np.ndarray,
               sowner: np.ndarray, tree: shapely.STRtree | SegmentGrid, reach: float
               ) -> np.ndarray:
    """Each point's distance to the nearest segment ``sa[k]-sb[k]`` of another part
    (``sowner[k] != owner[i]``), at most ``reach`` (map units). Searched within growing radii
    (``CLEARANCE_STAGES``): a distance found within a radius is the nearest (every segment
    that close is among the radius's candidates), and most points have a neighbour much
    closer than ``reach``, so far fewer (point, segment) pairs are measured than in one search
    within ``reach``; the same distances. The points are taken in Z order (batches of nearby
    points: 1.4 -> 0.9 s at 1,000 map vertices, the segments' data read from cache)."""
    order = z_order(pts, CLEARANCE_Z_CELL * reach)
    pts, owner = pts[order], owner[order]
    clear = np.full(len(pts), reach)
    cols = tuple(np.ascontiguousarray(c) for c in (sa[:, 0], sa[:, 1], sb[:, 0], sb[:, 1]))
    todo = np.arange(len(pts))
    for frac in CLEARANCE_STAGES:
        r = reach * frac

        def batch(lo: int, hi: int, r: float = r, todo: np.ndarray = todo) -> np.ndarray:
            rows = todo[lo:hi]  # bounded memory: (point, segment) pairs per batch
            qi, d = _other_distances(np.take(pts, rows, axis=0), owner[rows], cols, sowner, r,
                                     tree)
            nearest = np.full(len(rows), np.inf)
            np.minimum.at(nearest, qi, d)
            return nearest

        # in threads (numpy's big calls release the GIL)
        found = np.concatenate([np.zeros(0), *map_batches(batch, len(todo), CLEARANCE_BATCH)])
        hit = found <= r  # the nearest within r, if any (farther candidates do not lower it)
        clear[todo[hit]] = found[hit]
        todo = todo[~hit]
    out = np.empty_like(clear)
    out[order] = clear
    return out


def _other_distances(pts: np.ndarray, owner: np.ndarray, cols: tuple[np.ndarray, ...],
                     sowner: np.ndarray, r: float, tree: shapely.STRtree | SegmentGrid
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Distances from points (m, 2) to the segments of other parts (``sowner != owner``)
    whose envelopes meet the point's box of half-width ``r``: point indices and distances
    (map units; some beyond ``r``). ``cols``: the segments' ``ax, ay, bx, by`` columns,
    indexed by ``tree``. A point's own part, its nearest, is dropped before measuring."""
    qi, si = _segment_pairs(pts, r, tree)  # envelopes only; exact distances below
    k = np.flatnonzero(sowner[si] != owner[qi])
    qi, si = qi[k], si[k]
    ax, ay, bx, by = cols
    return qi, _point_segment_distance_xy(pts[:, 0][qi], pts[:, 1][qi], ax[si], ay[si],
                                          bx[si], by[si])


def _part_candidates(arr: _Arrangement, need: np.ndarray, tol: float, lss: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate crossing points of the parts flagged in ``need``: the midpoints of each
    part's 6 longest segments (part by part, longest first), their part and their clearance
    (distance to the nearest segment of another part, at most ``max(1e3 tol, 1e-3 lss)``).
    A part's candidates depend on the arrangement only: they are computed once per part and
    cached on ``arr`` (region merges recompute the chains, not the parts)."""
    sa, sb, sowner, tree = arr.segments()
    cache = arr.__dict__.get("_part_candidates")
    if cache is None:
        cache = arr.__dict__["_part_candidates"] = {
            "done": np.zeros(len(arr.parts), bool), "Q": np.zeros((0, 2)),
            "part": np.zeros(0, np.int64), "rank": np.zeros(0, np.int64), "clear": np.zeros(0)}
    todo = need & ~cache["done"]
    if todo.any():
        seg = np.flatnonzero(todo[sowner])
        if np.any(sowner[seg[1:]] < sowner[seg[:-1]]):  # not in part order (never so)
            seg = seg[np.argsort(sowner[seg], kind="stable")]
        a, b, part = sa[seg], sb[seg], sowner[seg]
        ln = np.hypot(*(b - a).T)
        head = np.flatnonzero(np.r_[True, part[1:] != part[:-1]]) if len(part) else \
            np.zeros(0, np.int64)  # segments are in part order
        count = np.diff(np.r_[head, len(part)])
        order = _descending_within_runs(ln, head, count)  # longest first, as a lexsort
        rank = np.arange(len(order)) - np.repeat(head, count)
        keep = (rank < 6) & (ln[order] > 0)
        take = order[keep]
        Q = 0.5 * (np.take(a, take, axis=0) + np.take(b, take, axis=0))
        mine = part[take]
        clear = _clearance(Q, mine, sa, sb, sowner, tree, max(1e3 * tol, 1e-3 * lss))
        cache["Q"] = np.vstack((cache["Q"], Q))
        cache["part"] = np.concatenate((cache["part"], mine))
        cache["rank"] = np.concatenate((cache["rank"], rank[keep]))
        cache["clear"] = np.concatenate((cache["clear"], clear))
        cache["done"] |= todo
    rows = np.flatnonzero(need[cache["part"]])
    key = cache["part"][rows] * 6 + cache["rank"][rows]  # ranks are 0..5
    if np.any(key[1:] <= key[:-1]):  # rows of several batches: in (part, rank) order
        rows = rows[np.argsort(key, kind="stable")]
    return cache["Q"][rows], cache["part"][rows], cache["clear"][rows]


def _pick_crossings(env: Environment, chains: _Chains, cands: _Candidates,
                    regions: list[Region], curves: list[Curve],
                    chain_srcs: tuple[np.ndarray, np.ndarray], lss: float
                    ) -> tuple[dict[str, np.ndarray], list[ArcTable]]:
    """For each chain, the first candidate whose two offsets (from the exact curve, along its
    exact normal) show the two regions' structures: ``(q, n into regions[0], eps)``. Candidates
    are tried in rounds, all chains at once (vectorized: structures compared as integer rows,
    :func:`_rows_equal`). A chain with no clean candidate keeps its first one (``check``
    reports it); a chain without candidates gets nothing (zeros). Returns arrays over the
    chains: ``q``, ``n``, ``eps``, ``ok`` (verified) and ``at``, saying where the arcs of the
    two sides are in the returned tables: ``(round, row of the +n side, row of the other)``;
    ``chain_srcs`` are the chains' curves (CSR, :meth:`_Arrangement.chain_sources`)."""
    m = len(chains)
    count = cands.count
    reg_rows, reg_of = _region_rows(regions, 2 * env.n + 1)
    sa, sb = reg_of[chains.pair[:, 0]], reg_of[chains.pair[:, 1]]
    out_q, out_n = np.zeros((m, 2)), np.zeros((m, 2))
    out_eps = np.zeros(m)
    out_ok = np.zeros(m, bool)
    out_at = np.full((m, 3), -1, dtype=np.int64)
    tables: list[ArcTable] = []
    pending = np.flatnonzero(count > 0)
    first = None
    rnd = 0
    while len(pending):
        row = cands.ptr[pending] + rnd
        q, n = _project_on_sources(curves, chain_srcs, pending, np.take(cands.q, row, axis=0))
        release_memory()  # the projection's temporaries, before the arcs allocate theirs
        eps = cands.eps[row]
        k = len(pending)
        j = np.arange(k)
        if first is None:  # every chain with a candidate is tried in round 0
            first = (q, n, eps, np.column_stack((np.zeros(k, np.int64), j, j + k)))
        table, sides = _arcs_across(env, lss, q, n, eps)
        tables.append(table)
        fwd = (_rows_equal(sides, j, reg_rows, sa[pending])
               & _rows_equal(sides, j + k, reg_rows, sb[pending]))
        back = ~fwd
        back[back] = (_rows_equal(sides, j[back], reg_rows, sb[pending[back]])
                      & _rows_equal(sides, j[back] + k, reg_rows, sa[pending[back]]))
        done = fwd | back
        for sel, sign, at in ((fwd, 1.0, np.column_stack((j, j + k))),
                              (back, -1.0, np.column_stack((j + k, j)))):
            i = pending[sel]
            out_q[i], out_n[i], out_eps[i] = q[sel], sign * n[sel], eps[sel]
            out_ok[i] = True
            out_at[i, 0] = rnd
            out_at[i, 1:] = at[sel]
        last = ~done & (rnd + 1 >= count[pending])  # out of candidates: keep the first
        if last.any():
            i = pending[last]
            f = np.searchsorted(np.flatnonzero(count > 0), i)
            out_q[i], out_n[i], out_eps[i] = first[0][f], first[1][f], first[2][f]
            out_at[i] = first[3][f]
        pending = pending[~done & ~last]
        rnd += 1
    return {"q": out_q, "n": out_n, "eps": out_eps, "ok": out_ok, "at": out_at}, tables


@dataclass
class _StructureRows:
    """Structures as integer rows (CSR), compared exactly and vectorized
    (:func:`_rows_equal`) instead of as frozensets: structure ``i`` is ``kind[i]`` (0:
    ``"EMPTY"``, 1: ``"FULL"``, 2: a set of ``(start_code, end_code)`` pairs), the set's
    pairs encoded ``start_code * base + end_code``, sorted and distinct, in
    ``pairs[ptr[i]:ptr[i + 1]]``."""

    kind: np.ndarray
    ptr: np.ndarray
    pairs: np.ndarray


def _table_rows(env: Environment, table: ArcTable, npts: int) -> _StructureRows:
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
    return _StructureRows(kind, np.r_[0, np.cumsum(size)], pair)


def _region_rows(regions: list[Region], base: int) -> tuple[_StructureRows, np.ndarray]:
    """The regions' structures as integer rows (internal codes) and the row of each region:
    the rows of the :class:`_Structures` the regions share, as made (else
    :func:`_set_rows` of their structures)."""
    held = regions[0]._structure if regions else None
    if (type(held) is _Structures and held._code_map is None
            and held.base == base and all(r._structure is held for r in regions)):
        return held.rows(), held.region[[r.id for r in regions]]
    return _set_rows([r.structure for r in regions], base)


def _set_rows(structs: list[Structure], base: int) -> tuple[_StructureRows, np.ndarray]:
    """The distinct structure objects of ``structs`` as integer rows (pairs encoded with
    ``base``, see :class:`_StructureRows`) and the row of each item. Equal structures are
    mostly one shared object: each distinct object is read once."""
    if not structs:
        return _StructureRows(np.zeros(0, np.int64), np.zeros(1, np.int64),
                              np.zeros(0, np.int64)), np.zeros(0, np.int64)
    obj = np.fromiter(map(id, structs), np.int64, len(structs))
    _, first, inv = np.unique(obj, return_index=True, return_inverse=True)
    objs = [structs[i] for i in first.tolist()]
    kind = np.fromiter((0 if s == "EMPTY" else 1 if s == "FULL" else 2 for s in objs),
                       np.int64, len(objs))
    sets = [s if k == 2 else () for s, k in zip(objs, kind.tolist(), strict=True)]
    size = np.fromiter(map(len, sets), np.int64, len(sets))
    flat = np.fromiter(itertools.chain.from_iterable(itertools.chain.from_iterable(sets)),
                       np.int64, 2 * int(size.sum()))
    code = flat[0::2] * base + flat[1::2]
    row = np.repeat(np.arange(len(objs)), size)
    code = code[np.lexsort((code, row))]  # frozensets hold distinct pairs
    return _StructureRows(kind, np.r_[0, np.cumsum(size)], code), inv.ravel()


def _rows_equal(a: _StructureRows, i: np.ndarray, b: _StructureRows, j: np.ndarray
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


def _arcs_across(env: Environment, lss: float, q: np.ndarray, n: np.ndarray, eps: np.ndarray
                 ) -> tuple[ArcTable, _StructureRows]:
    """Exact free arcs at both sides of crossings (rows ``0..k-1``: ``q + eps n``, then
    ``q - eps n``) and the structures of those ``2k`` points. Computed in batches of
    :data:`ACROSS_BATCH` points, each batch's structures from its own table, the batches
    joined column by column with the freed memory returned to the system: the peak is the
    table, its structures and the temporaries of one batch per thread."""
    pts = crossing_points(q, n, eps)

    def batch(lo: int, hi: int) -> tuple[ArcTable, _StructureRows]:
        if lo // ACROSS_BATCH % 8 == 7:  # the batches' freed temporaries, scattered among
            release_memory()             # the tables made
        t = free_arcs_many(env, pts[lo:hi], lss, check=False)
        return t, _table_rows(env, t, len(t.full))

    done = map_batches(batch, max(len(pts), 1), ACROSS_BATCH)  # in threads: numpy's big
    tables, rows = [t for t, _ in done], [r for _, r in done]   # calls release the GIL
    del done
    release_memory()
    return join_tables(tables, release_memory), _join_rows(rows)


#: Points per batch of :func:`_arcs_across` (half of :data:`tether.arcs.POINT_BATCH`: the
#: batch's temporaries come on top of the table made so far).
ACROSS_BATCH = 10_000


def _join_rows(parts: list[_StructureRows]) -> _StructureRows:
    """The structure rows of consecutive batches of points as one (see :func:`join_tables`)."""
    if len(parts) == 1:
        return parts[0]
    ends = np.cumsum([int(r.ptr[-1]) for r in parts])
    ptr = np.concatenate([[0]] + [r.ptr[1:] + (ends[i - 1] if i else 0)
                                  for i, r in enumerate(parts)])
    return _StructureRows(np.concatenate([r.kind for r in parts]), ptr,
                          np.concatenate([r.pairs for r in parts]))


def _crossing_table(tables: list[ArcTable], at: np.ndarray) -> ArcTable:
    """The arcs at both sides of every piece's crossing, gathered from the tables of the
    rounds that chose them (the very points of :meth:`Decomposition.piece_crossings`):
    points ``0..m-1`` on the ``+normal`` side, ``m..2m-1`` on the other. ``at``: each
    piece's ``(round, row of the +n side, row of the other)``, shape (m, 3). Empties
    ``tables``: their columns are freed one by one as they are gathered."""
    m = len(at)
    at_arr = np.asarray(at, dtype=np.int64).reshape(-1, 3)
    rnd = np.concatenate((at_arr[:, 0], at_arr[:, 0]))  # per output point
    src = np.concatenate((at_arr[:, 1], at_arr[:, 2]))
    full = np.zeros(2 * m, bool)
    first = np.zeros(2 * m, np.int64)  # first row in the tables' rows one after the other
    count = np.zeros(2 * m, np.int64)
    offset = 0
    for r, table in enumerate(tables):
        k = np.flatnonzero(rnd == r)
        full[k] = table.full[src[k]]
        size = np.bincount(table.point, minlength=len(table.full))  # rows of each point
        first[k] = offset + (np.cumsum(size) - size)[src[k]]
        count[k] = size[src[k]]
        offset += len(table.point)
    table = None  # no reference left to a round's table but ``tables``
    rows = ragged_arange(first, count)  # output points in order, no sort
    if not tables:
        return ArcTable(np.repeat(np.arange(2 * m), count), np.zeros(0), np.zeros(0),
                        np.zeros(0, np.int64), np.zeros(0, np.int64), full)
    fields = ("start", "end", "start_code", "end_code")
    src = {f: [getattr(t, f) for t in tables] for f in fields}
    tables.clear()  # each column of the rounds' tables freed once gathered
    cols = []
    for f in fields:
        parts = src.pop(f)
        cols.append((parts[0] if len(parts) == 1 else np.concatenate(parts))[rows])
        del parts
        release_memory()
    return ArcTable(np.repeat(np.arange(2 * m), count), *cols, full)


def _project_on_sources(curves: list[Curve], srcs: tuple[np.ndarray, np.ndarray],
                        which: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each point ``q0[k]``, the nearest point and unit normal on the exact curves of
    chain ``which[k]`` (``srcs``: the chains' curves, CSR ``(ptr, src)``; all rows at once); a
    row without a source curve keeps its point, normal (0, 1)."""
    q, n = q0.copy(), np.tile([0.0, 1.0], (len(q0), 1))
    ptr, src = srcs
    count = ptr[which + 1] - ptr[which]
    if count.sum() == 0:
        return q, n
    row = np.repeat(np.arange(len(which)), count)
    cid = src[ragged_arange(ptr[which], count)]
    at = np.take(q0, row, axis=0)  # rows of a 2-d array: np.take (fancy indexing is slower)
    _, p, nrm = project_many(curves, cid, at)
    # each row's nearest projection, the first among equals (no sort)
    best = first_nearest(row, np.hypot(*(p - at).T))
    q[row[best]] = p[best]
    n[row[best]] = nrm[best]
    return q, n


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


# ---------------------------------------------------------------------- verification
@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check`: sampled points whose exact structure disagrees with their
    region's, and pieces whose two sides do not show the two regions' structures."""

    samples: int
    point_disagreements: tuple[dict, ...]
    piece_disagreements: tuple[dict, ...]
    #: random lines scanned (:mod:`tether.scan`), points evaluated along them, and the
    #: disagreements found there (kinds ``point``, ``change``, ``boundary``, ``uncovered``)
    lines: int = 0
    line_points: int = 0
    line_disagreements: tuple[dict, ...] = ()

    @property
    def ok(self) -> bool:
        return not (self.point_disagreements or self.piece_disagreements
                    or self.line_disagreements)

    def to_dict(self) -> dict:
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
    index of each)."""
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
    shapes = regions[0]._polygon if len(regions) else None
    if (not isinstance(shapes, _Shapes) or shapes.converted or 4 * len(regions) > len(shapes)
            or any(r._polygon is not shapes for r in regions)):
        return [r.polygon for r in regions]
    return shapes.some([r.id for r in regions]).tolist()


def check(dec: Decomposition, per_region: int = 20, seed: int = 0, lines: int = CHECK_LINES
          ) -> CheckReport:
    """Verify a decomposition by sampling: every sampled point's exact structure must equal its
    region's, across every piece the two sides must show the two regions' structures, and
    along ``lines`` random lines (:func:`tether.scan.scan`) every change of the exact
    structure must be a region boundary and nothing else."""
    from tether.scan import scan

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
    """The cheap check :func:`tether.escape.analyze` runs by default: one random point in
    each of up to ``regions`` random regions against its region's structure, every piece's
    crossing as verified when the decomposition was built (no recomputation), and a scan of
    ``lines`` random lines (default :data:`tether.tolerances.SELF_CHECK_LINES`; see
    :func:`tether.scan.scan`)."""
    from tether.scan import scan

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
    if type(pieces) is _Pieces:
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


__all__ = ["ArrangementError", "Cell", "CheckReport", "Decomposition", "Piece", "Region",
           "cell_name", "check", "decompose", "sample_in_regions", "self_check", "structures"]
