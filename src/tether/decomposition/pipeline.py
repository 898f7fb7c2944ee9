"""``decompose``: the stages in order (critical curves, arrangement, face structures, regions,
pieces), the progress reported between them, the memory released after each, the result made
in the map's frame (:mod:`tether.decomposition.frame`)."""

from __future__ import annotations

import os
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
from shapely.errors import GEOSException

from tether._util.memory import gc_paused, release_memory
from tether.arcs import check_lss
from tether.curves import critical_curves
from tether.curves.budget import (  # issue 25: the memory estimate, checked first
    TilePlan,
    check_memory,
    tiled_checks,
)
from tether.decomposition.arrangement import arrangement
from tether.decomposition.faces import FaceRings
from tether.decomposition.frame import UserFrame
from tether.decomposition.model import Decomposition, region_rows
from tether.decomposition.noding import check_noding, geos_message
from tether.decomposition.pieces import (
    chain_descriptions,
    joined_crossings,
    longest_unresolved,
    make_pieces,
)
from tether.decomposition.regions import face_regions, make_regions
from tether.decomposition.store import (
    PartWriter,
    check_store_dir,
    read_decomposition,
    write_decomposition,
)
from tether.decomposition.structure import face_arcs, structure_ids_of
from tether.decomposition.tiles import (
    MAX_TILES,
    TILE_SEGMENTS,
    check_tiles,
    process_executor,
    tiled_crossings,
    tiled_noder,
)
from tether.decomposition.views import Pieces, PieceTable, Shapes
from tether.environment import Environment
from tether.errors import ArrangementError
from tether.tolerances import REL_CURVE_TOL

__all__ = ["decompose"]


def decompose(env: Environment, lss: float, rel_tol: float = REL_CURVE_TOL,
              progress: Any = None, tiles: tuple[int, int] | str | None = None,
              executor: Executor | None = None, noding: str = "auto",
              out: str | os.PathLike | None = None) -> Decomposition:
    """Decompose the free space for rod length ``lss`` into regions, cells and pieces.

    With ``tiles``, the arrangement is noded, its faces traced and their free arcs computed
    tile by tile, and so are the pieces' crossings, the arcs at them and the pieces' lines
    (:mod:`tether.decomposition.tiles`, ``docs/scale.md``): the result is equal to the
    untiled one up to the numbering of its regions and pieces (the same regions,
    structures, pieces and verdict).

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units, > 0.
    rel_tol : float
        Curve approximation tolerance relative to the map diameter.
    progress : callable, optional
        Called as ``progress(stage_name, fraction_done)``.
    tiles : (int, int) or str, optional
        ``(nx, ny)`` (or ``"NXxNY"``) tiles, at most :data:`tether.decomposition.tiles.MAX_TILES`,
        or ``"auto"`` (about :data:`tether.decomposition.tiles.TILE_SEGMENTS` input segments
        per tile, :data:`tether.decomposition.tiles.SNAP_TILE_SEGMENTS` where the tiles snap
        round); None (default): untiled. Only the noding, the face tracing, the faces'
        free arcs and the pieces' crossings, arcs and lines are tiled (the pieces on a grid
        of their own, :func:`tether.decomposition.tiles.tiled_crossings`): the curves,
        regions and the pieces' chains and candidates are made whole, so the memory check
        (``docs/memory.md``) and :data:`tether.curves.MAX_CURVE_VERTICES` apply to the
        whole map.
    executor : concurrent.futures.Executor, optional
        Runs the tiles' tasks (local processes, ``distributed.Client(...).get_executor()``,
        threads); by default local processes, one per core, started and shut down here
        (spawned: a script calling this must guard its entry point with ``if __name__ ==
        "__main__":``, as any ``multiprocessing`` code).
    noding : str
        How the arrangement is noded (:data:`tether.decomposition.noding.NODINGS`):
        ``"auto"`` (default), GEOS's floating-point noder, snap rounding where it fails;
        ``"snap"``, snap rounding from the start, tiled or not (the same result where the
        floating-point noder fails, without the minutes its tile tasks can take to fail on
        a large map: ``docs/scale.md``).
    out : str or path-like, optional
        Also write the decomposition to this folder (a store, ``docs/store.md``; checked
        before any work: missing, empty or an earlier store, replaced whole or not at all).
        With ``tiles``, each tile's pieces and the arcs at their crossings are written into
        a part of their own as its task returns and dropped from memory
        (:class:`tether.decomposition.store.PartWriter`), the regions, cells and curves
        and the index last; the decomposition returned is then the store read back
        (:func:`tether.decomposition.store.read_decomposition`: its columns read, its
        geometries and arcs when first used). Untiled, the decomposition is written once
        made and returned as made.

    Returns
    -------
    Decomposition

    Raises
    ------
    InvalidParameterError
        If ``lss`` is not a finite positive number within the range of
        :func:`tether.arcs.check_lss` relative to the map's diameter, or ``tiles`` is not
        valid (:func:`tether.decomposition.tiles.check_tiles`), or ``noding`` is not one of
        :data:`tether.decomposition.noding.NODINGS`.
    ArrangementError
        If the geometry engine fails even with snap rounding (one line, no traceback).
    OutputPathError
        If ``out`` cannot be written, or holds something else than a store.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.decomposition import decompose
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> dec = decompose(room, 1.0)
    >>> dec
    Decomposition(map='', lss=1, curves=8, regions=19, cells=32, pieces=28)
    >>> dec.region_at([(0.75, 1.5)]).tolist()  # the region holding the centre
    [9]
    """
    lss = check_lss(lss, env)
    noding = check_noding(noding)
    shape = None if tiles is None else check_tiles(tiles)
    target = None if out is None else check_store_dir(out)  # refused before any work
    plan = None if shape is None else TilePlan(
        None if shape == "auto" else shape[0] * shape[1], TILE_SEGMENTS, MAX_TILES)
    check_memory(env, lss, rel_tol, plan)  # issue 25: refused in milliseconds if it cannot fit
    own = process_executor() if shape is not None and executor is None else None
    # the last tile task returns with the pieces: tether's own workers shut down then (idle,
    # their freed memory returned, in between), a caller's executor left as it is
    tiling = None if shape is None else (shape, executor or own,
                                         own.shutdown if own is not None else None)
    out, inner_lss = None, lss
    if not env.is_internal:  # computed in the normalized frame, reported in the user's
        out = UserFrame(env, lss)
        inner_lss = check_lss(lss * env.frame.scale, env.internal)
    try:
        with gc_paused(), tiled_checks(plan):  # the late check: the tiled estimate
            dec = _decompose(env.internal, inner_lss, rel_tol, progress, out, tiling, noding,
                             target if tiling is not None else None)
    except GEOSException as exc:  # never a traceback from the geometry engine
        raise ArrangementError(f"geometry engine failed on map {env.name!r} at lss {lss:g}: "
                               f"{geos_message(exc)}") from exc
    finally:
        if own is not None:
            own.shutdown()
    if out is not None:
        release_memory()  # the arrangement and the internal frame's geometries, freed
    if dec is None:  # written tile by tile (:func:`_stored`): read back once all is freed
        release_memory()
        dec = read_decomposition(target)
    if target is not None and tiling is None:
        write_decomposition(dec, target)
    return dec


def _polygons(faces: np.ndarray | FaceRings) -> np.ndarray:
    """The faces' polygons: as they are, or made from ragged arrays (:class:`FaceRings`)."""
    return faces.polygons() if isinstance(faces, FaceRings) else faces


def _decompose(env: Environment, lss: float, rel_tol: float, progress: Any,
               out: UserFrame | None = None, tiling: tuple | None = None,
               noding: str = "auto", store: Path | None = None) -> Decomposition | None:
    """The decomposition of the internal map ``env`` for rod length ``lss`` (internal units),
    reported as is, or in the user's frame of ``out`` (the result objects made once);
    ``tiling``: ``(tiles, executor, done)`` to node the arrangement, trace its faces and
    make the pieces' crossings in tiles, ``done`` (or None) called once the tiles' last task
    (a pieces task) has returned; ``noding``: how the arrangement is
    noded (:data:`tether.decomposition.noding.NODINGS`); ``store`` (with ``tiling``): the
    folder the pieces are written to tile by tile (:func:`_stored`): then None is
    returned, and :func:`decompose` reads the store back once everything made here is
    freed (the arrangement, the regions and cells made, not held beside those read)."""
    tol = rel_tol * env.diameter
    report = progress or (lambda stage, frac: None)
    report("critical curves", 0.0)
    # whole: tiles node them, nothing earlier; their intervals made by the tiles' executor
    curves = critical_curves(env, lss, rel_tol, None if tiling is None else tiling[1])
    report("arrangement", 0.3)
    noder = None if tiling is None else tiled_noder(tiling[0], tiling[1], tol, report,
                                                    arcs=(env, lss), noding=noding)
    arr = arrangement(env, curves, tol, noder, noding)
    release_memory()  # the noder's and the face tracing's temporaries
    report("face structures", 0.5)
    # the faces' points and free arcs: computed by the tiles' face tasks, or here
    fa = arr.memo.pop("face_arcs", None) or face_arcs(env, _polygons(arr.faces), tol,
                                                      arr.grid, lss)
    pts, clear, keep, resolved = fa.pts, fa.clear, fa.keep, fa.resolved
    ok = keep[resolved]
    sid, structs = structure_ids_of(env.n, fa.full, fa.point, fa.start_code, fa.end_code,
                                    len(ok))
    del fa
    face_sid = np.full(len(arr.faces), -1, dtype=np.int64)  # the structure id of each face
    face_sid[ok] = sid
    release_memory()
    report("regions", 0.7)
    numbering, chains, cands = face_regions(arr, keep, resolved, face_sid, pts, clear, tol,
                                            lss, report)
    # the segments' grid and the candidates cache are no longer needed: freed before the
    # pieces allocate theirs (at 1,000 map vertices the grid is ~100 MB)
    arr.memo.pop("segments", None)
    arr.memo.pop("part_segments", None)  # the parts' segments the candidates' clearance read
    arr.memo.pop("part_candidates", None)
    release_memory()
    # the regions made after that: their polygons and cells do not add to the grid's peak
    report("region records", 0.8)
    regions, cells, codes = make_regions(env, arr, numbering, face_sid, structs, out)
    report("pieces", 0.85)
    if store is not None:  # the arrangement, chains and candidates held by _stored alone
        held = [arr, chains, cands]  # (freed there before the regions are written)
        del arr, chains, cands, numbering, face_sid, pts, clear, keep, resolved, ok, sid
        return _stored(env, lss, tol, held, curves, regions, cells, codes, out, tiling,
                       store, report)
    tiled = {} if tiling is None else {"crossings": tiled_crossings(tiling[0], tiling[1],
                                                                    report)}
    pieces, unresolved_pieces, arcs = make_pieces(env, arr, regions, chains, cands, curves,
                                                   lss, **tiled)
    if tiling is not None and tiling[2] is not None:
        tiling[2]()  # no task left: the workers' memory freed now, not when decompose returns
    longest = longest_unresolved(arr, chains, cands)
    report("done", 1.0)
    if out is None:
        dec = Decomposition(env, lss, tuple(curves), regions, cells, Pieces(pieces),
                            tol, unresolved_pieces, longest, _crossing_arcs=arcs,
                            _cell_codes=codes)
    else:  # the regions' polygons and structures and the pieces to the user's frame
        del arr, chains, cands  # the arrangement, freed first
        out.regions(regions)
        out.pieces(pieces)
        if longest is not None:
            longest["length"] /= out.scale
            longest["point"] = out.points(longest["point"])[0].tolist()
        dec = Decomposition(out.env, out.lss, out.curves(curves), regions, cells,
                            Pieces(pieces), tol / out.scale, unresolved_pieces, longest,
                            _crossing_arcs=out.crossing_arcs(arcs), _cell_codes=codes)
    return dec


def _stored(env: Environment, lss: float, tol: float, held: list, curves: list,
            regions: Any, cells: Any, codes: Any, out: UserFrame | None,
            tiling: tuple, store: Path, report: Any) -> None:
    """The pieces made in tiles and written to ``store`` as each tile's task returns (a
    part per tile: its pieces, in the user's frame of ``out`` if given, and the arcs at
    their crossings, :class:`tether.decomposition.store.PartWriter`), none kept; then the
    regions, cells, curves and the pieces' descriptions, and the index. Returns None: the
    store read back by :func:`decompose` is the decomposition, its pieces in the tile by
    tile order. ``held``: ``[arrangement, chains, candidates]``, emptied here (this
    frame the only one holding them: freed once the pieces are made)."""
    arr, chains, cands = held
    held.clear()
    sptr, ssrc = arr.chain_sources(chains)
    desc_of, descs = chain_descriptions(sptr, ssrc, cands, curves)
    pair = chains.pair
    with PartWriter(store) as writer:
        def sink(got: dict, kept: np.ndarray, arcs: Any, lines: tuple) -> None:
            table = PieceTable(pair[kept].astype(np.int64), got["q"], got["n"],
                               got["eps"], got["ok"], desc_of[kept], [],
                               Shapes(None, wkb=lines))
            if out is not None:
                out.pieces(table)
                arcs = out.crossing_arcs(arcs)
            writer.pieces(table, arcs)
            del table, arcs, got, lines
            release_memory()  # the part's columns, freed: returned to the system

        crossings = tiled_crossings(tiling[0], tiling[1], report, sink=sink)
        crossings(env, lss, curves, chains, cands, (sptr, ssrc),
                  region_rows(regions, 2 * env.n + 1), arr)
        del crossings, sink, sptr, ssrc  # the chains' columns, freed
        pair = desc_of = None  # (the sink's too)
        if tiling[2] is not None:
            tiling[2]()  # no task left: the workers' memory freed now
        unresolved = int(np.count_nonzero(cands.count == 0))
        longest = longest_unresolved(arr, chains, cands)
        none = joined_crossings([])
        table = PieceTable(np.zeros((0, 2), np.int64), none[0]["q"], none[0]["n"],
                           none[0]["eps"], none[0]["ok"], np.zeros(0, np.int64), descs,
                           Shapes(None, wkb=none[3]))
        del arr, chains, cands
        if out is None:
            dec = Decomposition(env, lss, tuple(curves), regions, cells, Pieces(table), tol,
                                unresolved, longest, _crossing_arcs=none[2],
                                _cell_codes=codes)
        else:
            out.regions(regions)
            if not out.same:
                table.descs = [(c, k, out.features(f)) for c, k, f in descs]
            if longest is not None:
                longest["length"] /= out.scale
                longest["point"] = out.points(longest["point"])[0].tolist()
            dec = Decomposition(out.env, out.lss, out.curves(curves), regions, cells,
                                Pieces(table), tol / out.scale, unresolved, longest,
                                _crossing_arcs=out.crossing_arcs(none[2]), _cell_codes=codes)
        writer.finish(dec)
    del dec, regions, cells
    report("done", 1.0)
    return None  # read back by :func:`decompose`, once this frame and its caller's are gone
