"""The decomposition's result: :class:`Decomposition` (curves, regions, cells, pieces and
point location) and its :class:`Region` records (see ``docs/formulas.md``, "The verdict")."""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import shapely

from tether._util.memo import Memo, memo_field
from tether.arcs import ArcTable, feature_name, free_arcs_many
from tether.curves import Curve
from tether.decomposition.structure import (
    FREE,
    Structure,
    StructureRows,
    Structures,
    crossing_points,
    set_rows,
)
from tether.decomposition.views import (
    PIECE_BATCH,
    Cell,
    Cells,
    CellsById,
    CellTable,
    Piece,
    Pieces,
    RegionShapes,
    RowSequence,
    Shapes,
    cell_name,
    small_ints,
    unique_pairs,
)
from tether.environment import Environment

__all__ = ["Decomposition", "Region", "RegionTable", "Regions", "compact_arcs", "region_rows",
           "shared_holder"]


@dataclass(frozen=True, eq=False, slots=True)
class Region:
    """A noncritical region: polygon, area, a representative interior point, its structure.

    ``_polygon`` is the polygon, or the decomposition's :class:`Shapes` holding it (item
    ``id``, converted to the map's frame on the first read of any region's polygon);
    ``_structure`` the structure, or the decomposition's :class:`Structures` holding it
    (the frozenset made on the first read)."""

    id: int
    _polygon: Any = field(repr=False)
    area: float
    point: tuple[float, float]
    _structure: Any = field(repr=False)
    _cells: Any = field(repr=False)  # the ids, or the decomposition's CellTable

    @property
    def name(self) -> str:
        """The region's name, ``R<id>``."""
        return f"R{self.id}"

    @property
    def structure(self) -> Structure | frozenset:
        """``"FULL"``, ``"EMPTY"`` or the frozenset of the cells' ``(start_code, end_code)``
        pairs (the file's feature codes)."""
        s = self._structure
        return s.of_region(self.id) if type(s) is Structures else s

    @property
    def cells(self) -> tuple[str, ...]:
        """The ids of the region's cells (made from the cells' columns on the first read)."""
        c = self._cells
        if type(c) is CellTable:
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
        return g[self.id] if isinstance(g, Shapes) else g

    def to_dict(self) -> dict:
        """The region as JSON-ready values (area in square map units)."""
        return {"id": self.name, "area": self.area, "point": list(self.point),
                "cells": list(self.cells)}

    def __eq__(self, other: object) -> bool:
        """Two reads of one region of a decomposition (:class:`Regions` makes a record per
        read) are equal: the same id, area and point and the same holders of its polygon and
        structure; regions of different decompositions are equal only if they are one
        object, as before."""
        if self is other:
            return True
        if type(other) is not Region:
            return NotImplemented
        return (self.id == other.id and self.area == other.area and self.point == other.point
                and self._polygon is other._polygon and self._structure is other._structure)

    def __hash__(self) -> int:
        return hash((self.id, self.area, self.point))


class RegionTable:
    """The regions of a decomposition as columns, in region order (region ``i`` is row
    ``i``): ``area`` (n,) and ``point`` (n, 2) float arrays (map units), the shared holders
    of their polygons (a :class:`Shapes`), structures (a :class:`Structures`) and cells (a
    :class:`CellTable`). :class:`Region` records are made from it when read: 16 + 8 bytes
    of columns a region instead of ~250 bytes of Python objects."""

    __slots__ = ("area", "point", "shapes", "structures", "cells")

    def __init__(self, area: np.ndarray, point: np.ndarray, shapes: Shapes,
                 structures: Structures, cells: CellTable) -> None:
        self.area = np.asarray(area, dtype=float)
        self.point = np.asarray(point, dtype=float).reshape(-1, 2)
        self.shapes, self.structures, self.cells = shapes, structures, cells

    def __len__(self) -> int:
        return len(self.area)

    def region(self, i: int) -> Region:
        """The :class:`Region` of row ``i``."""
        x, y = self.point[i].tolist()
        return Region(i, self.shapes, float(self.area[i]), (x, y), self.structures,
                      self.cells)

    def regions(self, lo: int = 0, hi: int | None = None) -> Iterator[Region]:
        """The regions ``lo:hi``, made one by one (a bounded batch of columns read at a
        time)."""
        hi = len(self) if hi is None else hi
        shapes, structs, cells = self.shapes, self.structures, self.cells
        for b in range(lo, hi, PIECE_BATCH):
            e = min(b + PIECE_BATCH, hi)
            for i, a, x, y in zip(range(b, e), self.area[b:e].tolist(),
                                  self.point[b:e, 0].tolist(), self.point[b:e, 1].tolist(),
                                  strict=True):
                yield Region(i, shapes, a, (x, y), structs, cells)

    def dicts(self) -> list[dict]:
        """Every region's :meth:`Region.to_dict`, made from the columns (the cell ids all in
        one pass)."""
        ids, first = self.cells.ids(), self.cells.first.tolist()
        return [{"id": f"R{i}", "area": a, "point": [x, y], "cells": ids[first[i]:first[i + 1]]}
                for i, (a, x, y) in enumerate(zip(self.area.tolist(), self.point[:, 0].tolist(),
                                                  self.point[:, 1].tolist(), strict=True))]


class Regions(RowSequence):
    """:attr:`Decomposition.regions` from :func:`decompose` and the store: the
    :class:`Region` s of a :class:`RegionTable`, each made when read (see
    :class:`RowSequence`: ``regions[i] is regions[i]`` may be False; they are equal)."""

    __slots__ = ()
    _what = "region"

    def _one(self, i: int) -> Region:
        return self._table.region(i)

    def _many(self, lo: int = 0, hi: int | None = None) -> Iterator[Region]:
        return self._table.regions(lo, hi)


def shared_holder(regions: Sequence[Region], attr: str) -> Any:
    """The holder every region of ``regions`` reads its ``attr`` from (``"_polygon"``,
    ``"_structure"`` or ``"_cells"``): the table's for :class:`Regions` (no record made),
    else the first region's if every region holds that very object, else None."""
    if type(regions) is Regions:
        t = regions._table
        return {"_polygon": t.shapes, "_structure": t.structures, "_cells": t.cells}[attr]
    if not len(regions):
        return None
    held = getattr(regions[0], attr)
    return held if all(getattr(r, attr) is held for r in regions) else None


@dataclass(frozen=True, eq=False)
class Decomposition:
    """The result of :func:`decompose`: curves, regions, cells, pieces and point location.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.decomposition import decompose
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> dec = decompose(room, 1.0)
    >>> dec.counts
    {'curves': 8, 'regions': 19, 'cells': 32, 'pieces': 28}
    >>> dec.cell_at([(0.75, 1.5)], [1.5708])  # the cell of the rod pointing up from the centre
    ['(R9,E1,E3)']
    """

    env: Environment = field(repr=False)
    lss: float
    curves: tuple[Curve, ...] = field(repr=False)
    #: the regions, in id order (a tuple, or from :func:`decompose` and the store an equal
    #: :class:`Regions` making each :class:`Region` when read)
    regions: Sequence[Region] = field(repr=False)
    #: the cells, region by region (a tuple, or from :func:`decompose` an equal sequence
    #: making each :class:`Cell` when read: ``cells[i] is cells[i]`` may be False)
    cells: Sequence[Cell] = field(repr=False)
    #: the pieces, in piece order (a tuple, or from :func:`decompose` an equal sequence
    #: making each :class:`Piece` when read: ``pieces[i] is pieces[i]`` may be False)
    pieces: Sequence[Piece] = field(repr=False)
    curve_tol: float
    unresolved_pieces: int = 0  # boundary stretches below resolution (see make_pieces)
    #: the longest of those stretches: ``{"length", "regions", "point"}`` (map units), or None;
    #: the self-check fails when it is longer than the resolution (``UNRESOLVED_MAX_ROOT``)
    unresolved_longest: dict | None = None
    #: values known when :func:`decompose` built it (else computed on the first read): the
    #: exact free arcs at the pieces' crossings (:meth:`crossing_arcs`) and the cells' codes
    #: (:meth:`cell_codes`)
    #: (the arcs may also be given as a function reading them, as the store does: called on
    #: each use, never held, so that G's build frees them)
    _crossing_arcs: ArcTable | Callable[[], ArcTable] | None = field(
        default=None, repr=False, compare=False)
    _cell_codes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(
        default=None, repr=False, compare=False)
    #: values derived on demand and kept (indexes, name tables): see :class:`Memo`
    memo: Memo = memo_field()

    def __post_init__(self) -> None:
        if type(self._crossing_arcs) is ArcTable:  # held for G: in the smallest int columns
            object.__setattr__(self, "_crossing_arcs",
                               compact_arcs(self._crossing_arcs, 2 * self.env.n))
        if self._cell_codes is not None and type(self.cells) is Cells:
            t = self.cells._table  # the codes are the cells' columns: held once, compact
            if all(np.array_equal(a, b) for a, b in zip(
                    self._cell_codes, (t.region, t.start, t.end), strict=True)):
                object.__setattr__(self, "_cell_codes", (t.region, t.start, t.end))

    def __repr__(self) -> str:
        return (f"Decomposition(map={self.env.name!r}, lss={self.lss:g}, "
                f"curves={len(self.curves)}, regions={len(self.regions)}, "
                f"cells={len(self.cells)}, pieces={len(self.pieces)})")

    @property
    def counts(self) -> dict:
        """Counts of curves, regions, cells and pieces."""
        return {"curves": len(self.curves), "regions": len(self.regions),
                "cells": len(self.cells), "pieces": len(self.pieces)}

    def cell(self, i: int | str) -> Cell:
        """The cell of index ``i`` into :attr:`cells` (a cell's identity; IndexError when out
        of range); a name such as ``"(R1,E1,E2)"`` is still accepted (see
        :meth:`cell_named`)."""
        if isinstance(i, str):
            return self.cell_named(i)
        return self.cells[operator.index(i)]

    def cell_named(self, name: str) -> Cell:
        """The cell named ``name`` (e.g. ``"(R1,E1,E2)"``, as printed; for user input),
        KeyError if there is none."""
        return self._cell_by_id[name]

    def cell_index(self, name: str) -> int:
        """The index into :attr:`cells` of the cell named ``name``, KeyError if there is
        none."""
        if type(self.cells) is Cells:
            i = self.cells._table.index(name)
            if i < 0:
                raise KeyError(name)
            return i
        return self._cell_positions[name]

    def cell_codes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cells' ``(region, start code, end code)`` as three int arrays in the order of
        :attr:`cells` (feature codes in :attr:`env`'s numbering, -1 for both ends of a FULL
        region's cell), cached: recorded by :func:`decompose`, else read from the cells."""
        return self._cell_codes if self._cell_codes is not None else self._read_cell_codes

    @cached_property
    def _read_cell_codes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`cell_codes` when :func:`decompose` did not record them."""
        if type(self.cells) is Cells:
            t = self.cells._table
            return t.region, t.start, t.end
        code = {feature_name(self.env, c): c for c in range(2 * self.env.n)}
        code[FREE] = -1
        n = len(self.cells)
        return (np.fromiter((c.region for c in self.cells), np.int64, n),
                np.fromiter((code[c.start_feature] for c in self.cells), np.int64, n),
                np.fromiter((code[c.end_feature] for c in self.cells), np.int64, n))

    @cached_property
    def _cell_positions(self) -> dict[str, int]:
        """Each cell's index by name (cells given as a tuple)."""
        return {c.id: i for i, c in enumerate(self.cells)}

    @cached_property
    def _cell_by_id(self) -> Mapping[str, Cell]:
        return (CellsById(self.cells._table) if type(self.cells) is Cells else
                {c.id: c for c in self.cells})

    @cached_property
    def _tree(self) -> shapely.STRtree:
        shapes = shared_holder(self.regions, "_polygon")
        if isinstance(shapes, Shapes):
            return shapely.STRtree(shapes.all())
        return shapely.STRtree([r.polygon for r in self.regions])

    def piece_crossings(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every piece's crossing sample: points (k, 2), unit normals into ``regions[0]``
        (k, 2), offsets (k,), map units."""
        if type(self.pieces) is Pieces:  # copies of the columns
            t = self.pieces._table
            return t.q.copy(), t.n.copy(), t.eps.copy()
        return (np.array([p.sample for p in self.pieces]).reshape(-1, 2),
                np.array([p.normal for p in self.pieces]).reshape(-1, 2),
                np.array([p.eps for p in self.pieces], dtype=float))

    def crossing_arcs(self) -> ArcTable:
        """The exact free arcs at both sides of every piece's crossing (the points
        :func:`crossing_points` of :meth:`piece_crossings`: point ``k`` is ``sample + eps
        normal`` of piece ``k``, point ``m + k`` the other side), as found while the
        crossings were chosen (computed now if the decomposition was built otherwise; read
        again on each call from a store, :func:`tether.decomposition.store.read_decomposition`:
        not kept)."""
        got = self._crossing_arcs
        if got is None:
            return self._found_arcs
        return got if type(got) is ArcTable else compact_arcs(got(), 2 * self.env.n)

    def crossing_arc_parts(self) -> Iterator[tuple[int, ArcTable]]:
        """The arcs of :meth:`crossing_arcs` part by part: ``(first, table)`` per run of
        consecutive pieces ``first .. first + k - 1``, ``table`` the arcs at their
        crossings numbered as a decomposition of those ``k`` pieces alone (point ``j < k``
        the ``+n`` side of piece ``first + j``, ``k + j`` its other side; ``table.full``
        has ``2 k`` entries). One part, the whole table, unless the decomposition was read
        from a store written in parts (version 2, ``docs/store.md``): then the store's
        parts, each read when reached and not kept, so that G's build holds one part's arcs
        at a time."""
        got = self._crossing_arcs
        parts = getattr(got, "parts", None)
        if parts is not None:
            for first, table in parts():
                yield first, compact_arcs(table, 2 * self.env.n)
            return
        yield 0, self.crossing_arcs()

    @cached_property
    def _found_arcs(self) -> ArcTable:
        """:meth:`crossing_arcs` when :func:`decompose` did not record them."""
        return free_arcs_many(self.env, crossing_points(*self.piece_crossings()), self.lss,
                              check=False)

    def regions_crossing(self, geoms: Any) -> tuple[np.ndarray, np.ndarray]:
        """The pairs ``(i, r)`` (two int arrays, sorted) such that region ``r``'s polygon
        intersects the shapely geometry ``geoms[i]`` (an array of them, map coordinates).
        Makes no region polygon that was not made yet."""
        geoms = np.asarray(geoms, dtype=object).reshape(-1)
        shapes = shared_holder(self.regions, "_polygon")
        if type(shapes) is RegionShapes and not shapes.converted:
            return shapes.crossing(geoms)
        gi, ri = self._tree.query(geoms, predicate="intersects")
        return unique_pairs(gi, ri)

    def region_polygons(self, ids: Any) -> np.ndarray:
        """The polygons of the regions ``ids`` (map coordinates, an object array), making and
        converting only those if the regions' polygons were not read yet."""
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        shapes = shared_holder(self.regions, "_polygon")
        if isinstance(shapes, Shapes):
            return shapes.some(ids) if not shapes.converted else shapes.all()[ids]
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
                out[i] = region.cells[0] if region.structure == Structure.FULL else None
                continue
            rows = table.rows_of(i)
            for s, e, sc, ec in zip(table.start[rows], table.end[rows], table.start_code[rows],
                                    table.end_code[rows], strict=True):
                if (ang[i] - s) % math.tau <= (e - s) % math.tau:
                    cid = cell_name(region.id, feature_name(self.env, sc),
                                    feature_name(self.env, ec))
                    out[i] = cid if cid in self._cell_by_id else None
                    break
        return out

    def to_dict(self, geometry: bool = False) -> dict:
        """Counts, regions and cells; with ``geometry`` also the pieces, the curves and each
        region's polygon (WKT) and each piece's line (WKT), map units. The lean form stays
        small on large maps (the full one is tens of MB at a few hundred vertices)."""
        table = self.cells._table if type(self.cells) is Cells else None
        lean = type(self.regions) is Regions and self.regions._table.cells is table
        if table is not None and not lean:
            table.fill(self.regions)
        out = {
            "map": self.env.name,
            "lss": self.lss,
            "curve_tolerance": self.curve_tol,
            "unresolved_pieces": self.unresolved_pieces,
            "counts": {k: v for k, v in self.counts.items() if k != "curves"},
            "regions": (self.regions._table.dicts() if lean else
                        [r.to_dict() for r in self.regions]),
            "cells": ([c.to_dict() for c in self.cells] if table is None else
                      table.dicts()),
        }
        if geometry:
            pieces = self.pieces._table if type(self.pieces) is Pieces else None
            out["pieces"] = ([p.to_dict() for p in self.pieces] if pieces is None else
                             pieces.dicts())
            out["curves"] = [c.to_dict() for c in self.curves]
            shapes = shared_holder(self.regions, "_polygon")
            wkt = shapely.to_wkt(shapes.all() if isinstance(shapes, Shapes) else
                                 [r.polygon for r in self.regions], rounding_precision=-1)
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


def compact_arcs(table: ArcTable, ncodes: int) -> ArcTable:
    """The arc table ``table`` with its point column in int32 (below 2**31 points) and its
    feature codes (``-1 .. ncodes - 1``) in int16 (fewer than 2**15 codes) or int32: the same
    values in 24 bytes a row instead of 40 (the crossings' arcs are the largest columns a
    decomposition holds, ~16 rows a piece). Columns already that small are kept as they
    are."""
    npts = len(table.full)
    pt = np.int32 if npts < 2**31 else np.int64
    code = np.int16 if ncodes < 2**15 else np.int32 if ncodes < 2**31 else np.int64
    return ArcTable(small_ints(table.point, pt), table.start, table.end,
                    small_ints(table.start_code, code), small_ints(table.end_code, code),
                    table.full)


def region_rows(regions: Sequence[Region], base: int) -> tuple[StructureRows, np.ndarray]:
    """The regions' structures as integer rows (internal codes) and the row of each region:
    the rows of the :class:`Structures` the regions share, as made (else
    :func:`set_rows` of their structures)."""
    held = shared_holder(regions, "_structure")
    if type(held) is Structures and held._code_map is None and held.base == base:
        ids = (np.arange(len(regions)) if type(regions) is Regions else
               [r.id for r in regions])
        return held.rows(), held.region[ids]
    return set_rows([r.structure for r in regions], base)
