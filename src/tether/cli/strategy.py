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
    cert = _certified_answer(world, x, y, a) if args.certified else None
    if args.plot:
        from tether.plot import plot_assessment

        _save_fig(plot_assessment(res, world).figure, args.plot)
    if args.json:
        out = res.to_dict()
        if cert is not None:
            out = {"certified": cert, **out}
        print_json(out)
        return 0
    if cert is not None:
        if not cert["field_certified"]:
            why = f"no certified field found at h {cert['h']:g}: nothing is claimed safe"
        elif cert["margin"] >= math.pi:
            why = "every orientation is certified at this point"
        else:
            why = f"margin {cert['margin']:+.3f} rad to the certified arc's nearest end"
        print(f"certified: {cert['answer'].upper()} ({why})")
    label = "paper's conditions (Props. 2-3): " if cert is not None else ""
    print(f"{label}start ({x:g}, {y:g}, a={a:g}) lss={args.lss:g} vt={args.vt:g} "
          f"vo={args.vo:g}: {'SAFE' if res.safe else 'UNSAFE'}")
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


def _certified_answer(world, x: float, y: float, a: float) -> dict:
    """``assess --certified``: safe / undecided / unsafe at ``(x, y, a)`` from the certified
    kernel (default mesh) and the optimistic grid kernel on the same lattice."""
    from tether._util.progress import Progress
    from tether.game import surveillance_kernel
    from tether.game.certified import certified_kernel, classify

    bar = Progress("certified kernel")
    ck = certified_kernel(world.env, world.lss, world.vt, world.vo,
                          progress=lambda e: bar(f"LP round {e['round']}",
                                                 min(e["round"] / 60, 0.99)))
    bar("done", 1.0)
    outer = surveillance_kernel(world.env, world.lss, world.vt, world.vo, h=ck.h,
                                scheme="outer")
    return {"answer": str(classify(ck, outer, [[x, y]], a)[0]),
            "margin": float(ck.margin([[x, y]], a)[0]), "field_certified": ck.certified,
            "h": ck.h, "seconds": ck.seconds}


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
    if args.duration is not None and not (args.duration >= 0 and math.isfinite(args.duration)):
        raise InvalidParameterError(f"--duration must be >= 0 (got {args.duration:g})")
    if (args.kernel and args.controller not in ("kernel", "certified")
            and args.target != "kernel-evader"):
        raise InvalidParameterError("--kernel applies to --controller kernel or certified, or "
                                    "--target kernel-evader only")
    if args.kernel and args.controller == "certified" and args.target == "kernel-evader":
        raise InvalidParameterError("--kernel is either a certified field (--controller "
                                    "certified) or a grid kernel (--target kernel-evader)")
    if args.path and args.target != "path":
        raise InvalidParameterError("--path applies to --target path only")
    _check_replay_options(args)
    if args.target in REPLAYED:
        target, start, duration = _replay_target(args)
    else:
        if args.start is None or len(args.start) != 3:
            raise InvalidParameterError(f"--target {args.target} needs --start X Y A")
        target, start, duration = None, tuple(args.start), args.duration
        duration = 20.0 if duration is None else duration
    args.start = start
    kernel = _load_kernel(args) if args.kernel else None
    world = _world(args, args.start, rod=True)
    if kernel is not None:
        world.extra["certified" if args.controller == "certified" else "kernel"] = kernel
    if args.delay:
        _check_delay(args, kernel, world)
    opts = {"path": args.path} if args.target == "path" else {}
    if target is None:
        target = make_target(args.target, world, **opts)
    paper = args.controller == "paper"
    controller = CONTROLLERS[args.controller](world, **({"record": True} if paper else {}))
    res = simulate(world, controller, target, tuple(args.start), duration=duration,
                   dt=args.dt, seed=args.seed, progress=Progress("simulate"),
                   **({"delay": args.delay} if args.delay else {}))
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
    replay = {}
    if args.target in REPLAYED:
        replay = {"track": {**target.report(),
                            "max_deviation": target.deviation(res.trace.t, res.trace.p)}}
    if args.json:
        print_json({**res.to_dict(), **({"cause": cause.to_dict()} if cause else {}), **replay})
        return 0
    print(f"{res.target} vs {res.controller} from {tuple(args.start)} for {res.duration:g}s "
          f"(dt={res.dt:g}, seed={res.seed}): {res.outcome.upper()}"
          + (f" at t={res.lost_at:.3f}s" if res.lost_at is not None else ""))
    if res.reason:
        print(f"  reason: {res.reason}")
    if res.delay_steps:
        r = args.vt * res.delay_steps * res.dt
        print(f"  sensing delay {res.delay:g} s, rounded up to {res.delay_steps} steps "
              f"({res.delay_steps * res.dt:g} s): the distance is held within lss +/- {r:.4g}")
    if cause is not None:
        kind = {"gap": "a gap of the paper's conditions", "bug": "a bug of tether's",
                "start": "not a loss from a safe start"}[cause.kind]
        print(f"  cause: {cause.cause} ({kind}): "
              + (f"safe by Props. 2-3 until t={cause.t_safe:.3f}s"
                 if cause.t_safe is not None else "unsafe from the start")
              + (f", then {cause.escape}" if cause.escape else "") + f"; {cause.text}")
    if replay:
        print("  " + _replay_line(replay["track"], args.vt))
    print("  modes: " + " -> ".join(res.modes))
    print("  time per mode: " + ", ".join(f"{m} {t:.2f}s" for m, t in res.mode_time.items()))
    m = res.monitor
    print(f"  monitor: max speed ratio {m.max_speed_ratio:.6f}, min clearance "
          f"{m.min_clearance:.3g}, max distance error {m.max_distance_error:.3g}")
    return 0


def _check_delay(args: argparse.Namespace, kernel, world) -> None:
    """``--delay``: a valid number; with ``--controller certified`` the field must be
    certified for the delay rounded up to whole steps (the one computed on demand is)."""
    if not (math.isfinite(args.delay) and args.delay >= 0):
        raise InvalidParameterError(f"--delay must be a finite number >= 0 s, got {args.delay}")
    if args.controller != "certified":
        return
    steps = math.ceil(args.delay / args.dt - 1e-9)
    world.extra["delay"] = steps * args.dt
    if kernel is not None and kernel.delay < steps * args.dt * (1 - 1e-12):
        raise InvalidParameterError(
            f"--kernel is certified for a delay of {kernel.delay:g} s, the run's is "
            f"{steps * args.dt:g} s ({args.delay:g} s rounded up to {steps} steps of --dt)")


#: Target kinds replayed from a track; the track fixes the start.
REPLAYED = ("track", "pedestrian")
#: A replay's largest distance from its track (map units) worth a word in the text output.
DEVIATION_SHOWN = 1e-6


def _check_replay_options(args: argparse.Namespace) -> None:
    """Refuse the replay options with a target kind they do not apply to."""
    for flag, value, kinds in (("--track", args.track, ("track",)),
                               ("--topic", args.topic, ("track",)),
                               ("--columns", args.columns, ("track",)),
                               ("--track-speed", args.track_speed, ("track",)),
                               ("--speed", args.speed, ("pedestrian",))):
        if value is not None and args.target not in kinds:
            raise InvalidParameterError(f"{flag} applies to --target {' or '.join(kinds)} only")
    if args.target == "track" and not args.track:
        raise InvalidParameterError("--target track needs --track FILE (CSV, JSON or a ROS bag)")


def _columns(text: str | None) -> tuple[str, ...] | None:
    """``--columns t,x,y``: the names of the time, x and y columns."""
    if text is None:
        return None
    cols = tuple(c.strip() for c in text.split(","))
    if len(cols) != 3 or not all(cols):
        raise InvalidParameterError(f"--columns takes three names T,X,Y (got {text!r})")
    return cols


def _replay_target(args: argparse.Namespace):
    """The replayed target of ``args`` (built on the map before the decomposition), the start
    ``(x, y, a)`` its track fixes and the run's duration (the track's by default).

    ``--start`` may be left out (the rod is put behind the target's first motion, free), give
    the rod orientation alone (``--start A``), or ``X Y A`` with ``X Y`` the track's start."""
    from tether.sim.protocols import World
    from tether.sim.replay import START_TOL
    from tether.strategies import make_target

    env = load_map_lss(args)
    _speeds(args)
    scene = World(env, args.lss, args.vt, args.vo)
    if args.target == "track":
        opts = {"path": args.track, "topic": args.topic, "columns": _columns(args.columns),
                "speed": args.track_speed or "refuse"}
    else:
        opts = {"seed": args.seed, "speed": args.speed}
    target = make_target(args.target, scene, dt=args.dt, duration=args.duration, **opts)
    duration = target.track.duration if args.duration is None else args.duration
    target.duration = duration
    x, y = (float(c) for c in target.start)
    given = args.start or []
    if len(given) not in (0, 1, 3):
        raise InvalidParameterError("--start takes X Y A, or the rod orientation A alone")
    if len(given) == 3 and math.hypot(given[0] - x, given[1] - y) > START_TOL * env.diameter:
        raise InvalidParameterError(
            f"--start {given[0]:g} {given[1]:g} is not the track's first position ({x:g}, "
            f"{y:g}): give --start A (the rod alone) or leave --start out")
    a = float(given[-1]) if given else target.start_angle(scene)
    return target, (x, y, a), duration


def _replay_line(rep: dict, vt: float) -> str:
    """The replay's line of the text output: the track and what the speed bound changed."""
    line = (f"track {rep['name'] or '(unnamed)'}: {rep['samples']} samples over "
            f"{rep['duration']:g}s")
    if rep["max_deviation"] > DEVIATION_SHOWN:
        line += (f"; the walls held the target up to {rep['max_deviation']:.3g} map units off "
                 "the track")
    clipped = rep["clipped_segments"]
    if clipped:
        first = clipped[0]
        line += (f"; {len(clipped)} segments faster than vt={vt:g} clipped to vt (first: "
                 f"segment {first['segment']} at t={first['t']:g}s, {first['speed']:.4g} map "
                 f"units/s), {rep['delay']:.3g}s later in all")
    return line


def _load_kernel(args: argparse.Namespace):
    """The kernel of ``--kernel FILE.npz`` (``tether kernel --save``; with ``--controller
    certified`` a field of ``tether kernel --certified --save``, certified again on reading),
    checked against the map, ``--lss`` and the speeds of the run (before the
    decomposition)."""
    from pathlib import Path

    from tether.game import load_kernel
    from tether.game.certified import load_certified

    path = Path(args.kernel)
    if not path.is_file():
        raise InvalidParameterError(f"--kernel: no such file {args.kernel!r}")
    certified = args.controller == "certified"
    try:
        k = load_certified(path) if certified else load_kernel(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error
        raise InvalidParameterError(f"--kernel: cannot read {args.kernel!r} ({exc})") from exc
    env = load_map_lss(args)
    for name, mine, theirs in (("lss", k.lss, args.lss), ("vt", k.vt, args.vt),
                               ("vo", k.vo, args.vo)):
        if not math.isclose(mine, theirs, rel_tol=1e-9, abs_tol=1e-12):
            raise InvalidParameterError(f"--kernel was computed with {name}={mine:g}, the run "
                                        f"has {name}={theirs:g}")
    k_env = k.env if certified else k.grid.env
    if tuple(round(b, 9) for b in k_env.bounds) != tuple(round(b, 9) for b in env.bounds):
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
    sp.add_argument("--certified", action="store_true",
                    help="first the certified answer (safe / undecided / unsafe, from the "
                         "certified kernel: seconds to minutes), then the paper's conditions")

    sp = add("simulate", cmd_simulate, "simulate a controller against a target kind, with "
             "an independent monitor")
    add_map_lss(sp)
    sp.add_argument("--vt", type=float_arg, required=True, help="target speed bound")
    sp.add_argument("--vo", type=float_arg, required=True, help="observer speed bound (> vt)")
    sp.add_argument("--start", type=float_arg, nargs="+", metavar="N",
                    help="X Y A: start target position and rod orientation (radians); for "
                    "--target track/pedestrian the track's start: give A alone or nothing (a "
                    "free rod behind the target)")
    sp.add_argument("--target", default="random",
                    help="target kind: path, random, wall, tangential, dash, escape, search, "
                    "kernel-evader, track (a recorded track, --track), pedestrian (a "
                    "simulated person, needs tether[crowd])")
    sp.add_argument("--path", help="waypoint file for --target path (JSON or 'x y' lines)")
    sp.add_argument("--track", metavar="FILE", help="track for --target track: CSV, JSON, "
                    "a rosbag2 folder or a ROS 1 .bag (docs/tracks.md)")
    sp.add_argument("--topic", help="the bag's topic for --track (default: its one topic of "
                    "a supported type)")
    sp.add_argument("--columns", metavar="T,X,Y", help="CSV columns (JSON keys) of time, x "
                    "and y for --track (default t,x,y)")
    sp.add_argument("--track-speed", choices=["refuse", "clip"], help="segments faster than "
                    "vt: refuse the track (default) or replay them at vt, reported")
    sp.add_argument("--speed", type=float_arg, help="desired walking speed of --target "
                    "pedestrian, map units/s (default vt)")
    sp.add_argument("--controller", default="paper",
                    help="paper, follow, translate, kernel (the surveillance kernel's "
                    "controller; the kernel is computed on a coarse grid unless --kernel) or "
                    "certified (keeps the state in the certified kernel; computed unless "
                    "--kernel)")
    sp.add_argument("--kernel", metavar="FILE.npz",
                    help="kernel for --controller kernel / --target kernel-evader, saved by "
                    "'tether kernel --save' with the same map, lss and speeds (for "
                    "--controller certified: 'tether kernel --certified --save')")
    sp.add_argument("--delay", type=float_arg, metavar="D",
                    help="sensing delay in seconds: the controller sees the target D s late "
                         "(rounded up to whole steps); the monitor checks the true line of "
                         "sight (with --controller certified: a field certified for D, "
                         "'tether kernel --certified --delay D')")
    sp.add_argument("--duration", type=float_arg, help="seconds (default 20; a replayed "
                    "track's own duration)")
    sp.add_argument("--dt", type=float_arg, default=0.02, help="step in seconds (0.02)")
    sp.add_argument("--seed", type=int, default=0, help="seed of the target (0)")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", help="figure of the run (.png, ...)")
    sp.add_argument("--animate", help="animation (.gif, .mp4 with ffmpeg, .html)")
    sp.add_argument("--trace", help="save the trace (.json, .csv, .npz)")
