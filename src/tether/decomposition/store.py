"""A :class:`~tether.decomposition.Decomposition` on disk, as columns (``docs/store.md``):
written by ``tether decompose MAP --lss L --out DIR``, read back for analysis by ``tether
analyze --from DIR``.

A store is a folder: ``index.json`` (the format, the map, ``lss``, the tolerances and the list
of *parts*) and one folder per part holding five ``.npz`` tables (``regions``, ``cells``,
``pieces``, ``curves``, ``arcs``: numpy arrays only, no pickled objects; geometries as WKB
bytes with offsets). Every id in a part is global (region, piece and curve ids, cell rows):
the tables of the whole decomposition are the parts' tables concatenated in the index's
order, so a tiled computation appends one part per tile and then the index. A store is
written into a temporary folder beside ``DIR`` and renamed onto it when whole: a failed or
interrupted write leaves nothing (an older store at ``DIR`` is replaced only on success).
"""

from __future__ import annotations

import contextlib
import json
import operator
import os
import shutil
import tempfile
import threading
import zipfile
from collections.abc import Iterator, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tether._util.files import check_output_dir
from tether._util.lazy import LazyTuple
from tether._util.memory import release_memory
from tether.arcs import ArcTable
from tether.curves import Curve, Family
from tether.decomposition.model import Decomposition, Regions, RegionTable, shared_holder
from tether.decomposition.structure import Structure, Structures
from tether.decomposition.views import (
    Cells,
    CellTable,
    PackedFaces,
    Pieces,
    PieceTable,
    RegionShapes,
    Shapes,
    cell_types,
    small_ints,
    wkb_column,
)
from tether.errors import InvalidParameterError, OutputPathError

__all__ = ["FORMAT", "TABLES", "VERSION", "PartWriter", "StoredArcs", "StoredCurves",
           "check_store_dir", "part_arcs", "read_decomposition", "write_decomposition"]

#: The store's format name and version (``index.json``'s ``format`` and ``version``).
#: Version 2: each part's ``arcs`` are those of its own pieces' crossings (version 1, also
#: read: the whole table's rows split in runs, ``full_points`` whole)
FORMAT = "tether-decomposition"
VERSION = 2

#: The versions read (:func:`read_decomposition`)
_READ_VERSIONS = (1, 2)

#: The tables of a part and their columns (documented in ``docs/store.md``)
TABLES = {
    "regions": ("area", "point", "structure", "polygon_ptr", "polygon_wkb", "union_ptr",
                "face_ptr", "face_wkb", "internal_frame", "structures_ptr", "structures_pairs"),
    "cells": ("region", "start", "end"),
    "pieces": ("pair", "q", "n", "eps", "ok", "desc", "internal_frame", "geometry_ptr",
               "geometry_wkb", "desc_kind", "desc_curve_ptr", "desc_curves", "desc_feature_ptr",
               "desc_features"),
    "curves": ("id", "kind", "index", "domain", "interval_ptr", "intervals", "feature_ptr",
               "features", "polyline_ptr", "vertex_ptr", "vertices", "params", "fam_p",
               "fam_d", "fam_w", "fam_lo", "fam_hi", "fam_lss"),
    "arcs": ("point", "start", "end", "start_code", "end_code", "full_points"),
}

# ----------------------------------------------------------------------------- writing
def write_decomposition(dec: Decomposition, path: str | os.PathLike, parts: int = 1,
                        progress: Any = None) -> Path:
    """Write ``dec`` to the folder ``path`` (see the module's docstring), whole or not at all.

    Parameters
    ----------
    dec : Decomposition
    path : str or path-like
        The store's folder: missing, empty, or an earlier store (replaced).
    parts : int
        Split the rows into this many parts (as tiles would write them; at least 1).
    progress : callable, optional
        Called as ``progress(table_name, fraction_done)``.

    Returns
    -------
    Path

    Raises
    ------
    OutputPathError
        If the folder cannot be written, or exists and holds something else than a store.

    Examples
    --------
    >>> import tempfile
    >>> from tether import Environment
    >>> from tether.decomposition import decompose
    >>> from tether.decomposition.store import read_decomposition, write_decomposition
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     read_decomposition(write_decomposition(decompose(room, 1.0), tmp + "/rect"))
    Decomposition(map='', lss=1, curves=8, regions=19, cells=32, pieces=28)
    """
    if int(parts) < 1:
        raise InvalidParameterError(f"parts must be >= 1, got {parts}")
    target = check_store_dir(path)
    report = progress or (lambda stage, frac: None)
    parts = int(parts)
    memo: dict[str, Any] = {"arcs": dec.crossing_arcs()}  # the whole-table columns, made
    total = _table_rows(dec, memo)                         # once for every part
    with _folder_written_whole(target) as tmp:
        entries = []
        for k in range(parts):  # each part's columns made, written and freed in turn
            name = f"part-{k:05d}"
            (tmp / name).mkdir()
            rows = {}
            for j, (table, fn) in enumerate(_WRITERS.items()):
                report(table, (k * len(_WRITERS) + j) / (parts * len(_WRITERS)))
                # the arcs: those of the part's pieces (version 2), as many rows as they have
                lo, hi = _split(total["pieces" if table == "arcs" else table], parts, k)
                cols = fn(dec, lo, hi, memo)
                if table == "arcs":
                    lo = memo.get("arc_rows", 0)
                    hi = memo["arc_rows"] = lo + len(cols["point"])
                np.savez(tmp / name / f"{table}.npz", **cols)
                rows[table] = [lo, hi]
            entries.append({"name": name, "rows": rows})
        _write_index(tmp, dec, dec.counts, entries)
    report("done", 1.0)
    return target


def _write_index(folder: Path, dec: Decomposition, counts: dict, entries: list[dict]) -> None:
    """The store's ``index.json`` for ``dec`` (its map, ``lss``, tolerances and names),
    ``counts`` and the parts ``entries``."""
    index = {"format": FORMAT, "version": VERSION, "map": dec.env.to_dict(),
             "lss": dec.lss, "curve_tol": dec.curve_tol,
             "unresolved_pieces": dec.unresolved_pieces,
             "unresolved_longest": dec.unresolved_longest,
             "feature_names": _feature_names(dec), "counts": counts, "parts": entries}
    (folder / "index.json").write_text(json.dumps(index, indent=1, allow_nan=False) + "\n")


class PartWriter:
    """A store written part by part, as a computation in tiles makes it
    (:func:`tether.decomposition.decompose` with ``out``): the pieces of each tile, with the
    arcs at their crossings, written into a part of their own as they come
    (:meth:`pieces`, numbered after those before), then the regions, cells and curves and
    the pieces' descriptions into the first part, and the index (:meth:`finish`). Used as a
    context manager: the store is written into a temporary folder beside ``path`` and
    renamed onto it when :meth:`finish` has run and the block ends without an exception;
    otherwise removed, ``path`` left as it was (:func:`write_decomposition`'s rule).

    Raises
    ------
    OutputPathError
        If the folder cannot be written, or holds something else than a store.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.target = check_store_dir(path)
        self._whole = _folder_written_whole(self.target)
        self._tmp: Path | None = None
        self._parts: list[dict] = []  # the pieces' parts' entries, in order
        self._done = False

    def __enter__(self) -> PartWriter:
        self._tmp = self._whole.__enter__()
        return self

    def __exit__(self, *exc: Any) -> bool | None:
        if exc[0] is None and not self._done:
            exc = (RuntimeError, RuntimeError("PartWriter closed before finish()"), None)
        return self._whole.__exit__(*exc)

    def pieces(self, table: PieceTable, arcs: ArcTable) -> None:
        """Write a part of pieces: the rows of ``table`` (their descriptions' ids global:
        the descriptions are written by :meth:`finish`) and the arcs at their crossings
        (points ``0..k-1`` the ``+n`` sides, ``k..2k-1`` the others, :func:`part_arcs`);
        its other tables empty."""
        name = f"part-{len(self._parts) + 1:05d}"
        lo = self._parts[-1]["rows"]["pieces"][1] if self._parts else 0
        alo = self._parts[-1]["rows"]["arcs"][1] if self._parts else 0
        folder = self._tmp / name
        folder.mkdir()
        memo = {"descs": _desc_columns([])}
        cols = _piece_columns(_HoldsPieces(Pieces(table)), 0, len(table), memo)
        np.savez(folder / "pieces.npz", **cols)
        np.savez(folder / "arcs.npz", **part_arcs(arcs))
        for t in ("regions", "cells", "curves"):
            np.savez(folder / f"{t}.npz", **_EMPTY[t]())
        self._parts.append({"name": name, "rows": {
            "regions": [0, 0], "cells": [0, 0], "curves": [0, 0],
            "pieces": [lo, lo + len(table)], "arcs": [alo, alo + len(arcs.point)]}})

    def finish(self, dec: Decomposition) -> None:
        """Write the first part, from ``dec`` (the regions, cells and curves, whole; its
        pieces none, but the descriptions the parts' pieces refer to), and the index: the
        counts ``dec``'s, the pieces those of the parts written."""
        folder = self._tmp / "part-00000"
        folder.mkdir()
        memo: dict[str, Any] = {"arcs": dec.crossing_arcs()}
        total = _table_rows(dec, memo)
        rows = {}
        for table, fn in _WRITERS.items():
            np.savez(folder / f"{table}.npz", **fn(dec, 0, total[table], memo))
            rows[table] = [0, total[table]]
        npieces = self._parts[-1]["rows"]["pieces"][1] if self._parts else 0
        _write_index(self._tmp, dec, {**dec.counts, "pieces": npieces},
                     [{"name": "part-00000", "rows": rows}, *self._parts])
        self._done = True


class _HoldsPieces:
    """What :func:`_piece_columns` reads of a decomposition: its ``pieces``."""

    def __init__(self, pieces: Pieces) -> None:
        self.pieces = pieces


def _empty_regions() -> dict[str, np.ndarray]:
    i, f, ptr = np.zeros(0, np.int64), np.zeros(0), np.zeros(1, np.int64)
    return {"area": f, "point": np.zeros((0, 2)), "structure": i, "polygon_ptr": ptr,
            "polygon_wkb": np.zeros(0, np.uint8), "union_ptr": ptr, "face_ptr": ptr,
            "face_wkb": np.zeros(0, np.uint8), "internal_frame": np.zeros(0, bool),
            "structures_ptr": ptr, "structures_pairs": np.zeros((0, 2), np.int64)}


def _empty_curves() -> dict[str, np.ndarray]:
    i, f, f2, ptr = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2)), np.zeros(1, np.int64)
    return {"id": i, "kind": np.zeros(0, "<U1"), "index": i, "domain": f2,
            "interval_ptr": ptr, "intervals": f2, "feature_ptr": ptr,
            "features": np.zeros(0, "<U1"), "polyline_ptr": ptr, "vertex_ptr": ptr,
            "vertices": f2, "params": f, "fam_p": f2, "fam_d": f2, "fam_w": f2, "fam_lo": f,
            "fam_hi": f, "fam_lss": f}


#: The columns of a part's empty tables (:meth:`PartWriter.pieces`; whole-table columns
#: empty: the reader takes the first part's)
_EMPTY = {"regions": _empty_regions, "curves": _empty_curves,
          "cells": lambda: {k: np.zeros(0, np.int64) for k in TABLES["cells"]}}


def _table_rows(dec: Decomposition, memo: dict) -> dict[str, int]:
    """The rows of each table of ``dec``'s store (``memo["arcs"]``: its crossings' arcs)."""
    return {"regions": len(dec.regions), "cells": len(dec.cells), "pieces": len(dec.pieces),
            "curves": len(dec.curves), "arcs": len(memo["arcs"].point)}


def check_store_dir(path: str | os.PathLike) -> Path:
    """The store's folder, checked before any work: writable, and missing, empty or a store."""
    p = check_output_dir(path)
    if p.exists() and any(p.iterdir()) and not (p / "index.json").is_file():
        raise OutputPathError(f"cannot write a decomposition into {os.fspath(path)!r}: the "
                              "folder is not empty and holds no tether store (index.json)")
    return p


@contextlib.contextmanager
def _folder_written_whole(target: Path) -> Iterator[Path]:
    """Yield a temporary folder beside ``target``; on success it replaces ``target`` (an
    earlier store or an empty folder), on failure it is removed and ``target`` left as is."""
    parent = target.absolute().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent))
    except OSError as exc:
        raise OutputPathError(f"cannot write {os.fspath(target)!r}: {exc.strerror or exc}") \
            from None
    old = None
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp's folder is private: as mkdir makes one
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old.", dir=parent))
            os.replace(target, old / "store")
        os.replace(tmp, target)
    except OSError as exc:
        if old is not None and not target.exists():
            os.replace(old / "store", target)  # the earlier store back in place
        raise OutputPathError(f"cannot write {os.fspath(target)!r}: {exc.strerror or exc}") \
            from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: The ragged columns: each ``*_ptr`` (one entry per row, plus one) and the columns it indexes
#: (``vertex_ptr`` is indexed by ``polyline_ptr`` in turn: two levels)
_RAGGED = {"polygon_ptr": ("polygon_wkb",), "union_ptr": ("face_ptr",),
           "face_ptr": ("face_wkb",), "structures_ptr": ("structures_pairs",),
           "geometry_ptr": ("geometry_wkb",), "interval_ptr": ("intervals",),
           "feature_ptr": ("features",), "polyline_ptr": ("vertex_ptr",),
           "vertex_ptr": ("vertices", "params")}
#: Columns of a whole table, not of its rows: written in every part, read from the first
#: (the pieces' distinct descriptions, the distinct structures, the arcs' per-point
#: ``full_points``)
_WHOLE = ("desc_kind", "desc_curve_ptr", "desc_curves", "desc_feature_ptr", "desc_features",
          "full_points", "structures_ptr", "structures_pairs")


def _split(n: int, parts: int, k: int) -> tuple[int, int]:
    """Rows ``lo:hi`` of part ``k`` of ``parts`` (near-equal runs)."""
    return n * k // parts, n * (k + 1) // parts


def _ragged(arrays: list[np.ndarray], width: int | None = None, dtype: Any = float
            ) -> tuple[np.ndarray, np.ndarray]:
    """``(ptr, values)`` of a list of arrays (CSR)."""
    ptr = np.zeros(len(arrays) + 1, dtype=np.int64)
    np.cumsum([len(a) for a in arrays], out=ptr[1:])
    shape = (0,) if width is None else (0, width)
    values = (np.concatenate([np.asarray(a, dtype=dtype).reshape((-1,) + shape[1:])
                              for a in arrays]) if arrays else np.zeros(shape, dtype=dtype))
    return ptr, values


def _wkb(geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geometries as one byte column and offsets (WKB keeps every double exactly; the
    bytes a decomposition holds them packed in, :func:`wkb_column`)."""
    return wkb_column(geoms)


def _region_columns(dec: Decomposition, lo: int, hi: int, memo: dict) -> dict[str, np.ndarray]:
    """Regions ``lo:hi``'s columns: the polygons as held (a multi-face region whose union is
    not made yet keeps its faces, the union made when read, as :func:`decompose` leaves it),
    each region's structure id, and the distinct structures (whole) in the file's codes."""
    regs = dec.regions
    holder = shared_holder(regs, "_polygon")
    packed = holder.held_wkb(lo, hi) if isinstance(holder, RegionShapes) else None
    unions = holder.held_unions() if isinstance(holder, RegionShapes) else None
    if packed is not None and (unions is None or type(unions) is PackedFaces):
        wkb, ptr, frame = packed  # as held, packed: the bytes, no geometry decoded
        count, face_wkb, face_ptr = (unions.held_wkb(lo, hi) if unions is not None else
                                     (np.zeros(hi - lo, np.int64), np.zeros(0, np.uint8),
                                      np.zeros(1, np.int64)))
    else:
        if isinstance(holder, RegionShapes):
            held, frame = holder.held()
            geoms = held[lo:hi]
            if "pending" not in memo:
                memo["pending"] = holder.pending_unions()
            pending = memo["pending"]
        else:
            geoms, frame, pending = dec.region_polygons(np.arange(lo, hi)), None, {}
        wkb, ptr = _wkb(geoms)
        multi = [i for i in sorted(pending) if lo <= i < hi]
        count = np.zeros(hi - lo, dtype=np.int64)
        count[np.asarray(multi, dtype=np.int64) - lo] = [len(pending[i]) for i in multi]
        face_wkb, face_ptr = _wkb(np.concatenate([pending[i] for i in multi]) if multi
                                  else np.zeros(0, dtype=object))
    union_ptr = np.concatenate(([0], np.cumsum(count))).astype(np.int64)
    if "structures" not in memo:
        memo["structures"] = _structure_columns(dec)
    sid, sptr, spairs = memo["structures"]
    if type(regs) is Regions:  # the columns as held, no record made
        area, point = regs._table.area[lo:hi], regs._table.point[lo:hi]
    else:
        area = np.array([r.area for r in regs[lo:hi]], dtype=float)
        point = np.array([r.point for r in regs[lo:hi]], dtype=float).reshape(-1, 2)
    return {"area": area, "point": point, "structure": sid[lo:hi], "polygon_ptr": ptr,
            "polygon_wkb": wkb, "union_ptr": union_ptr, "face_ptr": face_ptr,
            "face_wkb": face_wkb,
            "internal_frame": np.full(hi - lo, frame is not None, dtype=bool),
            "structures_ptr": sptr, "structures_pairs": spairs}


def _structure_columns(dec: Decomposition) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each region's structure id and the distinct structures (``ptr``, ``(k, 2)`` pairs of
    the file's feature codes, sorted; id 0 EMPTY, 1 FULL), read from the shared
    :class:`Structures` when the regions hold one (no frozenset made)."""
    regs = dec.regions
    held = shared_holder(regs, "_structure")
    if type(held) is Structures:
        a, b = np.divmod(held.pairs, held.base)
        if held._code_map is not None:  # the file's codes
            a, b = held._code_map[a], held._code_map[b]
        a, b = _sorted_pairs(a, b, np.diff(held.ptr), held.base)
        return (np.asarray(held.region, np.int64), np.asarray(held.ptr, np.int64),
                np.column_stack((a, b)).astype(np.int64))
    ids: dict[Any, int] = {Structure.EMPTY: 0, Structure.FULL: 1}
    sid = np.array([ids.setdefault(r.structure, len(ids)) for r in regs], dtype=np.int64)
    sets = [np.zeros((0, 2), np.int64)] * 2 + [
        np.array(sorted(s), dtype=np.int64).reshape(-1, 2) for s in list(ids)[2:]]
    ptr, pairs = _ragged(sets, 2, np.int64)
    return sid, ptr, pairs


def _sorted_pairs(a: np.ndarray, b: np.ndarray, size: np.ndarray, base: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``(a, b)`` (codes below ``base``) of consecutive runs of ``size`` rows,
    sorted by ``(a, b)`` within each run: the order of ``np.lexsort((b, a, run))``, by one
    stable sort of an exact integer key where it fits in 63 bits (several times faster; none
    if the key is sorted already, as the internal codes are made)."""
    run = np.repeat(np.arange(len(size)), size)
    if (len(size) + 1) * base * base < 2**62:
        key = (run * base + a) * base + b
        if np.all(key[1:] >= key[:-1]):  # sorted (the internal codes, as made)
            return a, b
        order = np.argsort(key, kind="stable")
    else:
        order = np.lexsort((b, a, run))
    return a[order], b[order]


def _cell_columns(dec: Decomposition, lo: int, hi: int, memo: dict) -> dict[str, np.ndarray]:
    """Cells ``lo:hi``'s columns in the types a :class:`CellTable` holds them
    (:func:`cell_types`: int32 regions, int16 codes below 2**15 feature names): as held,
    no int64 copy (8 bytes a cell instead of 24)."""
    region, start, end = dec.cell_codes()
    region_t, code_t = cell_types(len(_feature_names(dec)), len(dec.regions))
    return {"region": small_ints(region[lo:hi], region_t),
            "start": small_ints(start[lo:hi], code_t), "end": small_ints(end[lo:hi], code_t)}


def _feature_names(dec: Decomposition) -> list[str]:
    """The names of the feature codes ``-1 .. 2n - 1`` (:class:`CellTable`'s ``names``)."""
    if type(dec.cells) is Cells:
        return list(dec.cells._table.names)
    from tether.arcs import feature_name
    from tether.decomposition.structure import FREE

    return [FREE] + [feature_name(dec.env, c) for c in range(2 * dec.env.n)]


def _piece_table(dec: Decomposition, memo: dict) -> tuple:
    """The pieces' columns and the lines as held (read from the columns :func:`decompose`
    keeps, else made from the pieces once, for every part)."""
    if type(dec.pieces) is Pieces:
        t = dec.pieces._table
        if t.shapes.held_wkb(0, 0) is not None:  # packed: written as held, not decoded
            return t.pair, t.q, t.n, t.eps, t.ok, t.desc, t.descs, t.shapes, None
        geoms, frame = t.shapes.held()
        return t.pair, t.q, t.n, t.eps, t.ok, t.desc, t.descs, geoms, frame
    if "pieces" not in memo:
        pieces = list(dec.pieces)
        descs: dict[tuple, int] = {}
        desc = np.array([descs.setdefault((p.curves, p.kind, p.features), len(descs))
                         for p in pieces], dtype=np.int64)
        memo["pieces"] = (
            np.array([p.regions for p in pieces], np.int64).reshape(-1, 2),
            np.array([p.sample for p in pieces], float).reshape(-1, 2),
            np.array([p.normal for p in pieces], float).reshape(-1, 2),
            np.array([p.eps for p in pieces], float),
            np.array([p.verified for p in pieces], bool), desc, list(descs),
            np.fromiter((p.geometry for p in pieces), dtype=object, count=len(pieces)), None)
    return memo["pieces"]


def _piece_columns(dec: Decomposition, lo: int, hi: int, memo: dict) -> dict[str, np.ndarray]:
    """Pieces ``lo:hi``'s columns and the distinct descriptions (whole)."""
    pair, q, n, eps, ok, desc, dlist, geoms, frame = _piece_table(dec, memo)
    packed = geoms.held_wkb(lo, hi) if isinstance(geoms, Shapes) else None
    if packed is not None:  # packed: its bytes as held
        wkb, ptr, frame = packed
    else:
        if isinstance(geoms, Shapes):  # decoded since (read meanwhile)
            geoms, frame = geoms.held()
        wkb, ptr = _wkb(geoms[lo:hi])
    if "descs" not in memo:  # the distinct descriptions (a table of their own, in every part)
        memo["descs"] = _desc_columns(dlist)
    return {"pair": np.asarray(pair[lo:hi], np.int64), "q": np.asarray(q[lo:hi], float),
            "n": np.asarray(n[lo:hi], float), "eps": np.asarray(eps[lo:hi], float),
            "ok": np.asarray(ok[lo:hi], bool), "desc": np.asarray(desc[lo:hi], np.int64),
            "internal_frame": np.full(hi - lo, frame is not None, dtype=bool),
            "geometry_ptr": ptr, "geometry_wkb": wkb, **memo["descs"]}


def _desc_columns(dlist: list[tuple]) -> dict[str, np.ndarray]:
    """The columns of the pieces' distinct descriptions ``(curves, kind, features)``."""
    cptr, cvals = _ragged([np.array(d[0], np.int64) for d in dlist], dtype=np.int64)
    fptr, fvals = _ragged([np.array(d[2], dtype=str) for d in dlist], dtype=str)
    return {"desc_kind": np.array([d[1] for d in dlist], dtype=str).reshape(-1),
            "desc_curve_ptr": cptr, "desc_curves": cvals,
            "desc_feature_ptr": fptr, "desc_features": fvals}


def _curve_columns(dec: Decomposition, lo: int, hi: int, memo: dict) -> dict[str, np.ndarray]:
    cs = dec.curves[lo:hi]
    iptr, ivs = _ragged([np.array(c.intervals, float).reshape(-1, 2) for c in cs], 2)
    fptr, feats = _ragged([np.array(c.features, dtype=str) for c in cs], dtype=str)
    pptr = np.zeros(len(cs) + 1, dtype=np.int64)
    np.cumsum([len(c.polylines) for c in cs], out=pptr[1:])
    lines = [p for c in cs for p in c.polylines]
    vptr, verts = _ragged(lines, 2)
    _, params = _ragged([t for c in cs for t in c.params])
    fam = [c.family for c in cs]
    idx = [c.index for c in cs]

    def rows(attr: str, width: int) -> np.ndarray:
        return np.array([getattr(f, attr)[i] for f, i in zip(fam, idx, strict=True)],
                        dtype=float).reshape((-1, width) if width > 1 else (-1,))

    return {"id": np.array([c.id for c in cs], np.int64),
            "kind": np.array([c.kind for c in cs], dtype=str).reshape(-1),
            "index": np.array(idx, np.int64),
            "domain": np.array([c.domain for c in cs], float).reshape(-1, 2),
            "interval_ptr": iptr, "intervals": ivs, "feature_ptr": fptr, "features": feats,
            "polyline_ptr": pptr, "vertex_ptr": vptr, "vertices": verts, "params": params,
            "fam_p": rows("p", 2), "fam_d": rows("d", 2), "fam_w": rows("w", 2),
            "fam_lo": rows("lo", 1), "fam_hi": rows("hi", 1),
            "fam_lss": np.array([f.lss for f in fam], float)}


def _arc_columns(dec: Decomposition, lo: int, hi: int, memo: dict) -> dict[str, np.ndarray]:
    """The arcs at the crossings of pieces ``lo:hi`` (version 2): their points numbered in
    the part, ``0..k-1`` the ``+n`` sides of its ``k`` pieces, ``k..2k-1`` the others."""
    t = memo["arcs"]  # read once (from a store, each call reads them)
    m = len(t.full) // 2
    a0, a1, b0, b1 = np.searchsorted(t.point, [lo, hi, m + lo, m + hi]).tolist()
    return part_arcs(ArcTable(
        np.concatenate((t.point[a0:a1] - lo, t.point[b0:b1] - (m + lo) + (hi - lo))),
        *(np.concatenate((getattr(t, f)[a0:a1], getattr(t, f)[b0:b1]))
          for f in ("start", "end", "start_code", "end_code")),
        np.concatenate((t.full[lo:hi], t.full[m + lo:m + hi]))))


def part_arcs(t: ArcTable) -> dict[str, np.ndarray]:
    """A part's ``arcs`` columns from the arcs of its pieces' crossings (points ``0..k-1`` on
    the ``+n`` sides of its ``k`` pieces, in its pieces' order, ``k..2k-1`` the others): the
    points in int32 (below 2**31 points) and the feature codes in the smallest of int16,
    int32 and int64 that holds them (:func:`_narrow_ints`), as a decomposition holds them
    (:func:`tether.decomposition.model.compact_arcs`): 24 bytes a row instead of 40.

    Examples
    --------
    >>> t = ArcTable(np.array([0, 0, 1]), np.zeros(3), np.ones(3), np.array([-1, 3, 5]),
    ...              np.array([2, 4, 40000]), np.zeros(2, bool))
    >>> [str(v.dtype) for v in part_arcs(t).values()]
    ['int32', 'float64', 'float64', 'int16', 'int32', 'bool']
    """
    pt = np.int32 if len(t.full) < 2**31 else np.int64
    return {"point": small_ints(t.point, pt), "start": t.start, "end": t.end,
            "start_code": _narrow_ints(t.start_code), "end_code": _narrow_ints(t.end_code),
            "full_points": np.asarray(t.full, bool)}


def _narrow_ints(a: np.ndarray) -> np.ndarray:
    """The int array ``a`` in the smallest of int16, int32 and int64 that holds its values
    (as it is if its items are that small already).

    Examples
    --------
    >>> [str(_narrow_ints(np.array(v)).dtype) for v in ([-1, 300], [2**20], [], [-2**40])]
    ['int16', 'int32', 'int16', 'int64']
    """
    a = np.asarray(a)
    lo, hi = (int(a.min()), int(a.max())) if a.size else (0, 0)
    for t in (np.int16, np.int32):
        if np.iinfo(t).min <= lo and hi <= np.iinfo(t).max:
            return small_ints(a, t)
    return a


#: The tables' writers: ``fn(dec, lo, hi, memo)`` gives rows ``lo:hi``'s columns (ragged
#: offsets from 0) and the whole-table columns (made once, kept in ``memo``)
_WRITERS = {"regions": _region_columns, "cells": _cell_columns, "pieces": _piece_columns,
            "curves": _curve_columns, "arcs": _arc_columns}


# ----------------------------------------------------------------------------- reading
def read_decomposition(path: str | os.PathLike) -> Decomposition:
    """Read a store written by :func:`write_decomposition` (every part, in order).

    Raises
    ------
    InvalidParameterError
        If ``path`` is not a complete, readable store (one line naming what is missing or
        malformed).
    """
    root = Path(path)
    shown = repr(os.fspath(path))
    index = _read_index(root, shown)
    try:
        from tether.io.polygon import from_dict

        env = from_dict(index["map"], "map", index["map"].get("name", ""))
        tables = {name: _read_table([root / part["name"] / f"{name}.npz"
                                     for part in index["parts"]], name, shown)
                  for name in TABLES}
        dec = _assemble(env, index, tables)
        del tables
        release_memory()  # the columns read and dropped (int64 cells, pairs): to the system
        return dec
    except InvalidParameterError:
        raise
    except (KeyError, ValueError, IndexError, TypeError, shapely.errors.GEOSException) as exc:
        raise InvalidParameterError(f"{shown} is not a complete tether decomposition store: "
                                    f"{type(exc).__name__}: {exc}") from None


def _read_index(root: Path, shown: str) -> dict:
    if not root.is_dir():
        raise InvalidParameterError(f"{shown} is not a folder written by 'tether decompose "
                                    "--out'")
    try:
        index = json.loads((root / "index.json").read_text())
    except FileNotFoundError:
        raise InvalidParameterError(f"{shown} holds no index.json: not a tether "
                                    "decomposition store") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InvalidParameterError(f"{shown}: index.json cannot be read: {exc}") from None
    if not isinstance(index, dict) or index.get("format") != FORMAT:
        raise InvalidParameterError(f"{shown}: index.json is not a {FORMAT} index")
    if index.get("version") not in _READ_VERSIONS:
        raise InvalidParameterError(f"{shown}: store version {index.get('version')!r} is not "
                                    f"supported (this tether reads versions "
                                    f"{', '.join(map(str, _READ_VERSIONS))})")
    if not isinstance(index.get("parts"), list) or not index["parts"]:
        raise InvalidParameterError(f"{shown}: index.json lists no parts")
    return index


#: The columns read only when first used (analysis reads none of them): the polygons' and
#: lines' WKB, the pieces' samples, normals and offsets, and every column of the curves
_LATER = {"regions": ("polygon_wkb",), "pieces": ("geometry_wkb", "q", "n", "eps"),
          "curves": TABLES["curves"], "arcs": TABLES["arcs"]}


def _read_table(paths: list[Path], name: str, shown: str) -> Mapping[str, np.ndarray]:
    """A table over its parts: the columns of :data:`_LATER` read when first used (every part
    checked now: readable, with every documented column), the others now."""
    later = _LATER.get(name, ())
    for path in paths:
        files = _load(path, shown, ())
        missing = sorted(set(TABLES[name]) - set(files))
        if missing:
            raise InvalidParameterError(f"{shown}: {path.parent.name}/{path.name} lacks the "
                                        f"column(s) {', '.join(missing)}")
    now = _concat([_load(path, shown, None, later) for path in paths])
    return _Columns(paths, shown, now, later)


class _Columns(Mapping):
    """A table's columns: those read already, and the others read (every part's, joined as
    :func:`_concat` joins them) on first use."""

    def __init__(self, paths: list[Path], shown: str, now: dict[str, np.ndarray],
                 later: tuple[str, ...]) -> None:
        self._paths, self._shown, self._got, self._later = paths, shown, now, later

    def __getitem__(self, k: str) -> np.ndarray:
        if k not in self._got:
            if k not in self._later:
                raise KeyError(k)
            self._got[k] = _concat([_load(p, self._shown, (k,)) for p in self._paths])[k]
        return self._got[k]

    def __iter__(self) -> Iterator[str]:
        return iter(dict.fromkeys([*self._got, *self._later]))

    def __len__(self) -> int:
        return len(set(self._got) | set(self._later))


def _load(path: Path, shown: str, only: tuple[str, ...] | None = None,
          but: tuple[str, ...] = ()) -> Any:
    """A table's columns (no pickled objects allowed): all, those of ``only``, all but those
    of ``but``; ``only`` empty: the list of its column names (nothing read but the
    archive's directory)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if only == ():
                return list(z.files)
            return {k: z[k] for k in z.files if (only is None or k in only) and k not in but}
    except FileNotFoundError:
        raise InvalidParameterError(f"{shown} is incomplete: {path.parent.name}/{path.name} "
                                    "is missing") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise InvalidParameterError(f"{shown}: {path.parent.name}/{path.name} cannot be read "
                                    f"({type(exc).__name__}: {exc})") from None


def _concat(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The parts' tables as one: row and ragged columns concatenated (``*_ptr`` columns
    shifted by the values before them); whole-table columns from the first part."""
    if len(parts) == 1:
        return parts[0]
    out = {}
    for name in parts[0]:
        if name in _WHOLE:
            out[name] = parts[0][name]
        elif name in _RAGGED:  # offsets: each part's shifted past the parts before it
            pieces, shift = [parts[0][name]], int(parts[0][name][-1])
            for p in parts[1:]:
                pieces.append(p[name][1:] + shift)
                shift += int(p[name][-1])
            out[name] = np.concatenate(pieces)
        else:  # parts without rows (a part of pieces' empty tables) add nothing
            full = [p[name] for p in parts if len(p[name])]
            out[name] = np.concatenate(full) if len(full) > 1 else \
                full[0] if full else parts[0][name]
    return out


def _assemble(env: Any, index: dict, t: dict[str, dict[str, np.ndarray]]) -> Decomposition:
    """The decomposition of the tables (in the map's frame, as :func:`decompose` reports)."""
    names = list(index["feature_names"])
    frame = None if env.is_internal else env.frame
    reg = t["regions"]
    nreg = len(reg["area"])
    cells_t = t["cells"]
    table = CellTable(cells_t["region"], cells_t["start"], cells_t["end"], names, nreg)
    # the polygons and lines read and decoded on their first read (analysis reads none):
    # the multi-face regions' faces held packed (WKB, :class:`PackedFaces`), and only the
    # columns read later kept reachable from the result (not every column read now)
    uptr = np.asarray(reg["union_ptr"], np.int64)
    nfaces = np.diff(uptr)
    multi = np.flatnonzero(nfaces > 0)
    unions = PackedFaces(multi, np.r_[0, np.cumsum(nfaces[multi])] + uptr[0],
                         reg["face_wkb"], reg["face_ptr"])
    del nfaces
    later = _Columns(reg._paths, reg._shown, {}, ("polygon_wkb",))
    shapes = RegionShapes(None, unions, frame if _internal(reg) else None, prepare=True,
                          wkb=(partial(operator.getitem, later, "polygon_wkb"),
                               reg["polygon_ptr"]))
    base = len(names) + 1  # codes -1 .. 2n - 1 encoded start * base + end (>= 0 in sets)
    sp = np.asarray(reg["structures_pairs"], np.int64)
    structs = Structures(base, np.asarray(reg["structures_ptr"], np.int64),
                         sp[:, 0] * base + sp[:, 1], np.asarray(reg["structure"], np.int64))
    del sp
    regions = Regions(RegionTable(reg["area"], reg["point"], shapes, structs, table))
    pc = t["pieces"]
    descs = [(tuple(int(c) for c in pc["desc_curves"][pc["desc_curve_ptr"][j]:
                                                         pc["desc_curve_ptr"][j + 1]]),
              str(pc["desc_kind"][j]),
              tuple(str(f) for f in pc["desc_features"][pc["desc_feature_ptr"][j]:
                                                        pc["desc_feature_ptr"][j + 1]]))
             for j in range(len(pc["desc_kind"]))]
    lines = _Columns(pc._paths, pc._shown, {}, ("geometry_wkb",))
    # the samples, normals and offsets read on their first use (G reads none of them)
    cols = _Columns(pc._paths, pc._shown, {}, ("q", "n", "eps"))
    pieces = PieceTable(np.asarray(pc["pair"], np.int64),
                        *(partial(operator.getitem, cols, k) for k in ("q", "n", "eps")),
                        pc["ok"], pc["desc"], descs,
                        Shapes(None, frame if _internal(pc) else None,
                               wkb=(partial(operator.getitem, lines, "geometry_wkb"),
                                    pc["geometry_ptr"])))
    a = t["arcs"]  # read on each use, never held (G's build reads them once)
    arcs = (partial(_arc_table, a._paths, a._shown) if index["version"] == 1 else
            StoredArcs(a._paths, a._shown,
                       [int(np.diff(part["rows"]["pieces"])[0]) for part in index["parts"]]))
    codes = (cells_t["region"], cells_t["start"], cells_t["end"])
    got = {"curves": len(t["curves"]["id"]), "regions": nreg, "cells": len(table),
           "pieces": len(pieces)}
    if got != index["counts"]:
        raise ValueError(f"the parts hold {got}, the index says {index['counts']}")
    return Decomposition(env, float(index["lss"]), StoredCurves(env, t["curves"]), regions,
                         Cells(table), Pieces(pieces), float(index["curve_tol"]),
                         int(index["unresolved_pieces"]), index["unresolved_longest"],
                         _crossing_arcs=arcs, _cell_codes=codes)


def _arc_table(paths: list[Path], shown: str) -> ArcTable:
    """The crossings' arcs of a store, read from its parts now (every call: the
    decomposition read does not hold them, :meth:`Decomposition.crossing_arcs`)."""
    a = {}
    for col in TABLES["arcs"]:  # column by column: one column's parts alive at a time
        a[col] = _concat([_load(p, shown, (col,)) for p in paths])[col]
    return ArcTable(a["point"], a["start"], a["end"], a["start_code"], a["end_code"],
                    a["full_points"])


def _part_arc_table(paths: list[Path], shown: str, counts: list[int]) -> ArcTable:
    """The crossings' arcs of a version 2 store (each part's arcs those of its ``counts[p]``
    pieces' crossings, :func:`part_arcs`), read from its parts now: the ``+n`` sides of
    every part's pieces (points ``0..m-1`` in the pieces' order, the parts' pieces
    consecutive), then the other sides, column by column (no sort)."""
    m = sum(counts)
    first = np.cumsum([0, *counts[:-1]])  # each part's first piece
    point = [_load(p, shown, ("point",))["point"] for p in paths]
    cut = [int(np.searchsorted(pt, k)) for pt, k in zip(point, counts, strict=True)]
    pt = np.concatenate(
        [pt[:c].astype(np.int64) + f for pt, c, f in zip(point, cut, first, strict=True)]
        + [pt[c:].astype(np.int64) - k + m + f
           for pt, c, k, f in zip(point, cut, counts, first, strict=True)])
    del point
    a = {"point": pt.astype(np.int32 if 2 * m < 2**31 else np.int64)}
    for col in ("start", "end", "start_code", "end_code"):  # one column's parts at a time
        got = [_load(p, shown, (col,))[col] for p in paths]
        a[col] = np.concatenate([g[:c] for g, c in zip(got, cut, strict=True)]
                                + [g[c:] for g, c in zip(got, cut, strict=True)])
        del got
    full = [_load(p, shown, ("full_points",))["full_points"] for p in paths]
    a["full"] = np.concatenate([f[:k] for f, k in zip(full, counts, strict=True)]
                               + [f[k:] for f, k in zip(full, counts, strict=True)])
    for f, k in zip(full, counts, strict=True):
        if len(f) != 2 * k:
            raise ValueError(f"a part's arcs have {len(f)} points for its {k} pieces")
    return ArcTable(a["point"], a["start"], a["end"], a["start_code"], a["end_code"],
                    a["full"])


class StoredArcs:
    """The crossings' arcs of a version 2 store, read on each use and never held
    (:meth:`Decomposition.crossing_arcs` calls it: the whole table, :func:`_part_arc_table`;
    :meth:`Decomposition.crossing_arc_parts` reads :meth:`parts`: one part at a time)."""

    def __init__(self, paths: list[Path], shown: str, counts: list[int]) -> None:
        self._paths, self._shown, self._counts = paths, shown, counts

    def __call__(self) -> ArcTable:
        """The whole table (every part's arcs joined, :func:`_part_arc_table`)."""
        return _part_arc_table(self._paths, self._shown, self._counts)

    def parts(self) -> Iterator[tuple[int, ArcTable]]:
        """``(first piece, arcs)`` of each part holding pieces, in order, each part read
        when reached: its arcs as written (:func:`part_arcs`: points ``0..k-1`` the ``+n``
        sides of its ``k`` pieces, ``k..2k-1`` the others)."""
        first = 0
        for path, k in zip(self._paths, self._counts, strict=True):
            if k:
                a = _load(path, self._shown, TABLES["arcs"])
                if len(a["full_points"]) != 2 * k:
                    raise InvalidParameterError(
                        f"{self._shown}: {path.parent.name}/{path.name} has arcs at "
                        f"{len(a['full_points'])} points for its {k} pieces")
                yield first, ArcTable(a["point"], a["start"], a["end"], a["start_code"],
                                      a["end_code"], a["full_points"])
                del a
            first += k


def _internal(cols: dict[str, np.ndarray]) -> bool:
    """Whether a table's geometries are in the map's internal frame (converted when read)."""
    flag = cols["internal_frame"]
    if len(flag) and flag.min() != flag.max():
        raise ValueError("the parts' geometries are in different frames")
    return bool(flag[0]) if len(flag) else False


class StoredCurves(LazyTuple):
    """A store's critical curves (:attr:`Decomposition.curves`): a tuple of :class:`Curve`
    made from the curves' columns all at once on the first read of any item (their number is
    known without; analysis reads none), then kept: ``curves[i] is curves[i]``. Equal to the
    tuple of the same curves and hashed as it; pickled as that tuple."""

    def __init__(self, env: Any, cols: dict[str, np.ndarray]) -> None:
        self._env, self._cols = env, cols
        self._n = len(cols["id"])
        self._done: tuple[Curve, ...] | None = None
        self._lock = threading.Lock()

    def _all(self) -> tuple[Curve, ...]:
        with self._lock:
            if self._done is None:
                self._done = _curves(self._env, self._cols)
                self._env = self._cols = None
            return self._done

    def __len__(self) -> int:
        return self._n


def _curves(env: Any, c: dict[str, np.ndarray]) -> tuple[Curve, ...]:
    """The curves, each with a family of the curves of its kind (the stored rows: the exact
    points, rod angles and projections of the curve as computed)."""
    kinds = c["kind"].tolist()
    fams: dict[str, Family] = {}
    pos = np.zeros(len(kinds), dtype=np.int64)
    for k in sorted(set(kinds)):
        rows = np.flatnonzero(c["kind"] == k)
        pos[rows] = np.arange(len(rows))
        fams[k] = Family(k, float(c["fam_lss"][rows[0]]), c["fam_p"][rows], c["fam_d"][rows],
                         c["fam_w"][rows], c["fam_lo"][rows], c["fam_hi"][rows],
                         [tuple(_strs(c, "feature", i)) for i in rows.tolist()])
    frame = None if env.is_internal else env.frame
    iptr, pptr, vptr = c["interval_ptr"], c["polyline_ptr"], c["vertex_ptr"]
    out = []
    for i, k in enumerate(kinds):
        lines = range(int(pptr[i]), int(pptr[i + 1]))
        out.append(Curve(int(c["id"][i]), k, tuple(_strs(c, "feature", i)),
                         (float(c["domain"][i, 0]), float(c["domain"][i, 1])),
                         tuple((float(a), float(b)) for a, b in
                               c["intervals"][iptr[i]:iptr[i + 1]].tolist()),
                         tuple(c["vertices"][vptr[j]:vptr[j + 1]] for j in lines),
                         tuple(c["params"][vptr[j]:vptr[j + 1]] for j in lines),
                         fams[k], int(pos[i]), frame))
    return tuple(out)


def _strs(c: dict[str, np.ndarray], name: str, i: int) -> list[str]:
    ptr = c[f"{name}_ptr"]
    return [str(s) for s in c[f"{name}s"][ptr[i]:ptr[i + 1]]]
