"""Commands on a map: info, arcs, decompose, check, analyze, and the demo."""

from __future__ import annotations

import argparse
import math

from tether.cli.common import (
    LSS_HELP,
    MAP_HELP,
    add_map_lss,
    add_memory_limit,
    check_plot_arg,
    dask_executor,
    deg,
    example_path,
    finite_arg,
    float_arg,
    int_range,
    load_map_lss,
    print_json,
)
from tether.errors import InvalidParameterError
from tether.tolerances import CHECK_LINES, LINES_RANGE, SAMPLES_RANGE

__all__ = [
    "INFO_MAX_ROWS", "LINE_ROWS", "cmd_analyze", "cmd_arcs", "cmd_check", "cmd_decompose",
    "cmd_demo", "cmd_info", "describe_line_disagreement", "format_arcs", "format_verdict",
    "register", "vertex_rows"
]

#: ``tether info`` lists at most this many vertices unless ``--all``.
INFO_MAX_ROWS = 40


def vertex_rows(env) -> list[dict]:
    """One row per vertex in file order: name, coordinates, ring (0 = boundary), reflex."""
    return [{"name": env.vertex_name(j), "x": float(x), "y": float(y),
             "ring": int(env.ring_of[j]), "reflex": bool(env.reflex[j])}
            for j, (x, y) in enumerate(env.vertices)]


def cmd_info(args: argparse.Namespace) -> int:
    """``tether info``: the map's vertices, edges, reflex vertices and size; exit status."""
    from tether.io import load_map

    env = load_map(args.map)
    info = env.summary()
    if args.json:
        print_json({**info, "vertex_list": vertex_rows(env)})
        return 0
    x0, y0, x1, y1 = info["bounding_box"]
    print(f"map {info['name']!r}: {info['vertices']} vertices, {info['edges']} edges, "
          f"{info['holes']} holes")
    print(f"area {info['area']:.6g}, bounding box [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}], "
          f"diameter {env.diameter:.6g}")
    reflex = info["reflex_vertices"]
    print(f"reflex vertices ({len(reflex)}): {' '.join(reflex) if reflex else '-'}")
    straight = info.get("straight_vertices", [])
    if straight:
        print(f"straight vertices ({len(straight)}, no features: their walls keep the name of "
              f"their first edge): {' '.join(straight)}")
    rows = vertex_rows(env)
    shown = rows if args.all or len(rows) <= INFO_MAX_ROWS else rows[:INFO_MAX_ROWS]
    for r in shown:
        ring = "boundary" if r["ring"] == 0 else f"hole {r['ring'] - 1}"
        print(f"  {r['name']:>6}  ({r['x']:.6g}, {r['y']:.6g})  {ring}"
              + ("  reflex" if r["reflex"] else ""))
    if len(shown) < len(rows):
        print(f"  ... {len(rows) - len(shown)} more vertices (--all lists them)")
    return 0


def format_arcs(fa) -> str:
    """Human-readable lines for a :class:`tether.arcs.FreeArcs`."""
    head = f"at ({fa.point[0]:g}, {fa.point[1]:g}), lss {fa.lss:g}: "
    if fa.full:
        return head + "the rod turns freely (no obstacle within reach)"
    if fa.empty:
        return head + "no free orientation"
    lines = [head + f"{len(fa.arcs)} free arc(s)"]
    for a in fa.arcs:
        lines.append(f"  [{a.start_feature:>4} -> {a.end_feature:<4}]  {deg(a.start)} .. "
                     f"{deg(a.end)}  ({math.degrees(a.length):.2f}° wide)")
    return "\n".join(lines)


def cmd_arcs(args: argparse.Namespace) -> int:
    """``tether arcs``: the free arcs at one target point; exit status."""
    from tether.arcs import free_arcs

    env = load_map_lss(args)
    fa = free_arcs(env, args.at, args.lss)
    if args.json:
        print_json(fa.to_dict())
    else:
        print(format_arcs(fa))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """``tether demo``: every stage on one map, figures written to a folder; exit status."""
    from tether._util.files import make_output_dir
    from tether.analysis import analyze
    from tether.arcs import free_arcs
    from tether.decomposition import decompose
    from tether.io import load_map
    from tether.plot import plot_verdict, save

    out = make_output_dir(args.out)
    env = load_map(example_path("gallery"))
    info = env.summary()
    print(f"== tether demo: the bundled map {info['name']!r} ==")
    print(f"{info['vertices']} vertices, {info['holes']} holes, area {info['area']:.4g}, "
          f"reflex: {' '.join(info['reflex_vertices'])}")
    lss = 2.0
    print(f"\n1. Free rod orientations (exact arcs) at a few target points, lss = {lss:g}:")
    for p in [(2.0, 2.0), (9.0, 1.5), (7.5, 5.0), (14.0, 9.0)]:
        print(format_arcs(free_arcs(env, p, lss)))
    print("\n2-3. Decomposition, graph G and existence verdict (paper Section IV):")
    runs = [("rectangle", 1.0, "paper Fig. 6: 18 regions, 32 cells, no strategy"),
            ("convex_corner", 1.0, "paper Fig. 7: 6 regions, 6 cells near the corner"),
            ("nonconvex_corner", 1.0, "paper Fig. 8: 5 regions, 6 cells near the corner"),
            ("gallery", lss, "a gallery with two pillars")]
    for name, l, paper in runs:
        dec = decompose(load_map(example_path(name)), l)
        verdict = analyze(dec)
        c = verdict.counts()
        word = "strategy can exist" if verdict.strategy_exists else "NO strategy"
        print(f"  {name:<17} lss {l:g}: {c['regions']:>3} regions, {c['cells']:>3} cells, "
              f"{c['surviving_cells']:>3} survive -> {word}   ({paper})")
        fig = plot_verdict(verdict)
        save(fig, out / f"{name}.png")
    print(f"\nFigures written to {out}/ (one per map: decomposition and graph G).")
    return 0


def _decompose(args: argparse.Namespace, out: str | None = None):
    """The decomposition of the command's map, tiled as its options say; with ``out`` (a
    tiled run only), written to that store tile by tile as it is made and read back."""
    from tether._util.progress import Progress
    from tether.decomposition import decompose

    env = load_map_lss(args)
    tiles = getattr(args, "tiles", None)
    if tiles is None and (getattr(args, "workers", None) or getattr(args, "dask", None)):
        tiles = "auto"
    noding = getattr(args, "noding", "auto")
    if tiles is None:
        return decompose(env, args.lss, progress=Progress("decompose"), noding=noding)
    from tether.decomposition.tiles import check_tiles

    tiles = check_tiles(tiles)  # refused before any worker starts
    executor, close = _tile_executor(args)
    try:
        return decompose(env, args.lss, progress=Progress("decompose"), tiles=tiles,
                         executor=executor, noding=noding, out=out)
    finally:
        close()


def _tile_executor(args: argparse.Namespace):
    """The executor of the tiles (local processes, ``--workers`` of them, by default one per
    core; or a Dask cluster's, ``--dask``) and a function to shut it down."""
    if args.dask and args.workers:
        raise InvalidParameterError("give --workers or --dask, not both")
    if args.dask:
        return dask_executor(args.dask, args.dask_timeout)
    from tether.decomposition.tiles import process_executor

    ex = process_executor(args.workers)
    return ex, ex.shutdown


def _add_tile_options(sp: argparse.ArgumentParser) -> None:
    """``--tiles``, ``--workers`` and ``--dask``: the decomposition in tiles (docs/scale.md)."""
    sp.add_argument("--tiles", metavar="NXxNY",
                    help="node the arrangement and trace its faces in NX x NY tiles (or "
                    "'auto'), each a task of a worker process; the same result up to "
                    "numbering (docs/scale.md)")
    sp.add_argument("--workers", type=int_range(1, 1024), metavar="N",
                    help="worker processes for the tiles (default: one per core; implies "
                    "--tiles auto)")
    sp.add_argument("--dask", metavar="ADDRESS",
                    help="run the tiles on a Dask scheduler (implies --tiles auto; needs the "
                    "cluster extra)")
    sp.add_argument("--dask-timeout", type=float_arg, default=10.0, help=argparse.SUPPRESS)
    sp.add_argument("--noding", choices=("auto", "snap"), default="auto",
                    help="'snap': snap round the arrangement from the start, where the "
                    "floating-point noder is known to fail on this map (default 'auto': "
                    "floating point, snap rounding where it fails; docs/scale.md)")


def cmd_decompose(args: argparse.Namespace) -> int:
    """``tether decompose``: regions, cells and pieces (and a figure); exit status."""
    check_plot_arg(args)
    if args.out is not None:  # checked before any computation
        from tether.decomposition.store import check_store_dir

        check_store_dir(args.out)
    tiled = any(getattr(args, k, None) for k in ("tiles", "workers", "dask"))
    dec = _decompose(args, args.out if tiled else None)  # tiled: written tile by tile
    if args.out is not None and not tiled:
        from tether._util.progress import Progress
        from tether.decomposition.store import write_decomposition

        write_decomposition(dec, args.out, progress=Progress("store"))
    if args.plot:
        from tether.plot import new_axes, plot_decomposition, save

        fig, ax = new_axes(size=(8, 8))
        plot_decomposition(dec, ax, by_type=args.by_type)
        save(fig, args.plot)
    if args.json:
        print_json(dec.to_dict(geometry=args.geometry))
        return 0
    c = dec.counts
    print(f"map {dec.env.name!r}, lss {dec.lss:.15g}: {c['curves']} critical curves, "
          f"{c['regions']} regions, {c['cells']} cells, {c['pieces']} boundary pieces")
    if dec.unresolved_pieces:
        print(f"({dec.unresolved_pieces} boundary stretches below the curve tolerance "
              f"{dec.curve_tol:.2g} were not counted as pieces)")
    if args.out is not None:
        print(f"written to {args.out} (columns, docs/store.md; 'tether analyze --from "
              f"{args.out}' analyzes it)")
    if args.verbose:
        for r in dec.regions:
            print(f"  {r.name:>5}  area {r.area:9.4g}  at ({r.point[0]:.4g}, {r.point[1]:.4g})  "
                  f"{' '.join(r.cells) or '(no free orientation)'}")
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    """``tether analyze``: the verdict, surviving cells and witness (and a figure); exit status."""
    from tether.analysis import analyze

    check_plot_arg(args)
    if args.arrays is not None:  # checked before any computation
        from tether._util.files import check_output_path

        check_output_path(args.arrays, (".npz",))
    if args.from_dir is not None:
        dec = _stored(args)
    elif args.map is None or args.lss is None:
        raise InvalidParameterError("analyze needs MAP --lss L, or --from DIR")
    else:
        dec = _decompose(args)
    tiles = args.tiles or ("auto" if args.workers or args.dask else None)
    progress = _store_progress() if args.from_dir is not None else None
    verdict = analyze(dec, tiles=tiles, progress=progress)  # near critical: in tiles too
    if args.plot:
        from tether.plot import plot_verdict, save

        save(plot_verdict(verdict), args.plot)
    if args.arrays is not None:  # G's edges, the survivors and eliminations as columns
        verdict.save_arrays(args.arrays)
    if args.json:
        print_json(verdict.to_dict(arrays=args.arrays))
        return 0 if verdict.verified is not False else 1
    print(format_verdict(verdict))
    return 0 if verdict.verified is not False else 1


#: The share of ``analyze --from``'s bar at which each of its steps begins and ends
_ANALYZE_STEPS = {"self-check": (0.0, 0.1), "cells index": (0.1, 0.15),
                  "G edges": (0.15, 0.55), "G slots": (0.55, 0.65),
                  "elimination": (0.65, 0.95), "verdict": (0.95, 0.95),
                  "near critical": (0.95, 0.95), "done": (1.0, 1.0)}


def _store_progress():
    """``analyze``'s progress on a store (its steps: G part by part, the elimination) as a
    bar on stderr (a terminal only, :class:`Progress`)."""
    from tether._util.progress import Progress

    bar = Progress("analyze")

    def progress(stage: str, frac: float) -> None:
        lo, hi = _ANALYZE_STEPS.get(stage, (frac, frac))
        bar(stage, lo + (hi - lo) * frac)

    return progress


def _stored(args: argparse.Namespace):
    """The decomposition of ``analyze --from DIR`` (MAP and --lss not given)."""
    from tether.decomposition.store import read_decomposition

    if args.map is not None or args.lss is not None:
        raise InvalidParameterError("give MAP --lss L or --from DIR, not both (the store "
                                    "holds its map and lss)")
    return read_decomposition(args.from_dir)


def format_verdict(verdict) -> str:
    """Human-readable verdict: counts before/after elimination, witness, escape story."""
    c = verdict.counts()
    head = "a surveillance strategy CAN exist" if verdict.strategy_exists \
        else "NO surveillance strategy exists"
    lines = [f"map {verdict.dec.env.name!r}, lss {verdict.dec.lss:.15g}: {head}",
             f"  {c['regions']} regions, {c['cells']} cells, {c['edges']} edges in G; "
             f"{c['surviving_cells']} cells survive the elimination "
             f"({len(verdict.eliminated)} eliminated in {verdict.rounds} "
             f"round{'' if verdict.rounds == 1 else 's'})"]
    if verdict.witness_region is not None:
        lines.append(f"  witness region: R{verdict.witness_region}")
    lines += ["  " + s for s in verdict.story()]
    if verdict.critical is not None:
        lines += ["  " + s for s in verdict.critical.describe()]
    rep = verdict.self_check
    if rep is not None and not rep.ok:
        lines.insert(0, f"SELF-CHECK FAILED: {len(rep.point_disagreements)} point, "
                        f"{len(rep.piece_disagreements)} piece and "
                        f"{len(rep.line_disagreements)} line disagreements with exact "
                        "evaluation; the verdict below is NOT verified (run `tether check`)")
    return "\n".join(lines)


def cmd_check(args: argparse.Namespace) -> int:
    """``tether check``: verify a decomposition by sampling; exit status."""
    from tether.decomposition import check

    dec = _decompose(args)
    rep = check(dec, args.samples, args.seed, args.lines)
    if args.json:
        print_json(rep.to_dict())
    else:
        print(f"checked {rep.samples} sampled points in {len(dec.regions)} regions, "
              f"{len(dec.pieces)} piece crossings and {rep.lines} random lines "
              f"({rep.line_points} points): "
              f"{len(rep.point_disagreements)} point, {len(rep.piece_disagreements)} piece "
              f"and {len(rep.line_disagreements)} line disagreements")
        for d in rep.point_disagreements:
            print(f"  point ({d['point'][0]:.6g}, {d['point'][1]:.6g}) in {d['region']}: "
                  f"found {d['found']}, expected {d['expected']}")
        for d in rep.piece_disagreements:
            if d["piece"] == "unresolved":
                print(f"  the boundary between {d['regions'][0]} and {d['regions'][1]} near "
                      f"({d['point'][0]:.6g}, {d['point'][1]:.6g}) has no crossing over "
                      f"{d['length']:.3g}: longer than tether's resolution")
                continue
            print(f"  piece {d['piece']} between {d['regions'][0]} and {d['regions'][1]} at "
                  f"({d['point'][0]:.6g}, {d['point'][1]:.6g})")
        for d in rep.line_disagreements[:LINE_ROWS]:
            print("  " + describe_line_disagreement(d))
        if len(rep.line_disagreements) > LINE_ROWS:
            print(f"  ... and {len(rep.line_disagreements) - LINE_ROWS} more line "
                  "disagreements (--json lists all)")
    return 0 if rep.ok else 1


#: Line disagreements printed by ``tether check`` (``--json`` has them all).
LINE_ROWS = 20


def describe_line_disagreement(d: dict) -> str:
    """One line of text for a disagreement found along a scanned line."""
    at = f"({d['point'][0]:.6g}, {d['point'][1]:.6g})"
    kind = d["kind"]
    if kind == "point":
        return (f"line {d['line']}: point {at} in {d['region']}: found {d['found']}, "
                f"expected {d['expected']}")
    if kind == "change":
        return (f"line {d['line']}: the exact structure changes at {at}, inside "
                f"{d['region']} ({d['distance']:.3g} from its boundary)")
    if kind == "boundary":
        return (f"line {d['line']}: {d['regions'][0]} and {d['regions'][1]} meet at {at} "
                "with equal structures")
    return f"line {d['line']}: point {at} of the free space lies in no region"


def register(add) -> None:
    """Add this group's subcommands; ``add(name, fn, help)`` returns the subparser."""
    sp = add("demo", cmd_demo, "run the whole pipeline on the bundled examples")
    sp.add_argument("--out", default="tether-demo", help="folder for the demo's figures")

    sp = add("info", cmd_info, "summarize a map: vertices (coordinates, reflex), edges, area")
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--all", action="store_true",
                    help=f"list every vertex (default: the first {INFO_MAX_ROWS})")

    sp = add("arcs", cmd_arcs, "exact free rod orientations at a target point")
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("--lss", type=float_arg, required=True, help=LSS_HELP)
    sp.add_argument("--at", nargs=2, type=finite_arg, required=True, metavar=("X", "Y"),
                    help="target point")
    sp.add_argument("--json", action="store_true", help="print JSON")

    sp = add("decompose", cmd_decompose, "critical curves, regions, cells and pieces")
    add_map_lss(sp)
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", metavar="FILE", help="draw the decomposition to an image file")
    sp.add_argument("--by-type", action="store_true", help="colour the curves by type")
    sp.add_argument("--geometry", action="store_true",
                    help="with --json: also pieces, curves and every region's polygon (large)")
    sp.add_argument("-v", "--verbose", action="store_true", help="list the regions")
    sp.add_argument("--out", metavar="DIR",
                    help="also write the decomposition to the folder DIR as columns "
                    "(docs/store.md), for 'tether analyze --from DIR'")
    _add_tile_options(sp)

    sp = add("analyze", cmd_analyze, "graph G, escapable cells and the existence verdict")
    sp.add_argument("map", nargs="?", help=MAP_HELP + " (or --from DIR)")
    sp.add_argument("--lss", type=float_arg, help=LSS_HELP + " (required with MAP)")
    add_memory_limit(sp)
    sp.add_argument("--from", dest="from_dir", metavar="DIR",
                    help="analyze the decomposition stored in DIR by 'tether decompose --out "
                    "DIR' (instead of MAP --lss L)")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", metavar="FILE", help="draw the verdict figure to an image file")
    sp.add_argument("--arrays", metavar="FILE.npz",
                    help="also write G's edges, the surviving cells and the eliminations as "
                    "integer columns to FILE.npz (--json lists them only up to 200,000 items "
                    "each; docs/memory.md)")
    _add_tile_options(sp)

    sp = add("check", cmd_check, "verify a decomposition by sampling (exit 1 on disagreement)")
    add_map_lss(sp)
    sp.add_argument("--samples", type=int_range(*SAMPLES_RANGE), default=20,
                    help=f"sample points per region, {SAMPLES_RANGE[0]} to {SAMPLES_RANGE[1]} "
                    "(default 20)")
    sp.add_argument("--seed", type=int_range(0, 2**32 - 1), default=0,
                    help="seed of the random sample points, 0 to 2**32-1 (default 0): the same "
                    "seed gives the same points")
    sp.add_argument("--lines", type=int_range(*LINES_RANGE), default=CHECK_LINES,
                    help="random lines scanned for changes of the exact structure, "
                    f"{LINES_RANGE[0]} to {LINES_RANGE[1]} (default {CHECK_LINES})")
    sp.add_argument("--json", action="store_true", help="print JSON")
    _add_tile_options(sp)
