"""Commands for real robot maps: ``convert`` (ROS occupancy map or any map to a polygon file)
and ``sweep`` (the verdict over a range of ``lss``, on local processes or a Dask cluster)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from tether._util.files import IMAGE_KINDS
from tether.cli.common import (
    MAP_HELP,
    add_memory_limit,
    dask_executor,
    finite_arg,
    float_arg,
    int_range,
    print_json,
)
from tether.errors import InvalidParameterError
from tether.io.polygon import text_of as map_text

__all__ = ["cmd_convert", "cmd_sweep", "format_sweep", "register"]

_MAP_KINDS = (".json", ".geojson", ".wkt", ".yaml")


def _check_output(path: str, kinds: tuple[str, ...]) -> Path:
    """Validate an output path before computing (:func:`tether._util.files.check_output_path`)."""
    from tether._util.files import check_output_path

    return check_output_path(path, kinds)


def _write_text(path: Path, text: str) -> None:
    """Write ``text`` whole or not at all (:func:`tether._util.files.atomic_output`)."""
    from tether._util.files import atomic_output

    with atomic_output(path) as tmp:
        Path(tmp).write_text(text)


# ---------------------------------------------------------------------- reading
def _load(args: argparse.Namespace):
    """The map of ``args.map``, with the ROS options applied to a ``.yaml`` map."""
    return _load_with_summary(args)[0]


def _load_with_summary(args: argparse.Namespace):
    """The map and, for a ROS map, a line saying what the conversion kept (else ``None``)."""
    from tether.io import load_map, read_grid

    ros_opts = (args.seed, args.simplify, args.min_hole_area)
    if Path(args.map).suffix.lower() in (".yaml", ".yml"):
        conv = read_grid(args.map).convert(args.seed, args.simplify, args.min_hole_area)
        return conv.env, conv.summary()
    if any(o is not None for o in ros_opts):
        raise InvalidParameterError("--seed, --simplify and --min-hole-area apply to ROS maps "
                                    "(.yaml) only")
    return load_map(args.map), None


def _add_ros_options(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--seed", nargs=2, type=finite_arg, metavar=("X", "Y"),
                    help="ROS map: a point of the free space wanted (metres, map frame); "
                         "default: the largest free component")
    sp.add_argument("--simplify", type=float_arg, metavar="M",
                    help="ROS map: simplification tolerance in metres (default: one cell)")
    sp.add_argument("--min-hole-area", type=float_arg, metavar="A",
                    help="ROS map: drop holes smaller than A square metres (default: 4 cells)")


# ---------------------------------------------------------------------- convert
def cmd_convert(args: argparse.Namespace) -> int:
    """``tether convert``: write the map in another format; exit status."""
    out = _check_output(args.out, _MAP_KINDS)
    suffix = out.suffix.lower()
    if suffix == ".yaml" and args.resolution is None:
        raise InvalidParameterError("writing a ROS map (.yaml) needs --resolution (metres)")
    if suffix != ".yaml" and args.resolution is not None:
        raise InvalidParameterError("--resolution applies to a ROS map output (.yaml) only")
    env, summary = _load_with_summary(args)
    if suffix == ".yaml":
        from tether.io.ros import rasterize

        grid = rasterize(env, args.resolution)
        img = grid.save(out)
        print(f"wrote {out} and {img}: {grid.shape[1]} x {grid.shape[0]} cells of "
              f"{grid.resolution:g} m")
        return 0
    _write_text(out, map_text(env, suffix))
    print(f"wrote {out}: {env.n} vertices, {len(env.holes)} holes, area {env.area:.6g}")
    if summary:
        print(summary)
    return 0


# ---------------------------------------------------------------------- sweep
def _executor(args: argparse.Namespace):
    """The executor asked for (``None``: serial), and a function to shut it down."""
    if args.dask and args.workers:
        raise InvalidParameterError("give --workers or --dask, not both")
    if args.workers is not None:
        if args.workers < 1:
            raise InvalidParameterError(f"--workers must be >= 1, got {args.workers}")
        from concurrent.futures import ProcessPoolExecutor

        from tether._util.threads import single_threaded

        ex = ProcessPoolExecutor(max_workers=args.workers, initializer=single_threaded)
        return ex, ex.shutdown
    if args.dask:
        return dask_executor(args.dask, args.dask_timeout)
    return None, lambda: None


def format_sweep(res) -> str:
    """The sweep as a table, its intervals, and the longest lss with a strategy."""
    kernel = any(r.safe_fraction is not None for r in res.rows)
    head = f"{'lss':>9}  {'verdict':<11} {'regions':>7} {'cells':>6} {'surviving':>9}"
    lines = [f"map {res.map_name!r}: {len(res.rows)} lss values "
             f"({sum(r.refined for r in res.rows)} by bisection"
             + (f" to {res.tol:.3g}" if res.tol else "") + ")",
             head + ("  safe" if kernel else "")]
    for r in res.rows:
        word = "error" if r.strategy_exists is None else \
            ("strategy" if r.strategy_exists else "none")
        c = r.counts
        line = (f"{r.lss:9.4f}{'*' if r.refined else ' '} {word:<11} {c.get('regions', ''):>7} "
                f"{c.get('cells', ''):>6} {c.get('surviving_cells', ''):>9}")
        if kernel:
            line += "  " + ("-" if r.safe_fraction is None else f"{r.safe_fraction:.3f}")
        if r.verified is False:
            line += "  (self-check FAILED: verdict not verified)"
        if r.error:
            line += f"  ({r.error})"
        lines.append(line)
    if not res.intervals:
        lines.append("no evaluated lss has a strategy")
    for iv in res.intervals:
        lo = f"{iv.lo:.4g}" if iv.below is None else f"({iv.below:.4g}..{iv.lo:.4g}]"
        hi = f"{iv.hi:.4g}" if iv.above is None else f"[{iv.hi:.4g}..{iv.above:.4g})"
        lines.append(f"strategy can exist for lss from {lo} to {hi}")
    if res.longest is not None:
        lines.append(f"longest lss with a strategy: {res.longest:.4g}")
    if res.errors:
        lines.append(f"{len(res.errors)} lss values failed (see the rows marked error)")
    if res.unverified:
        lines.append(f"{len(res.unverified)} lss values failed the self-check; their verdicts "
                     "are not verified (tether check MAP --lss L for details)")
    return "\n".join(lines)


def cmd_sweep(args: argparse.Namespace) -> int:
    """``tether sweep``: the verdict over a range of rod lengths; exit status."""
    from tether._util.progress import Progress
    from tether.sweep import parse_lss_range, sweep

    if args.json and args.csv:
        raise InvalidParameterError("give --json or --csv, not both")
    if args.delay is not None:
        return _delay_sweep(args)
    if args.h is not None:
        raise InvalidParameterError("--h applies to --delay only")
    plot = _check_output(args.plot, IMAGE_KINDS) if args.plot is not None else None
    values = parse_lss_range(args.lss)
    env = _load(args)
    executor, close = _executor(args)
    try:
        res = sweep(env, values, executor, args.vt, args.vo, args.tol,
                    progress=Progress("sweep"))
    finally:
        close()
    if plot is not None:
        from tether.plot import new_axes, plot_sweep, save

        fig, ax = new_axes(size=(8, 4.5))
        plot_sweep(res, ax)
        save(fig, plot)
    if args.json:
        print_json(res.to_dict())
    elif args.csv:
        sys.stdout.write(res.to_csv())
    else:
        print(format_sweep(res))
    return 0


def _delay_sweep(args: argparse.Namespace) -> int:
    """``tether sweep --delay``: the certified kernel's safe fraction per sensing delay."""
    from tether._util.progress import Progress
    from tether.bounds import check_speeds
    from tether.sweep import delay_sweep, parse_lss_range

    for flag, given in (("--csv", args.csv), ("--plot", args.plot), ("--tol", args.tol),
                        ("--workers", args.workers), ("--dask", args.dask)):
        if given:
            raise InvalidParameterError(f"{flag} does not apply to --delay")
    if args.vt is None or args.vo is None:
        raise InvalidParameterError("--delay needs --vt and --vo")
    lss = parse_lss_range(args.lss)
    if len(lss) != 1:
        raise InvalidParameterError("--delay needs a single --lss")
    try:
        delays = parse_lss_range(args.delay)
    except InvalidParameterError as exc:  # the parser names lss; here it reads delays
        raise InvalidParameterError(str(exc).replace("lss", "--delay", 1)) from None
    env = _load(args)
    check_speeds(args.vt, args.vo, lss[0])
    if args.h is not None and not (math.isfinite(args.h) and args.h > 0):
        raise InvalidParameterError(f"--h must be a finite number > 0, got {args.h}")
    res = delay_sweep(env, lss[0], args.vt, args.vo, delays, h=args.h,
                      progress=Progress("delay sweep"))
    if args.json:
        print_json(res.to_dict())
    else:
        print(res.format())
    return 0


def register(add) -> None:
    """Add this group's subcommands; ``add(name, fn, help)`` returns the subparser."""
    sp = add("convert", cmd_convert,
             "convert a map (a ROS occupancy map .yaml among them) to .json, .geojson, .wkt or "
             "a ROS map .yaml")
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("out", help="output file (.json, .geojson, .wkt, or .yaml with --resolution)")
    _add_ros_options(sp)
    sp.add_argument("--resolution", type=float_arg, metavar="M",
                    help="cell size of a ROS map output (.yaml), metres")

    sp = add("sweep", cmd_sweep,
             "verdict over a range of lss and the intervals with a strategy (bisection)")
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("--lss", required=True, metavar="RANGE",
                    help="START:STOP:STEP (both ends included), a list 0.5,1,2, or a number")
    sp.add_argument("--vt", type=float_arg, help="target speed bound (with --vo: kernel column)")
    sp.add_argument("--vo", type=float_arg, help="observer speed bound (> vt)")
    sp.add_argument("--tol", type=float_arg,
                    help="bisection tolerance on interval ends (default: step/8; 0: none)")
    out = sp.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print JSON")
    out.add_argument("--csv", action="store_true", help="print CSV")
    sp.add_argument("--plot", metavar="FILE", help="draw the sweep to an image file")
    sp.add_argument("--workers", type=int_range(1, 1024), metavar="N",
                    help="run on N local processes (1 to 1024)")
    sp.add_argument("--dask", metavar="ADDRESS",
                    help="run on a Dask cluster (scheduler address; extra [cluster])")
    sp.add_argument("--dask-timeout", type=float_arg, default=10.0, help=argparse.SUPPRESS)
    sp.add_argument("--delay", metavar="RANGE",
                    help="sensing delays in seconds (START:STOP:STEP, a list or a number): "
                         "the certified kernel's safe fraction per delay, at one --lss, with "
                         "--vt and --vo (docs/certified.md)")
    sp.add_argument("--h", type=float_arg, default=None,
                    help="with --delay: the certified kernel's mesh spacing (map units; "
                         "default 1/40 of the map's larger side)")
    _add_ros_options(sp)
    add_memory_limit(sp)  # issue 25: per process (each worker decomposes one lss at a time)
