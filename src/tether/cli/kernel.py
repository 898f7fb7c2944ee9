"""``tether kernel``: the surveillance kernel of the bounded-speed game on a grid (issue #11)."""

from __future__ import annotations

import argparse
import math

from tether.cli.common import (
    LSS_HELP,
    MAP_HELP,
    check_plot_arg,
    finite_arg,
    float_arg,
    int_range,
    load_map_lss,
    print_json,
)

__all__ = ["cmd_kernel", "register"]

#: Refinement rounds of ``--band-width`` or ``--max-vertices`` without ``--refine``.
DEFAULT_ROUNDS = 4


def cmd_kernel(args: argparse.Namespace) -> int:
    """``tether kernel``: compute or load the surveillance kernel and report it; exit status."""
    from tether.bounds import check_speeds
    from tether.game import surveillance_kernel

    check_plot_arg(args)
    if args.save is not None:
        from tether._util.files import check_output_path

        check_output_path(args.save, (".npz",))
    env = load_map_lss(args)
    check_speeds(args.vt, args.vo, args.lss)
    if args.h is not None and not (math.isfinite(args.h) and args.h > 0):
        from tether.errors import InvalidParameterError

        raise InvalidParameterError(f"--h must be a finite number > 0, got {args.h}")
    if args.delay is not None and not args.certified:
        from tether.errors import InvalidParameterError

        raise InvalidParameterError("--delay applies to --certified only")
    if args.coarse is not None and not args.certified:
        from tether.errors import InvalidParameterError

        raise InvalidParameterError("--coarse applies to --certified only")
    refining = (args.refine, args.band_width, args.max_vertices) != (None, None, None)
    if refining and not args.certified:
        from tether.errors import InvalidParameterError

        raise InvalidParameterError("--refine, --band-width and --max-vertices apply to "
                                    "--certified only")
    if args.band_width is not None and not (math.isfinite(args.band_width)
                                            and args.band_width >= 0):
        from tether.errors import InvalidParameterError

        raise InvalidParameterError(f"--band-width must be a finite number >= 0, got "
                                    f"{args.band_width}")
    if args.certified:
        return _certified(args, env)
    k = surveillance_kernel(env, args.lss, args.vt, args.vo, h=args.h,
                            orientations=args.orientations, directions=args.directions,
                            scheme=args.scheme)
    out = k.to_dict()
    if args.at is not None:
        x, y, a = args.at
        out["at"] = {"x": x, "y": y, "a": a, "in_kernel": bool(k.contains([[x, y]], a)[0]),
                     "margin": float(k.margin([[x, y]], a)[0])}
    if args.save is not None:
        _save(args.save, k)
    if args.plot:
        from tether.plot import kernel_figure, save

        save(kernel_figure(k), args.plot)
    if args.json:
        print_json(out)
        return 0
    g = out["grid"]
    print(f"map {out['map']!r}, lss {k.lss:g}, vt {k.vt:g}, vo {k.vo:g} ({k.scheme} scheme)")
    print(f"  grid h {g['h']:.4g}, {g['orientations']} orientations, shape {g['shape']}: "
          f"{out['states']} states, {out['free_states']} free")
    print(f"  kernel: {out['kernel_states']} states ({100 * out['safe_fraction']:.1f}% of the "
          f"free ones); {out['no_safe_start_points']} target points with no safe start")
    state = "converged" if out["converged"] else "NOT converged"
    print(f"  {out['iterations']} iterations, {state}, {out['seconds']:.2f} s")
    if "at" in out:
        at = out["at"]
        verdict = "IN the kernel" if at["in_kernel"] else "outside the kernel"
        print(f"  ({at['x']:g}, {at['y']:g}, {at['a']:g} rad) is {verdict}, "
              f"margin {at['margin']:+.4f} rad")
    return 0


def _certified(args: argparse.Namespace, env) -> int:
    """``tether kernel --certified``: the certified kernel, and at ``--at`` the answer
    safe / undecided / unsafe (with the optimistic grid kernel on the same lattice)."""
    from tether._util.progress import Progress
    from tether.errors import InvalidParameterError
    from tether.game import surveillance_kernel
    from tether.game.band import undecided_band
    from tether.game.certified import certified_kernel, classify

    if args.scheme != "inner" or args.directions != 8:
        raise InvalidParameterError("--scheme and --directions choose a grid game; "
                                    "--certified has none")
    bar = Progress("certified kernel")
    ck = certified_kernel(env, args.lss, args.vt, args.vo, h=args.h,
                          orientations=args.orientations, delay=args.delay or 0.0,
                          progress=lambda e: bar(f"LP round {e['round']}",
                                                 min(e["round"] / 60, 0.99))
                          if "round" in e else bar(f"patches, pass {e['pass']}: "
                                                   f"{e['failing']} triangles failed", 0.99),
                          coarse_h=args.coarse)
    bar("done", 1.0)
    out = ck.to_dict()
    frac, err = ck.safe_fraction(samples=20_000)
    out["safe_fraction"], out["safe_fraction_error"] = frac, err
    # the optimistic kernel on the same lattice: the unsafe answer, and the band between
    outer = surveillance_kernel(env, args.lss, args.vt, args.vo, h=ck.h,
                                orientations=args.orientations, scheme="outer")
    if (args.refine, args.band_width, args.max_vertices) != (None, None, None):
        ck = _refine(args, ck, outer)
        out = ck.to_dict()
        frac, err = ck.safe_fraction(samples=20_000)
        out["safe_fraction"], out["safe_fraction_error"] = frac, err
    band = undecided_band(ck, outer)
    out["band"] = band.to_dict()
    if args.at is not None:
        x, y, a = args.at
        answer = str(classify(ck, outer, [[x, y]], a)[0])
        out["at"] = {"x": x, "y": y, "a": a, "certified": answer,
                     "margin": float(ck.margin([[x, y]], a)[0])}
    if args.save is not None:
        _save(args.save, ck)
    if args.plot:
        from tether.plot import certified_figure, save

        save(certified_figure(ck, outer), args.plot)
    if args.json:
        print_json(out)
        return 0
    m = out["mesh"]
    print(f"map {out['map']!r}, lss {ck.lss:g}, vt {ck.vt:g}, vo {ck.vo:g} (certified)")
    refined = f", refined in {ck.refined} rounds" if ck.refined else ""
    print(f"  mesh h {ck.h:.4g}{refined}: {m['vertices']} vertices, {m['triangles']} triangles")
    if ck.delay > 0:
        r = ck.vt * ck.delay
        print(f"  sensing delay {ck.delay:g} s: the observer sees the target {ck.delay:g} s late; "
              f"distance observer-target within lss +/- {r:.4g} ({ck.lss - r:.4g} to "
              f"{ck.lss + r:.4g})")
    if ck.certified:
        print(f"  CERTIFIED: {100 * frac:.1f}% of the free states (+/- {100 * err:.1f}, "
              f"Monte Carlo), mean arc {100 * out['mean_arc_fraction']:.1f}% of the circle")
    else:
        fail = out["failing_triangles"] or {}
        bad = sum(fail.values()) if fail else "all"
        print(f"  NOT certified ({bad} triangles fail the checks): no state is claimed safe; "
              f"try a finer --h or a lower vt/vo")
    unsafe = 100 * band.unsafe_states / max(band.free_states, 1)
    print(f"  undecided: {100 * band.share:.1f}% of the lattice's free states (in the optimistic "
          f"kernel, not certified),\n    within {band.reach:.3g} map units of a decided state "
          f"(95%: {band.reach_95:.3g}); unsafe: {unsafe:.1f}%")
    if band.contradictions:
        print(f"  WARNING: {band.contradictions} certified states lie outside the optimistic "
              f"kernel (one of the two games is wrong there, or within a bin of both boundaries)")
    print(f"  {out['seconds']:.2f} s")
    if "at" in out:
        at = out["at"]
        print(f"  ({at['x']:g}, {at['y']:g}, {at['a']:g} rad) is {at['certified'].upper()}")
    return 0


def _refine(args: argparse.Namespace, ck, outer):
    """``--refine`` / ``--band-width`` / ``--max-vertices``: ``ck`` refined where its band is,
    each round's band on stderr."""
    import sys

    from tether.game.refine import refine_certified

    def say(e: dict) -> None:
        if e.get("stopped") == "max_vertices":
            print(f"refine round {e['round']}: stopped, the mesh would have {e['would_have']} "
                  f"vertices (--max-vertices)", file=sys.stderr, flush=True)
            return
        if e.get("stopped") == "failed":
            print(f"refine round {e['round']}: stopped, the refined field fails the checks "
                  f"({e['failing']} triangles): the previous field kept", file=sys.stderr,
                  flush=True)
            return
        kept = {"lp": "", "search": ", field searched again",
                "carried": ", the LP's field failed the checks: the previous field kept"
                if e["certified"] else ", the search found no better field"}
        state = "certified" if e["certified"] else f"NOT certified ({e['failing']} fail)"
        print(f"refine round {e['round']}: {e['vertices']} vertices, {state}, undecided "
              f"{100 * e['undecided_share']:.2f}%, reach {e['reach']:.3g} (95%: "
              f"{e['reach_95']:.3g}){kept.get(e.get('kept'), '')}, {e['seconds']:.1f} s",
              file=sys.stderr, flush=True)

    rounds = args.refine if args.refine is not None else DEFAULT_ROUNDS
    return refine_certified(ck, outer, max_rounds=rounds, max_vertices=args.max_vertices,
                            width=args.band_width, progress=say)


def _save(path: str, kernel) -> None:
    """Write ``kernel`` (grid or certified) to ``path`` atomically: nothing half-written."""
    from tether._util.files import atomic_output

    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            kernel.save(fh)


def register(add) -> None:
    """Add this group's subcommands; ``add(name, fn, help)`` returns the subparser."""
    sp = add("kernel", cmd_kernel,
             "the surveillance kernel: the states from which the observer can keep the target "
             "in sight forever (bounded-speed game on a grid)")
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("--lss", type=float_arg, required=True, help=LSS_HELP)
    sp.add_argument("--vt", type=float_arg, required=True, help="target speed bound")
    sp.add_argument("--vo", type=float_arg, required=True, help="observer speed bound (> vt)")
    sp.add_argument("--h", type=float_arg, default=None,
                    help="lattice spacing (map units; default 1/100 of the map's larger side)")
    sp.add_argument("--orientations", type=int_range(8, 3600), default=180,
                    help="orientation bins (default 180)")
    sp.add_argument("--directions", type=int, choices=(8, 16), default=8,
                    help="target headings of the discrete game (default 8)")
    sp.add_argument("--scheme", choices=("inner", "outer"), default="inner",
                    help="rounding of the observer's rates: inner = conservative (default), "
                         "outer = optimistic")
    sp.add_argument("--certified", action="store_true",
                    help="the certified kernel: an arc field proven by exact checks (safe "
                         "means no target within the speeds can break the line of sight); "
                         "--h is then the mesh spacing (default 1/40 of the larger side)")
    sp.add_argument("--delay", type=float_arg, metavar="D",
                    help="with --certified: sensing delay in seconds (the observer sees the "
                         "target D s late; safe then holds for the seen position, the line of "
                         "sight to the true one is free, and the distance is lss +/- vt*D)")
    sp.add_argument("--refine", type=int_range(0, 100), metavar="ROUNDS",
                    help="with --certified: split the mesh's triangles where the certified and "
                         "the optimistic kernel disagree and widen the field again, at most "
                         f"ROUNDS times (default {DEFAULT_ROUNDS} with --band-width or "
                         "--max-vertices); the band after each round on stderr")
    sp.add_argument("--band-width", type=float_arg, metavar="W",
                    help="with --certified: refine until the band's reach is at most W map "
                         "units (measured on the lattice of spacing --h: below h only when "
                         "nothing is undecided there)")
    sp.add_argument("--max-vertices", type=int_range(3, 10**8), metavar="N",
                    help="with --certified: refine no further than N mesh vertices")
    sp.add_argument("--coarse", type=float_arg, metavar="H",
                    help="with --certified, for big maps: search the field on a mesh of "
                         "spacing H first, read it on the mesh of --h and repair it there in "
                         "patches (no grid kernel at --h)")
    sp.add_argument("--at", nargs=3, type=finite_arg, metavar=("X", "Y", "A"),
                    help="also report whether (x, y, a) (a in radians) is in the kernel")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", metavar="FILE",
                    help="draw the safe fraction and slices of the kernel to an image file")
    sp.add_argument("--save", metavar="FILE.npz", help="save the kernel (numpy .npz)")
