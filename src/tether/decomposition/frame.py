"""Reporting in the user's frame: a decomposition is computed on :attr:`Environment.internal`
(normalized frame, no straight vertices) and reported in the map's coordinates and feature
names (file numbering). Angles are unchanged by the frame; lengths scale by a power of two.

The result objects are made once: the regions' areas, points and cell names are converted
(vectorized) before the regions are made, cells are named after the file when made; the
pieces' samples and offsets are converted once the pieces' columns are made (the pieces
stage works in the internal frame), vectorized, in the columns, which nothing else holds yet.
The geometries (polygons and pieces' lines) stay in the internal frame, one shared holder
each, converted all at once (one vectorized call) on their first read: G and the analysis
never read them. Where the map keeps its internal numbering (no straight vertex), names, cells
and structures are left as they are."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

from tether._util.lazy import LazyTuple
from tether.arcs import ArcTable
from tether.curves import curves_to_user
from tether.decomposition.model import shared_holder
from tether.decomposition.structure import FREE, Structures
from tether.decomposition.views import PieceTable, Shapes
from tether.environment import Environment

__all__ = ["UserFrame"]


class UserFrame:
    """How results computed on ``env.internal`` are reported for ``env``: coordinates (map
    units), lengths (divided by the frame's scale), areas (by its square), feature names
    (``"E3"`` -> the file's ``"E5"``) and structures (internal feature codes -> the file's).
    """

    def __init__(self, env: Environment, lss: float) -> None:
        self.env = env
        self.lss = lss  # rod length, map units
        self.frame = env.frame
        self.scale = float(self.frame.scale)
        self.code_map = env.code_map
        # the map's features keep their internal numbering (no straight vertex, same order)
        self.same = len(self.code_map) == 2 * env.internal.n and bool(
            np.array_equal(self.code_map, np.arange(len(self.code_map))))
        self.names = env.feature_names_map()
        self.names[FREE] = FREE
        self._structures: dict = {}  # many regions share a structure: remap each once

    def geometries(self, geoms: Any) -> np.ndarray:
        """Shapely geometries (an object array; None stays None) in map coordinates, all at
        once."""
        if isinstance(geoms, list):  # np.asarray inspects each geometry: much slower
            geoms = np.fromiter(geoms, dtype=object, count=len(geoms))
        return self.frame.geometry_to_user(geoms)

    def points(self, pts: Any) -> np.ndarray:
        """Points (m, 2) in map coordinates."""
        return self.frame.to_user(np.asarray(pts, dtype=float).reshape(-1, 2))

    def structure(self, st: Any) -> Any:
        """A structure (``"FULL"``, ``"EMPTY"`` or a frozenset of internal feature-code pairs)
        in the file's feature codes."""
        if isinstance(st, str) or self.same:
            return st
        got = self._structures.get(st)
        if got is None:
            cm = self.code_map
            got = self._structures[st] = frozenset((int(cm[a]), int(cm[b])) for a, b in st)
        return got

    def feature_pairs(self, pairs: list[tuple[str, str]]) -> list[tuple[str, str]]:
        """``(start, end)`` internal feature names renamed after the file (order kept)."""
        if self.same:
            return pairs
        names = self.names
        return [(names[s], names[e]) for s, e in pairs]

    def features(self, feats: tuple[str, ...]) -> tuple[str, ...]:
        """Internal feature names renamed after the file."""
        if self.same:
            return feats
        return tuple(self.names.get(f, f) for f in feats)

    def curves(self, curves: list) -> _UserCurves:
        """The critical curves reported in map coordinates and file names, converted on the
        first read of any of them (decompose and the analysis only count them)."""
        return _UserCurves(self, list(curves))

    def converted_curves(self, curves: list) -> tuple:
        """The curves of :meth:`Curve.to_user`, their polylines and parameters converted all
        at once (:func:`~tether.curves.curves_to_user`)."""
        return tuple(curves_to_user(curves, self.frame, self.names))

    def pieces(self, table: PieceTable) -> None:
        """Convert the pieces' columns to the user's frame, in place (they were just made in
        the internal frame and nothing else holds them): samples and offsets vectorized,
        features renamed in the small table of distinct descriptions. Their lines are kept as
        made (packed as WKB), in the shared holder, now converting them all at once on the
        first read
        (:class:`~tether.decomposition.views.Shapes`). Normals are unchanged (the frame scales
        and translates)."""
        if not len(table):
            return
        packed = table.shapes.held_wkb(0, len(table))
        table.shapes = (self.shapes(table.shapes.all()) if packed is None else
                        Shapes(None, self.frame, wkb=packed[:2]))
        table.q = self.points(table.q)
        table.eps = table.eps / self.scale
        if not self.same:
            table.descs = [(c, k, self.features(f)) for c, k, f in table.descs]

    def regions(self, regions: list) -> None:
        """Have the regions' structures read in the file's feature codes: the shared
        :class:`~tether.decomposition.structure.Structures` they hold makes its frozensets so
        from now on (regions holding their own structure, just made and held by nothing else,
        have it rewritten in place); their area, point and cell names are the user's already,
        their polygons converted (and prepared) all at once on the first read of any of them
        (:func:`~tether.decomposition.regions.make_regions`)."""
        if not regions or self.same:
            return
        held = shared_holder(regions, "_structure")
        if type(held) is Structures:
            held.to_file(self.code_map)
            return
        put = object.__setattr__
        for r in regions:
            put(r, "_structure", self.structure(r.structure))

    def shapes(self, geoms: Any, prepare: bool = False) -> Shapes:
        """The internal-frame ``geoms`` (a list or an object array) of regions or pieces in a
        holder converting them to the map's frame (and preparing them) on the first read.
        Item ``i`` is read by the object of id ``i``: regions and pieces are numbered in order
        as made."""
        arr = (geoms if isinstance(geoms, np.ndarray) else
               np.fromiter(geoms, dtype=object, count=len(geoms)))
        return Shapes(arr, self.frame, prepare)

    def crossing_arcs(self, arcs: ArcTable) -> ArcTable:
        """The crossings' arc table with the file's feature codes (angles are those of the
        map's frame already)."""
        if self.same:
            return arcs
        cm = self.code_map
        return ArcTable(arcs.point, arcs.start, arcs.end, cm[arcs.start_code],
                        cm[arcs.end_code], arcs.full)



class _UserCurves(LazyTuple):
    """The critical curves in the map's frame (a tuple of :class:`Curve`), made all at once
    by :meth:`UserFrame.converted_curves` on the first read of any item (their number is
    known without), then kept: ``curves[i] is curves[i]``. Equal to the tuple of the same
    curves and hashed as it; pickled as that tuple."""

    def __init__(self, frame: UserFrame, inner: list) -> None:
        self._frame: UserFrame | None = frame
        self._inner: list | None = inner  # the internal curves, until converted
        self._done: tuple | None = None
        self._lock = threading.Lock()

    def _all(self) -> tuple:
        with self._lock:
            if self._done is None:
                assert self._frame is not None and self._inner is not None
                self._done = self._frame.converted_curves(self._inner)
                self._frame = self._inner = None
            return self._done

    def __len__(self) -> int:
        with self._lock:
            return len(self._done if self._done is not None else self._inner or ())
