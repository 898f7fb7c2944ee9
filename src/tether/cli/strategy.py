"""Commands of the strategy layer: ``assess`` (a start's escape points and verdict) and
``simulate`` (a controller against a target kind, with the monitor)."""

from __future__ import annotations

import argparse
import math

from tether.cli.common import add_map_lss, float_arg, load_map_lss, print_json
from tether.errors import InvalidParameterError

__all__ = ["cmd_assess", "cmd_simulate", "register"]


def _speeds(args: argparse.Namespace) -> None:
    for name in ("vt", "vo"):
        v = getattr(args, name)
        if not math.isfinite(v) or v < 0:
            raise InvalidParameterError(f"--{name} must be a finite number >= 0 (got {v:g})")
    if not args.vo > args.vt:
        raise InvalidParameterError(f"vo must exceed vt (vo={args.vo:g}, vt={args.vt:g})")


def _world(args: argparse.Namespace, start: tuple[float, ...], rod: bool):
    """The scene of ``args``. The target ``start = (x, y, a)`` must be inside the free space and,
    with ``rod``, the rod free: checked before the decomposition, so a wrong start costs no
    wait."""
    import numpy as np

    from tether._util.progress import Progress
    from tether.analysis import analyze
    from tether.arcs import check_inside
    from tether.decomposition import decompose
    from tether.sim.protocols import World
    from tether.sim.simulate import check_start

    env = load_map_lss(args)
    _speeds(args)
    if rod:
        check_start(World(env, args.lss, args.vt, args.vo), *start)
    else:
        check_inside(env, np.array([start[:2]], dtype=float))
    dec = decompose(env, args.lss, progress=Progress("decompose"))
    return World(env, args.lss, args.vt, args.vo, dec, analyze(dec, near_critical=False))


def _check_outputs(args: argparse.Namespace) -> None:
    from tether._util.files import ANIMATION_KINDS, IMAGE_KINDS, check_output_path

    if getattr(args, "plot", None):
        check_output_path(args.plot, IMAGE_KINDS)
    if getattr(args, "animate", None):
        check_output_path(args.animate, ANIMATION_KINDS)
    if getattr(args, "trace", None):
        check_output_path(args.trace, (".json", ".csv", ".npz"))


def _save_fig(fig, path: str) -> None:
    from tether.plot import save

    save(fig, path)


# ---------------------------------------------------------------------- assess
def cmd_assess(args: argparse.Namespace) -> int:
    """``tether assess``: is a start ``(x, y, a)`` safe, and why; exit status."""
    from tether.analysis import assess

    _check_outputs(args)
    x, y, a = args.at
    world = _world(args, args.at, rod=False)
    res = assess(world.verdict, args.vt, args.vo, x, y, a)
    if args.plot:
        from tether.plot import plot_assessment

        _save_fig(plot_assessment(res, world).figure, args.plot)
    if args.json:
        print_json(res.to_dict())
        return 0
    print(f"start ({x:g}, {y:g}, a={a:g}) lss={args.lss:g} vt={args.vt:g} vo={args.vo:g}: "
          f"{'SAFE' if res.safe else 'UNSAFE'}")
    print(f"  cell: {res.cell} ({'survives' if res.survives else 'does not survive'})")
    for r in res.reasons:
        print(f"  - {r}")
    if res.escape_points:
        print("  escape points in reach (tightest first):")
        print(f"    {'kind':6} {'where':>18} {'at':>8} {'dist':>7} {'sweep':>7} {'L':>7} "
              f"{'L_g':>7} {'margin':>7}")
        for e in res.escape_points[:10]:
            print(f"    {e.kind:6} {f'({e.point[0]:.2f}, {e.point[1]:.2f})':>18} {e.piece:>8} "
                  f"{e.distance:7.3f} {math.degrees(e.sweep):6.1f}° {e.L:7.3f} {e.L_g:7.3f} "
                  f"{e.margin:7.3f}")
    return 0


# ---------------------------------------------------------------------- simulate
def cmd_simulate(args: argparse.Namespace) -> int:
    """``tether simulate``: run a controller against a target; exit status."""
    from tether._util.progress import Progress
    from tether.sim.simulate import save_trace, simulate
    from tether.strategies import CONTROLLERS, TARGETS, make_target

    _check_outputs(args)
    if args.controller not in CONTROLLERS:
        raise InvalidParameterError(f"unknown controller {args.controller!r} (choose from "
                                    f"{', '.join(sorted(CONTROLLERS))})")
    if args.target not in TARGETS:
        raise InvalidParameterError(f"unknown target kind {args.target!r} (choose from "
                                    f"{', '.join(sorted(TARGETS))})")
    if not (args.dt > 0 and math.isfinite(args.dt)):
        raise InvalidParameterError(f"--dt must be > 0 (got {args.dt:g})")
    if not (args.duration >= 0 and math.isfinite(args.duration)):
        raise InvalidParameterError(f"--duration must be >= 0 (got {args.duration:g})")
    if args.kernel and args.controller != "kernel" and args.target != "kernel-evader":
        raise InvalidParameterError("--kernel applies to --controller kernel or "
                                    "--target kernel-evader only")
    if args.path and args.target != "path":
        raise InvalidParameterError("--path applies to --target path only")
    kernel = _load_kernel(args) if args.kernel else None
    world = _world(args, args.start, rod=True)
    if kernel is not None:
        world.extra["kernel"] = kernel
    opts = {"path": args.path} if args.target == "path" else {}
    target = make_target(args.target, world, **opts)
    paper = args.controller == "paper"
    controller = CONTROLLERS[args.controller](world, **({"record": True} if paper else {}))
    res = simulate(world, controller, target, tuple(args.start), duration=args.duration,
                   dt=args.dt, seed=args.seed, progress=Progress("simulate"))
    cause = None
    if paper and not res.held:
        from tether.sim.diagnose import explain_loss

        cause = explain_loss(world, res, controller)
    if args.trace:
        from tether._util.files import atomic_output

        with atomic_output(args.trace) as tmp:
            save_trace(res, tmp)
    if args.plot:
        from tether.plot import plot_run

        _save_fig(plot_run(res, world).figure, args.plot)
    if args.animate:
        from tether.plot import animate_run

        animate_run(res, world, args.animate)
    if args.json:
        print_json({**res.to_dict(), **({"cause": cause.to_dict()} if cause else {})})
        return 0
    print(f"{res.target} vs {res.controller} from {tuple(args.start)} for {res.duration:g}s "
          f"(dt={res.dt:g}, seed={res.seed}): {res.outcome.upper()}"
          + (f" at t={res.lost_at:.3f}s" if res.lost_at is not None else ""))
    if res.reason:
        print(f"  reason: {res.reason}")
    if cause is not None:
        kind = {"gap": "a gap of the paper's conditions", "bug": "a bug of tether's",
                "start": "not a loss from a safe start"}[cause.kind]
        print(f"  cause: {cause.cause} ({kind}): "
              + (f"safe by Props. 2-3 until t={cause.t_safe:.3f}s"
                 if cause.t_safe is not None else "unsafe from the start")
              + (f", then {cause.escape}" if cause.escape else "") + f"; {cause.text}")
    print("  modes: " + " -> ".join(res.modes))
    print("  time per mode: " + ", ".join(f"{m} {t:.2f}s" for m, t in res.mode_time.items()))
    m = res.monitor
    print(f"  monitor: max speed ratio {m.max_speed_ratio:.6f}, min clearance "
          f"{m.min_clearance:.3g}, max distance error {m.max_distance_error:.3g}")
    return 0


def _load_kernel(args: argparse.Namespace):
    """The kernel of ``--kernel FILE.npz`` (``tether kernel --save``), checked against the
    map, ``--lss`` and the speeds of the run (before the decomposition)."""
    from pathlib import Path

    from tether.game import load_kernel

    path = Path(args.kernel)
    if not path.is_file():
        raise InvalidParameterError(f"--kernel: no such file {args.kernel!r}")
    try:
        k = load_kernel(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error
        raise InvalidParameterError(f"--kernel: cannot read {args.kernel!r} ({exc})") from exc
    env = load_map_lss(args)
    for name, mine, theirs in (("lss", k.lss, args.lss), ("vt", k.vt, args.vt),
                               ("vo", k.vo, args.vo)):
        if not math.isclose(mine, theirs, rel_tol=1e-9, abs_tol=1e-12):
            raise InvalidParameterError(f"--kernel was computed with {name}={mine:g}, the run "
                                        f"has {name}={theirs:g}")
    if tuple(round(b, 9) for b in k.grid.env.bounds) != tuple(
            round(b, 9) for b in env.bounds):
        raise InvalidParameterError("--kernel was computed on another map")
    return k


def register(add) -> None:
    """Add the strategy subcommands (assess, simulate) with ``add``."""
    sp = add("assess", cmd_assess, "analyse a start (x, y, a): cell, escape points, L, L_g, "
             "margins, safe or unsafe with reasons")
    add_map_lss(sp)
    sp.add_argument("--vt", type=float_arg, required=True, help="target speed bound")
    sp.add_argument("--vo", type=float_arg, required=True, help="observer speed bound (> vt)")
    sp.add_argument("--at", type=float_arg, nargs=3, required=True, metavar=("X", "Y", "A"),
                    help="target position and rod orientation (radians)")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", help="figure of the start over the decomposition (.png, ...)")

    sp = add("simulate", cmd_simulate, "simulate a controller against a target kind, with "
             "an independent monitor")
    add_map_lss(sp)
    sp.add_argument("--vt", type=float_arg, required=True, help="target speed bound")
    sp.add_argument("--vo", type=float_arg, required=True, help="observer speed bound (> vt)")
    sp.add_argument("--start", type=float_arg, nargs=3, required=True, metavar=("X", "Y", "A"),
                    help="start target position and rod orientation (radians)")
    sp.add_argument("--target", default="random",
                    help="target kind: path, random, wall, tangential, dash, escape, search, "
                    "kernel-evader")
    sp.add_argument("--path", help="waypoint file for --target path (JSON or 'x y' lines)")
    sp.add_argument("--controller", default="paper",
                    help="paper, follow, translate or kernel (the surveillance kernel's "
                    "controller; the kernel is computed on a coarse grid unless --kernel)")
    sp.add_argument("--kernel", metavar="FILE.npz",
                    help="kernel for --controller kernel / --target kernel-evader, saved by "
                    "'tether kernel --save' with the same map, lss and speeds")
    sp.add_argument("--duration", type=float_arg, default=20.0, help="seconds (default 20)")
    sp.add_argument("--dt", type=float_arg, default=0.02, help="step in seconds (0.02)")
    sp.add_argument("--seed", type=int, default=0, help="seed of the target (0)")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", help="figure of the run (.png, ...)")
    sp.add_argument("--animate", help="animation (.gif, .mp4 with ffmpeg, .html)")
    sp.add_argument("--trace", help="save the trace (.json, .csv, .npz)")
