"""The storage of a decomposition's results and the views over it: the geometry holders
(:class:`Shapes`, :class:`RegionShapes`: converted to the map's frame all at once on the first
read), the cells' and pieces' column tables (:class:`CellTable`, :class:`PieceTable`), the lazy
sequences over them (:class:`Cells`, :class:`Pieces`, :class:`CellsById`), and the row records
they make, :class:`Cell` and :class:`Piece`, with the cells' names (:func:`cell_name`,
:func:`parse_cell_name`)."""

from __future__ import annotations

import operator
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely

__all__ = ["PACK_BATCH", "PIECE_BATCH", "Cell", "CellTable", "Cells", "CellsById",
           "PackedFaces", "Piece", "PieceTable", "Pieces", "RegionShapes", "RowSequence",
           "Shapes", "cell_name", "cell_types", "packed_geometries", "parse_cell_name",
           "small_ints", "unique_pairs", "valid_polygons", "wkb_column", "wkb_geometries"]


@dataclass(frozen=True, slots=True)  # no __dict__: 624k cells at 1,000 map vertices
class Cell:
    """A connected component of free rod orientations above a region: ``(R, start, end)``."""

    id: str
    region: int
    start_feature: str
    end_feature: str

    def to_dict(self) -> dict:
        """The cell as JSON-ready values."""
        return {"id": self.id, "region": f"R{self.region}",
                "start_feature": self.start_feature, "end_feature": self.end_feature}


def cell_name(region: int, start: str, end: str) -> str:
    """The paper's cell name, e.g. ``(R1,E1,E2)``."""
    return f"(R{region},{start},{end})"


def parse_cell_name(name: Any) -> tuple[int, str, str] | None:
    """The ``(region, start, end)`` of a cell name such as ``"(R1,E1,E2)"`` (the inverse of
    :func:`cell_name`), None if ``name`` is not one; whether the features exist is not
    checked."""
    if not isinstance(name, str) or name[:2] != "(R" or name[-1:] != ")":
        return None
    parts = name[2:-1].split(",")
    if len(parts) != 3 or not parts[0].isdigit():
        return None
    return int(parts[0]), parts[1], parts[2]


class Shapes:
    """The geometries of a decomposition's regions (or of its pieces), shared by them: item
    ``i`` is the geometry of the object whose ``id`` is ``i``. Kept as made, in the internal
    frame, and converted to the map's frame all at once on the first read (one vectorized
    ``shapely.transform``, the very numbers an eager conversion gives, then cached; the
    internal ones are dropped): building the graph and analyzing read no geometry and never
    pay for it, and reading one region's polygon converts the batch once, never one by one.
    ``frame`` None: the geometries are the map's already. Held as shapely objects, or packed
    as WKB (``wkb``: :func:`wkb_column`'s bytes and offsets, as :func:`decompose` and the
    store leave them), decoded on the first read."""

    __slots__ = ("_held", "_wkb", "_frame", "_prepare")

    def __init__(self, geoms: np.ndarray | None, frame: Any = None, prepare: bool = False,
                 wkb: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self._held = geoms  # object array of shapely geometries (None stays None)
        #: or, with ``geoms`` None, the geometries as WKB, decoded on the first read
        #: (``(bytes, offsets)``: a store's columns, :mod:`tether.decomposition.store`; the
        #: bytes may be a function reading them, called then)
        self._wkb = wkb
        self._frame = frame  # tether.environment frame: internal -> map coordinates
        self._prepare = prepare  # shapely.prepare the converted geometries

    def _wkb_column(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The WKB bytes and offsets (the bytes read now if given as a function), None once
        decoded (by another thread meanwhile: the geometries are then held)."""
        got = self._wkb
        if got is None:
            return None
        raw, ptr = got
        if callable(raw):
            raw = raw()
            self._wkb = (raw, ptr)
        return raw, ptr

    @property
    def _geoms(self) -> np.ndarray:
        """The geometries as kept (decoded from the WKB column on the first read; two
        threads reading at once may both decode, to the same geometries)."""
        held = self._held
        if held is None:
            column = self._wkb_column()
            if column is None:
                return self._held
            held = wkb_geometries(*column)
            if self._frame is None and self._prepare:  # in the map's frame: as read
                shapely.prepare(held)
            self._held, self._wkb = held, None
        return held

    @_geoms.setter
    def _geoms(self, geoms: np.ndarray) -> None:
        self._held, self._wkb = geoms, None

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
        column = self._wkb_column() if self._held is None else None
        if column is not None:  # still WKB: only these decoded
            geoms = wkb_geometries(*column, np.asarray(ids, dtype=np.int64).reshape(-1))
        else:
            geoms = self._geoms[ids]
        return geoms if self._frame is None else self._to_user(geoms)

    def held(self) -> tuple[np.ndarray, Any]:
        """The geometries as kept and the frame they are in (None: the map's), for a store
        to write them as made (:mod:`tether.decomposition.store`)."""
        return self._geoms, self._frame

    def held_wkb(self, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray, Any] | None:
        """Items ``lo:hi`` as still held in WKB (:func:`wkb_column`: bytes and offsets from
        0) and their frame, without decoding them; None once they are decoded (or when the
        bytes are still to be read from a store)."""
        got = self._wkb
        if got is None or callable(got[0]):
            return None
        raw, ptr = got
        return raw[ptr[lo]:ptr[hi]], ptr[lo:hi + 1] - ptr[lo], self._frame

    def _to_user(self, geoms: np.ndarray) -> np.ndarray:
        """Geometries converted to the map's frame (:class:`RegionShapes` also repairs
        polygons that rounding made invalid)."""
        return self._frame.geometry_to_user(geoms)

    def __len__(self) -> int:
        return len(self._held) if self._held is not None else len(self._wkb[1]) - 1


def wkb_geometries(raw: np.ndarray, ptr: np.ndarray, ids: np.ndarray | None = None
                   ) -> np.ndarray:
    """Geometries from a byte column and offsets (item ``i`` is
    ``raw[ptr[i]:ptr[i + 1]]``, None where that is empty): all, or those of ``ids`` (an
    object array)."""
    if ids is None:
        data, bounds = raw.tobytes(), ptr.tolist()
        blobs = [data[a:b] if b > a else None for a, b in zip(bounds[:-1], bounds[1:],
                                                               strict=True)]
    else:
        blobs = [raw[a:b].tobytes() if b > a else None for a, b in zip(
            ptr[ids].tolist(), ptr[ids + 1].tolist(), strict=True)]
    if not blobs:
        return np.zeros(0, dtype=object)
    return shapely.from_wkb(np.array(blobs, dtype=object))


def wkb_column(geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geometries (an object array) as one WKB byte column and offsets (item ``i`` is
    ``raw[ptr[i]:ptr[i + 1]]``; None an empty item): every double kept exactly, a linestring
    of 3 points in 57 bytes instead of ~0.28 KB as a shapely object, a polygon of 9 points in
    157 instead of ~0.93 KB. :func:`wkb_geometries` reads it back.

    Examples
    --------
    >>> import shapely
    >>> raw, ptr = wkb_column(np.array([shapely.box(0, 0, 1, 1), None], dtype=object))
    >>> ptr.tolist(), wkb_geometries(raw, ptr)[0].area
    ([0, 93, 93], 1.0)
    """
    blobs = shapely.to_wkb(geoms, output_dimension=2) if len(geoms) else []
    ptr = np.zeros(len(blobs) + 1, dtype=np.int64)
    np.cumsum(np.fromiter((0 if b is None else len(b) for b in blobs), dtype=np.int64,
                          count=len(blobs)), out=ptr[1:])
    return np.frombuffer(b"".join(b for b in blobs if b is not None), dtype=np.uint8), ptr


#: Geometries made and encoded per batch by :func:`packed_geometries`: bounds the shapely
#: objects alive at once (~1 KB each) while a decomposition's geometries are packed.
PACK_BATCH = 65_536


def packed_geometries(make: Callable[[np.ndarray], np.ndarray], ids: np.ndarray,
                      batch: int = PACK_BATCH) -> tuple[np.ndarray, np.ndarray]:
    """The :func:`wkb_column` of ``make(ids)`` (``make`` turns an id array into an object
    array of geometries, e.g. :class:`~tether.decomposition.faces.FaceRings` indexing), made
    ``batch`` ids at a time: at most one batch of shapely objects alive, the same bytes."""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    raws, sizes = [], []
    for lo in range(0, len(ids), batch):
        raw, ptr = wkb_column(np.asarray(make(ids[lo:lo + batch]), dtype=object))
        raws.append(raw)
        sizes.append(np.diff(ptr))
    ptr = np.zeros(len(ids) + 1, dtype=np.int64)
    if raws:
        np.cumsum(np.concatenate(sizes), out=ptr[1:])
    raw = (raws[0] if len(raws) == 1 else np.concatenate(raws) if raws
           else np.zeros(0, np.uint8))
    return raw, ptr


class PackedFaces(Mapping):
    """The faces of the multi-face regions, packed (:func:`wkb_column`): region
    ``ids[j]``'s faces (``ids`` increasing) are items ``ptr[j]:ptr[j + 1]`` of the column
    ``(raw, fptr)``; read as a mapping from region id to its faces (an object array,
    decoded when read; :meth:`items` decodes all at once)."""

    __slots__ = ("ids", "ptr", "raw", "fptr")

    def __init__(self, ids: np.ndarray, ptr: np.ndarray, raw: np.ndarray,
                 fptr: np.ndarray) -> None:
        self.ids, self.ptr = np.asarray(ids, np.int64), np.asarray(ptr, np.int64)
        self.raw, self.fptr = raw, fptr

    def __getitem__(self, rid: Any) -> np.ndarray:
        j = int(np.searchsorted(self.ids, rid))
        if j >= len(self.ids) or self.ids[j] != rid:
            raise KeyError(rid)
        return wkb_geometries(self.raw, self.fptr, np.arange(self.ptr[j], self.ptr[j + 1]))

    def __iter__(self) -> Iterator[int]:
        return iter(self.ids.tolist())

    def __len__(self) -> int:
        return len(self.ids)

    def items(self) -> list[tuple[int, np.ndarray]]:  # type: ignore[override]
        """Every ``(region id, faces)``, the faces all decoded at once."""
        faces = wkb_geometries(self.raw, self.fptr)
        bounds = self.ptr.tolist()
        return [(i, faces[a:b]) for i, a, b in zip(self.ids.tolist(), bounds[:-1],
                                                    bounds[1:], strict=True)]

    def values(self) -> list[np.ndarray]:  # type: ignore[override]
        """Every region's faces, in :attr:`ids` order (decoded at once)."""
        return [f for _, f in self.items()]

    def held_wkb(self, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The faces of the regions ``lo <= id < hi`` without decoding them: each of those
        regions' face count (``hi - lo``, 0 for a single-face region), the faces' bytes
        and offsets (from 0)."""
        a, b = np.searchsorted(self.ids, [lo, hi]).tolist()
        count = np.zeros(hi - lo, dtype=np.int64)
        count[self.ids[a:b] - lo] = np.diff(self.ptr[a:b + 1])
        f0, f1 = int(self.ptr[a]), int(self.ptr[b])
        fptr = self.fptr[f0:f1 + 1] - self.fptr[f0]
        return count, self.raw[self.fptr[f0]:self.fptr[f1]], fptr


class RegionShapes(Shapes):
    """The regions' polygons (see :class:`Shapes`), the unions of the multi-face regions made
    on the first read: ``unions[i]`` the faces (an object array) whose ``shapely.union_all``
    is item ``i`` (a dict, or the faces packed, :class:`PackedFaces`), all made at once on
    the first read of all (then prepared, converted), only those asked for by :meth:`some`.
    Building G and analyzing never pay for them."""

    __slots__ = ("_unions", "_face_tree", "_face_owner")

    def __init__(self, geoms: np.ndarray | None, unions: Mapping[int, np.ndarray],
                 frame: Any = None, prepare: bool = True,
                 wkb: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        super().__init__(geoms, frame, prepare, wkb)
        self._unions = unions or None

    @property
    def converted(self) -> bool:
        """Whether the polygons are made and in the map's frame already (read or made so)."""
        return self._unions is None and self._frame is None

    def all(self) -> np.ndarray:
        """Every region polygon, in the map's frame."""
        if self._unions is not None:
            geoms = self._geoms.copy()  # never the caller's array
            for i, faces in self._unions.items():
                geoms[i] = shapely.union_all(faces)
            self._geoms, self._unions = geoms, None
            self._face_tree = None  # the faces' tree: no longer valid once converted
            if self._frame is None and self._prepare:
                shapely.prepare(geoms)
        return super().all()

    def pending_unions(self) -> dict[int, np.ndarray]:
        """The faces of each multi-face region whose union is not made yet (its item in
        :meth:`held` is then a placeholder)."""
        return dict(self._unions.items()) if self._unions else {}

    def held_unions(self) -> Mapping[int, np.ndarray] | None:
        """The pending unions' faces as held (a dict, or :class:`PackedFaces`), None when
        made."""
        return self._unions

    def crossing(self, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pairs ``(i, region)`` where region's polygon intersects ``geoms[i]`` (map
        coordinates), sorted, found over the faces as made (a face tree built once) without
        making or converting any region's polygon. Only while :attr:`converted` is False."""
        if self._frame is not None:
            geoms = shapely.transform(geoms, self._frame.to_internal)
        gi, hit = self._tree().query(geoms, predicate="intersects")
        return unique_pairs(gi, self._face_owner[hit])

    def _tree(self) -> shapely.STRtree:
        """An STRtree of the single-face regions' polygons and the multi-face regions' faces
        (``_face_owner``: the region of each), built on the first call."""
        got = getattr(self, "_face_tree", None)
        if got is None:
            items, owner = [self._geoms], [np.arange(len(self._geoms))]
            if self._unions:
                got = list(self._unions.items())  # decoded once
                items += [f for _, f in got]
                owner += [np.full(len(f), i) for i, f in got]
            geoms, owner_arr = np.concatenate(items), np.concatenate(owner)
            keep = ~shapely.is_missing(geoms)
            self._face_owner = owner_arr[keep]
            got = self._face_tree = shapely.STRtree(geoms[keep])
        return got

    def _to_user(self, geoms: np.ndarray) -> np.ndarray:
        return valid_polygons(self._frame.geometry_to_user(geoms))

    def some(self, ids: Any) -> np.ndarray:
        """The polygons of regions ``ids``, in the map's frame."""
        if self._unions is None:
            return super().some(ids)
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        column = self._wkb_column() if self._held is None else None
        if column is not None:  # still WKB: only these decoded
            geoms = wkb_geometries(*column, ids)
        else:
            geoms = self._geoms[ids]
        for k, i in enumerate(ids.tolist()):
            faces = self._unions.get(i)
            if faces is not None:
                geoms[k] = shapely.union_all(faces)
        return geoms if self._frame is None else self._to_user(geoms)


def unique_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


class CellTable:
    """The cells of a decomposition as int columns (int32 regions, int16 codes where they
    fit), in cell order (region by region):
    ``region``, ``start`` and ``end`` feature codes (the reported map's numbering, -1 for both
    ends of a FULL region's cell); ``names[code + 1]`` is a code's feature name (``FREE`` for
    -1); region ``r``'s cells are ``first[r]:first[r + 1]``. :class:`Cell` objects and id
    strings are made from it when read."""

    __slots__ = ("region", "start", "end", "names", "first", "_codes")

    def __init__(self, region: np.ndarray, start: np.ndarray, end: np.ndarray,
                 names: list[str], nregions: int) -> None:
        # held in the smallest int types that hold them (:func:`small_ints`): 8 bytes a
        # cell below 2**31 regions and 2**15 feature codes, instead of 24
        region_t, code_t = cell_types(len(names), nregions)
        self.region = small_ints(region, region_t)
        self.start, self.end = small_ints(start, code_t), small_ints(end, code_t)
        self.names = names
        count = np.bincount(region, minlength=nregions)
        self.first = np.concatenate(([0], np.cumsum(count))).astype(np.int64)
        self._codes: dict[str, int] | None = None

    def __len__(self) -> int:
        return len(self.region)

    def cell(self, i: int) -> Cell:
        """The :class:`Cell` of row ``i``."""
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
        parsed = parse_cell_name(cell_id)
        if parsed is None:
            return -1
        r, start, end = parsed
        if r >= len(self.first) - 1:
            return -1
        code = self._codes
        if code is None:
            code = self._codes = {n: c - 1 for c, n in enumerate(self.names) if n is not None}
        s, e = code.get(start), code.get(end)
        if s is None or e is None:
            return -1
        lo, hi = int(self.first[r]), int(self.first[r + 1])
        hit = np.flatnonzero((self.start[lo:hi] == s) & (self.end[lo:hi] == e))
        if len(hit) == 0:
            return -1
        i = lo + int(hit[0])
        return i if self.cell(i).id == cell_id else -1  # the canonical spelling only


def cell_types(nnames: int, nregions: int) -> tuple[type, type]:
    """The int types of a :class:`CellTable`'s region and feature code columns for
    ``nregions`` regions and ``nnames`` feature names (``FREE`` included): the smallest
    that hold them."""
    code_t = np.int16 if nnames < 2**15 else np.int32 if nnames < 2**31 else np.int64
    return (np.int32 if nregions < 2**31 else np.int64), code_t


def small_ints(a: np.ndarray, dtype: type) -> np.ndarray:
    """``a`` as ``dtype`` (an int type whose range the caller knows holds every value), or
    as it is if its items are that small already."""
    a = np.asarray(a)
    return a if a.dtype.itemsize <= np.dtype(dtype).itemsize else a.astype(dtype)


class RowSequence(Sequence):
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


class Cells(RowSequence):
    """:attr:`Decomposition.cells`: the :class:`Cell` s of a :class:`CellTable`, each made
    when read (see :class:`RowSequence`)."""

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


class CellsById(Mapping):
    """``dec.cell(id)``'s lookup over a :class:`CellTable` (no dict of every cell)."""

    __slots__ = ("_table",)

    def __init__(self, table: CellTable) -> None:
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


@dataclass(frozen=True, slots=True)
class Piece:
    """A maximal stretch of critical curve separating two regions (``docs/formulas.md``, "The
    verdict").

    ``sample`` is a point of the piece, ``normal`` the unit normal there pointing into
    ``regions[0]``, ``eps`` an offset small enough that ``sample ± eps * normal`` lie in the two
    regions (and on the right sides of the exact curve). Pieces compare (and hash) by value,
    their line aside: a decomposition's pieces are made when read (:class:`Pieces`), so two
    reads of one piece are equal objects, not the same one.
    """

    id: int
    regions: tuple[int, int]
    curves: tuple[int, ...]
    kind: str
    features: tuple[str, ...]
    # the line, or a Shapes holding it (item ``id``)
    _geometry: Any = field(repr=False, compare=False)
    sample: tuple[float, float]
    normal: tuple[float, float]
    eps: float
    #: whether the two sides of the crossing showed the two regions' structures when the
    #: decomposition was built (False: no candidate point did; ``check`` reports it)
    verified: bool = True

    @property
    def name(self) -> str:
        """The piece's name, ``P<id>``."""
        return f"P{self.id}"

    @property
    def geometry(self) -> Any:
        """The piece's line (a shapely LineString or MultiLineString, map units)."""
        g = self._geometry
        return g[self.id] if type(g) is Shapes else g

    @property
    def length(self) -> float:
        """Length of the piece, map units."""
        return float(self.geometry.length)

    def to_dict(self) -> dict:
        """The piece as JSON-ready values (length and point in map units)."""
        return {"id": self.name, "regions": [f"R{r}" for r in self.regions],
                "type": self.kind, "features": list(self.features), "length": self.length,
                "point": list(self.sample)}


class PieceTable:
    """The pieces of a decomposition as columns, in piece order (piece ``i`` is row ``i``):
    ``pair`` (m, 2) int64, the two regions (``regions[0]`` the side ``n`` points into);
    ``q`` (m, 2) crossing samples and ``n`` (m, 2) unit normals, ``eps`` (m,) offsets (map
    units once :meth:`tether.decomposition.frame.UserFrame.pieces` converted them); ``ok`` (m,)
    bool, verified; ``desc`` (m,) int ids into ``descs``, the distinct ``(curves, kind, features)``
    (many pieces share their curves); ``shapes`` the lines (a :class:`Shapes`, item ``i``
    piece ``i``). :class:`Piece` objects are made from it when read. ``q``, ``n`` and
    ``eps`` may each be given as a function of no argument returning the column (a store's,
    :func:`tether.decomposition.store.read_decomposition`), called on its first read: G and
    the elimination read none of them."""

    __slots__ = ("pair", "_q", "_n", "_eps", "ok", "desc", "descs", "shapes")

    def __init__(self, pair: np.ndarray, q: np.ndarray | Callable[[], np.ndarray],
                 n: np.ndarray | Callable[[], np.ndarray],
                 eps: np.ndarray | Callable[[], np.ndarray],
                 ok: np.ndarray, desc: np.ndarray, descs: list[tuple], shapes: Shapes) -> None:
        self.pair, self._q, self._n, self._eps, self.ok = pair, q, n, eps, ok
        self.desc, self.descs, self.shapes = desc, descs, shapes
        pair.flags.writeable = False  # G reads it as is (graph._piece_regions)

    def _column(self, slot: str) -> np.ndarray:
        """The column held in ``slot``, read now (and kept) if it was given as a function."""
        got = getattr(self, slot)
        if callable(got):
            got = got()
            setattr(self, slot, got)
        return got

    @property
    def q(self) -> np.ndarray:
        """The crossing samples (m, 2)."""
        return self._column("_q")

    @q.setter
    def q(self, value: np.ndarray) -> None:
        self._q = value

    @property
    def n(self) -> np.ndarray:
        """The unit normals (m, 2)."""
        return self._column("_n")

    @property
    def eps(self) -> np.ndarray:
        """The offsets (m,)."""
        return self._column("_eps")

    @eps.setter
    def eps(self, value: np.ndarray) -> None:
        self._eps = value

    def __len__(self) -> int:
        return len(self.pair)

    def piece(self, i: int) -> Piece:
        """The :class:`Piece` of row ``i``."""
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


class Pieces(RowSequence):
    """:attr:`Decomposition.pieces`: the :class:`Piece` s of a :class:`PieceTable`, each
    made when read (see :class:`RowSequence`)."""

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
